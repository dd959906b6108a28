//! Helpers shared by the CLI integration tests: real STB labels projected with
//! the real STB cameras into OpenPose files, and running the built binary.

#![allow(dead_code)]

use monohand_core::prelude::*;
use monohand_eval::stb::{stb_cameras, StbSequence};
use monohand_io::jsonl::{read_jsonl, FrameRecord};
use monohand_io::openpose::{write_openpose_file, OpenPoseHandOut, OpenPosePerson};
use nalgebra::Vector3;
use std::path::Path;
use std::process::{Command, Output};

/// Every `step`-th STB frame (3D joints, our order; index 0 = palm centre) and the stereo pair.
pub fn stb_frames(dir: &Path, step: usize) -> (Vec<[Vector3<f64>; 21]>, Camera, Camera) {
    let seq = StbSequence::load(dir.join("labels/B1Counting_BB.mat")).expect("STB labels");
    let (left, right) = stb_cameras(dir.join("camera_params.json")).expect("STB cameras");
    let frames = seq.frames.iter().step_by(step).map(|f| f.joints).collect();
    (frames, left, right)
}

/// Projects the joints; joint 0 (the STB palm centre, not a wrist) gets confidence 0.
pub fn project(camera: &Camera, joints: &[Vector3<f64>; 21]) -> Keypoints2d {
    let mut kp = Keypoints2d::default();
    for (j, x) in joints.iter().enumerate().skip(1) {
        let px = camera.project(x).expect("label in front of the camera");
        kp.points[j] = [px.x, px.y, 1.0];
    }
    kp
}

/// Writes one OpenPose file per frame (left hand) into `dir`.
pub fn write_view(dir: &Path, camera: &Camera, frames: &[[Vector3<f64>; 21]]) {
    std::fs::create_dir_all(dir).unwrap();
    for (i, joints) in frames.iter().enumerate() {
        let person = OpenPosePerson {
            left: Some(OpenPoseHandOut {
                keypoints_2d: project(camera, joints),
                joints_3d: None,
            }),
            right: None,
        };
        write_openpose_file(dir.join(format!("stb_{i:012}_keypoints.json")), &[person]).unwrap();
    }
}

/// Flags that turn every fusion off: the output joints are the posed skeleton's.
pub const NO_FUSION: [&str; 6] = [
    "--fuse-world",
    "0",
    "--fuse-depth",
    "0",
    "--fuse-pixels",
    "0",
];

/// Runs the built `monohand` binary.
pub fn monohand(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args(args)
        .output()
        .expect("run monohand")
}

/// Panics with the binary's stderr unless it succeeded.
pub fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "monohand failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Per-frame mean distance (mm) over joints 1..21 between the fitted left hand and the labels.
pub fn errors(output: &Path, labels: &[[Vector3<f64>; 21]]) -> Vec<f64> {
    let frames: Vec<FrameRecord> = read_jsonl(output).unwrap();
    assert_eq!(frames.len(), labels.len());
    frames
        .iter()
        .zip(labels)
        .map(|(f, truth)| {
            assert_eq!(f.hands.len(), 1, "frame {}: {:?}", f.frame, f.hands);
            let h = &f.hands[0];
            assert_eq!(h.side, HandSide::Left);
            let joints = h.joints_3d().expect("joints_3d_mm");
            (1..21).map(|j| (joints[j] - truth[j]).norm()).sum::<f64>() / 20.0
        })
        .collect()
}

/// Mean and 90th percentile.
pub fn stats(e: &[f64]) -> (f64, f64) {
    let mut s = e.to_vec();
    s.sort_by(f64::total_cmp);
    (s.iter().sum::<f64>() / s.len() as f64, s[s.len() * 9 / 10])
}

pub fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 temp path")
}

/// Fetches the networks through the CLI; `false` (after SKIP) when pip or the network is
/// missing and `MONOHAND_REQUIRE_MODELS` is unset (CI sets it: there a failure panics).
pub fn networks_ready() -> bool {
    let out = monohand(&["models", "fetch"]);
    if out.status.success() {
        return true;
    }
    let err = String::from_utf8_lossy(&out.stderr);
    if std::env::var_os("MONOHAND_REQUIRE_MODELS").is_none() && err.contains("pip") {
        eprintln!("SKIP: MediaPipe networks unavailable: {err}");
        return false;
    }
    panic!("monohand models fetch failed: {err}");
}

/// The serials of the table rig's 4 views (`../shared/data/table_rig_dev`), the master first.
pub const RIG_SERIALS: [&str; 4] = [
    "141122079464",
    "141722072294",
    "141722075121",
    "141722076181",
];

/// The table rig's folder; a clear failure when it is missing.
pub fn table_rig() -> std::path::PathBuf {
    let d = monohand_testkit::shared_data().join("table_rig_dev");
    assert!(
        d.join("cameras").is_dir() && d.join("images").is_dir(),
        "the table rig is missing at {} (../shared/data beside the repository)",
        d.display()
    );
    d
}
