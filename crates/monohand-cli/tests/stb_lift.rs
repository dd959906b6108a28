//! End to end on real data: the STB B1Counting 3D labels (a left hand, mm, left
//! camera frame) projected with the real STB stereo cameras into OpenPose files,
//! lifted back by the built binary, compared with the labels.
//!
//! STB has no wrist (its root is the palm centre), so joint 0 is given with
//! confidence 0 and errors are measured on joints 1..21. The fit uses the
//! default skeleton, not the subject's, so errors are dominated by the model/
//! subject mismatch:
//!
//! - mono: depth is fixed by the assumed hand size. The default hand is ~6%
//!   larger than the STB subject, so the hand is placed ~6% too far (~40 mm at
//!   650 mm); the centroid-aligned (shape) error is 12-15 mm.
//! - stereo: the baseline fixes the depth (bias < 1%), leaving the shape error.
//!
//! Measured on 60 frames spread over the sequence (every 25th), debug build of
//! this repository at the time of writing: mono mean 47.1 mm (p90 76.2,
//! centroid-aligned 15.4, depth ratio 1.063); stereo mean 14.3 mm (p90 17.6,
//! depth ratio 1.007). Bounds below leave ~15-25% headroom for solver changes.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;
use common::*;
use monohand_core::prelude::*;
use monohand_io::calibration::write_camera_json;
use monohand_io::jsonl::{read_jsonl, FrameRecord};
use monohand_testkit::stb_dir;
use nalgebra::Vector3;
use std::path::Path;

struct Summary {
    mean: f64,
    p90: f64,
    shape: f64,
    depth_ratio: f64,
    iterations: f64,
}

fn summarise(out: &Path, labels: &[[Vector3<f64>; 21]]) -> Summary {
    let e = errors(out, labels);
    let (mean, p90) = stats(&e);
    let recs: Vec<FrameRecord> = read_jsonl(out).unwrap();
    let (mut shape, mut ratio, mut iters) = (Vec::new(), Vec::new(), 0.0);
    for (r, truth) in recs.iter().zip(labels) {
        let h = &r.hands[0];
        let j = h.joints_3d().unwrap();
        let cf: Vector3<f64> = (1..21).map(|k| j[k]).sum::<Vector3<f64>>() / 20.0;
        let ct: Vector3<f64> = (1..21).map(|k| truth[k]).sum::<Vector3<f64>>() / 20.0;
        shape.push(
            (1..21)
                .map(|k| ((j[k] - cf) - (truth[k] - ct)).norm())
                .sum::<f64>()
                / 20.0,
        );
        ratio.push(cf.z / ct.z);
        iters += h.iterations.unwrap() as f64;
        // The pose and the joints agree: the wrist is the translation.
        let t = h.pose.unwrap().translation_mm;
        assert!((Vector3::from(t) - j[0]).norm() < 1e-6);
        assert!(h.reprojection_error_px.unwrap() < 20.0);
    }
    Summary {
        mean,
        p90,
        shape: stats(&shape).0,
        depth_ratio: stats(&ratio).0,
        iterations: iters / recs.len() as f64,
    }
}

struct Fixture {
    _tmp: tempfile::TempDir,
    dir: std::path::PathBuf,
    labels: Vec<[Vector3<f64>; 21]>,
    left: Camera,
}

fn fixture(step: usize, n: usize) -> Option<Fixture> {
    let stb = stb_dir();
    let (mut labels, left, right) = stb_frames(&stb, step);
    labels.truncate(n);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    write_camera_json(dir.join("left.json"), &left).unwrap();
    write_camera_json(dir.join("right.json"), &right).unwrap();
    write_view(&dir.join("L"), &left, &labels);
    write_view(&dir.join("R"), &right, &labels);
    Some(Fixture {
        _tmp: tmp,
        dir,
        labels,
        left,
    })
}

