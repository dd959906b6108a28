//! The engine: the whole frames-to-3D pipeline, from sources of frames to sinks of
//! records, with its stages on threads of their own.
//!
//! ```text
//! FrameSource(s) ─ reader thread ─▶ networks thread (CropTracker) ─▶ fit (HandsFitter),
//!                  decode ahead     detection, crops, keypoints        on the calling
//!                                                                       thread ─▶ Sinks
//! ```
//!
//! - Frames stay in order. Each queue holds a few frames: a full queue makes the stage
//!   before it wait, so a long video never sits in memory.
//! - Independent images (no tracking, one view) run the networks on all cores instead, a
//!   chunk of frames at a time, still written in order.
//! - An [`Observer`] can cancel the run (the frame in flight is finished and every sink
//!   closed), and hears of every frame written and every note for the user.
//! - A failing sink stops the run; the others are closed so that each holds whole frames.
//!
//! `monohand run`, the Python package and `monohand eval --stage full` all run this.

pub mod corpus;
pub mod detect;
pub mod lift;
mod sinks;
mod source;
pub mod sync;

pub use crate::base::errors::SourceError;
#[cfg(feature = "lerobot")]
pub use sinks::LeRobotSink;
pub use sinks::{
    CsvSink, GltfSink, JsonlSink, OpenPoseSink, Output, OverlaySink, Sink, SinkError, WindowSink,
};
#[cfg(feature = "rerun")]
pub use sinks::{RerunError, RerunSink};
pub use source::{
    chain, stated_camera, CallerFrames, FrameSource, ImageFiles, Input, InputError, SourceFrame,
    VideoSource,
};

/// Overlay file-name conventions (which names are videos, which one image).
pub mod overlay_paths {
    pub use super::sinks::{has_extension, IMAGE_EXTENSIONS, VIDEO_EXTENSIONS};
}

use crate::base::frame::{FittedFrame, FittedGuide, ViewError, VisionFrame};
use crate::base::notes::{Note, NoteTopic};
use crate::settings::ResolvedSettings;
use crate::stages::crops::CropTracker;
use crate::stages::fitter::HandsFitter;
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_vision::tflite_import::allow_split_here;
use monohand_vision::{HandPipeline, RgbImage};
use std::sync::mpsc::{sync_channel, Receiver, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What can stop the engine.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// An input could not be opened, or does not fit the cameras.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A setting was refused ([`crate::settings`]), or the networks do not run as the
    /// settings ask.
    #[error(transparent)]
    Settings(#[from] crate::base::errors::SettingsError),
    /// The settings are inconsistent.
    #[error(transparent)]
    Session(#[from] crate::SessionError),
    /// A sink could not write; the others were closed and hold `frames` whole frames. (The
    /// message is the consequence; the sink's error is its [`std::error::Error::source`].)
    #[error(
        "an output could not be written after {frames} frame(s); the run stopped, the other \
         outputs were closed and every file holds whole frames only"
    )]
    Output {
        /// Frames every sink holds in full.
        frames: u64,
        /// The sink's error.
        source: SinkError,
    },
    /// A stage's thread failed (a panic); the sinks were closed and hold `frames` frames.
    #[error("the {stage} thread failed after {frames} frames; the output is complete up to there")]
    ThreadFailed {
        /// `network` or `reader`.
        stage: &'static str,
        /// Frames every sink holds in full.
        frames: u64,
    },
}

/// Result type of the engine.
pub type EngineResult<T> = std::result::Result<T, EngineError>;

/// Hears from a run: whether to stop, each frame written, and notes for the user.
/// Every method has a default that does nothing.
pub trait Observer: Sync {
    /// Whether the run should stop now (checked before each frame is read).
    fn cancelled(&self) -> bool {
        false
    }
    /// A frame was written to every sink; `report` holds the totals so far.
    fn frame_written(&self, report: &RunReport) {
        let _ = report;
    }
    /// A message for the user: an assumption made (a generic camera), a hand size found.
    fn note(&self, note: &Note) {
        let _ = note;
    }
}

/// An observer that hears nothing and never cancels.
#[derive(Debug, Default, Clone, Copy)]
pub struct Quiet;

