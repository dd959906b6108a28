//! Helpers shared by the calibration tests (`calibrate.rs`, `fisheye.rs`): the fixtures of
//! `tests/data` made from OpenCV's stereo sample, and bad input.
#![allow(dead_code)] // each test file uses its own part of them

use monohand_calib::calibrate::BoardView;
use nalgebra::{Point2, Rotation3};
use rand::{rngs::StdRng, Rng, SeedableRng};
use serde_json::Value;
use std::path::PathBuf;

/// This crate's `tests/data`.
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

/// A JSON file of `tests/data`.
pub fn read_json(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(data_dir().join(name)).unwrap()).unwrap()
}

/// A JSON number.
pub fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// Camera `side`'s views per instant in `opencv_corners.json` (OpenCV's corners on the
/// sample photos; `None` where OpenCV found no board).
pub fn fixture_views(corners: &Value, side: &str) -> Vec<Option<BoardView>> {
    corners[side]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            let c = v["corners"].as_array()?;
            Some(BoardView {
                name: v["name"].as_str().unwrap().to_string(),
                corners: c.iter().map(|p| Point2::new(f(&p[0]), f(&p[1]))).collect(),
            })
        })
        .collect()
}

/// The angle of a rotation, degrees.
pub fn angle_deg(r: &Rotation3<f64>) -> f64 {
    r.angle().to_degrees()
}

/// Five views of 54 garbage corners (random pixels of a 1280x720 image, seed 5): an error
/// or a result, never a panic.
pub fn junk_views() -> Vec<BoardView> {
    let mut rng = StdRng::seed_from_u64(5);
    (0..5)
        .map(|i| BoardView {
            name: format!("junk {i}"),
            corners: (0..54)
                .map(|_| Point2::new(rng.random_range(0.0..1280.0), rng.random_range(0.0..720.0)))
                .collect(),
        })
        .collect()
}
