//! The engine on real frames (the first 40 frames of the hand-graph-cnn development set in
//! `../shared/data`, real networks): it gives the session's records, in order, through its
//! threads; cancelling stops it cleanly; a failing sink stops it and the others are closed.
//!
//! Needs `../shared/data` and the MediaPipe weights (fetched with pip on first use): without
//! them the tests fail, they do not skip.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand::engine::{
    CallerFrames, Engine, EngineError, FrameSource, Observer, Output, Quiet, RunReport, Sink,
    SinkError,
};
use monohand::records::fitted_record;
use monohand::{HandPipeline, RgbImage, Session, SessionOptions};
use monohand_io::jsonl::{CameraSource, FrameRecord};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// The first `n` dev frames (256x256 crops) with their times at 30 fps.
fn frames(n: usize) -> Vec<(RgbImage, f64)> {
    let dir = monohand_testkit::dev_set_dir().join("images");
    let files = monohand::vision::image_io::images_in_folder(&dir).expect("dev set");
    assert!(
        files.len() >= n,
        "{} images in {}",
        files.len(),
        dir.display()
    );
    files[..n]
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let image = monohand::vision::image_io::load_rgb(f).expect("image");
            (image, k as f64 / 30.0)
        })
        .collect()
}

/// Keeps every record; counts `finish` calls.
#[derive(Default, Clone)]
struct Collect {
    records: Arc<Mutex<Vec<FrameRecord>>>,
    finished: Arc<AtomicU64>,
    fail_at: Option<u64>,
}

impl Sink for Collect {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        if self.fail_at == Some(frame.record.frame) {
            return Err("disk full (a test's sink)".into());
        }
        self.records.lock().unwrap().push(frame.record.clone());
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        self.finished.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }
}

fn source(frames: Vec<(RgbImage, f64)>) -> Box<dyn FrameSource> {
    Box::new(CallerFrames::new(frames.into_iter(), true))
}

fn engine(pipeline: &Arc<HandPipeline>) -> Engine {
    let settings = monohand::Settings::default().resolve().expect("settings");
    Engine::new(Arc::clone(pipeline), Vec::new(), settings).expect("engine")
}

/// Runs `engine` over `input` into one collecting sink and returns its records.
fn records_of(engine: &Engine, input: &[(RgbImage, f64)]) -> Vec<FrameRecord> {
    let sink = Collect::default();
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink.clone())];
    engine
        .run(vec![source(input.to_vec())], &mut sinks, &Quiet)
        .expect("run");
    let records = sink.records.lock().unwrap().clone();
    records
}

fn without_timings(mut r: FrameRecord) -> FrameRecord {
    r.timings_ms = None;
    r
}

#[test]
fn the_engine_gives_the_sessions_records_in_order() {
    let input = frames(40);
    let options = SessionOptions::default();
    let pipeline = Arc::new(Session::load_pipeline(&options).expect("networks"));
    let mut session =
        Session::with_pipeline(Vec::new(), Arc::clone(&pipeline), options).expect("session");
    let want: Vec<FrameRecord> = input
        .iter()
        .flat_map(|(image, t)| {
            let done = session.process(&[image], *t).expect("frame");
            done.into_iter().map(|f| {
                let mut r = fitted_record(&f, None);
                r.time_s = Some(*t);
                r
            })
        })
        .collect();
    let sink = Collect::default();
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink.clone())];
    let report = engine(&pipeline)
        .run(vec![source(input)], &mut sinks, &Quiet)
        .expect("run");
    let got: Vec<FrameRecord> = sink
        .records
        .lock()
        .unwrap()
        .drain(..)
        .map(without_timings)
        .collect();
    assert_eq!(got.len(), 40);
    assert_eq!(
        got, want,
        "the engine and the session give the same records"
    );
    assert_eq!(sink.finished.load(Ordering::Relaxed), 1);
    assert_eq!((report.frames, report.unreadable), (40, 0));
    assert!(report.hands_3d >= 38, "{report:?}");
    // Every record says which camera its hands were fitted with: the generic one here.
    assert!(got.iter().all(|r| r.cameras.len() == 1
        && r.cameras[0].source == CameraSource::Generic
        && (
            r.cameras[0].intrinsics.width,
            r.cameras[0].intrinsics.height
        ) == (256, 256)));
}

