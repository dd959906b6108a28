//! The full stage's bookkeeping with a stand-in detector: detection rate, 2D
//! error of the detections, fps, and the fit on what was detected.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand_core::prelude::*;
use monohand_eval::dataset::project_joints;
use monohand_eval::evaluate::evaluated_joints;
use monohand_eval::metrics::to_joints;
use monohand_eval::*;
use nalgebra::{UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// "Detects" by looking the frame up in a table: the label projected and
/// shifted by 1 px in u, or nothing for frames listed as misses.
struct TableDetector {
    truth: Vec<(PathBuf, Keypoints2d)>,
}

impl ImageDetector for TableDetector {
    fn describe(&self) -> String {
        "table lookup (test)".into()
    }
    fn detect(&mut self, image: &Path, _camera: &Camera) -> Result<Vec<HandObservation>, String> {
        if image.to_string_lossy().contains("missing") {
            return Err("no such image".into());
        }
        Ok(self
            .truth
            .iter()
            .filter(|(p, _)| p == image)
            .map(|(_, k)| HandObservation {
                side: HandSide::Right,
                keypoints: *k,
                cues: None,
            })
            .collect())
    }
}

#[test]
fn detection_rate_2d_error_and_fit() {
    let cam = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
    let sk = HandSkeleton::default_for(HandSide::Right);
    let mut frames = Vec::new();
    let mut truth = Vec::new();
    for i in 0..8 {
        let pose = HandPose {
            translation: Vector3::new(10.0 * i as f64, -5.0, 450.0),
            rotation: UnitQuaternion::from_euler_angles(3.0, 0.1 * i as f64, 0.2),
            ..HandPose::default()
        };
        let joints = to_joints(&forward_kinematics(&sk, &pose));
        let image = PathBuf::from(format!("img/{i}.png"));
        if i % 4 != 3 {
            let mut k = project_joints(&cam, &joints);
            for p in k.points.iter_mut() {
                p[0] += 1.0;
            }
            truth.push((image.clone(), k));
        }
        frames.push(Frame {
            sequence: "s".into(),
            index: i,
            images: vec![image],
            cameras: vec![cam],
            hands: vec![GtHand {
                side: HandSide::Right,
                joints_3d: joints,
                keypoints_2d: None,
            }],
        });
    }
    let ds = Dataset {
        name: "synthetic".into(),
        source: PathBuf::from("-"),
        root: RootJoint::Wrist,
        frames,
    };
    let settings = EvalSettings {
        modes: vec![ViewMode::Mono],
        skeleton: SkeletonChoice::Default,
        ..EvalSettings::default()
    };
    let mut src = Detected(TableDetector { truth });
    let (runs, _) = evaluate(&ds, &mut src, &settings, None).unwrap();
    let s = runs[0].summary(&evaluated_joints(ds.root));
    assert_eq!((s.hands, s.detected), (8, 6));
    assert!((s.detection_rate() - 0.75).abs() < 1e-12);
    assert!((s.keypoints_px - 1.0).abs() < 1e-9, "{}", s.keypoints_px);
    // A 1 px shift of every keypoint is a small sideways move of the hand.
    assert!(s.pa_mpjpe < 1.0 && s.mpjpe < 5.0, "{s:?}");
    assert!(s.fps.is_finite() && s.fps > 0.0);
    assert!(runs[0].source.contains("table lookup"));

    // A detector failure is an error naming the image, not a silent miss.
    let mut bad = ds.clone();
    bad.frames[0].images = vec![PathBuf::from("missing.png")];
    let mut src = Detected(TableDetector { truth: Vec::new() });
    let e = evaluate(&bad, &mut src, &settings, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing.png") && e.contains("no such image"),
        "{e}"
    );
    // Label-only frames cannot run the full stage.
    bad.frames[0].images.clear();
    let e = evaluate(&bad, &mut src, &settings, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("needs images"), "{e}");
}

#[test]
fn dropped_joints_and_bad_settings() {
    let cam = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
    let sk = HandSkeleton::default_for(HandSide::Left);
    let pose = HandPose {
        translation: Vector3::new(0.0, 0.0, 500.0),
        rotation: UnitQuaternion::from_euler_angles(3.0, 0.2, 0.1),
        ..HandPose::default()
    };
    let joints = to_joints(&forward_kinematics(&sk, &pose));
    let frame = Frame {
        sequence: String::new(),
        index: 0,
        images: vec![],
        cameras: vec![cam],
        hands: vec![GtHand {
            side: HandSide::Left,
            joints_3d: joints,
            keypoints_2d: None,
        }],
    };
    let mut src = ProjectedLabels::new(0.0, 5, 3).unwrap();
    let k = src.keypoints(&frame).unwrap()[0][0].unwrap();
    assert_eq!(k.keypoints.count_usable(0.5), 16);
    assert!(ProjectedLabels::new(-1.0, 0, 0).is_err());
    assert!(ProjectedLabels::new(1.0, 22, 0).is_err());
    let ds = Dataset {
        name: "one".into(),
        source: PathBuf::from("-"),
        root: RootJoint::Wrist,
        frames: vec![frame],
    };
    let settings = EvalSettings {
        skeleton: SkeletonChoice::Default,
        ..EvalSettings::default()
    };
    let e = evaluate(&ds, &mut src, &settings, Some(0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("stereo needs two cameras"), "{e}");
    // 16 of 21 exact keypoints still pin the hand down.
    let mono = EvalSettings {
        modes: vec![ViewMode::Mono],
        ..settings
    };
    let (runs, _) = evaluate(&ds, &mut src, &mono, Some(0.0)).unwrap();
    assert!(runs[0].summary(&evaluated_joints(ds.root)).mpjpe < 5.0);
}
