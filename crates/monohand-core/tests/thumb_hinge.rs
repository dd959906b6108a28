//! The default thumb's hinge against its source, UmeTrack's generic hand model
//! (`../shared/data/hand_models/umetrack/generic_hand_model.json`, a population
//! model independent of every evaluation subject).
//!
//! The model's thumb is posed so that its metacarpal points where UmeTrack's does
//! at rest; its hinge axis must then lie within a few degrees of UmeTrack's MCP and
//! IP flexion axes, rolled about the metacarpal (`THUMB_HINGE_ROLL_DEG` is the mean
//! of the two). Before that roll the axes were 39 and 48 degrees apart.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand_core::hand_model::{palm_frame, Finger, HandSide, HandSkeleton, NUM_JOINTS};
use monohand_core::kinematics::finger_chain;
use nalgebra::Vector3;
use std::path::PathBuf;

fn umetrack() -> serde_json::Value {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/hand_models/umetrack/generic_hand_model.json");
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| {
        panic!(
            "UmeTrack's hand model not found at {} ({e}; needs ../shared beside the repo)",
            p.display()
        )
    });
    serde_json::from_str(&text).expect("UmeTrack JSON")
}

fn rows(v: &serde_json::Value, key: &str) -> Vec<Vector3<f64>> {
    v[key]
        .as_array()
        .expect(key)
        .iter()
        .map(|r| {
            let r: Vec<f64> = r
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            // UmeTrack's generic hand is a left hand: mirror it (z -> -z) to compare
            // with the right-hand skeleton.
            Vector3::new(r[0], r[1], -r[2])
        })
        .collect()
}

/// Signed angle (degrees) from `u` to `v` about `m`, both projected perpendicular to `m`.
fn roll_deg(u: Vector3<f64>, v: Vector3<f64>, m: Vector3<f64>) -> f64 {
    let u = (u - m * u.dot(&m)).normalize();
    let v = (v - m * v.dot(&m)).normalize();
    u.cross(&v).dot(&m).atan2(u.dot(&v)).to_degrees()
}

#[test]
fn default_thumb_hinge_follows_umetrack() {
    let model = umetrack();
    let joints = rows(&model, "joint_rest_positions");
    let axes = rows(&model, "joint_rotation_axes");
    let landmarks = rows(&model, "landmark_rest_positions");
    // UmeTrack's landmarks: 5 = wrist, 8 / 11 / 17 = index / middle / little MCP.
    let mut ours = [Vector3::zeros(); NUM_JOINTS];
    ours[0] = landmarks[5];
    ours[5] = landmarks[8];
    ours[9] = landmarks[11];
    ours[17] = landmarks[17];
    let (r, _) = palm_frame(&ours, HandSide::Right).expect("palm frame");
    let to_palm = r.inverse();
    // Thumb joints 1 (CMC) and 2 (MCP) bound the metacarpal; joints 2 and 3 carry
    // the MCP and IP flexion axes.
    let meta = (to_palm * (joints[2] - joints[1])).normalize();
    let (mcp, ip) = (to_palm * axes[2], to_palm * axes[3]);
    assert!(
        (to_palm * (landmarks[0] - landmarks[5])).z > 0.0,
        "the mirrored thumb tip must lie on the palmar side"
    );

    // Pose the default right thumb (CMC flexion and abduction) onto that metacarpal.
    let sk = HandSkeleton::default_for(HandSide::Right);
    let mut angles = sk.limits.neutral();
    let mut best = (f64::INFINITY, Vector3::zeros(), Vector3::zeros());
    for flex in (-60..=90).map(|d| f64::from(d).to_radians()) {
        for abd in (-60..=60).map(|d| f64::from(d).to_radians()) {
            angles[0] = flex;
            angles[1] = abd;
            let c = finger_chain(&sk, Finger::Thumb, &angles);
            let d = (c.points[1] - c.points[0]).normalize();
            let err = d.dot(&meta).clamp(-1.0, 1.0).acos();
            if err < best.0 {
                best = (err, d, c.flexion_axis);
            }
        }
    }
    assert!(
        best.0.to_degrees() < 1.5,
        "metacarpal not reached: {} deg",
        best.0.to_degrees()
    );
    // Axes are lines: compare modulo 180 degrees.
    let line = |a: f64| {
        let a = a.rem_euclid(180.0);
        a.min(180.0 - a)
    };
    let (m, h) = (best.1, best.2);
    let (r_mcp, r_ip) = (line(roll_deg(h, mcp, m)), line(roll_deg(h, ip, m)));
    assert!(
        r_mcp < 6.0 && r_ip < 6.0,
        "hinge off UmeTrack's: MCP {r_mcp:.1}, IP {r_ip:.1} deg"
    );
}
