//! The person's hand measured once and reused (issue 56): `run --save-hand` on the table
//! rig's 4 calibrated views (`../shared/data/table_rig_dev`, made into videos), then
//! `--hand` and `--hand-length-mm` on one view alone; the records and the summary say which
//! size was used; bad uses are refused with the reason. Needs `../shared/data`, ffmpeg and
//! the MediaPipe weights: without them the tests fail, they do not skip.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;
use common::*;
use monohand_io::hand::{read_hand, HandSource};
use monohand_io::jsonl::{read_jsonl, FrameRecord};
use monohand_testkit::{ffmpeg, table_rig_dir, TABLE_RIG_VIEWS};
use std::path::{Path, PathBuf};

/// Frames of each view made into its video.
const FRAMES: usize = 60;

/// Each view's first [`FRAMES`] frames as an MPEG-4 video in `dir`, with its camera file.
fn rig_videos(dir: &Path) -> Vec<(PathBuf, PathBuf)> {
    let rig = table_rig_dir();
    TABLE_RIG_VIEWS
        .iter()
        .map(|v| {
            let video = dir.join(format!("{v}.mp4"));
            let frames = rig.join("images").join(v).join("color_%06d.jpg");
            ffmpeg(&[
                "-framerate",
                "30",
                "-i",
                p(&frames),
                "-frames:v",
                &FRAMES.to_string(),
                "-c:v",
                "mpeg4",
                "-q:v",
                "2",
                p(&video),
            ]);
            (video, rig.join("cameras").join(format!("{v}.json")))
        })
        .collect()
}

/// The `hand_size` of every hand with 3D in `path`: its source and scale.
fn sizes(path: &Path) -> Vec<(String, f64)> {
    let frames: Vec<FrameRecord> = read_jsonl(path).unwrap();
    frames
        .iter()
        .flat_map(|f| &f.hands)
        .filter(|h| h.joints_3d_mm.is_some())
        .map(|h| {
            let s = h.hand_size.as_ref().expect("a 3D hand says its size");
            (s.source.clone(), s.scale)
        })
        .collect()
}

#[test]
fn a_rig_measures_the_hand_once_and_one_camera_reuses_it() {
    assert!(networks_ready());
    let tmp = tempfile::tempdir().unwrap();
    let views = rig_videos(tmp.path());
    let hand = tmp.path().join("hand.json");
    let multi = tmp.path().join("multi.jsonl");
    let mut args: Vec<&str> = vec!["run"];
    for (video, camera) in &views {
        args.extend(["--view", p(video), "--camera", p(camera)]);
    }
    args.extend(["--save-hand", p(&hand), "-o", p(&multi)]);
    let out = monohand(&args);
    ok(&out);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("hand measured by 4 views"), "{said}");
    // The person's hand: the reference's own is 0.943 of the default (178.3 of 189 mm);
    // the views measure it in the keypoints' convention (docs/absolute-depth.md).
    let measured = read_hand(&hand).unwrap();
    assert_eq!(measured.source, HandSource::Views);
    assert_eq!(measured.views, Some(4));
    assert_eq!(
        measured.side,
        Some(monohand_core::hand_model::HandSide::Right)
    );
    assert!((0.90..0.97).contains(&measured.scale), "{measured:?}");
    assert!(
        measured.scale_sigma.is_some_and(|s| s < 0.05),
        "{measured:?}"
    );
    assert!(measured.frames.len() >= 10, "{:?}", measured.frames);
    let bones = measured.bone_lengths_mm.unwrap();
    assert!(bones.iter().flatten().count() >= 5, "{bones:?}");
    assert!(
        bones.iter().flatten().all(|l| (5.0..120.0).contains(l)),
        "{bones:?}"
    );
    let rig_sizes = sizes(&multi);
    assert!(!rig_sizes.is_empty());
    assert!(rig_sizes
        .iter()
        .all(|(s, k)| s == "measured" && (k - measured.scale).abs() < 1e-9));

    // One camera alone, with the file: every 3D hand at the measured size.
    let (video, camera) = &views[0];
    let mono = tmp.path().join("mono.jsonl");
    let out = monohand(&[
        "run",
        p(video),
        "--camera",
        p(camera),
        "--hand",
        p(&hand),
        "-o",
        p(&mono),
    ]);
    ok(&out);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("x the default, file)"), "{said}");
    let mono_sizes = sizes(&mono);
    assert!(
        mono_sizes.len() >= FRAMES * 9 / 10,
        "{} 3D hands",
        mono_sizes.len()
    );
    assert!(mono_sizes
        .iter()
        .all(|(s, k)| s == "file" && (k - measured.scale).abs() < 1e-9));

    // A ruler's length; and the default, said as such.
    let ruler = tmp.path().join("ruler.jsonl");
    ok(&monohand(&[
        "run",
        p(video),
        "--camera",
        p(camera),
        "--hand-length-mm",
        "180",
        "-o",
        p(&ruler),
    ]));
    let expected = (180.0 - monohand::RULER_OFFSET_MM)
        / monohand_core::hand_model::HandSkeleton::default_for(
            monohand_core::hand_model::HandSide::Right,
        )
        .hand_length();
    assert!(sizes(&ruler)
        .iter()
        .all(|(s, k)| s == "ruler" && (k - expected).abs() < 1e-9));
    let plain = tmp.path().join("plain.jsonl");
    ok(&monohand(&[
        "run",
        p(video),
        "--camera",
        p(camera),
        "-o",
        p(&plain),
    ]));
    assert!(sizes(&plain)
        .iter()
        .all(|(s, k)| s == "default" && *k == 1.0));
}

