//! The session's refusals (its accuracy on real frames with 3D labels is tested in
//! `monohand-eval`, which scores it). Needs the MediaPipe weights (fetched with pip on first
//! use): without them the tests fail, they do not skip.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand::prelude::*;
use monohand::{Session, SessionError, SessionOptions};

#[test]
fn calls_that_do_not_fit_the_session_are_refused() {
    let camera = Camera::generic(64, 48).expect("camera");
    let mut session =
        Session::new(vec![camera], SessionOptions::default().hands(1)).expect("networks");
    let image = monohand::RgbImage::new(64, 48);
    assert!(matches!(
        session.process(&[&image, &image], 0.0),
        Err(SessionError::Views {
            images: 2,
            cameras: 1
        })
    ));
    assert!(matches!(
        session.process(&[&image], f64::NAN),
        Err(SessionError::FrameTime(_))
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
        Err(SessionError::Settings(e)) if e.field == monohand::Field::MaxHands
    ));
    // A shared pipeline that does not run as the options ask is refused, not ignored.
    let pipeline = std::sync::Arc::new(
        Session::load_pipeline(&SessionOptions::default().hands(1)).expect("networks"),
    );
    for (options, field) in [
        (SessionOptions::default(), monohand::Field::MaxHands),
        (
            SessionOptions::default().hands(1).tracking(false),
            monohand::Field::Tracking,
        ),
        (
            SessionOptions::default().hands(1).mirror_pass(false),
            monohand::Field::MirrorPass,
        ),
        (
            SessionOptions::default().hands(1).heads(true),
            monohand::Field::Heads,
        ),
    ] {
        assert!(matches!(
            Session::with_pipeline(Vec::new(), pipeline.clone(), options),
            Err(SessionError::Settings(e)) if e.field == field
        ));
    }
    assert!(
        Session::with_pipeline(Vec::new(), pipeline, SessionOptions::default().hands(1)).is_ok()
    );
}
