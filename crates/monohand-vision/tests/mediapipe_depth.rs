//! The landmark `z` (relative depth, image pixels) is MediaPipe's own: on ten real photos,
//! MediaPipe 0.10.14's Python pipeline's `z` (times the image width, its `normalize_z`
//! included; fixture written by `tools/mediapipe_z.py`) against ours, one landmark pass per
//! crop as MediaPipe reads it. Before `NORMALIZE_Z` ours was 2.5 times flatter (ratio 0.37).
//!
//! Needs `../shared/data` and the MediaPipe weights.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use monohand_vision::landmarks::LandmarkOptions;
use monohand_vision::{HandPipeline, ModelOptions, PipelineOptions};

#[test]
fn relative_depth_has_mediapipes_scale() {
    let Some(store) = common::models() else {
        return;
    };
    let options = PipelineOptions {
        landmarks: LandmarkOptions {
            mirror_pass: false,
            ..Default::default()
        },
        ..Default::default()
    };
    let models = ModelOptions {
        model_dir: Some(store.dir().to_path_buf()),
        detect_heads: false,
        ..Default::default()
    };
    let pipeline = HandPipeline::new(&models, options).expect("pipeline");
    let text = std::fs::read_to_string(common::fixture("mediapipe_z.json")).expect("fixture");
    let fixture: serde_json::Value = serde_json::from_str(&text).expect("json");
    let mut ratios = Vec::new();
    for hand in fixture["hands"].as_array().expect("hands") {
        let photo = common::shared(hand["photo"].as_str().expect("photo")).expect("photo");
        let theirs: Vec<[f64; 3]> =
            serde_json::from_value(hand["mediapipe_uvz_px"].clone()).unwrap();
        let found = pipeline.detect_file(&photo).expect("detect");
        // Our hand on MediaPipe's: the nearest by mean keypoint distance.
        let dist = |k: &monohand_core::observation::Keypoints2d| {
            (0..21)
                .map(|j| (k.points[j][0] - theirs[j][0]).hypot(k.points[j][1] - theirs[j][1]))
                .sum::<f64>()
                / 21.0
        };
        let ours = found
            .hands
            .iter()
            .min_by(|a, b| dist(&a.keypoints).total_cmp(&dist(&b.keypoints)))
            .unwrap_or_else(|| panic!("{}: no hand", photo.display()));
        assert!(
            dist(&ours.keypoints) < 10.0,
            "{}: the hands differ",
            photo.display()
        );
        let z = ours.cues.and_then(|c| c.depth_px).expect("depth");
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..21 {
            let (a, b) = (z[j] - z[0], theirs[j][2] - theirs[0][2]);
            num += a * b;
            den += b * b;
        }
        ratios.push(num / den);
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    // Measured: 0.91 to 1.06 per hand, median 0.965 (our crop is re-centred once on the
    // first pass's keypoints; MediaPipe reads the palm's crop).
    assert!(
        (0.85..1.15).contains(&median),
        "median ratio {median:.3}: {ratios:?}"
    );
    assert!(ratios.iter().all(|r| (0.7..1.4).contains(r)), "{ratios:?}");
}