impl Observer for Quiet {}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunReport {
    /// Frames written.
    pub frames: u64,
    /// Frames with at least one hand.
    pub frames_with_hands: u64,
    /// Hands written.
    pub hands: u64,
    /// Hands with 3D.
    pub hands_3d: u64,
    /// Sum of the hands' mean reprojection errors, pixels.
    pub reprojection_sum_px: f64,
    /// Frames that could not be read (their records carry the error).
    pub unreadable: u64,
    /// The error that ended the input early, after `frames` good frames.
    pub input_error: Option<SourceError>,
    /// The observer cancelled the run.
    pub cancelled: bool,
    /// Wall-clock seconds of the run.
    pub seconds: f64,
    /// The hand the views measured (with [`crate::FitSettings::auto_scale_frames`]).
    pub measured_hand: Option<monohand_io::hand::HandFile>,
    /// The hand size the fits used at the end, and where it came from.
    pub hand_size: Option<monohand_io::jsonl::HandSizeRecord>,
    /// With several cameras: each view's agreement with the fitted hands
    /// ([`crate::rig_check`]; [`RunReport::rig_summary`]).
    pub rig: crate::stages::rig_check::RigCheck,
}

impl RunReport {
    fn add(&mut self, rec: &FrameRecord) {
        self.frames += 1;
        self.rig.add(rec);
        if rec.error.is_some() {
            self.unreadable += 1;
        }
        if !rec.hands.is_empty() {
            self.frames_with_hands += 1;
        }
        for h in &rec.hands {
            self.hands += 1;
            if let Some(e) = h.reprojection_error_px {
                self.hands_3d += 1;
                self.reprojection_sum_px += e;
            }
        }
    }

    /// The mean reprojection error of the hands with 3D, pixels.
    pub fn mean_reprojection_px(&self) -> Option<f64> {
        (self.hands_3d > 0).then(|| self.reprojection_sum_px / self.hands_3d as f64)
    }

    /// With several cameras, each view's median reprojection error and the views whose
    /// error stays far above the others' ([`crate::stages::rig_check::RigCheck::verdict`]);
    /// `None` when no hand was fitted from several views.
    pub fn rig_summary(&self) -> Option<String> {
        self.rig.verdict().map(|v| v.to_string())
    }

    /// Whether frames were written and none of them could be read.
    pub fn nothing_readable(&self) -> bool {
        self.frames > 0 && self.unreadable == self.frames
    }

    /// One line saying what the run did: frames, hands, the mean reprojection error, the
    /// frame rate, and whether it was interrupted.
    pub fn summary(&self) -> String {
        let mean_rep = match self.mean_reprojection_px() {
            Some(e) => format!("{e:.2} px"),
            None => "-".into(),
        };
        let size = match &self.hand_size {
            Some(h) => format!(
                ", hand size {:.0} mm ({:.3} x the default, {})",
                h.length_mm, h.scale, h.source
            ),
            None => String::new(),
        };
        format!(
            "{} frames ({} with hands, {} unreadable), {} hands ({} in 3D), mean reprojection error {mean_rep}{size}, {:.1} fps{}",
            self.frames,
            self.frames_with_hands,
            self.unreadable,
            self.hands,
            self.hands_3d,
            self.frames as f64 / self.seconds.max(1e-9),
            if self.cancelled { " (interrupted)" } else { "" }
        )
    }
}

/// The pipeline over networks already loaded and the cameras of every view (none: a camera
/// per image from its EXIF focal length, else the generic guess).
///
/// ```no_run
/// use monohand::engine::{Engine, Input, JsonlSink, Quiet, Sink};
/// use monohand::{HandPipeline, Settings, vision::ModelOptions};
/// use std::sync::Arc;
///
/// let settings = Settings::default().resolve()?;
/// let pipeline = Arc::new(HandPipeline::new(&ModelOptions::default(), settings.pipeline())?);
/// let engine = Engine::new(pipeline, vec![], settings)?;
/// let source = Input::parse("clip.mp4")?.open(std::time::Duration::from_secs(10))?;
/// let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(JsonlSink::create("hands.jsonl".as_ref())?)];
/// let report = engine.run(vec![source], &mut sinks, &Quiet)?;
/// println!("{} frames, {} hands", report.frames, report.hands);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct Engine {
    pipeline: Arc<HandPipeline>,
    cameras: Vec<Camera>,
    settings: ResolvedSettings,
    /// How late each view started against the first, seconds; empty: the views' frames
    /// are matched by index ([`Engine::with_view_offsets`]).
    offsets_s: Vec<f64>,
}