impl Fixture {
    fn lift(&self, name: &str, stereo: bool, extra: &[&str]) -> Summary {
        let d = &self.dir;
        let (lj, ld, rj, rd) = (
            d.join("left.json"),
            d.join("L"),
            d.join("right.json"),
            d.join("R"),
        );
        let out = d.join(format!("{name}.jsonl"));
        let mut args = vec!["lift", "--camera", p(&lj), "--openpose", p(&ld)];
        if stereo {
            args.extend(["--camera", p(&rj), "--openpose", p(&rd)]);
        }
        args.extend(["--output", p(&out)]);
        args.extend(extra);
        let o = monohand(&args);
        ok(&o);
        // Clean input: no warnings at all.
        assert!(
            o.stderr.is_empty(),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let s = summarise(&out, &self.labels);
        println!(
            "{name}: mean {:.2} mm, p90 {:.2}, shape {:.2}, depth ratio {:.3}, {:.1} iterations",
            s.mean, s.p90, s.shape, s.depth_ratio, s.iterations
        );
        s
    }
}

#[test]
fn stb_mono_and_stereo_lift() {
    let Some(fx) = fixture(25, 60) else { return };
    let mono = fx.lift("mono", false, &[]);
    let stereo = fx.lift("stereo", true, &[]);
    // Mono: the depth bias of the size assumption, and the shape error.
    assert!(mono.mean < 55.0 && mono.p90 < 90.0, "mono too far off");
    assert!(mono.shape < 18.0, "mono shape error {:.2}", mono.shape);
    assert!(
        (1.03..1.10).contains(&mono.depth_ratio),
        "the default hand is ~6% larger than the STB subject: depth ratio {:.3}",
        mono.depth_ratio
    );
    // Stereo fixes the depth.
    assert!(
        stereo.mean < 17.0 && stereo.p90 < 21.0,
        "stereo too far off"
    );
    assert!((stereo.depth_ratio - 1.0).abs() < 0.02);
    assert!(
        stereo.mean < 0.4 * mono.mean,
        "stereo must beat mono clearly"
    );

    // The output echoes the first view's keypoints.
    let recs = read_jsonl(fx.dir.join("stereo.jsonl")).unwrap();
    let kp = project(&fx.left, &fx.labels[3]);
    assert_eq!(recs[3].hands[0].keypoints_2d, kp.points);
    assert_eq!(
        recs[3].source.as_deref(),
        Some("stb_000000000003_keypoints.json")
    );
}

#[test]
fn stb_tracking_and_skeleton_flags() {
    // 40 consecutive frames: what tracking is for.
    let Some(fx) = fixture(1, 40) else { return };
    let single = fx.lift("single", false, &[]);
    let tracked = fx.lift("tracked", false, &["--track"]);
    let tracked_stereo = fx.lift("tracked_stereo", true, &["--track"]);
    assert!(tracked.mean < 50.0 && tracked.shape < 15.0);
    assert!(tracked_stereo.mean < 17.0);
    // Measured: 66.8 vs 95.3 after the LM's failed-step backtracking (the default hand
    // does not fit this subject exactly, so some warm fits exceed the 5 px reset and the
    // tracker also tries a cold fit, whose count is reported when it wins).
    assert!(
        tracked.iterations < 0.8 * single.iterations,
        "a warm start must need fewer iterations ({:.1} vs {:.1})",
        tracked.iterations,
        single.iterations
    );
    // A smaller hand model moves the hand closer, in proportion.
    let small = fx.lift("small", false, &["--hand-scale", "0.9"]);
    assert!(small.depth_ratio < single.depth_ratio - 0.05);
    // --bone-lengths with the default lengths scaled by 0.9 is --hand-scale 0.9, up to
    // rounding in the skeleton (1e-13 mm), which the iteration-capped solver (95 of its
    // 100 iterations here) does not erase: single frames end up to 4.7 mm apart, the
    // means 0.04 mm (full thumb) and 0.16 mm (planar thumb, what 2D-only fits pose).
    let lengths = HandSkeleton::default_for(HandSide::Left)
        .scaled(0.9)
        .unwrap()
        .bone_lengths();
    let bl = fx.dir.join("bones.json");
    std::fs::write(
        &bl,
        serde_json::json!({ "bone_lengths_mm": lengths }).to_string(),
    )
    .unwrap();
    let via_file = fx.lift("bones", false, &["--bone-lengths", p(&bl)]);
    assert!((via_file.mean - small.mean).abs() < 0.3);
    assert!((via_file.depth_ratio - small.depth_ratio).abs() < 1e-3);
}