#[test]
fn offline_runs_write_every_frame_in_order_with_the_same_hands() {
    let input = frames(30);
    let pipeline = Arc::new(Session::load_pipeline(&SessionOptions::default()).expect("networks"));
    let run = |offline: bool| {
        let engine = engine(&pipeline).with_offline(offline).expect("engine");
        records_of(&engine, &input)
    };
    let (causal, offline) = (run(false), run(true));
    assert_eq!(offline.len(), 30, "the last frames are written at the end");
    let mut moved = 0;
    for (k, (c, o)) in causal.iter().zip(&offline).enumerate() {
        assert_eq!(o.frame, k as u64);
        assert_eq!(c.hands.len(), o.hands.len(), "frame {k}");
        for (hc, ho) in c.hands.iter().zip(&o.hands) {
            // The smoother refits the 3D; what the networks saw is the same.
            assert_eq!(
                (hc.id, hc.side, hc.keypoints_2d),
                (ho.id, ho.side, ho.keypoints_2d)
            );
            let (Some(jc), Some(jo)) = (hc.joints_3d_mm, ho.joints_3d_mm) else {
                continue;
            };
            let d = jc
                .iter()
                .zip(&jo)
                .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt())
                .fold(0.0, f64::max);
            moved += usize::from(d > 0.1);
            assert!(d < 50.0, "frame {k}: a joint moved {d} mm");
        }
    }
    assert!(moved >= 20, "{moved} of 30 frames refitted");
    // Without tracking there is nothing to smooth over.
    let mut independent = monohand::Settings::default();
    independent.fit.tracking = false;
    let independent = independent.resolve().expect("settings");
    assert!(matches!(
        independent.clone().with_offline(true),
        Err(e) if e.field == monohand::Field::Offline
    ));
    // Nor do the networks loaded for tracking run independent images.
    assert!(matches!(
        Engine::new(Arc::clone(&pipeline), Vec::new(), independent),
        Err(EngineError::Settings(e)) if e.field == monohand::Field::Tracking
    ));
}

/// Cancels once `after` frames were written, and keeps the notes.
struct CancelAfter {
    after: u64,
    stop: AtomicBool,
    notes: Mutex<Vec<monohand::Note>>,
}

impl Observer for CancelAfter {
    fn cancelled(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn frame_written(&self, report: &RunReport) {
        if report.frames >= self.after {
            self.stop.store(true, Ordering::Relaxed);
        }
    }

    fn note(&self, note: &monohand::Note) {
        self.notes.lock().unwrap().push(note.clone());
    }
}

#[test]
fn cancelling_finishes_the_frames_in_flight_and_closes_the_sinks() {
    let input = frames(40);
    let pipeline = Arc::new(Session::load_pipeline(&SessionOptions::default()).expect("networks"));
    let sink = Collect::default();
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink.clone())];
    let observer = CancelAfter {
        after: 5,
        stop: AtomicBool::new(false),
        notes: Mutex::new(Vec::new()),
    };
    let report = engine(&pipeline)
        .run(vec![source(input)], &mut sinks, &observer)
        .expect("run");
    let got = sink.records.lock().unwrap();
    // Frames already read when it was cancelled are finished (at most the queues' 8 and the
    // two in the stages); none is lost or reordered.
    assert!(report.cancelled);
    assert!(report.frames >= 5 && report.frames < 40, "{report:?}");
    assert_eq!(got.len() as u64, report.frames);
    assert!(got.iter().enumerate().all(|(k, r)| r.frame == k as u64));
    assert_eq!(sink.finished.load(Ordering::Relaxed), 1);
    // The note about the generic camera names no command-line flag.
    let notes = observer.notes.lock().unwrap();
    assert!(notes.iter().any(|n| n.topic == monohand::NoteTopic::Camera
        && n.message
            .starts_with("assuming a generic camera for 256x256")));
    assert!(notes.iter().all(|n| !n.message.contains("--")), "{notes:?}");
}