impl std::fmt::Debug for Engine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Engine")
            .field("cameras", &self.cameras)
            .field("settings", &self.settings)
            .finish()
    }
}

/// One frame of all views before the networks run.
struct RawFrame {
    index: u64,
    source: Option<String>,
    timestamp_s: f64,
    images: Vec<Result<RgbImage, SourceError>>,
    decode_ms: f64,
    /// What the first view's file states about its camera.
    focal: crate::StatedCamera,
}

/// What the engine carries beside each frame through the fit.
struct Extra {
    source: Option<String>,
    is_video: bool,
    image: Option<RgbImage>,
    /// The other views' images, when a sink wants every view's.
    others: Vec<Option<RgbImage>>,
    decode_ms: f64,
}

/// Which images the sinks want kept beside each frame.
#[derive(Debug, Clone, Copy)]
struct Keep {
    /// The first view's ([`Sink::wants_images`]).
    first: bool,
    /// Every view's ([`Sink::wants_every_view`]).
    all: bool,
}

impl Engine {
    /// An engine over `pipeline` with one camera per view (none: one view, its camera from
    /// each image). The cameras are checked here, and the networks against the settings
    /// ([`ResolvedSettings::check_pipeline`]).
    pub fn new(
        pipeline: Arc<HandPipeline>,
        cameras: Vec<Camera>,
        settings: ResolvedSettings,
    ) -> EngineResult<Engine> {
        settings.check_pipeline(&pipeline, None)?;
        // The fitter checks the cameras.
        HandsFitter::<()>::new(cameras.clone(), *settings.fit())
            .map_err(crate::SessionError::from)?;
        Ok(Engine {
            pipeline,
            cameras,
            settings,
            offsets_s: Vec::new(),
        })
    }

    /// The networks.
    pub fn pipeline(&self) -> &Arc<HandPipeline> {
        &self.pipeline
    }

    /// The cameras, one per view (empty: a camera per image).
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The settings.
    pub fn settings(&self) -> &ResolvedSettings {
        &self.settings
    }

    /// The same engine with each later view's frames matched to the first view's by time,
    /// `offsets_s[v]` being how late view `v` started, seconds ([`sync::align`]; found by
    /// [`sync::find_offsets`]); each record's cameras say it (`time_offset_s`). Empty: the
    /// frames are matched by index, as without.
    pub fn with_view_offsets(mut self, offsets_s: Vec<f64>) -> Engine {
        self.offsets_s = offsets_s;
        self
    }

    /// The same engine, stopping after `max_frames` frames (`None`: at the input's end).
    pub fn with_max_frames(mut self, max_frames: Option<u64>) -> Engine {
        self.settings = self.settings.with_max_frames(max_frames);
        self
    }

    /// The same engine with the offline smoother on (its default settings) or off; refused
    /// without tracking.
    pub fn with_offline(mut self, on: bool) -> EngineResult<Engine> {
        self.settings = self.settings.with_offline(on)?;
        Ok(self)
    }

    /// Checks that the calibrated cameras fit the sources' frames (one source per view).
    pub fn check_sources(&self, sources: &[Box<dyn FrameSource>]) -> EngineResult<()> {
        if !self.cameras.is_empty() && self.cameras.len() != sources.len() {
            return Err(InputError::CameraCount {
                cameras: self.cameras.len(),
                views: sources.len(),
                what: "",
                per: "calibration",
                order: ", in the same order",
            }
            .into());
        }
        if sources.len() > 1 && self.cameras.is_empty() {
            return Err(InputError::Uncalibrated.into());
        }
        for (v, (s, cam)) in sources.iter().zip(&self.cameras).enumerate() {
            let Some((w, h)) = s.video_size() else {
                continue;
            };
            let k = &cam.intrinsics;
            let quarter_turn = s.rotation_deg().rem_euclid(180) == 90;
            if quarter_turn && (k.width, k.height) == (h, w) {
                let rotation = s.rotation_deg();
                return Err(InputError::Rotated {
                    view: v + 1,
                    w,
                    h,
                    rotation,
                }
                .into());
            }
            // Another size of the same shape is scaled frame by frame (said then); another
            // shape cannot be the same lens's frame.
            if let Err(source) = cam.scaled_to(w, h) {
                return Err(InputError::OtherSize {
                    view: v + 1,
                    size: (w, h),
                    calibrated: (k.width, k.height),
                    source,
                }
                .into());
            }
        }
        Ok(())
    }