/// Frames of each view copied into its folder for the untracked measurement.
const FOLDER_FRAMES: usize = 30;

#[test]
fn folders_of_photos_measure_the_hand_over_all_their_frames() {
    // A folder per camera is a set of photos: untracked, each frame's hands get new ids, so
    // the hand measured is the one side seen by two views, over every frame (before, the
    // measurement took one frame, and gave 0.76 of the default on the rig).
    assert!(networks_ready());
    let tmp = tempfile::tempdir().unwrap();
    let rig = table_rig_dir();
    let mut args: Vec<String> = vec!["run".into()];
    for v in TABLE_RIG_VIEWS {
        let dir = tmp.path().join(v);
        std::fs::create_dir(&dir).unwrap();
        for f in 0..FOLDER_FRAMES {
            let name = format!("color_{f:06}.jpg");
            std::fs::copy(rig.join("images").join(v).join(&name), dir.join(&name)).unwrap();
        }
        let camera = rig.join("cameras").join(format!("{v}.json"));
        args.extend([
            "--view".into(),
            p(&dir).into(),
            "--camera".into(),
            p(&camera).into(),
        ]);
    }
    let hand = tmp.path().join("hand.json");
    let multi = tmp.path().join("multi.jsonl");
    args.extend([
        "--save-hand".into(),
        p(&hand).into(),
        "-o".into(),
        p(&multi).into(),
    ]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    ok(&monohand(&args));
    let measured = read_hand(&hand).unwrap();
    assert!(measured.frames.len() >= 20, "{:?}", measured.frames);
    assert!((0.90..0.97).contains(&measured.scale), "{measured:?}");
    assert!(
        measured.scale_sigma.is_some_and(|s| s < 0.05),
        "{measured:?}"
    );
}

#[test]
fn bad_hand_sizes_are_refused_with_the_reason_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let rig = table_rig_dir();
    let frame = rig
        .join("images")
        .join(TABLE_RIG_VIEWS[0])
        .join("color_000020.jpg");
    let camera = rig
        .join("cameras")
        .join(format!("{}.json", TABLE_RIG_VIEWS[0]));
    let out_file = tmp.path().join("out.jsonl");
    let hand = tmp.path().join("hand.json");
    // One camera cannot measure a hand.
    let out = monohand(&[
        "run",
        p(&frame),
        "--camera",
        p(&camera),
        "--save-hand",
        p(&hand),
        "-o",
        p(&out_file),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--save-hand measures the hand with two or more"),
        "{err}"
    );
    assert!(!hand.exists() && !out_file.exists());
    // A hand file with an impossible size names the file and the field.
    std::fs::write(
        &hand,
        r#"{"format": "monohand-hand/1", "source": "views", "scale": -1, "hand_length_mm": 170}"#,
    )
    .unwrap();
    let out = monohand(&[
        "run",
        p(&frame),
        "--camera",
        p(&camera),
        "--hand",
        p(&hand),
        "-o",
        p(&out_file),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("hand.json") && err.contains("scale"), "{err}");
    // Two sizes at once, and a ruler length no hand has.
    let out = monohand(&["run", p(&frame), "--hand", p(&hand), "--hand-scale", "0.9"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
    let out = monohand(&[
        "run",
        p(&frame),
        "--hand-length-mm",
        "20",
        "-o",
        p(&out_file),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--hand-length-mm") && err.contains("20 mm"),
        "{err}"
    );
}
