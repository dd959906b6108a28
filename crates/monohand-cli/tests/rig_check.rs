//! A rig that checks itself (issue 57), on the real table rig
//! (`../shared/data/table_rig_dev`, its 4 views, all 148 frames, tracked): every record
//! says how each view agreed with each fitted hand, and the run's summary names a camera
//! whose file was turned by 2 degrees and a video 3 frames ahead of the others, and
//! nothing on the unchanged rig.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, networks_ready, ok, p, table_rig as rig, RIG_SERIALS as SERIALS};
use monohand_io::jsonl::read_jsonl;
use std::path::{Path, PathBuf};

/// Runs the rig with these views' image folders and camera files; its records and stderr.
fn run(dir: &Path, views: &[PathBuf], cameras: &[PathBuf]) -> (Vec<serde_json::Value>, String) {
    let out = dir.join(format!("rig{}.jsonl", std::process::id()));
    let mut args: Vec<String> = vec!["run".into(), "--track".into()];
    for (v, c) in views.iter().zip(cameras) {
        args.extend(["--view".into(), p(v).into(), "--camera".into(), p(c).into()]);
    }
    args.extend(["-o".into(), p(&out).into()]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = monohand(&refs);
    ok(&o);
    let text = std::fs::read_to_string(&out).unwrap();
    let records = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // The typed reader takes the new fields too.
    assert!(!read_jsonl(&out).unwrap().is_empty());
    (records, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The rig's image folders and camera files, its 4 views given `copies` times over.
fn rig_files(rig: &Path, copies: usize) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let serials = || SERIALS.iter().cycle().take(SERIALS.len() * copies);
    let views = serials().map(|s| rig.join("images").join(s)).collect();
    let cameras = serials()
        .map(|s| rig.join("cameras").join(format!("{s}.json")))
        .collect();
    (views, cameras)
}

/// The lines of the summary that name a view.
fn named(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains("stays far off") || l.contains("check its calibration"))
        .collect()
}

/// The summary names view `view`, whose files include `file`, and no other view.
fn named_only(stderr: &str, view: usize, file: &Path) {
    let lines = named(stderr);
    assert_eq!(lines.len(), 2, "{stderr}");
    assert!(
        lines[0].contains(&format!("view {view} stays far off")),
        "{stderr}"
    );
    assert!(lines[0].matches("stays far off").count() == 1, "{stderr}");
    assert!(
        lines[1].starts_with(&format!("view {view}: ")) && lines[1].contains(p(file)),
        "{stderr}"
    );
}

/// A camera file turned by `deg` degrees about its own y axis (`R' = R_y R`, `t' = R_y t`).
fn turned(camera: &Path, deg: f64, out: &Path) {
    let mut c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(camera).unwrap()).unwrap();
    let r = |i: usize, j: usize| -> f64 {
        c.get("R").map_or(if i == j { 1.0 } else { 0.0 }, |r| {
            r[i][j].as_f64().unwrap()
        })
    };
    let t = |i: usize| -> f64 { c.get("t").map_or(0.0, |t| t[i].as_f64().unwrap()) };
    let (s, co) = deg.to_radians().sin_cos();
    let ry = [[co, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, co]];
    let rotated: Vec<Vec<f64>> = (0..3)
        .map(|i| {
            (0..3)
                .map(|j| (0..3).map(|k| ry[i][k] * r(k, j)).sum())
                .collect()
        })
        .collect();
    let moved: Vec<f64> = (0..3)
        .map(|i| (0..3).map(|k| ry[i][k] * t(k)).sum())
        .collect();
    c["R"] = serde_json::json!(rotated);
    c["t"] = serde_json::json!(moved);
    std::fs::write(out, c.to_string()).unwrap();
}