    /// Runs every frame of `sources` (one per view, frames matched by index) through the
    /// pipeline into `sinks`, in order, and closes the sinks. The input ending on an error
    /// after good frames is not an error of the run: [`RunReport::input_error`] says it.
    pub fn run(
        &self,
        mut sources: Vec<Box<dyn FrameSource>>,
        sinks: &mut [Box<dyn Sink>],
        observer: &dyn Observer,
    ) -> EngineResult<RunReport> {
        self.check_sources(&sources)?;
        if sources.is_empty() {
            return Err(InputError::Nothing.into());
        }
        let tracking = self.settings.tracking();
        let mut fit = HandsFitter::new(self.cameras.clone(), *self.settings.fit())
            .map_err(crate::SessionError::from)?;
        let all = sinks.iter().any(|s| s.wants_every_view());
        let keep = Keep {
            first: all || sinks.iter().any(|s| s.wants_images()),
            all,
        };
        let mut out = Writer::new(sinks, observer);
        out.offsets_s.clone_from(&self.offsets_s);
        if !self.offsets_s.is_empty() {
            sources = sync::align(sources, &self.offsets_s);
        }
        let result = if tracking || sources.len() > 1 {
            self.run_threaded(sources, &mut fit, &mut out, keep)
        } else {
            let source = sources.swap_remove(0);
            self.run_independent(source, &mut fit, &mut out, keep.first)
        };
        let mut report = out.end(result)?;
        report.measured_hand = fit.measured_hand().cloned();
        report.hand_size = (report.hands_3d > 0).then(|| fit.hand_size());
        Ok(report)
    }

    /// Decode → networks → fit on three threads, in order.
    fn run_threaded(
        &self,
        sources: Vec<Box<dyn FrameSource>>,
        fit: &mut HandsFitter<Extra>,
        out: &mut Writer<'_, '_>,
        keep: Keep,
    ) -> EngineResult<()> {
        let max_frames = self.settings.max_frames();
        let tracking = self.settings.tracking();
        let n_views = sources.len();
        let settings = &self.settings;
        let observer = out.observer;
        let panic_at = injected_network_panic();
        // The first view's frames go back to its reader once the networks are done with
        // them (unless a sink keeps them): no new frame buffer per frame.
        let recycler = sources.first().and_then(|s| s.recycler());
        // With several calibrated views, each frame's crops come from the hands fitted in
        // the frame before: the networks wait for that fit.
        // The crop stage alone decides whether it is guided: the fit sends guides exactly
        // when the stage waits for them.
        let stage = CropTracker::new(
            Arc::clone(&self.pipeline),
            n_views,
            settings.crops(&self.cameras),
        );
        let (guide_tx, guide_rx) = sync_channel::<Vec<FittedGuide>>(1);
        let guide_tx = stage.is_guided().then_some(guide_tx);
        std::thread::scope(|scope| {
            let (raw_tx, raw_rx) = sync_channel::<RawFrame>(4);
            let (vis_tx, vis_rx) = sync_channel::<(VisionFrame, Extra)>(4);
            let reader = scope.spawn(move || {
                let mut sources = sources;
                read_all(&mut sources, max_frames, observer, |f| {
                    raw_tx.send(f).is_ok()
                })
            });
            let handoff = Handoff {
                keep,
                recycler,
                tracking,
                panic_at,
            };
            let vision =
                scope.spawn(move || network_loop(stage, &raw_rx, &vis_tx, &guide_rx, &handoff));
            let result = fit_all(&vis_rx, fit, out, guide_tx);
            drop(vis_rx);
            let vision_panicked = vision.join().is_err();
            let reader = reader.join();
            let reader_panicked = reader.is_err();
            out.report.input_error = reader.unwrap_or(None);
            result?;
            if vision_panicked || reader_panicked {
                return Err(EngineError::ThreadFailed {
                    stage: if vision_panicked { "network" } else { "reader" },
                    frames: out.report.frames,
                });
            }
            Ok(())
        })
    }

