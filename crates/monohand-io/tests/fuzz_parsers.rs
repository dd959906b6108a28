//! Fuzzing of monohand-io's parsers of outside input (see docs/fuzzing.md): calibration files
//! (project JSON, WACV'18 JSON, OpenCV YAML and XML FileStorage, ROS camera_info, Kalibr
//! camera chains), OpenPose JSON, the JSON
//! Lines input of `lift` and bone-length JSON (ffprobe's JSON: monohand-media's tests). Every mutated input must give
//! `Ok` or `Err`: no panic, no allocation over the harness limit, no hang.
//!
//! `MONOHAND_FUZZ_CASES` sets the number of mutated inputs per parser (default below, sized
//! for `.ci/run`), `MONOHAND_FUZZ_SEED` the RNG seed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{cases, mutate_text, run, shared, text, TrackingAlloc};
use monohand_io::calibration::{camera_to_json, parse_calibration, parse_calibrations};
use monohand_io::jsonl::parse_jsonl;
use monohand_io::openpose::parse_openpose;
use monohand_io::skeleton::parse_bone_lengths;
use serde_json::json;

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated inputs per text parser in a default `cargo test`.
const CI_CASES: usize = 3000;

const DIR: &str = env!("CARGO_MANIFEST_DIR");

fn calibration(input: &[u8]) -> Result<(), monohand_io::IoError> {
    for c in parse_calibrations(&text(input), "fuzz")? {
        // What a caller does next with a calibration: project a point, and back.
        let _ = c.camera.project(&nalgebra::Vector3::new(10.0, 20.0, 500.0));
        let _ = c.camera.ray(nalgebra::Point2::new(10.0, 20.0));
    }
    Ok(())
}

#[test]
fn fuzz_calibration_json() {
    let camera = parse_calibration(
        r#"{"fx": 800, "fy": 810, "cx": 320, "cy": 240, "width": 640, "height": 480,
            "dist": [0.1, -0.2, 0.001, 0.002, 0.05], "R": [0, 0.2, 0], "t": [1, 2, 3]}"#,
        "seed",
    )
    .expect("seed calibration")
    .camera;
    let seeds = vec![
        serde_json::to_vec_pretty(&camera_to_json(&camera)).unwrap(),
        br#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480}"#.to_vec(),
        shared(DIR, "hand_models/wacv18/calib_webcam_mshd_vga.json"),
        br#"{"CameraMatrix": [[600, 0, 320], [0, 600, 240], [0, 0, 1]], "Dims": [640, 480],
            "Distortion": [0.1, 0.2, 0, 0, 0.3], "Rotation": [[1,0,0],[0,1,0],[0,0,1]],
            "Translation": [0, 0, 0]}"#
            .to_vec(),
    ];
    run(
        "calibration_json",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        calibration,
    );
}

const YAML: &str = r#"%YAML:1.0
---
calibration_time: "Wed 12 Nov 2025 10:00:00 CET"
nr_of_frames: 25
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 6.7724586254666637e+02, 0., 3.1994756334894319e+02, 0.,
       6.8024297317066178e+02, 2.3882859474169499e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ 1.8681114967853352e-01, -1.3734152813512340e+00, 0., 0.,
       2.6679646461641733e+00 ]
avg_reprojection_error: 2.2683652780513805e-01
nested:
   k: [ 1, 2 ]
   l:
      - 3
      - { x: 1, y: 2 }
      - a: 1
        b: 2
seq:
- 1
- 2
"#;

/// The stereo right camera of the calibration unit tests.
const STEREO_YAML: &str = include_str!("data/stereo_right.yml");

#[test]
fn fuzz_calibration_yaml() {
    let seeds = vec![YAML.as_bytes().to_vec(), STEREO_YAML.as_bytes().to_vec()];
    run(
        "calibration_yaml",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        calibration,
    );
}

#[test]
fn fuzz_calibration_robotics_yaml() {
    let seeds: Vec<Vec<u8>> = [
        "ros_plumb_bob.yaml",
        "ros_rational.yaml",
        "ros_equidistant.yaml",
        "kalibr_camchain_imucam.yaml",
        "kalibr_camchain_block.yaml",
        "opencv_fisheye.yaml",
        "opencv_fisheye_sample.yml",
    ]
    .iter()
    .map(|f| std::fs::read(format!("{DIR}/tests/data/{f}")).unwrap())
    .collect();
    run(
        "calibration_robotics_yaml",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        calibration,
    );
}

const XML: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<calibration_time>"Wed 12 Nov 2025 10:00:00 CET"</calibration_time>
<image_width>640</image_width>
<image_height>480</image_height>
<camera_matrix type_id="opencv-matrix">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>
    6.7724586254666637e+02 0. 3.1994756334894319e+02 0.
    6.8024297317066178e+02 2.3882859474169499e+02 0. 0. 1.</data></camera_matrix>
