//! A network alone shares its large operators between the cores, with the bits of one core.
//! (A test binary of its own: networks run by other tests at the same time would, rightly,
//! keep this one from sharing.)
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use monohand_vision::{ModelFile, NetOutputs, TfliteNet, VisionError};

/// The bits of every output of a run.
fn all_bits(out: NetOutputs<'_>) -> Result<Vec<Vec<u32>>, VisionError> {
    (0..out.len())
        .map(|i| out.get(i).map(|v| v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

/// A deterministic input in `[0, 1)`.
fn pseudo_random(len: usize) -> Vec<f32> {
    (0..len)
        .map(|i| ((i * 7919) % 1009) as f32 / 1009.0)
        .collect()
}

/// The operators sharing their rows between the cores (the default when a network runs
/// alone) give exactly the outputs of the same networks imported without it.
#[test]
fn operators_shared_between_cores_give_the_bits_of_one_core() {
    let Some(store) = common::models() else {
        return;
    };
    assert!(
        monohand_vision::tflite_import::team_size() >= 2,
        "this test needs two cores (or MONOHAND_OP_THREADS=2) to share anything"
    );
    let whole = monohand_vision::tflite_import::ImportOptions {
        split_rows: false,
        ..Default::default()
    };
    for file in [
        ModelFile::HandLandmarkFull,
        ModelFile::HandLandmarkLite,
        ModelFile::PalmDetectionFull,
        ModelFile::FaceDetectionShortRange,
    ] {
        let bytes = store.load(file).expect("load model");
        let path = store.path_of(file);
        let split = TfliteNet::from_bytes(&bytes, &path).expect("import");
        let one = TfliteNet::from_bytes_with(&bytes, &path, whole).expect("import");
        let shape = split.input_shape();
        let data = pseudo_random(shape.iter().product());
        let run = |net: &TfliteNet| {
            net.run_pooled(|buf| buf.copy_from_slice(&data), all_bits)
                .expect("run")
        };
        let want = run(&one);
        let before = monohand_vision::tflite_import::shared_operators();
        let got = run(&split);
        assert!(
            monohand_vision::tflite_import::shared_operators() > before,
            "{file:?}: nothing was shared"
        );
        assert_eq!(got, want, "{file:?}");
    }
}
