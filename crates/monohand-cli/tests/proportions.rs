//! `--proportion-frames`: the hand's proportions learnt from the network's metric 3D, in
//! `lift` (from the JSON Lines input's `world_mm`) and in `run` (from the landmark
//! network, the first frames kept back until the estimate is made).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;
use common::*;
use monohand_core::prelude::*;
use monohand_io::calibration::write_camera_json;
use monohand_io::jsonl::{read_jsonl, FrameRecord, HandRecord, JsonlWriter};
use monohand_testkit::dev_set_dir;
use nalgebra::{UnitQuaternion, Vector3};

/// The mean over fingers of (proximal + middle + distal) / wrist-to-base length of the
/// lifted joints of every frame.
fn finger_to_palm(joints: &[[Vector3<f64>; 21]]) -> f64 {
    let d = |j: &[Vector3<f64>; 21], a: usize, b: usize| (j[a] - j[b]).norm();
    let per_frame = joints.iter().map(|j| {
        (0..5)
            .map(|f| {
                let base = 4 * f + 1;
                (d(j, base, base + 1) + d(j, base + 1, base + 2) + d(j, base + 2, base + 3))
                    / d(j, 0, base)
            })
            .sum::<f64>()
            / 5.0
    });
    per_frame.clone().sum::<f64>() / per_frame.count() as f64
}

#[test]
fn lift_learns_the_proportions_from_world_landmarks() {
    let tmp = tempfile::tempdir().unwrap();
    let camera = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
    let cam_path = tmp.path().join("cam.json");
    write_camera_json(&cam_path, &camera).unwrap();
    // A subject whose phalanges are 15% longer than the default hand's, same palm.
    let template = HandSkeleton::default_for(HandSide::Left);
    let mut lengths = template.bone_lengths();
    for (b, l) in lengths.iter_mut().enumerate() {
        if b % 4 != 0 {
            *l *= 1.15;
        }
    }
    let subject = template.with_bone_lengths(&lengths).unwrap();
    // 24 frames of the hand turning and its fingers bending, 450 mm away.
    let frames: Vec<[Vector3<f64>; 21]> = (0..24)
        .map(|k| {
            let t = k as f64 / 24.0;
            let mut pose = HandPose {
                translation: Vector3::new(-20.0, 10.0, 450.0),
                rotation: UnitQuaternion::from_euler_angles(0.3 * t, -0.4 + 0.5 * t, 0.2),
                ..HandPose::default()
            };
            for (i, a) in pose.angles.iter_mut().enumerate() {
                if i % 4 != 1 {
                    *a = 0.6 * t * (1.0 + (i as f64 * 0.7).sin()) * 0.5;
                }
            }
            subject.limits.clamp(&mut pose.angles);
            forward_kinematics(&subject, &pose)
        })
        .collect();
    let input = tmp.path().join("in.jsonl");
    let mut w = JsonlWriter::create(&input).unwrap();
    for (i, j) in frames.iter().enumerate() {
        let mut kp = Keypoints2d::default();
        for (k, x) in j.iter().enumerate() {
            let px = camera.project(x).unwrap();
            kp.points[k] = [px.x, px.y, 1.0];
        }
        w.write_frame(&FrameRecord {
            frame: i as u64,
            hands: vec![HandRecord {
                world_mm: Some(j.map(|x| [x.x, x.y, x.z - 450.0])),
                ..HandRecord::from_keypoints(HandSide::Left, &kp)
            }],
            ..Default::default()
        })
        .unwrap();
    }
    drop(w);
    let lift = |extra: &[&str]| {
        let out = tmp.path().join("out.jsonl");
        let mut args = vec![
            "lift",
            "--camera",
            p(&cam_path),
            "--jsonl",
            p(&input),
            "--output",
            p(&out),
            "--track",
        ];
        // The skeleton's own joints, so that their bone lengths are the model's.
        args.extend_from_slice(&NO_FUSION);
        args.extend_from_slice(extra);
        let o = monohand(&args);
        ok(&o);
        let joints: Vec<[Vector3<f64>; 21]> = read_jsonl(&out)
            .unwrap()
            .iter()
            .map(|r| r.hands[0].joints_3d().expect("a 3D hand"))
            .collect();
        assert_eq!(joints.len(), frames.len());
        (
            finger_to_palm(&joints),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let truth = finger_to_palm(&frames);
    let (default, _) = lift(&[]);
    let (learnt, said) = lift(&["--proportion-frames", "12"]);
    assert!(
        (default / truth - 1.0).abs() > 0.1,
        "the default hand already has the subject's proportions: {default} vs {truth}"
    );
    assert!(
        (learnt / truth - 1.0).abs() < 0.01,
        "learnt {learnt}, subject {truth}"
    );
    assert!(
        said.contains("left hand proportions from 12 frames, settled"),
        "{said}"
    );
}

#[test]
fn run_keeps_the_first_frames_back_and_says_what_it_learnt() {
    assert!(networks_ready(), "the networks must be available");
    let tmp = tempfile::tempdir().unwrap();
    let images = dev_set_dir().join("images");
    let out = tmp.path().join("out.jsonl");
    let o = monohand(&[
        "run",
        p(&images),
        "--max-frames",
        "20",
        "--proportion-frames",
        "8",
        "--output",
        p(&out),
    ]);
    ok(&o);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        said.contains("--proportion-frames: left hand proportions from 8 frames"),
        "{said}"
    );
    // Every frame is written, in order, the kept-back ones included.
    let records = read_jsonl(&out).unwrap();
    assert_eq!(records.len(), 20);
    assert!(records.iter().enumerate().all(|(i, r)| r.frame == i as u64));
    assert!(records
        .iter()
        .all(|r| r.hands.iter().any(|h| h.joints_3d().is_some())));
}
