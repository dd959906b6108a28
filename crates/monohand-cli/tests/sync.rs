//! Videos that did not start together (issue 64), on the real table rig
//! (`../shared/data/table_rig_dev`, its 4 views, 148 frames, tracked): `run --sync auto`
//! finds a view that started 5 frames late and one that started 3 frames early exactly,
//! and gives the 3D of the run whose views started together; a view at 15 fps is matched
//! to the others at 30 by time.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, networks_ready, ok, p, table_rig as rig, RIG_SERIALS as SERIALS};
use std::path::{Path, PathBuf};

const FRAMES: usize = 148;

/// Runs the rig on these views with `extra` arguments: the records and stderr.
fn run(out: &Path, views: &[PathBuf], extra: &[&str]) -> (Vec<serde_json::Value>, String) {
    let rig = rig();
    let mut args: Vec<String> = vec!["run".into(), "--track".into()];
    for (v, s) in views.iter().zip(SERIALS) {
        let camera = rig.join("cameras").join(format!("{s}.json"));
        args.extend([
            "--view".into(),
            p(v).into(),
            "--camera".into(),
            p(&camera).into(),
        ]);
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    args.extend(["-o".into(), p(out).into()]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = monohand(&refs);
    ok(&o);
    let records = std::fs::read_to_string(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (records, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A folder of links to `view`'s frames `frames`, renumbered from 0.
fn relinked(dir: &Path, name: &str, view: &Path, frames: impl Iterator<Item = usize>) -> PathBuf {
    let d = dir.join(name);
    std::fs::create_dir(&d).unwrap();
    for (k, i) in frames.enumerate() {
        let from = view.join(format!("color_{i:06}.jpg"));
        std::os::unix::fs::symlink(from, d.join(format!("color_{k:06}.jpg"))).unwrap();
    }
    d
}

/// Per frame, the first fitted hand's 21 joints, mm (`None`: no 3D).
fn joints(records: &[serde_json::Value]) -> Vec<Option<Vec<f64>>> {
    records
        .iter()
        .map(|r| {
            let h = r["hands"]
                .as_array()?
                .iter()
                .find(|h| h.get("joints_3d_mm").is_some())?;
            let j = h["joints_3d_mm"].as_array()?;
            Some(
                j.iter()
                    .flat_map(|x| x.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()))
                    .collect(),
            )
        })
        .collect()
}

/// The largest distance between the same joint of two runs over `frames`, mm, and how
/// many frames both fitted.
fn largest_difference(
    a: &[Option<Vec<f64>>],
    b: &[Option<Vec<f64>>],
    frames: std::ops::Range<usize>,
) -> (f64, usize) {
    let mut worst = 0.0f64;
    let mut n = 0;
    for i in frames {
        if let (Some(x), Some(y)) = (&a[i], &b[i]) {
            n += 1;
            for (p, q) in x.chunks(3).zip(y.chunks(3)) {
                let d =
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                worst = worst.max(d);
            }
        }
    }
    (worst, n)
}

/// The mean joint error of the first fitted hand against the rig's reference 3D over
/// `frames`, mm, and the frames counted.
fn error_mm(records: &[serde_json::Value], frames: std::ops::Range<usize>) -> (f64, usize) {
    let text = std::fs::read_to_string(rig().join("reference_3d_mm.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let fitted = joints(records);
    let (mut sum, mut n) = (0.0, 0);
    for i in frames {
        let (Some(truth), Some(fit)) = (reference["frames"][i].as_array(), &fitted[i]) else {
            continue;
        };
        let d: Vec<f64> = truth
            .iter()
            .zip(fit.chunks(3))
            .filter_map(|(t, f)| {
                let t: Vec<f64> = t
                    .as_array()?
                    .iter()
                    .filter_map(serde_json::Value::as_f64)
                    .collect();
                Some(((t[0] - f[0]).powi(2) + (t[1] - f[1]).powi(2) + (t[2] - f[2]).powi(2)).sqrt())
            })
            .collect();
        sum += d.iter().sum::<f64>() / d.len() as f64;
        n += 1;
    }
    (sum / n.max(1) as f64, n)
}

/// Each record's cameras' `time_offset_s`.
fn offsets(r: &serde_json::Value) -> Vec<f64> {
    r["cameras"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["time_offset_s"].as_f64().unwrap())
        .collect()
}

#[test]
fn sync_auto_finds_a_late_and_an_early_view_exactly_and_gives_the_synced_3d() {
    let rig = rig();
    assert!(networks_ready(), "the networks are needed");
    let tmp = tempfile::tempdir().unwrap();
    let views: Vec<PathBuf> = SERIALS.iter().map(|s| rig.join("images").join(s)).collect();
    let (synced, _) = run(&tmp.path().join("synced.jsonl"), &views, &[]);
    assert_eq!(synced.len(), FRAMES);

    // View 2 started 5 frames late (its first 5 frames are missing), view 4 three frames
    // early (three dark frames before the others' first).
    let mut shifted = views.clone();
    shifted[1] = relinked(tmp.path(), "late", &views[1], 5..FRAMES);
    let early = relinked(tmp.path(), "early", &views[3], 0..FRAMES);
    for k in (0..FRAMES).rev() {
        let (from, to) = (
            format!("color_{k:06}.jpg"),
            format!("color_{:06}.jpg", k + 3),
        );
        std::fs::rename(early.join(from), early.join(to)).unwrap();
    }
    let o = std::process::Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-f",
            "lavfi",
            "-i",
            "color=c=black:s=640x480",
        ])
        .args(["-frames:v", "3", "-start_number", "0"])
        .arg(early.join("color_%06d.jpg"))
        .output()
        .expect("ffmpeg is needed (scripts/prerequisites.sh)");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    shifted[3] = early;
    let (records, stderr) = run(
        &tmp.path().join("auto.jsonl"),
        &shifted,
        &["--sync", "auto"],
    );
    assert!(
        stderr.contains("sync: view 2 starts 5 frames late"),
        "{stderr}"
    );
    assert!(
        stderr.contains("sync: view 3 starts with view 1"),
        "{stderr}"
    );
    assert!(
        stderr.contains("sync: view 4 starts 3 frames early"),
        "{stderr}"
    );
    assert!(
        stderr.contains("--sync 0.16667,0.00000,-0.10000"),
        "{stderr}"
    );
    assert_eq!(records.len(), FRAMES);
    let found = offsets(&records[0]);
    let want = [0.0, 5.0 / 30.0, 0.0, -3.0 / 30.0];
    assert!(
        found.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6),
        "{found:?}"
    );
    // The first 5 frames have no frame of view 2 (it had not started): fitted without it.
    assert!(
        records[0]["hands"][0].get("joints_3d_mm").is_some(),
        "{}",
        records[0]
    );
    let (worst, n) = largest_difference(&joints(&synced), &joints(&records), 5..FRAMES);
    assert!(
        n >= 135 && worst <= 0.5,
        "3D {worst:.3} mm off the synced run over {n} frames"
    );

    // The offsets `auto` printed, given again: the same records.
    let (again, _) = run(
        &tmp.path().join("given.jsonl"),
        &shifted,
        &["--sync", "0.16667,0,-0.1"],
    );
    let (worst, n) = largest_difference(&joints(&records), &joints(&again), 0..FRAMES);
    assert!(n >= 140 && worst <= 0.01, "{worst} over {n}");

    // Matched by index as before, the shifted views make the 3D worse.
    let (index, _) = run(&tmp.path().join("index.jsonl"), &shifted, &[]);
    assert!(index[0]["cameras"][0].get("time_offset_s").is_none());
    let (worst, _) = largest_difference(&joints(&synced), &joints(&index), 5..FRAMES);
    assert!(worst > 5.0, "{worst}");
    // There, a view's hand that its crop took from the fitted hand but that disagrees with
    // the other views is fitted as a hand of its own: with an identity of its own, never
    // the other's (which would also share its track).
    let mut split = 0;
    for r in &index {
        let ids: Vec<u64> = r["hands"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| h["id"].as_u64().unwrap())
            .collect();
        let mut unique = ids.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), ids.len(), "frame {}: ids {ids:?}", r["frame"]);
        // One hand, and at most its split-off view: the split hand is not put into the
        // other views' crops, where it would find the same hand a second time.
        assert!(ids.len() <= 2, "frame {}: ids {ids:?}", r["frame"]);
        split += usize::from(ids.len() > 1);
    }
    assert!(
        split > 0,
        "no frame fitted a disagreeing view's hand on its own"
    );
}

#[test]
fn a_view_at_15_fps_is_matched_to_the_others_at_30_by_time() {
    let rig = rig();
    assert!(networks_ready(), "the networks are needed");
    let tmp = tempfile::tempdir().unwrap();
    let views: Vec<PathBuf> = SERIALS.iter().map(|s| rig.join("images").join(s)).collect();
    let (synced, _) = run(&tmp.path().join("synced.jsonl"), &views, &[]);
    // View 3 as a 15 fps video of its even frames, starting at its frame 4 (4/30 s late).
    let even = relinked(tmp.path(), "even", &views[2], (4..FRAMES).step_by(2));
    let video = tmp.path().join("view3_15fps.mkv");
    let o = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-framerate", "15", "-i"])
        .arg(even.join("color_%06d.jpg"))
        .args(["-c:v", "ffv1", "-pix_fmt", "yuv420p"])
        .arg(&video)
        .output()
        .expect("ffmpeg is needed (scripts/prerequisites.sh)");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut mixed = views.clone();
    mixed[2] = video;
    let (records, stderr) = run(&tmp.path().join("mixed.jsonl"), &mixed, &["--sync", "auto"]);
    assert!(
        stderr.contains("sync: view 3 starts 4 frames late"),
        "{stderr}"
    );
    assert_eq!(records.len(), FRAMES);
    // As good as the synced run against the rig's reference 3D (labelled frames 4-75).
    let (synced_mm, n) = error_mm(&synced, 4..76);
    let (mixed_mm, m) = error_mm(&records, 4..76);
    assert!(n == 72 && m == 72, "{n} {m}");
    assert!(
        mixed_mm <= synced_mm + 1.5,
        "15 fps view: {mixed_mm:.2} mm against {synced_mm:.2} with every view at 30"
    );
    // Before view 3's first frame, the frames are fitted from the other three.
    assert!(
        records[0]["hands"][0].get("joints_3d_mm").is_some(),
        "{}",
        records[0]
    );
}