    /// Independent images: the networks on all cores, a chunk at a time, in order.
    fn run_independent(
        &self,
        mut source: Box<dyn FrameSource>,
        fit: &mut HandsFitter<Extra>,
        out: &mut Writer<'_, '_>,
        keep_image: bool,
    ) -> EngineResult<()> {
        use rayon::prelude::*;
        let pool = thread_pool(self.settings.threads())?;
        let chunk = 2 * pool.current_num_threads();
        // Not tracking here: every image is detected on its own.
        let mut stage = CropTracker::new(Arc::clone(&self.pipeline), 1, self.settings.crops(&[]));
        stage.rectify_through(self.settings.lenses(&self.cameras));
        let mut batch: Vec<RawFrame> = Vec::with_capacity(chunk);
        let mut done = false;
        while !done {
            batch.clear();
            while batch.len() < chunk {
                if out.observer.cancelled()
                    || self
                        .settings
                        .max_frames()
                        .is_some_and(|m| out.report.frames + batch.len() as u64 >= m)
                {
                    done = true;
                    break;
                }
                match next_raw(std::slice::from_mut(&mut source)) {
                    Ok(Some(f)) => batch.push(f),
                    Ok(None) => {
                        done = true;
                        break;
                    }
                    Err(e) => {
                        out.report.input_error = Some(e);
                        done = true;
                        break;
                    }
                }
            }
            let pipeline = &self.pipeline;
            let lenses = &stage;
            let detected: Vec<_> = pool.install(|| {
                batch
                    .par_iter()
                    .map(|raw| {
                        let t = Instant::now();
                        let d = match &raw.images[0] {
                            Ok(img) => pipeline
                                .detect_through(img, lenses.lens(0, img.dimensions()).as_ref())
                                .map_err(ViewError::from),
                            Err(e) => Err(ViewError::Unreadable(e.clone())),
                        };
                        (d, t.elapsed().as_secs_f64() * 1e3)
                    })
                    .collect()
            });
            for (raw, (d, ms)) in batch.drain(..).zip(detected) {
                let image = raw.images.into_iter().next().and_then(Result::ok);
                let mut f = stage.assign(raw.index, raw.timestamp_s, d, ms);
                f.focal = raw.focal;
                let extra = Extra {
                    source: raw.source,
                    is_video: false,
                    image: image.filter(|_| keep_image),
                    others: Vec::new(),
                    decode_ms: raw.decode_ms,
                };
                let done = fit.push(f, extra);
                out.emit(fit, done)?;
            }
        }
        let done = fit.flush();
        out.emit(fit, done)
    }
}

/// The sinks of a run, with the totals written so far.
struct Writer<'s, 'o> {
    sinks: &'s mut [Box<dyn Sink>],
    report: RunReport,
    observer: &'o dyn Observer,
    start: Instant,
    /// Each view's offset, for the records' cameras ([`Engine::with_view_offsets`]).
    offsets_s: Vec<f64>,
}

impl<'s, 'o> Writer<'s, 'o> {
    /// A job writing to `sinks`, heard by `observer`, from now on.
    fn new(sinks: &'s mut [Box<dyn Sink>], observer: &'o dyn Observer) -> Writer<'s, 'o> {
        Writer {
            sinks,
            report: RunReport::default(),
            observer,
            start: Instant::now(),
            offsets_s: Vec::new(),
        }
    }

    /// Writes one frame to every sink, then counts it.
    fn write(&mut self, frame: &Output<'_>) -> EngineResult<()> {
        for sink in self.sinks.iter_mut() {
            sink.write(frame).map_err(|source| EngineError::Output {
                frames: self.report.frames,
                source,
            })?;
        }
        self.report.add(frame.record);
        self.observer.frame_written(&self.report);
        Ok(())
    }

