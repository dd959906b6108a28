//! The table rig's real frames through the engine, for the tests of several cameras
//! (`../shared/data/table_rig_dev`; without it the tests fail, they do not skip).
#![allow(dead_code)] // each test uses its part

use monohand::engine::{CallerFrames, Engine, FrameSource, Output, Quiet, Sink, SinkError};
use monohand::{HandPipeline, RgbImage, Settings};
use monohand_core::prelude::*;
use monohand_io::jsonl::FrameRecord;
use monohand_testkit::table_rig_dir;
use std::ops::Range;
use std::sync::{Arc, Mutex};

/// The frames `range` of `view` with their times at 30 fps.
pub fn frames(view: &str, range: Range<usize>) -> Vec<(RgbImage, f64)> {
    let dir = table_rig_dir().join("images").join(view);
    range
        .map(|k| {
            let path = dir.join(format!("color_{k:06}.jpg"));
            let image = monohand::vision::image_io::load_rgb(&path).expect("rig frame");
            (image, k as f64 / 30.0)
        })
        .collect()
}

/// The camera of `view` as its file gives it (extrinsics from the master camera's frame).
pub fn camera(view: &str) -> Camera {
    let path = table_rig_dir().join("cameras").join(format!("{view}.json"));
    monohand_io::calibration::read_camera(path).expect("rig camera")
}

/// Keeps every record.
#[derive(Default, Clone)]
pub struct Collect(pub Arc<Mutex<Vec<FrameRecord>>>);

impl Sink for Collect {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        self.0.lock().unwrap().push(frame.record.clone());
        Ok(())
    }
}

/// The records of a tracked run of the frames `range` of `views` with `cameras` and
/// `settings`.
pub fn run(
    pipeline: &Arc<HandPipeline>,
    cameras: Vec<Camera>,
    views: &[&str],
    range: Range<usize>,
    settings: Settings,
) -> Vec<FrameRecord> {
    let settings = settings.resolve().expect("settings");
    let engine = Engine::new(Arc::clone(pipeline), cameras, settings).expect("engine");
    let sources: Vec<Box<dyn FrameSource>> = views
        .iter()
        .map(|v| {
            let frames = frames(v, range.clone()).into_iter();
            Box::new(CallerFrames::new(frames, true)) as Box<dyn FrameSource>
        })
        .collect();
    let sink = Collect::default();
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink.clone())];
    engine.run(sources, &mut sinks, &Quiet).expect("run");
    let records = sink.0.lock().unwrap().clone();
    records
}