#[test]
fn the_rig_names_a_turned_camera_and_a_late_video_and_nothing_when_unchanged() {
    let rig = rig();
    assert!(networks_ready(), "the networks are needed");
    let tmp = tempfile::tempdir().unwrap();
    let (views, cameras) = rig_files(&rig, 1);

    // Unchanged: every record says how each of the 4 views agreed; nothing is named.
    let (records, stderr) = run(tmp.path(), &views, &cameras);
    assert_eq!(records.len(), 148);
    let mut hands = 0;
    for r in &records {
        for h in r["hands"].as_array().unwrap() {
            if h.get("joints_3d_mm").is_none() {
                continue;
            }
            let v = h["views"].as_array().expect("views in a multi-view record");
            assert_eq!(v.len(), 4, "{h}");
            let used = v.iter().filter(|x| x["used"] == true).count();
            assert!(
                used >= 1
                    && v.iter()
                        .all(|x| (x["used"] == true) == x.get("offset_px").is_some())
            );
            hands += 1;
        }
    }
    assert!(hands >= 140, "hands with 3D: {hands}");
    assert!(
        stderr.contains("views' median reprojection error 1: "),
        "{stderr}"
    );
    assert!(named(&stderr).is_empty(), "{stderr}");

    // The 4th camera's file turned by 2 degrees: it is named, and only it.
    let turned_file = tmp.path().join("turned.json");
    turned(&cameras[3], 2.0, &turned_file);
    let mut bumped = cameras.clone();
    bumped[3] = turned_file.clone();
    let (_, stderr) = run(tmp.path(), &views, &bumped);
    named_only(&stderr, 4, &turned_file);

    // The 4th video 3 frames ahead (its frame i is the others' i + 3): it is named.
    let late = tmp.path().join("late");
    std::fs::create_dir(&late).unwrap();
    for i in 3..148 {
        let from = views[3].join(format!("color_{i:06}.jpg"));
        std::os::unix::fs::symlink(from, late.join(format!("color_{:06}.jpg", i - 3))).unwrap();
    }
    let mut shifted = views.clone();
    shifted[3] = late.clone();
    let (records, stderr) = run(tmp.path(), &shifted, &cameras);
    assert_eq!(records.len(), 148);
    named_only(&stderr, 4, &late);
}

/// Eight views (the rig's 4, each given twice: the networks' work of eight views) run in
/// int8 by default (`--precision auto` from `monohand::INT8_FROM_VIEWS` views), say so, and
/// the rig check still names nothing on the unchanged rig and the one turned camera file.
#[test]
fn eight_views_run_in_int8_and_the_rig_check_still_holds() {
    let rig = rig();
    assert!(networks_ready(), "the networks are needed");
    let tmp = tempfile::tempdir().unwrap();
    let (views, cameras) = rig_files(&rig, 2);
    let (records, stderr) = run(tmp.path(), &views, &cameras);
    assert_eq!(records.len(), 148);
    assert!(
        records.iter().all(|r| r["precision"] == "int8"),
        "{}",
        records[0]
    );
    assert!(
        stderr.contains("8 views: the networks run in int8"),
        "{stderr}"
    );
    let fitted = records
        .iter()
        .filter(|r| {
            r["hands"]
                .as_array()
                .unwrap()
                .iter()
                .any(|h| h.get("joints_3d_mm").is_some())
        })
        .count();
    assert!(fitted >= 140, "frames with a 3D hand: {fitted}");
    assert!(named(&stderr).is_empty(), "{stderr}");

    // The 8th camera's file (the 4th's twin) turned by 2 degrees: it is named, and only it.
    let turned_file = tmp.path().join("turned.json");
    turned(&cameras[7], 2.0, &turned_file);
    let mut bumped = cameras.clone();
    bumped[7] = turned_file.clone();
    let (_, stderr) = run(tmp.path(), &views, &bumped);
    named_only(&stderr, 8, &turned_file);
}