#[test]
fn a_failing_sink_stops_the_run_and_the_others_are_closed() {
    let input = frames(12);
    let pipeline = Arc::new(Session::load_pipeline(&SessionOptions::default()).expect("networks"));
    let good = Collect::default();
    let bad = Collect {
        fail_at: Some(7),
        ..Collect::default()
    };
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(good.clone()), Box::new(bad.clone())];
    let err = engine(&pipeline)
        .run(vec![source(input)], &mut sinks, &Quiet)
        .expect_err("the sink fails");
    let EngineError::Output { frames, source } = err else {
        panic!("not an output error: {err}");
    };
    // Frames 0-6 are whole in every sink; the good sink got frame 7 before the bad one failed.
    assert_eq!(frames, 7);
    assert!(source.to_string().contains("disk full"));
    assert_eq!(bad.records.lock().unwrap().len(), 7);
    assert_eq!(good.finished.load(Ordering::Relaxed), 1);
    assert_eq!(bad.finished.load(Ordering::Relaxed), 1);
}

#[test]
fn the_depth_filter_steadies_the_distance_and_keeps_every_joint_on_its_ray() {
    let (on, off) = runs_with_and_without(|settings, on| {
        if !on {
            settings.fit.depth_filter = None;
        }
    });
    let (filtered, raw) = depth_shake_on_the_same_rays(&on, &off);
    println!("depth second differences: {filtered:.1} mm filtered, {raw:.1} mm raw");
    assert!(filtered < 0.7 * raw, "{filtered} against {raw}");
}

#[test]
fn the_offline_depth_pass_steadies_the_distance_and_keeps_every_joint_on_its_ray() {
    let (on, off) = runs_with_and_without(|settings, depth_pass| {
        settings.fit.offline = Some(monohand::OfflineSettings {
            depth_pass,
            ..Default::default()
        });
    });
    let (smoothed, refitted) = depth_shake_on_the_same_rays(&on, &off);
    println!("depth second differences: {smoothed:.1} mm with the pass, {refitted:.1} mm without");
    assert!(smoothed < 0.8 * refitted, "{smoothed} against {refitted}");
}

#[test]
fn a_tracked_hand_seen_by_one_camera_carries_its_distance_and_the_fit_is_held_at_it() {
    let (on, off) = runs_with_and_without(|settings, on| {
        // The depth filter moves the written joints after the fit: off in both runs.
        settings.fit.depth_filter = None;
        if !on {
            settings.fit.options.distance.weight = 0.0;
        }
    });
    let (mut held, mut worst) = (0, 0.0f64);
    for (k, record) in on.iter().enumerate() {
        for hand in record.hands.iter().filter(|h| h.joints_3d_mm.is_some()) {
            let d = hand.distance.expect("a fitted hand's distance");
            assert!(
                d.fused_mm > 100.0 && d.fused_mm < 2000.0,
                "frame {k}: {d:?}"
            );
            assert!(
                d.fused_sigma_mm > 0.0 && d.fused_sigma_mm < d.fused_mm,
                "{d:?}"
            );
            let (kp, sigma) = (
                d.keypoints_mm.expect("keypoints"),
                d.keypoints_sigma_mm.expect("σ"),
            );
            assert!(
                sigma > 0.0 && kp > 0.0 && d.cues_mm.expect("cues") > 0.0,
                "{d:?}"
            );
            // The filter is no less sure than one frame's keypoints.
            assert!(d.fused_sigma_mm <= sigma, "frame {k}: {d:?}");
            if k == 0 {
                continue;
            }
            // From the second frame on the fit is held at the filtered distance (a pull
            // weighed by its certainty, against the pixels'): its palm (the wrist and the
            // fingers' bases) is there, within the fusion's small moves of the joints
            // (at most 0.98 σ on these frames).
            let joints = hand.joints_3d_mm.unwrap();
            let palm = [0, 1, 5, 9, 13, 17]
                .map(|j| joints[j][2])
                .iter()
                .sum::<f64>()
                / 6.0;
            let off_by = (palm - d.fused_mm).abs() / d.fused_sigma_mm;
            worst = worst.max(off_by);
            assert!(
                off_by < 1.5,
                "frame {k}: palm at {palm:.1} mm, held at {:.1} ± {:.1}",
                d.fused_mm,
                d.fused_sigma_mm
            );
            held += 1;
        }
    }
    println!("{held} frames held, the palm at most {worst:.2} σ from the distance");
    assert!(held >= 20, "{held} frames held");
    // Without the mechanism nothing is said of it.
    assert!(off
        .iter()
        .flat_map(|r| &r.hands)
        .all(|h| h.distance.is_none()));
}

