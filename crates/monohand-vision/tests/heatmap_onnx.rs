//! The heatmap keypoint path end to end through tract-onnx, on a tiny synthetic ONNX network
//! (`tools/make_heatmap_fixture.py`) whose 21 heatmaps peak at known sub-cell positions:
//! peak finding, sub-pixel refinement, crop → image mapping, and mirroring for a network
//! trained on right hands only.
#![cfg(feature = "onnx")]
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_core::hand_model::HandSide;
use monohand_vision::geometry::RotatedRect;
use monohand_vision::heatmap::{HeatmapModelConfig, OnnxHeatmapEstimator};
use monohand_vision::warp::Normalization;
use monohand_vision::{HandRegion, KeypointEstimator, RgbImage};

fn fixture_peaks() -> Vec<[f64; 2]> {
    let text = std::fs::read_to_string(common::fixture("heatmap_fixture.json")).expect("fixture");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    v["peaks_cells"]
        .as_array()
        .expect("peaks")
        .iter()
        .map(|p| [p[0].as_f64().expect("x"), p[1].as_f64().expect("y")])
        .collect()
}

#[test]
fn heatmap_peaks_map_back_to_the_image_and_left_hands_are_mirrored() {
    let config = HeatmapModelConfig {
        input_size: (64, 64),
        normalization: Normalization::UNIT,
        bgr: false,
        trained_side: Some(HandSide::Right),
    };
    let net = OnnxHeatmapEstimator::load(&common::fixture("synthetic_heatmaps.onnx"), config)
        .expect("load onnx");
    let img = RgbImage::from_pixel(200, 200, image::Rgb([90, 90, 90]));
    // A 128-pixel square crop centred at (100, 100): one heatmap cell = 8 crop px = 16 image px.
    let region = HandRegion {
        score: 1.0,
        roi: RotatedRect {
            center: [100.0, 100.0],
            width: 128.0,
            height: 128.0,
            rotation: 0.0,
        },
    };
    let peaks = fixture_peaks();
    let tol = 0.15 * 16.0; // parabola refinement of a sampled Gaussian: within 0.15 cell
    for (hint, mirrored) in [
        (Some(HandSide::Right), false),
        (None, false),
        (Some(HandSide::Left), true),
    ] {
        let kp = net.estimate(&img, &region, hint).expect("estimate");
        for (j, (p, want)) in kp.points.iter().zip(&peaks).enumerate() {
            let x = 36.0 + want[0] * 16.0;
            let y = 36.0 + want[1] * 16.0;
            let x = if mirrored { 200.0 - x } else { x };
            let e = ((p[0] - x).powi(2) + (p[1] - y).powi(2)).sqrt();
            assert!(
                e < tol,
                "hint {hint:?} joint {j}: ({:.2}, {:.2}) vs ({x:.2}, {y:.2})",
                p[0],
                p[1]
            );
            assert!(
                p[2] > 0.6 && p[2] <= 0.9 + 1e-6,
                "confidence = peak value, got {}",
                p[2]
            );
        }
    }
}