    /// Closes the sinks after a job that ended with `result` (all of them, a failed one
    /// too) and gives the totals, or the job's error.
    fn end(mut self, result: EngineResult<()>) -> EngineResult<RunReport> {
        match result {
            Ok(()) => self.finish()?,
            Err(e) => {
                self.close_after_failure();
                return Err(e);
            }
        }
        let mut report = self.report;
        report.cancelled = self.observer.cancelled();
        report.seconds = self.start.elapsed().as_secs_f64();
        Ok(report)
    }

    /// Writes the fitted frames (in order) to every sink, and passes on the fitter's notes.
    fn emit(
        &mut self,
        fit: &mut HandsFitter<Extra>,
        done: Vec<(FittedFrame, Extra)>,
    ) -> EngineResult<()> {
        for note in fit.take_notes() {
            self.observer.note(&note);
        }
        for (f, extra) in done {
            let mut record = record(&f, &extra);
            for (c, off) in record.cameras.iter_mut().zip(&self.offsets_s) {
                c.time_offset_s = Some(*off);
            }
            self.write(&Output {
                record: &record,
                image: extra.image.as_ref(),
                cameras: &f.cameras,
                other_images: &extra.others,
                fitted: Some(&f),
            })?;
        }
        Ok(())
    }

    /// Closes every sink; the first failure is returned after all were tried.
    fn finish(&mut self) -> EngineResult<()> {
        let mut closed = Ok(());
        for sink in self.sinks.iter_mut() {
            if let Err(source) = sink.finish() {
                if closed.is_ok() {
                    closed = Err(EngineError::Output {
                        frames: self.report.frames,
                        source,
                    });
                }
            }
        }
        closed
    }

    /// After a failure: closes the others (an overlay video finalised, a glTF written),
    /// saying so if that fails too.
    fn close_after_failure(&mut self) {
        if let Err(more) = self.finish() {
            self.observer.note(&Note::new(
                NoteTopic::Output,
                format!("closing the other outputs failed too: {more}"),
            ));
        }
    }
}

/// The output record of a fitted frame, with its time (video) and stage timings.
fn record(done: &FittedFrame, extra: &Extra) -> FrameRecord {
    crate::stages::records::timed_record(
        done,
        extra.source.clone(),
        extra.is_video,
        Some(extra.decode_ms),
    )
}

/// What the network thread hands on beside each frame, and how.
struct Handoff {
    /// Which images the sinks keep.
    keep: Keep,
    /// Where the first view's frames go back once the networks are done with them.
    recycler: Option<monohand_media::video::FrameRecycler>,
    /// Whether the frames are a video's (tracked).
    tracking: bool,
    /// The frame at which the network thread panics on purpose (`MONOHAND_FAULT`).
    panic_at: Option<u64>,
}

/// The next frame from the reader, `None` once it is done. A network alone shares its
/// operators with the other cores only while frames are waiting: while this thread waits
/// for the decoder, that core is better left to it (docs/performance.md).
fn receive_raw(raw_rx: &Receiver<RawFrame>) -> Option<RawFrame> {
    match raw_rx.try_recv() {
        Ok(raw) => {
            allow_split_here(true);
            Some(raw)
        }
        Err(TryRecvError::Empty) => {
            allow_split_here(false);
            raw_rx.recv().ok()
        }
        Err(TryRecvError::Disconnected) => None,
    }
}

/// The network thread: each frame of the reader through the crop stage and the networks,
/// on to the fit, with the images the sinks keep; a guided stage waits for the fit's guides
/// after each frame. Ends when the reader or the fit is done.
fn network_loop(
    mut stage: CropTracker,
    raw_rx: &Receiver<RawFrame>,
    vis_tx: &std::sync::mpsc::SyncSender<(VisionFrame, Extra)>,
    guide_rx: &Receiver<Vec<FittedGuide>>,
    handoff: &Handoff,
) {
    while let Some(raw) = receive_raw(raw_rx) {
        if handoff.panic_at == Some(raw.index) {
            panic!(
                "injected fault: network thread panics at frame {}",
                raw.index
            );
        }
        let images: Vec<Result<&RgbImage, SourceError>> = raw
            .images
            .iter()
            .map(|i| i.as_ref().map_err(Clone::clone))
            .collect();
        let mut f = stage.process(raw.index, raw.timestamp_s, &images);
        f.focal = raw.focal;
        let mut images = raw.images.into_iter();
        let first = images.next().and_then(Result::ok);
        let others = match handoff.keep.all {
            true => images.map(Result::ok).collect(),
            false => Vec::new(),
        };
        let image = match (handoff.keep.first, first, &handoff.recycler) {
            (true, image, _) => image,
            (false, Some(image), Some(r)) => {
                r.recycle(image);
                None
            }
            _ => None,
        };
        let extra = Extra {
            source: raw.source,
            is_video: handoff.tracking,
            image,
            others,
            decode_ms: raw.decode_ms,
        };
        if vis_tx.send((f, extra)).is_err() {
            return;
        }
        if stage.is_guided() {
            match guide_rx.recv() {
                Ok(g) => stage.guide(g),
                Err(_) => return,
            }
        }
    }
}