/// The case of a view held closer to the truth by more views (the 8-view rig, where the
/// side view was named for the network's own steady error): the rig's reference 3D as the
/// fit, each view's own tracked keypoints (`run` on the view alone). The side view
/// 141722072294's offset is far above the others', yet it follows the hand, not the
/// camera: the check names nothing; the same offsets with the rule before issue 64 (ratio
/// and floor alone) would have named it. A camera file turned by 2 degrees is still named.
#[test]
fn a_view_held_to_the_truth_is_not_named_for_the_networks_own_error() {
    let rig = rig();
    assert!(networks_ready(), "the networks are needed");
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(rig.join("reference_3d_mm.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let frames = reference["frames"].as_array().unwrap();
    // Each view's keypoints, tracked on its own.
    let keypoints: Vec<Vec<serde_json::Value>> = SERIALS
        .iter()
        .map(|s| {
            let out = tmp.path().join(format!("{s}.jsonl"));
            let (view, camera) = (
                rig.join("images").join(s),
                rig.join("cameras").join(format!("{s}.json")),
            );
            ok(&monohand(&[
                "run",
                p(&view),
                "--camera",
                p(&camera),
                "--track",
                "-o",
                p(&out),
            ]));
            let text = std::fs::read_to_string(&out).unwrap();
            text.lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect()
        })
        .collect();
    let verdict = |cameras: &[monohand_core::camera::Camera]| {
        let mut check = monohand::rig_check::RigCheck::default();
        for (i, truth) in frames.iter().enumerate() {
            let Some(truth) = truth.as_array() else {
                continue;
            };
            let joints: Vec<Option<nalgebra::Vector3<f64>>> = truth
                .iter()
                .map(|x| {
                    let x = x.as_array()?;
                    Some(nalgebra::Vector3::new(
                        x[0].as_f64()?,
                        x[1].as_f64()?,
                        x[2].as_f64()?,
                    ))
                })
                .collect();
            let views = cameras
                .iter()
                .zip(&keypoints)
                .map(|(camera, records)| reference_fit(camera, &joints, &records[i]))
                .collect();
            let mut hand = monohand_io::jsonl::HandRecord::from_keypoints(
                monohand_core::hand_model::HandSide::Right,
                &Default::default(),
            );
            hand.id = Some(0);
            hand.views = Some(views);
            check.add(&monohand_io::jsonl::FrameRecord {
                frame: i as u64,
                hands: vec![hand],
                ..Default::default()
            });
        }
        check.verdict().unwrap()
    };
    let cameras: Vec<_> = SERIALS
        .iter()
        .map(|s| {
            monohand_io::calibration::read_camera(rig.join("cameras").join(format!("{s}.json")))
                .unwrap()
        })
        .collect();
    let held = verdict(&cameras);
    eprintln!("held to the reference: {held}");
    let side = &held.views[1];
    let before = side.ratio.unwrap() > monohand::rig_check::SUSPECT_RATIO
        && side.median_offset_px.unwrap() > monohand::rig_check::SUSPECT_FLOOR_PX;
    assert!(before && side.network_bias, "{held}");
    assert!(held.suspects().is_empty(), "{held}");
    // The side view's camera turned by 2 degrees: named.
    let turned_file = tmp.path().join("turned.json");
    turned(
        &rig.join("cameras").join(format!("{}.json", SERIALS[1])),
        2.0,
        &turned_file,
    );
    let mut bumped = cameras.clone();
    bumped[1] = monohand_io::calibration::read_camera(&turned_file).unwrap();
    let moved = verdict(&bumped);
    eprintln!("side view turned: {moved}");
    assert_eq!(moved.suspects(), vec![1], "{moved}");
}

/// How `camera`'s view agreed with the reference joints, from its record's first hand.
fn reference_fit(
    camera: &monohand_core::camera::Camera,
    joints: &[Option<nalgebra::Vector3<f64>>],
    record: &serde_json::Value,
) -> monohand_io::jsonl::ViewFitRecord {
    let kp = record["hands"]
        .as_array()
        .and_then(|h| h.iter().find_map(|h| h["keypoints_2d"].as_array()));
    let (mut offset, mut centre, mut error, mut n) = ([0.0, 0.0], [0.0, 0.0], 0.0, 0.0);
    for (x, k) in joints.iter().zip(kp.into_iter().flatten()) {
        let k: Vec<f64> = k
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let (Some(x), true) = (x, k[2] >= 0.1) else {
            continue;
        };
        let Some(px) = camera.project(x) else {
            continue;
        };
        let d = [px.x - k[0], px.y - k[1]];
        offset = [offset[0] + d[0], offset[1] + d[1]];
        centre = [centre[0] + px.x, centre[1] + px.y];
        error += d[0].hypot(d[1]);
        n += 1.0;
    }
    let seen = n >= 8.0;
    monohand_io::jsonl::ViewFitRecord {
        used: seen,
        reprojection_error_px: seen.then(|| error / n),
        offset_px: seen.then(|| [offset[0] / n, offset[1] / n]),
        centre_px: seen.then(|| [centre[0] / n, centre[1] / n]),
    }
}
