//! The browser build's Rust core, natively, on the real networks and the shared photo: RGBA
//! frames give the records of the library's session on the same pixels (the browser adds
//! nothing of its own), and the hand is found and fitted in 3D. Needs the networks
//! (`monohand models fetch`) and `../shared`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand::{Session, SessionOptions};
use monohand_vision::{ModelFile, ModelStore};
use monohand_web::{records_json, Tracker, TrackerOptions};
use std::sync::Arc;

fn weights(file: ModelFile) -> Vec<u8> {
    ModelStore::new(None).unwrap().load(file).unwrap()
}

#[test]
fn rgba_frames_give_the_sessions_records_with_the_hand_in_3d() {
    let photo = image::open(monohand_testkit::hand_png()).unwrap();
    let rgb = photo.to_rgb8();
    let rgba = photo.to_rgba8();
    let (w, h) = rgb.dimensions();
    let palm = weights(ModelFile::PalmDetectionFull);
    let landmark = weights(ModelFile::HandLandmarkFull);

    let mut tracker = Tracker::new(&palm, &landmark, TrackerOptions::default()).unwrap();
    let pipeline = Session::load_pipeline(&SessionOptions::default()).unwrap();
    let mut session =
        Session::with_pipeline(Vec::new(), Arc::new(pipeline), SessionOptions::default()).unwrap();
    for i in 0..3 {
        let t = f64::from(i) / 30.0;
        let web = tracker.process_rgba(rgba.as_raw(), w, h, t).unwrap();
        let native = session.process(&[&rgb], t).unwrap();
        assert_eq!(web.len(), 1);
        assert_eq!(native.len(), 1);
        let mut expected = monohand::records::timed_record(&native[0], None, true, None);
        let mut got = web[0].clone();
        expected.timings_ms = None;
        got.timings_ms = None;
        assert_eq!(got, expected, "frame {i}");
        assert_eq!(got.hands.len(), 1, "frame {i}: one hand in the photo");
        let wrist = got.hands[0].joints_3d_mm.expect("fitted")[0];
        assert!(
            (200.0..1500.0).contains(&wrist[2]),
            "frame {i}: wrist {wrist:?} mm is not in front of the camera at arm's length"
        );
    }
    assert!(tracker.finish().is_empty());
    let json = records_json(&tracker.process_rgba(rgba.as_raw(), w, h, 0.1).unwrap()).unwrap();
    assert!(
        json.starts_with("[{\"frame\":3,") && json.contains("\"joints_3d_mm\""),
        "{json}"
    );
    let notes = tracker.take_notes().join("; ");
    assert!(
        notes.contains("generic"),
        "the assumed camera is said: {notes}"
    );
}
