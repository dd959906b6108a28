//! The session on real frames with 3D labels (the first 40 frames of the hand-graph-cnn
//! development set in `../shared/data`, real networks), and its refusals.
//!
//! Needs `../shared/data` and the MediaPipe weights (fetched with pip on first use): without
//! them the tests fail, they do not skip.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand::prelude::*;
use monohand::{Session, SessionError, SessionOptions};
use monohand_eval::datasets::hand_graph_cnn::load_hand_graph_cnn;
use monohand_eval::metrics::{masked_mean, procrustes_errors, to_joints};
use monohand_testkit::dev_set_dir;

#[test]
fn a_tracked_session_follows_one_left_hand_with_the_networks_shape() {
    let data = load_hand_graph_cnn(dev_set_dir()).expect("dev set");
    let frames = &data.frames[..40];
    // The crops are 256x256; without a calibration the session assumes a generic camera,
    // which changes the absolute depth but not the shape that PA-MPJPE measures.
    let mut session = Session::new(Vec::new(), SessionOptions::default()).expect("networks");
    let (mut fitted, mut pa_sum, mut ids) = (0usize, 0.0, Vec::new());
    for (k, frame) in frames.iter().enumerate() {
        let image = monohand::vision::image_io::load_rgb(&frame.images[0]).expect("image");
        let done = session.process(&[&image], k as f64 / 30.0).expect("frame");
        assert_eq!(done.len(), 1, "one frame out per frame in");
        let done = &done[0];
        assert_eq!(done.vision.index, k as u64);
        assert!(done.hands.len() <= 2);
        let Some((hand, fit)) = done
            .hands
            .iter()
            .find_map(|h| h.fit.as_ref().map(|f| (h, f)))
        else {
            continue;
        };
        assert_eq!(hand.side, HandSide::Left, "frame {k}");
        ids.push(hand.id);
        fitted += 1;
        let gt = frame.hands[0].joints_3d;
        let pa = masked_mean(
            &procrustes_errors(&to_joints(&fit.joints_3d), &gt, &[true; NUM_JOINTS]),
            &[true; NUM_JOINTS],
        );
        pa_sum += pa;
    }
    assert!(fitted >= 38, "3D in {fitted} of 40 frames");
    // Tracking keeps the hand's identity: at most one re-detection in 40 frames.
    ids.dedup();
    assert!(ids.len() <= 2, "identities {ids:?}");
    // The network's own 3D scores about 9 mm PA-MPJPE on these frames, the 2D-only fit
    // about 14 (docs/accuracy.md).
    let pa = pa_sum / fitted as f64;
    assert!(pa < 11.0, "PA-MPJPE {pa:.2} mm");
    assert!(session
        .take_notes()
        .iter()
        .any(|n| n.contains("generic camera")));
    assert_eq!(session.cameras()[0].intrinsics.width, 256);
}

#[test]
fn calls_that_do_not_fit_the_session_are_refused() {
    let camera = Camera::generic(64, 48).expect("camera");
    let mut session =
        Session::new(vec![camera], SessionOptions::default().hands(1)).expect("networks");
    let image = monohand::RgbImage::new(64, 48);
    assert!(matches!(
        session.process(&[&image, &image], 0.0),
        Err(SessionError::Invalid(_))
    ));
    assert!(matches!(
        session.process(&[&image], f64::NAN),
        Err(SessionError::Invalid(_))
    ));
    // A frame of another shape gets no 3D and says why; the session goes on.
    let wide = monohand::RgbImage::new(128, 64);
    let done = session.process(&[&wide], 0.0).expect("frame");
    assert!(
        done[0]
            .error
            .as_deref()
            .is_some_and(|e| e.contains("the calibration is for 64x48") && e.contains("128x64")),
        "{:?}",
        done[0].error
    );
    // One of another size but the same shape gets the calibration scaled, and says so.
    let big = monohand::RgbImage::new(128, 96);
    let done = session.process(&[&big], 0.05).expect("frame");
    assert!(done[0].error.is_none(), "{:?}", done[0].error);
    let k = done[0].cameras[0].intrinsics;
    assert_eq!((k.width, k.height), (128, 96));
    assert!((k.fx - 2.0 * camera.intrinsics.fx).abs() < 1e-9);
    assert!((k.cx - 63.5).abs() < 1e-9 && (k.cy - 47.5).abs() < 1e-9);
    let origin = &done[0].camera_origins[0];
    assert_eq!(origin.source, monohand_io::jsonl::CameraSource::FileScaled);
    assert_eq!(
        origin.reason.as_deref(),
        Some("calibrated for 64x48, scaled by 2.0000 to the frames' 128x96")
    );
    assert!(session
        .take_notes()
        .iter()
        .any(|n| n.contains("camera 1: calibrated for 64x48, scaled by 2.0000")));
    let done = session.process(&[&image], 0.1).expect("frame");
    assert!(done[0].error.is_none() && done[0].hands.is_empty());
    assert!(matches!(
        Session::new(Vec::new(), SessionOptions::default().hands(0)),
        Err(SessionError::Invalid(_))
    ));
}
