//! `monohand detect` and `monohand models` on real photos (the networks are fetched with pip
//! on first use; without pip or network the tests print SKIP, unless
//! MONOHAND_REQUIRE_MODELS is set, as in CI, where they fail).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use common::{monohand, networks_ready, ok, p};
use monohand_core::hand_model::HandSide;
use monohand_io::jsonl::read_jsonl;
use std::path::{Path, PathBuf};

fn images() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/images");
    if d.is_dir() {
        Some(d)
    } else {
        panic!("shared images not found at {}", d.display())
    }
}

#[test]
fn detect_a_folder_in_name_order_and_survive_a_bad_file() {
    let Some(images) = images() else { return };
    if !networks_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("in");
    std::fs::create_dir(&folder).unwrap();
    std::fs::copy(images.join("hamer/test1.jpg"), folder.join("a_people.jpg")).unwrap();
    std::fs::write(
        folder.join("b_broken.jpg"),
        b"\xff\xd8\xff\xe0 this is not a JPEG",
    )
    .unwrap();
    std::fs::copy(images.join("pinto/hand.png"), folder.join("c_hand.png")).unwrap();
    std::fs::write(folder.join("notes.txt"), b"not an image").unwrap();
    let out_path = dir.path().join("out.jsonl");
    let out = monohand(&["detect", p(&folder), "--output", p(&out_path)]);
    ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("b_broken.jpg") || stderr.contains("frame 1"),
        "{stderr}"
    );
    let frames = read_jsonl(&out_path).unwrap();
    let names: Vec<_> = frames.iter().map(|f| f.source.clone().unwrap()).collect();
    assert_eq!(names, ["a_people.jpg", "b_broken.jpg", "c_hand.png"]);
    assert_eq!(
        frames.iter().map(|f| f.frame).collect::<Vec<_>>(),
        [0, 1, 2]
    );

    // Two hands and one head in the photo; the OK sign is her right hand.
    let people = &frames[0];
    assert!(people.error.is_none());
    assert_eq!(people.hands.len(), 2, "{:?}", people.hands);
    assert_eq!(people.heads.len(), 1);
    let ok_sign = people
        .hands
        .iter()
        .find(|h| {
            let [cx, cy] = h.bbox.unwrap().centre();
            cx < 380.0 && cy < 300.0
        })
        .expect("the OK-sign hand near (320, 250)");
    assert_eq!(ok_sign.side, HandSide::Right);
    for h in &people.hands {
        assert!(h.score.unwrap() > 0.5 && h.side_score.unwrap() >= 0.5);
        let ob = h.oriented_box.unwrap();
        assert!(ob.size[0] > 30.0 && ob.size[1] > 30.0, "{ob:?}");
        assert!(h.keypoints_2d.iter().all(|k| (0.0..=1.0).contains(&k[2])));
    }

    assert!(frames[1].hands.is_empty());
    assert!(frames[1]
        .error
        .as_deref()
        .unwrap_or("")
        .contains("b_broken.jpg"));

    let hand = &frames[2];
    assert_eq!(hand.image_size, Some([640, 480]));
    assert_eq!(hand.hands.len(), 1);
    let b = hand.hands[0].bbox.unwrap();
    // Pinned by eye once: the open palm spans about (57, 123) - (319, 316).
    for (got, want) in b.to_array().iter().zip([57.0, 123.0, 319.0, 316.0]) {
        assert!((got - want).abs() < 25.0, "box {b:?}");
    }
}

#[test]
fn detect_reports_unreadable_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.jpg");
    let out = monohand(&["detect", p(&missing)]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.jpg"));
    if !networks_ready() {
        return;
    }
    let bad = dir.path().join("bad.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\n truncated").unwrap();
    let out_path = dir.path().join("o.jsonl");
    let out = monohand(&["detect", p(&bad), "-o", p(&out_path)]);
    assert!(
        !out.status.success(),
        "a run where nothing could be read fails"
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("none of the 1 images"), "{stderr}");
    // The record of the failure was still written.
    assert_eq!(read_jsonl(&out_path).unwrap().len(), 1);
}

#[test]
fn models_list_tells_what_is_cached() {
    if !networks_ready() {
        return;
    }
    let out = monohand(&["models", "list"]);
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    for name in [
        "palm_detection_full.tflite",
        "hand_landmark_lite.tflite",
        "face_detection_short_range.tflite",
    ] {
        assert!(text.contains(name) && text.contains("ok"), "{text}");
    }
    let empty = tempfile::tempdir().unwrap();
    let out = monohand(&["models", "list", "--model-dir", p(empty.path())]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("monohand models fetch"));
}
