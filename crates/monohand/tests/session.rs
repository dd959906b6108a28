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
        Err(SessionError::Invalid(_))
    ));
    assert!(matches!(
        session.process(&[&image], f64::NAN),
        Err(SessionError::Invalid(_))
    ));
    // A frame of the wrong size gets no 3D and says why; the session goes on.
    let big = monohand::RgbImage::new(128, 96);
    let done = session.process(&[&big], 0.0).expect("frame");
    assert!(done[0]
        .error
        .as_deref()
        .is_some_and(|e| e.contains("calibrated for 64x48")));
    let done = session.process(&[&image], 0.1).expect("frame");
    assert!(done[0].error.is_none() && done[0].hands.is_empty());
    assert!(matches!(
        Session::new(Vec::new(), SessionOptions::default().hands(0)),
        Err(SessionError::Invalid(_))
    ));
}