<distortion_coefficients type_id="opencv-matrix">
  <rows>5</rows>
  <cols>1</cols>
  <dt>d</dt>
  <data>
    1.8681114967853352e-01 -1.3734152813512340e+00 0. 0.
    2.6679646461641733e+00</data></distortion_coefficients>
<!-- a comment -->
<v>
  <_>1</_><_>2</_></v>
<s attr="&amp;&lt;x&gt;">&quot;a &amp; b&quot;</s>
</opencv_storage>
"#;

#[test]
fn fuzz_calibration_xml() {
    let seeds = vec![
        XML.as_bytes().to_vec(),
        // A libhand pose: OpenCV XML despite its extension.
        shared(DIR, "hand_models/libhand/poses/fist.yml"),
    ];
    run(
        "calibration_xml",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        calibration,
    );
}

fn keypoints(offset: f64) -> Vec<f64> {
    (0..21)
        .flat_map(|j| {
            [
                100.0 + offset + j as f64,
                200.0 - j as f64,
                0.5 + j as f64 / 50.0,
            ]
        })
        .collect()
}

#[test]
fn fuzz_openpose() {
    let two_people = json!({"version": 1.3, "people": [
        {"person_id": [-1], "pose_keypoints_2d": [1.0, 2.0, 0.5],
         "hand_left_keypoints_2d": keypoints(0.0), "hand_right_keypoints_2d": keypoints(50.0),
         "hand_left_keypoints_3d": [], "hand_right_keypoints_3d": []},
        {"hand_left_keypoints_2d": [], "hand_right_keypoints_2d": keypoints(300.0)}]});
    let seeds = vec![
        serde_json::to_vec_pretty(&two_people).unwrap(),
        br#"{"version": 1.3, "people": []}"#.to_vec(),
    ];
    run("openpose", &seeds, cases(CI_CASES), mutate_text, |input| {
        let frame = parse_openpose(&text(input), "f_000000000000_keypoints.json")?;
        for h in &frame.hands {
            let _ = h.keypoints.points.len();
        }
        Ok::<_, monohand_io::IoError>(())
    });
}

#[test]
fn fuzz_jsonl() {
    let kp: Vec<[f64; 3]> = keypoints(0.0)
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let joints: Vec<[f64; 3]> = (0..21).map(|j| [j as f64, 2.0 * j as f64, 500.0]).collect();
    let full = json!({"frame": 3, "source": "cam0.mp4", "time_s": 0.1, "image_size": [640, 480],
        "hands": [{"side": "right", "keypoints_2d": kp, "joints_3d_mm": joints,
            "pose": {"translation_mm": [1.0, 2.0, 500.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0],
                     "angles_rad": vec![0.1; 20]},
            "reprojection_error_px": 1.5, "converged": true, "iterations": 12,
            "bbox": [10.0, 20.0, 110.0, 140.0], "score": 0.9, "id": 7, "side_score": 0.8,
            "oriented_box": {"center": [60.0, 80.0], "size": [100.0, 120.0], "angle_deg": 15.0},
            "world_mm": joints, "depth_px": vec![0.5; 21]},
            {"side": "left", "keypoints_2d": kp}],
        "heads": [{"box": [1.0, 2.0, 30.0, 40.0], "score": 0.7}],
        "timings_ms": {"detect": 3.5, "fit": 1.0}});
    let mut file = Vec::new();
    for line in [
        full.clone(),
        json!({"frame": 4, "hands": []}),
        json!({"frame": 5, "error": "cannot decode"}),
        full,
    ] {
        file.extend(serde_json::to_vec(&line).unwrap());
        file.push(b'\n');
    }
    let seeds = vec![file, b"{\"frame\": 0, \"hands\": []}\n\n".to_vec()];
    run("jsonl", &seeds, cases(CI_CASES), mutate_text, |input| {
        let records = parse_jsonl(input, "fuzz.jsonl")?;
        // What `lift` does with each hand next.
        for r in &records {
            for h in &r.hands {
                let _ = h.keypoints();
                let _ = h.cues();
                let _ = h.joints_3d();
                let _ = h.pose.as_ref().map(|p| p.to_pose());
            }
        }
        Ok::<_, monohand_io::IoError>(())
    });
}

#[test]
fn fuzz_bone_lengths() {
    let seeds = vec![
        br#"{"bone_lengths_mm": [35, 40, 30, 25, 90, 45, 25, 20, 88, 48, 28, 22,
                                 84, 44, 27, 21, 80, 35, 20, 19]}"#
            .to_vec(),
        b"[35, 40, 30, 25, 90, 45, 25, 20, 88, 48, 28, 22, 84, 44, 27, 21, 80, 35, 20, 19]"
            .to_vec(),
        shared(DIR, "hand_models/bone_length_stats.json"),
    ];
    run(
        "bone_lengths",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        |input| parse_bone_lengths(&text(input), "bones.json"),
    );
}
