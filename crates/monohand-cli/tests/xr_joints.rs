//! `lift --xr-joints`: each fitted hand's OpenXR joints in the records, from the binary.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;
use common::*;
use monohand_core::prelude::*;
use monohand_core::xr::{xr_joints, XR_JOINT_NAMES};
use monohand_io::calibration::write_camera_json;
use monohand_io::jsonl::{read_jsonl, FrameRecord, HandRecord, JsonlWriter};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

#[test]
fn lift_writes_xr_joints_when_asked() {
    let tmp = tempfile::tempdir().unwrap();
    let camera = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
    let cam_path = tmp.path().join("cam.json");
    write_camera_json(&cam_path, &camera).unwrap();
    // A right hand with its fingers bent, turned, 420 mm away, seen in 2D only: the fit
    // poses the planar thumb then (HandFitter::skeleton), so the truth does too.
    let sk = HandSkeleton::default_for(HandSide::Right).planar_thumb();
    let mut truth = HandPose {
        translation: Vector3::new(15.0, -10.0, 420.0),
        rotation: UnitQuaternion::from_euler_angles(2.9, 0.3, -0.2),
        ..HandPose::default()
    };
    for (i, a) in truth.angles.iter_mut().enumerate() {
        *a = match i % 4 {
            1 => 0.05,
            _ => 0.3 + 0.02 * i as f64,
        };
    }
    let joints = forward_kinematics(&sk, &truth);
    let mut kp = Keypoints2d::default();
    for (k, x) in joints.iter().enumerate() {
        let px = camera.project(x).unwrap();
        kp.points[k] = [px.x, px.y, 1.0];
    }
    let input = tmp.path().join("in.jsonl");
    let mut w = JsonlWriter::create(&input).unwrap();
    w.write_frame(&FrameRecord {
        frame: 0,
        hands: vec![HandRecord::from_keypoints(HandSide::Right, &kp)],
        ..Default::default()
    })
    .unwrap();
    drop(w);
    let lift = |name: &str, extra: &[&str]| {
        let out = tmp.path().join(name);
        let mut args = vec!["lift", "--camera", p(&cam_path), "--jsonl", p(&input)];
        args.extend_from_slice(&["--output", p(&out)]);
        args.extend_from_slice(extra);
        ok(&monohand(&args));
        read_jsonl(&out).unwrap().remove(0).hands.remove(0)
    };
    let plain = lift("plain.jsonl", &[]);
    assert!(plain.xr_joints.is_none(), "off by default");
    let hand = lift("xr.jsonl", &["--xr-joints"]);
    let fitted = hand.joints_3d().unwrap();
    let xr = hand.xr_joints.as_ref().unwrap();
    assert_eq!(xr.len(), 26);
    let names: Vec<&str> = xr.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, XR_JOINT_NAMES);
    // The joints the model has are the record's, and the index finger's proximal joint
    // looks down its phalanx at the intermediate joint.
    assert_eq!(xr[7].position_mm, hand.joints_3d_mm.unwrap()[5]);
    let q = |j: usize| {
        let [x, y, z, w] = xr[j].orientation_xyzw;
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
    };
    let forward = q(7) * -Vector3::z();
    let bone = Vector3::from(xr[8].position_mm) - Vector3::from(xr[7].position_mm);
    let off = forward.cross(&bone).norm().atan2(forward.dot(&bone));
    assert!(off < 1e-6, "index proximal -Z off its bone by {off} rad");
    assert!((bone - (fitted[6] - fitted[5])).norm() < 1e-9);
    // The fit found the hand (its joints within 0.1 mm of the truth's), so its XR joints
    // are the truth's: those of the same joints, oriented by the default hand's axes (a
    // record's, whichever thumb hinge the fit posed).
    assert!((0..21).all(|j| (fitted[j] - joints[j]).norm() < 0.1));
    let default = HandSkeleton::default_for(HandSide::Right);
    let want = xr_joints(&default, &truth, &joints).unwrap();
    let worst = (0..26)
        .map(|j| q(j).angle_to(&want[j].orientation).to_degrees())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.1,
        "a joint turned {worst:.3} degrees from the truth's"
    );
    assert!(xr.iter().all(|j| (4.0..25.0).contains(&j.radius_mm)));
}
