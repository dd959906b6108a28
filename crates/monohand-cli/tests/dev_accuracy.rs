//! 3D accuracy on real frames with 3D labels (the hand-graph-cnn development set, read
//! natively by `monohand eval`), through the real networks: the fit that uses the
//! network's 3D cues against the paper's 2D-only fit and against the network's own 3D.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;
use common::*;
use monohand_testkit::dev_set_dir;

/// `(label, cells)` of the table rows of `monohand eval`'s stdout.
fn table(stdout: &str) -> Vec<(String, Vec<String>)> {
    stdout
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| run"))
        .map(|l| {
            let cells: Vec<String> = l.split('|').map(|c| c.trim().to_string()).collect();
            (cells[1].clone(), cells[2..].to_vec())
        })
        .collect()
}

/// Columns after the label: hands, detected, MPJPE abs, median, root-rel, aligned,
/// centroid, PA-MPJPE, jitter, ...
fn num(cells: &[String], col: usize) -> f64 {
    cells[col].trim_end_matches('%').parse().expect("a number")
}

fn eval(extra: &[&str]) -> Vec<(String, Vec<String>)> {
    let dir = dev_set_dir();
    let mut args = vec![
        "eval",
        "--dataset",
        p(&dir),
        "--stage",
        "full",
        "--views",
        "left",
        "--skeleton",
        "default",
        "--track",
        "--max-frames",
        "100",
    ];
    args.extend_from_slice(extra);
    let out = monohand(&args);
    ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    eprintln!("{stdout}");
    table(&stdout)
}

#[test]
fn network_cues_beat_the_2d_only_fit_on_real_frames() {
    assert!(networks_ready(), "the networks must be available");
    let with = eval(&[]);
    let without = eval(&[
        "--world-weight",
        "0",
        "--depth-weight",
        "0",
        "--hand-frame-weight",
        "0",
        "--temporal-weight",
        "0",
    ]);
    let row = |t: &[(String, Vec<String>)], label: &str| {
        t.iter()
            .find(|(l, _)| l == label)
            .map(|(_, c)| c.clone())
            .unwrap_or_else(|| panic!("no {label} row"))
    };
    // MediaPipe's own 3D: the landmark network read once per crop, as MediaPipe does.
    let single = eval(&["--no-mirror-pass"]);
    // The posed skeleton's joints, nothing fused in; and the depth fusion alone.
    let unfused = eval(&NO_FUSION);
    let depth_only = eval(&["--fuse-pixels", "0"]);
    let (fit, paper) = (row(&with, "mono"), row(&without, "mono"));
    let (skeleton, deep) = (row(&unfused, "mono"), row(&depth_only, "mono"));
    let network = row(&with, "network 3D (no position)");
    let mediapipe = row(&single, "network 3D (no position)");
    // The same detections feed all the rows.
    assert_eq!(num(&fit, 1), num(&paper, 1));
    assert_eq!(num(&fit, 1), num(&mediapipe, 1));
    assert!(num(&fit, 1) >= 95.0, "detected {}", num(&fit, 1));
    let (pa_fit, pa_paper, pa_mp) = (num(&fit, 7), num(&paper, 7), num(&mediapipe, 7));
    let (abs_fit, abs_paper) = (num(&fit, 2), num(&paper, 2));
    // Measured on these 100 frames (2026-11-24, the defaults, mirror pass on, before
    // depth fusion): PA 8.38 mm with the cues (7.54 with fusion, 2026-11-24) against
    // 18.75 for the paper's cost on the same keypoints and 8.95 for MediaPipe's own 3D
    // (8.66 for the mean of the two passes); absolute 32.95 against
    // 37.17 mm (the mirror pass also improves the 2D-only fit's position: 41.59 mm
    // without it).
    assert!(pa_fit < 0.8 * pa_paper, "PA {pa_fit} vs 2D-only {pa_paper}");
    assert!(pa_fit < pa_mp, "PA {pa_fit} vs MediaPipe's own 3D {pa_mp}");
    assert!(
        abs_fit < 0.93 * abs_paper && abs_fit < 35.0,
        "absolute {abs_fit} vs {abs_paper}"
    );
    // Fusion (docs/accuracy.md; measured 2026-11-24 on these frames: PA 8.38 mm for the
    // skeleton, 7.54 with the network's depth, 7.34 with the keypoints' pixels too;
    // centroid 10.31, 9.47, 9.37; absolute 32.95, 32.90, 32.84) improves the shape. The
    // depth fusion moves joints only along their viewing rays: the reprojection error
    // is the skeleton's; the pixel fusion brings it towards the keypoints (6.63 to 6.24).
    let (pa_skel, cen_fit, cen_skel) = (num(&skeleton, 7), num(&fit, 6), num(&skeleton, 6));
    assert!(
        pa_fit < pa_skel - 0.5,
        "PA fused {pa_fit} vs skeleton {pa_skel}"
    );
    assert!(
        cen_fit < cen_skel - 0.5,
        "centroid fused {cen_fit} vs skeleton {cen_skel}"
    );
    assert!(pa_fit < num(&deep, 7), "PA {pa_fit} vs depth fusion alone");
    assert!(
        pa_fit < 0.85 * pa_mp,
        "PA {pa_fit} vs MediaPipe's own 3D {pa_mp}"
    );
    assert_eq!(
        deep[16], skeleton[16],
        "reprojection error (px) changed by the depth fusion"
    );
    assert!(
        num(&fit, 16) < num(&skeleton, 16) - 0.2,
        "reprojection {} vs the skeleton's {}",
        fit[16],
        skeleton[16]
    );
    assert!(
        (num(&fit, 2) - num(&skeleton, 2)).abs() < 1.0,
        "absolute moved"
    );
    // The network's own 3D has no position: no absolute error is claimed for it.
    assert_eq!(network[2], "-");
    assert_eq!(mediapipe[2], "-");
}
