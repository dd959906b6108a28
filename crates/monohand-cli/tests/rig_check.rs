//! A rig that checks itself (issue 57), on the real table rig
//! (`../shared/data/table_rig_dev`, its 4 views, all 148 frames, tracked): every record
//! says how each view agreed with each fitted hand, and the run's summary names a camera
//! whose file was turned by 2 degrees and a video 3 frames ahead of the others, and
//! nothing on the unchanged rig.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, networks_ready, ok, p};
use monohand_io::jsonl::read_jsonl;
use std::path::{Path, PathBuf};

const SERIALS: [&str; 4] = [
    "141122079464",
    "141722072294",
    "141722075121",
    "141722076181",
];

fn rig() -> PathBuf {
    let d = monohand_testkit::shared_data().join("table_rig_dev");
    assert!(
        d.join("cameras").is_dir() && d.join("images").is_dir(),
        "the table rig is missing at {} (../shared/data beside the repository)",
        d.display()
    );
    d
}

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

/// The lines of the summary that name a view.
fn named(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains("stays far off") || l.contains("check its calibration"))
        .collect()
}

/// The summary names view 4, whose files include `file`, and no other view.
fn named_only_view_4(stderr: &str, file: &Path) {
    let lines = named(stderr);
    assert_eq!(lines.len(), 2, "{stderr}");
    assert!(lines[0].contains("view 4 stays far off"), "{stderr}");
    assert!(lines[0].matches("stays far off").count() == 1, "{stderr}");
    assert!(
        lines[1].starts_with("view 4: ") && lines[1].contains(p(file)),
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
    let views: Vec<PathBuf> = SERIALS.iter().map(|s| rig.join("images").join(s)).collect();
    let cameras: Vec<PathBuf> = SERIALS
        .iter()
        .map(|s| rig.join("cameras").join(format!("{s}.json")))
        .collect();

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
    named_only_view_4(&stderr, &turned_file);

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
    named_only_view_4(&stderr, &late);
}
