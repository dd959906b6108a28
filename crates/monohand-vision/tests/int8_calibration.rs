//! The int8 networks: the shipped calibration tables are what the calibration frames give,
//! bit for bit, and the int8 pipeline finds the same hands as the f32 one.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use std::path::Path;

use monohand_vision::int8::{calibrate, calibration_images, Int8Table, FRAMES};
use monohand_vision::{
    HandPipeline, ModelFile, ModelOptions, ModelVariant, PipelineOptions, Precision,
};

#[test]
fn the_shipped_tables_are_what_the_calibration_frames_give() {
    let Some(store) = common::models() else {
        return;
    };
    let data = common::shared("").expect("shared data");
    let images = calibration_images(&data).expect("calibration frames");
    assert_eq!(images.len(), 36 + 30, "36 shared photos, 30 dev frames");
    for variant in [ModelVariant::Full, ModelVariant::Lite] {
        let models = ModelOptions {
            model_dir: Some(store.dir().to_path_buf()),
            palm: variant,
            landmark: variant,
            ..Default::default()
        };
        for (file, table) in calibrate(&models, &images, FRAMES).expect("calibrate") {
            let shipped = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("int8")
                .join(file.file_name().replace(".tflite", ".txt"));
            let shipped = std::fs::read_to_string(&shipped).expect("shipped table");
            assert_eq!(
                table.to_text(),
                shipped,
                "{file:?}: the calibration frames no longer give the shipped table \
                 (examples/int8_calibrate.rs writes it)"
            );
            let parsed = Int8Table::shipped_for(file.sha256())
                .expect("shipped")
                .expect("valid");
            assert_eq!(parsed, table);
            // Every 1x1 layer of the table runs in int8.
            let bytes = store.load(file).expect("load");
            let net = monohand_vision::TfliteNet::from_bytes_in(
                &bytes,
                &store.path_of(file),
                Default::default(),
                Precision::Int8,
            )
            .expect("int8 network");
            assert_eq!(net.precision(), Precision::Int8);
            assert_eq!(net.int8_layers(), table.ranges.len(), "{file:?}");
        }
    }
}

#[test]
fn the_int8_pipeline_finds_the_hands_the_f32_one_does() {
    let Some(store) = common::models() else {
        return;
    };
    let models = ModelOptions {
        model_dir: Some(store.dir().to_path_buf()),
        ..Default::default()
    };
    let f32_pipeline = HandPipeline::new(&models, PipelineOptions::default()).expect("f32");
    let int8_options = PipelineOptions {
        precision: Precision::Int8,
        ..Default::default()
    };
    let int8_pipeline = HandPipeline::new(&models, int8_options).expect("int8");
    // The second half of the dev video, never seen by the calibration, and the shipped photo.
    let dev = common::shared("hand_graph_cnn_dev/images").expect("dev set");
    let mut paths: Vec<_> = (146..292)
        .step_by(10)
        .map(|i| dev.join(format!("{i:05}.jpg")))
        .collect();
    paths.push(common::shared("images/pinto/hand.png").expect("photo"));
    let mut dists = Vec::new();
    let mut with_hands = 0;
    for path in &paths {
        let a = f32_pipeline.detect_file(path).expect("f32 detect");
        let b = int8_pipeline.detect_file(path).expect("int8 detect");
        assert_eq!(a.precision, Precision::F32);
        assert_eq!(b.precision, Precision::Int8);
        assert_eq!(a.hands.len(), b.hands.len(), "{}", path.display());
        with_hands += usize::from(!a.hands.is_empty());
        for (a, b) in a.hands.iter().zip(&b.hands) {
            assert_eq!(a.side, b.side, "{}", path.display());
            let d: f64 = a
                .keypoints
                .points
                .iter()
                .zip(&b.keypoints.points)
                .map(|(p, q)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
                .sum::<f64>()
                / 21.0;
            dists.push(d);
        }
    }
    eprintln!("hands found in {with_hands} of {} images", paths.len());
    assert!(
        with_hands * 4 >= paths.len() * 3,
        "a hand in {with_hands} of {} images",
        paths.len()
    );
    dists.sort_by(f64::total_cmp);
    let median = dists[dists.len() / 2];
    eprintln!(
        "int8 against f32: mean keypoint distance per hand, median {median:.3} px, most {:.3} px",
        dists[dists.len() - 1]
    );
    // The images are 256x256 (dev) and 640x480: int8 moves the keypoints by a fraction of
    // a pixel, not by a joint's width.
    assert!(median < 1.0, "median {median} px");
    assert!(
        dists[dists.len() - 1] < 4.0,
        "largest {} px",
        dists[dists.len() - 1]
    );
}

#[test]
fn int8_of_a_network_without_a_table_is_a_clear_error() {
    let Some(store) = common::models() else {
        return;
    };
    let file = ModelFile::FaceDetectionShortRange;
    let bytes = store.load(file).expect("load");
    let e = monohand_vision::TfliteNet::from_bytes_in(
        &bytes,
        &store.path_of(file),
        Default::default(),
        Precision::Int8,
    )
    .expect_err("no table for the face detector");
    assert!(e.to_string().contains("no int8 calibration"), "{e}");
}