/// Fits and writes every frame that comes out of the networks; with `guides`, sends each
/// frame's fitted hands back to the networks for the next frame's crops, before writing.
fn fit_all(
    rx: &Receiver<(VisionFrame, Extra)>,
    fit: &mut HandsFitter<Extra>,
    out: &mut Writer<'_, '_>,
    guides: Option<std::sync::mpsc::SyncSender<Vec<FittedGuide>>>,
) -> EngineResult<()> {
    for (f, extra) in rx {
        let done = fit.push(f, extra);
        if let Some(tx) = &guides {
            // The networks have stopped when nobody listens; the frames in hand are written.
            let _ = tx.send(fit.guides());
        }
        out.emit(fit, done)?;
    }
    let done = fit.flush();
    out.emit(fit, done)
}

/// A thread pool of `threads` (all cores when `None`); with one thread the networks do
/// not share their operators with other cores either.
fn thread_pool(threads: Option<usize>) -> EngineResult<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        builder = builder
            .num_threads(n)
            .start_handler(move |_| allow_split_here(n > 1));
    }
    builder
        .build()
        .map_err(|e| InputError::Threads(e.to_string()).into())
}

/// Fault injection for the tests of a failing run: `MONOHAND_FAULT=network-panic:N` makes
/// the network thread panic on frame `N` (docs/pipeline.md).
fn injected_network_panic() -> Option<u64> {
    let spec = std::env::var("MONOHAND_FAULT").ok()?;
    spec.strip_prefix("network-panic:")?.parse().ok()
}

/// The next frame of every view; `Ok(None)` when the first view ended.
fn next_raw(sources: &mut [Box<dyn FrameSource>]) -> Result<Option<RawFrame>, SourceError> {
    let Some((first, others)) = sources.split_first_mut() else {
        return Ok(None);
    };
    let Some(f) = first.next_frame()? else {
        return Ok(None);
    };
    let mut decode_ms = f.decode_ms;
    let mut images = Vec::with_capacity(1 + others.len());
    images.push(f.image);
    for (k, s) in others.iter_mut().enumerate() {
        let view = k + 2;
        images.push(match s.frame_at(f.index, f.timestamp_s) {
            Ok(Some(g)) => {
                decode_ms += g.decode_ms;
                g.image
            }
            Ok(None) => Err(SourceError::ViewEnded { view }),
            Err(e) => Err(SourceError::View {
                view,
                source: Box::new(e),
            }),
        });
    }
    Ok(Some(RawFrame {
        index: f.index,
        source: f.source,
        timestamp_s: f.timestamp_s,
        images,
        decode_ms,
        focal: f.focal,
    }))
}

/// Reads frames until the end, cancellation, `max_frames` or `send` refusing; returns the
/// error that ended the input early, if any.
fn read_all(
    sources: &mut [Box<dyn FrameSource>],
    max_frames: Option<u64>,
    observer: &dyn Observer,
    mut send: impl FnMut(RawFrame) -> bool,
) -> Option<SourceError> {
    let mut n = 0u64;
    loop {
        if observer.cancelled() || max_frames.is_some_and(|m| n >= m) {
            return None;
        }
        match next_raw(sources) {
            Ok(Some(f)) => {
                if !send(f) {
                    return None;
                }
                n += 1;
            }
            Ok(None) => return None,
            Err(e) => return Some(e),
        }
    }
}

/// The default stall timeout of video sources.
pub const DEFAULT_STALL_TIMEOUT: Duration = monohand_media::video::DEFAULT_STALL_TIMEOUT;