/// The records of 30 frames run with the default settings changed by `set(settings, true)`
/// and by `set(settings, false)`.
fn runs_with_and_without(
    set: impl Fn(&mut monohand::Settings, bool),
) -> (Vec<FrameRecord>, Vec<FrameRecord>) {
    let input = frames(30);
    let pipeline = Arc::new(Session::load_pipeline(&SessionOptions::default()).expect("networks"));
    let run = |on: bool| {
        let mut settings = monohand::Settings::default();
        set(&mut settings, on);
        let settings = settings.resolve().expect("settings");
        let engine = Engine::new(Arc::clone(&pipeline), Vec::new(), settings).expect("engine");
        records_of(&engine, &input)
    };
    (run(true), run(false))
}

/// Checks that `on` and `off`, two runs over 30 frames, have the same hands and keypoints,
/// and every joint of `on` on the ray of its joint in `off`; returns the sums over the
/// frames of the absolute second differences of the first hand's mean distance, in `on`
/// and in `off` (mm).
fn depth_shake_on_the_same_rays(on: &[FrameRecord], off: &[FrameRecord]) -> (f64, f64) {
    assert_eq!((on.len(), off.len()), (30, 30));
    // The mean distance of the first hand, per frame, in each run.
    let mut depths: Vec<(f64, f64)> = Vec::new();
    for (k, (a, b)) in on.iter().zip(off).enumerate() {
        assert_eq!(a.hands.len(), b.hands.len(), "frame {k}");
        for (ha, hb) in a.hands.iter().zip(&b.hands) {
            assert_eq!(ha.keypoints_2d, hb.keypoints_2d, "frame {k}");
            let (Some(ja), Some(jb)) = (ha.joints_3d_mm, hb.joints_3d_mm) else {
                continue;
            };
            // The camera is at the origin (no calibration): the same ray is the same
            // direction from it.
            for (x, y) in ja.iter().zip(&jb) {
                let (nx, ny) = (norm(x), norm(y));
                let cross = [
                    x[1] * y[2] - x[2] * y[1],
                    x[2] * y[0] - x[0] * y[2],
                    x[0] * y[1] - x[1] * y[0],
                ];
                assert!(
                    norm(&cross) < 1e-9 * nx * ny,
                    "frame {k}: a joint left its ray"
                );
            }
        }
        let mean_z = |j: &[[f64; 3]; 21]| j.iter().map(|x| x[2]).sum::<f64>() / 21.0;
        if let (Some(ha), Some(hb)) = (a.hands.first(), b.hands.first()) {
            if let (Some(ja), Some(jb)) = (ha.joints_3d_mm, hb.joints_3d_mm) {
                depths.push((mean_z(&ja), mean_z(&jb)));
            }
        }
    }
    assert!(depths.len() >= 25, "{} frames with a hand", depths.len());
    let shake = |pick: fn(&(f64, f64)) -> f64| {
        depths
            .windows(3)
            .map(|w| (pick(&w[0]) - 2.0 * pick(&w[1]) + pick(&w[2])).abs())
            .sum::<f64>()
    };
    (shake(|d| d.0), shake(|d| d.1))
}

fn norm(x: &[f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}
