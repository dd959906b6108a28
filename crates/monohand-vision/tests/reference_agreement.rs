//! The project's TFLite importer + tract agrees with the independent LiteRT interpreter on
//! the committed fixture (real image crops, outputs by `tools/litert_reference.py`).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_vision::{ModelFile, TfliteNet};
use tract_core::prelude::Tensor;

fn net(file: ModelFile) -> Option<TfliteNet> {
    let store = common::models()?;
    let bytes = store.load(file).expect("load model");
    Some(TfliteNet::from_bytes(&bytes, &store.path_of(file)).expect("import"))
}

fn input(name: &str, scale: f32, offset: f32) -> Tensor {
    let npy = common::read_npy(name);
    let mut shape = vec![1];
    shape.extend(&npy.shape);
    let data: Vec<f32> = npy.data.iter().map(|v| v * scale + offset).collect();
    Tensor::from_shape(&shape, &data).expect("tensor")
}

/// Max |a - b| / max(1, |b|): absolute for small values, relative for pixel-sized ones.
fn max_err(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1.0))
        .fold(0.0, f32::max)
}

fn check(what: &str, got: &[f32], want_file: &str, tol: f32) {
    let want = common::read_npy(want_file).data;
    let e = max_err(got, &want);
    let abs = got
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    println!(
        "{what}: max |err|/max(1,|ref|) = {e:.2e}, max |err| = {abs:.2e}, over {} values",
        want.len()
    );
    assert!(e < tol, "{what}: error {e} exceeds {tol}");
}

#[test]
fn palm_detector_full_matches_litert() {
    let Some(net) = net(ModelFile::PalmDetectionFull) else {
        return;
    };
    let out = net
        .run(input("palm_input_u8.npy", 1.0 / 255.0, 0.0))
        .expect("run");
    // Box regressors are in input pixels (|values| up to a few hundred on background anchors):
    // summation-order noise between XNNPACK and tract reaches ~1.4e-4 of the magnitude there.
    check(
        "palm_full regressors",
        &out[0],
        "palm_full_regressors.npy",
        3e-4,
    );
    check("palm_full scores", &out[1], "palm_full_scores.npy", 1e-4);
}

#[test]
fn palm_detector_lite_matches_litert() {
    let Some(net) = net(ModelFile::PalmDetectionLite) else {
        return;
    };
    let out = net
        .run(input("palm_input_u8.npy", 1.0 / 255.0, 0.0))
        .expect("run");
    check("palm_lite scores", &out[1], "palm_lite_scores.npy", 1e-4);
}

fn landmark(file: ModelFile, fixture: &str) {
    let Some(net) = net(file) else { return };
    let out = net
        .run(input("landmark_input_u8.npy", 1.0 / 255.0, 0.0))
        .expect("run");
    let flat: Vec<f32> = out.concat();
    check(fixture, &flat, fixture, 1e-4);
}

#[test]
fn hand_landmark_full_matches_litert() {
    landmark(ModelFile::HandLandmarkFull, "landmark_full_outputs.npy");
}

#[test]
fn hand_landmark_lite_matches_litert() {
    landmark(ModelFile::HandLandmarkLite, "landmark_lite_outputs.npy");
}

#[test]
fn face_detector_matches_litert() {
    let Some(net) = net(ModelFile::FaceDetectionShortRange) else {
        return;
    };
    let out = net
        .run(input("face_input_u8.npy", 1.0 / 127.5, -1.0))
        .expect("run");
    check("face regressors", &out[0], "face_regressors.npy", 1e-4);
    check("face scores", &out[1], "face_scores.npy", 1e-4);
}

/// monohand's `NhwcConv` (the first layer, on the image) against tract's own `Conv` for
/// that layer, every other operator the same: every output of every network is the same
/// bits, on the real inputs above.
#[test]
fn the_direct_first_layer_gives_the_same_bits_as_tracts_conv() {
    use monohand_vision::tflite_import::ImportOptions;
    let Some(store) = common::models() else {
        return;
    };
    let tract_conv = ImportOptions {
        fast_conv: false,
        ..ImportOptions::default()
    };
    for (file, fixture, scale, offset) in [
        (
            ModelFile::PalmDetectionFull,
            "palm_input_u8.npy",
            1.0 / 255.0,
            0.0,
        ),
        (
            ModelFile::PalmDetectionLite,
            "palm_input_u8.npy",
            1.0 / 255.0,
            0.0,
        ),
        (
            ModelFile::HandLandmarkFull,
            "landmark_input_u8.npy",
            1.0 / 255.0,
            0.0,
        ),
        (
            ModelFile::HandLandmarkLite,
            "landmark_input_u8.npy",
            1.0 / 255.0,
            0.0,
        ),
        (
            ModelFile::FaceDetectionShortRange,
            "face_input_u8.npy",
            1.0 / 127.5,
            -1.0,
        ),
    ] {
        let bytes = store.load(file).expect("load model");
        let path = store.path_of(file);
        let ours = TfliteNet::from_bytes(&bytes, &path).expect("import");
        let theirs = TfliteNet::from_bytes_with(&bytes, &path, tract_conv).expect("import");
        let x = input(fixture, scale, offset);
        let (a, b) = (
            ours.run(x.clone()).expect("run"),
            theirs.run(x).expect("run"),
        );
        assert_eq!(a.len(), b.len());
        for (i, (a, b)) in a.iter().zip(&b).enumerate() {
            let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert!(bits(a) == bits(b), "{file:?} output {i} differs");
        }
    }
}
