//! `monohand run`: images, videos, a webcam or a calibrated multi-view rig in; absolute 3D
//! hands out. Detection → keypoints → 3D fit, for every hand in every frame.
//!
//! Threads: one reads and decodes frames (ffmpeg itself decodes in its own process), one
//! runs the networks, and the calling thread fits and writes, so the stages overlap without
//! reordering frames. Independent images (no tracking) run the networks on all cores.

mod hands;
mod input;
mod output;
#[cfg(feature = "show")]
mod show;
#[cfg(not(feature = "show"))]
#[path = "show_off.rs"]
mod show;

use crate::hand_args::{HandModelArgs, HandScale};
use crate::vision::ModelArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use hands::{Done, FrameExtra};
use input::{FrameSource, InputKind};
use monohand::{CropTracker, FitSettings, HandsFitter, VisionFrame};
use monohand_core::filtering::OneEuroParams;
use monohand_core::prelude::*;
use monohand_vision::tflite_import::allow_split_here;
use monohand_vision::RgbImage;
use output::{OutputFormat, Outputs};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, Receiver, TryRecvError};
use std::sync::Arc;
use std::time::Instant;

/// Arguments of `monohand run`.
#[derive(Debug, Args)]
pub(crate) struct RunArgs {
    /// An image, a folder of images (file-name order), a video file (anything ffmpeg
    /// reads) or `webcam:N` (/dev/videoN). For several calibrated cameras use --view
    /// instead, once per camera.
    #[arg(value_name = "INPUT", required_unless_present = "views")]
    pub input: Option<String>,
    /// One view of a calibrated multi-camera rig (repeat, with one --camera each, in the
    /// same order); frames are matched by index across views.
    #[arg(long = "view", value_name = "INPUT", conflicts_with = "input")]
    pub views: Vec<String>,
    /// Camera calibration (project JSON, WACV'18 JSON or OpenCV YAML/XML; see
    /// docs/calibration.md), one per view. Without it a generic camera (60 degree
    /// horizontal field of view) is assumed for the image size, and said once.
    #[arg(long = "camera", value_name = "FILE")]
    pub cameras: Vec<PathBuf>,
    /// Where to write the hands ("-" for standard output), one record per frame, flushed
    /// as it goes.
    #[arg(short, long, value_name = "FILE", default_value = "-")]
    pub output: PathBuf,
    /// Format of --output: JSON Lines (docs/output-format.md), CSV (one row per hand per
    /// frame), or OpenPose JSON (--output is then a folder, one file per frame).
    #[arg(long, value_enum, default_value = "jsonl")]
    pub format: OutputFormat,
    /// Draw the 2D keypoints and the fitted 3D model on the frames: a video file
    /// (.mp4/.mkv/.avi/.mov/.webm, through ffmpeg), a folder of PNG images, or, for an
    /// input of one image, an image file (.png/.jpg).
    #[arg(long, value_name = "OUT.mp4|DIR|OUT.png")]
    pub overlay: Option<PathBuf>,
    /// What the overlay (and --show) draws, comma-separated: `bones` (the fitted model as
    /// shaded 3D capsules, nearer over farther), `top` (an inset seen from above with a mm
    /// scale), `labels` (side, id, score, distance), `keypoints` (the network's 2D
    /// skeleton), `model` (the fitted model as thin projected lines).
    #[arg(
        long,
        value_name = "LAYER,..",
        value_delimiter = ',',
        default_value = "bones,top,labels"
    )]
    pub layers: Vec<monohand_media::scene::Layer>,
    /// Show the frames live in a window with the overlay (--layers), the frame rate and
    /// each hand's id, side and distance. Keys: Space pause, . step, 1-5 toggle layers
    /// (keypoints, model, bones, top, labels), Q quit; closing the window stops the run
    /// like Ctrl-C. Needs the `show` feature (on by default) and a display.
    #[arg(long)]
    pub show: bool,
    /// Write the 3D hands as an animated glTF binary (.glb) that Blender or any glTF
    /// viewer plays.
    #[arg(long, value_name = "OUT.glb")]
    pub gltf: Option<PathBuf>,
    /// How --gltf draws each hand: a real hand mesh posed by the fit (the WebXR generic
    /// hand, MIT), or the 21 joints and 20 bones as sticks.
    #[arg(long, value_enum, value_name = "STYLE", default_value = "skinned")]
    pub gltf_hand: output::GltfStyle,
    /// Track on video (default for videos and webcams): the next crop comes from the last
    /// keypoints, the detector runs only when a hand is lost or every --detect-every
    /// frames, the 3D fit starts from the last pose, and hands keep their id.
    #[arg(long, overrides_with = "no_track")]
    pub track: bool,
    /// Treat every frame on its own (default for images).
    #[arg(long)]
    pub no_track: bool,
    /// While tracking, look for new hands every N frames.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub detect_every: usize,
    /// Smooth the 3D joints over time with a One Euro filter (video only; off by default:
    /// it trades a little lag for less jitter).
    #[arg(long)]
    pub smooth: bool,
    /// One Euro filter: minimum cutoff frequency, Hz (lower: smoother when still).
    #[arg(long, value_name = "HZ", default_value_t = OneEuroParams::default().min_cutoff)]
    pub smooth_min_cutoff: f64,
    /// One Euro filter: speed coefficient (higher: less lag when moving fast).
    #[arg(long, value_name = "BETA", default_value_t = OneEuroParams::default().beta)]
    pub smooth_beta: f64,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    pub max_frames: Option<u64>,
    /// A video or webcam that delivers no frame for this many seconds counts as stalled:
    /// it is closed, the outputs are finished and the run exits with status 3.
    #[arg(long, value_name = "SECS", default_value_t = monohand_media::video::DEFAULT_STALL_TIMEOUT.as_secs_f64())]
    pub stall_timeout: f64,
    /// Worker threads for independent images (default: all cores; 1: one core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub hand: HandModelArgs,
    #[command(flatten)]
    pub models: ModelArgs,
}

/// What one frame of all views is before the networks run.
struct RawFrame {
    index: u64,
    source: Option<String>,
    timestamp_s: f64,
    images: Vec<Result<RgbImage, String>>,
    decode_ms: f64,
    /// The EXIF focal length of the first view's image file.
    focal: Option<monohand_vision::image_io::PhotoFocal>,
}

/// Totals for the summary line.
#[derive(Default)]
struct Summary {
    frames: u64,
    frames_with_hands: u64,
    hands: u64,
    hands_3d: u64,
    reprojection_sum: f64,
    unreadable: u64,
    input_error: Option<String>,
}

impl Summary {
    fn add(&mut self, rec: &monohand_io::jsonl::FrameRecord) {
        self.frames += 1;
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
                self.reprojection_sum += e;
            }
        }
    }
}

/// How a run ended, when it wrote what it could (each has its exit status:
/// [`crate::exit`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Every frame of the input was read and written.
    Complete,
    /// The input ended with an error (a damaged video, ffmpeg killed, a stalled source)
    /// after some good frames; the outputs are complete up to there.
    InputEndedEarly,
    /// Stopped by SIGINT (Ctrl-C), SIGTERM or SIGHUP; the outputs are complete up to the
    /// last frame.
    Interrupted,
}

/// An output failed mid-run (a full disk, a folder that cannot be written): the error's
/// context, so that `main` can give it its own exit status.
#[derive(Debug)]
pub(crate) struct OutputFailed {
    /// Frames every output holds in full.
    pub frames: u64,
}

impl std::fmt::Display for OutputFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "an output could not be written after {} frame(s); the run stopped, the other \
             outputs were closed and every file holds whole frames only",
            self.frames
        )
    }
}

pub(crate) fn run(args: &RunArgs) -> Result<Outcome> {
    // Everything that can be checked is checked before any output is created.
    let specs: Vec<String> = match &args.input {
        Some(i) => vec![i.clone()],
        None => args.views.clone(),
    };
    let kinds: Vec<InputKind> = specs
        .iter()
        .enumerate()
        .map(|(v, s)| InputKind::parse(s).with_context(|| format!("view {}", v + 1)))
        .collect::<Result<_>>()?;
    if !args.cameras.is_empty() && args.cameras.len() != kinds.len() {
        bail!(
            "{} --camera for {} view(s): give one calibration per view, in the same order",
            args.cameras.len(),
            kinds.len()
        );
    }
    if kinds.len() > 1 && args.cameras.is_empty() {
        bail!(
            "several views need their calibrations: one --camera per --view (docs/calibration.md)"
        );
    }
    let mut cameras = Vec::new();
    for (i, p) in args.cameras.iter().enumerate() {
        cameras.push(
            monohand_io::calibration::read_camera(p)
                .with_context(|| format!("camera of view {}", i + 1))?,
        );
    }
    let options = args.hand.fit_options()?;
    let scale = args.hand.initial_scale();
    let skeletons = [
        args.hand.skeleton(HandSide::Left, scale)?,
        args.hand.skeleton(HandSide::Right, scale)?,
    ];
    if args.detect_every == 0 {
        bail!("--detect-every must be at least 1");
    }
    let video = kinds.iter().any(InputKind::is_video);
    let tracking = (video || args.track) && !args.no_track;
    let cutoff_ok = args.smooth_min_cutoff.is_finite() && args.smooth_min_cutoff > 0.0;
    let beta_ok = args.smooth_beta.is_finite() && args.smooth_beta >= 0.0;
    if !(cutoff_ok && beta_ok) {
        bail!("--smooth-min-cutoff must be positive and --smooth-beta not negative");
    }
    if !(args.stall_timeout.is_finite() && args.stall_timeout > 0.0) {
        bail!("--stall-timeout must be a positive number of seconds");
    }
    let stall = std::time::Duration::from_secs_f64(args.stall_timeout.min(1e6));
    if args.smooth && !tracking {
        bail!("--smooth needs tracking (a video, or --track on an image sequence)");
    }
    let mut sources: Vec<FrameSource> = kinds
        .iter()
        .enumerate()
        .map(|(v, k)| FrameSource::open(k, stall).with_context(|| format!("view {}", v + 1)))
        .collect::<Result<_>>()?;
    for (v, s) in sources.iter().enumerate() {
        if let (Some((w, h)), Some(cam)) = (s.video_size(), cameras.get(v)) {
            let k = &cam.intrinsics;
            let quarter_turn = s.rotation_deg().rem_euclid(180) == 90;
            if quarter_turn && (k.width, k.height) == (h, w) {
                bail!(
                    "view {}: the video is stored {h}x{w} and carries rotation metadata of {} \
                     degrees (a phone held upright), so its frames are decoded upright at \
                     {w}x{h}; the calibration is for the stored {h}x{w} frames. Give a \
                     calibration of the upright frames (fx and fy swapped, the principal point \
                     turned with the image), or strip the rotation from the file (ffmpeg -i IN \
                     -c copy -metadata:s:v:0 rotate=0 OUT)",
                    v + 1,
                    s.rotation_deg()
                );
            }
            if (k.width, k.height) != (w, h) {
                bail!(
                    "view {}: the video is {w}x{h} but its calibration is for {}x{}; calibrate \
                     at the video's resolution (or scale fx, fy, cx, cy with the image)",
                    v + 1,
                    k.width,
                    k.height
                );
            }
        }
    }
    let fps = sources[0].fps();
    let total = sources[0]
        .len_hint()
        .map(|n| args.max_frames.map_or(n, |m| n.min(m)));
    let pipeline = Arc::new(args.models.pipeline(if tracking { 0 } else { 1 })?);
    let single_image = matches!(kinds.as_slice(), [InputKind::Images(files)] if files.len() == 1);
    let mut outputs = Outputs::create(args, fps, &cameras, single_image)?;
    let auto_frames = (args.hand.hand_scale == HandScale::Auto).then_some(args.hand.scale_frames);
    let settings = FitSettings {
        skeletons,
        options,
        tracking,
        auto_scale_frames: auto_frames,
        proportion_frames: args.hand.proportion_frames.map(|n| n as usize),
        smoothing: args.smooth.then(|| OneEuroParams {
            min_cutoff: args.smooth_min_cutoff,
            beta: args.smooth_beta,
            ..Default::default()
        }),
    };
    let mut fit = Fit(HandsFitter::new(cameras.clone(), settings)?);
    let progress = crate::progress::Progress::new(total);
    let start = Instant::now();
    let mut summary = Summary::default();
    let keep_image = outputs.wants_images();
    let emit = |done: Vec<Done>, summary: &mut Summary, outputs: &mut Outputs| -> Result<()> {
        for (rec, image) in done {
            summary.add(&rec);
            outputs.write(&rec, image)?;
            progress.tick(summary.frames, summary.hands);
        }
        Ok(())
    };

    if tracking || kinds.len() > 1 {
        // Decode -> networks -> fit on three threads, in order.
        let max_frames = args.max_frames;
        let (raw_tx, raw_rx) = sync_channel::<RawFrame>(4);
        let (vis_tx, vis_rx) = sync_channel::<(VisionFrame, FrameExtra)>(4);
        let reader = std::thread::spawn(move || -> Option<String> {
            read_all(&mut sources, max_frames, |f| raw_tx.send(f).is_ok())
        });
        let n_views = kinds.len();
        let detect_every = args.detect_every;
        let pipe = Arc::clone(&pipeline);
        let panic_at = injected_network_panic();
        let vision = std::thread::spawn(move || {
            let mut stage = CropTracker::new(pipe, n_views, tracking, detect_every);
            loop {
                // A network alone shares its operators with the other cores only while
                // frames are waiting: while this thread waits for the decoder, that core is
                // better left to it (docs/performance.md).
                let raw = match raw_rx.try_recv() {
                    Ok(raw) => {
                        allow_split_here(true);
                        raw
                    }
                    Err(TryRecvError::Empty) => {
                        allow_split_here(false);
                        match raw_rx.recv() {
                            Ok(raw) => raw,
                            Err(_) => break,
                        }
                    }
                    Err(TryRecvError::Disconnected) => break,
                };
                if panic_at == Some(raw.index) {
                    panic!(
                        "injected fault: network thread panics at frame {}",
                        raw.index
                    );
                }
                let images: Vec<Result<&RgbImage, String>> = raw
                    .images
                    .iter()
                    .map(|i| i.as_ref().map_err(Clone::clone))
                    .collect();
                let mut f = stage.process(raw.index, raw.timestamp_s, &images);
                f.focal = raw.focal;
                let extra = FrameExtra {
                    source: raw.source,
                    is_video: tracking,
                    image: if keep_image {
                        raw.images.into_iter().next().and_then(Result::ok)
                    } else {
                        None
                    },
                    decode_ms: raw.decode_ms,
                };
                if vis_tx.send((f, extra)).is_err() {
                    break;
                }
            }
        });
        let result = fit_all(
            &vis_rx,
            &mut fit,
            &mut |d, s: &mut Summary| emit(d, s, &mut outputs),
            &mut summary,
        );
        drop(vis_rx);
        let vision_panicked = vision.join().is_err();
        let reader = reader.join();
        let reader_panicked = reader.is_err();
        summary.input_error = reader.unwrap_or(None);
        if let Err(e) = result {
            return Err(output_failed(e, outputs));
        }
        if vision_panicked || reader_panicked {
            // What was written is complete up to the last frame; the exit code says the
            // run did not finish.
            outputs.finish()?;
            bail!(
                "the {} thread failed after {} frames; the output is complete up to there",
                if vision_panicked { "network" } else { "reader" },
                summary.frames
            );
        }
    } else {
        // Independent images: the networks on all cores, a chunk at a time, in order.
        let pool = crate::thread_pool(args.threads)?;
        let chunk = 2 * pool.current_num_threads();
        let mut stage = CropTracker::new(Arc::clone(&pipeline), 1, false, 1);
        let mut batch: Vec<RawFrame> = Vec::with_capacity(chunk);
        let mut source = sources.remove(0);
        let mut done = false;
        while !done {
            batch.clear();
            while batch.len() < chunk {
                if crate::interrupted()
                    || args
                        .max_frames
                        .is_some_and(|m| summary.frames + batch.len() as u64 >= m)
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
                        summary.input_error = Some(e);
                        done = true;
                        break;
                    }
                }
            }
            let detected: Vec<_> = pool.install(|| {
                batch
                    .par_iter()
                    .map(|raw| {
                        let t = Instant::now();
                        let d = match &raw.images[0] {
                            Ok(img) => pipeline.detect(img).map_err(|e| e.to_string()),
                            Err(e) => Err(e.clone()),
                        };
                        (d, t.elapsed().as_secs_f64() * 1e3)
                    })
                    .collect()
            });
            for (raw, (d, ms)) in batch.drain(..).zip(detected) {
                let image = raw.images.into_iter().next().and_then(Result::ok);
                let mut f = stage.assign(raw.index, raw.timestamp_s, d, ms);
                f.focal = raw.focal;
                let extra = FrameExtra {
                    source: raw.source,
                    is_video: false,
                    image: image.filter(|_| keep_image),
                    decode_ms: raw.decode_ms,
                };
                if let Err(e) = emit(fit.push(f, extra), &mut summary, &mut outputs) {
                    return Err(output_failed(e, outputs));
                }
            }
        }
        if let Err(e) = emit(fit.flush(), &mut summary, &mut outputs) {
            return Err(output_failed(e, outputs));
        }
    }
    progress.finish();
    outputs.finish()?;
    let secs = start.elapsed().as_secs_f64();
    let mean_rep = if summary.hands_3d > 0 {
        format!(
            "{:.2} px",
            summary.reprojection_sum / summary.hands_3d as f64
        )
    } else {
        "-".into()
    };
    crate::say(&format!(
        "{} frames ({} with hands, {} unreadable), {} hands ({} in 3D), mean reprojection error {mean_rep}, {:.1} fps{}",
        summary.frames,
        summary.frames_with_hands,
        summary.unreadable,
        summary.hands,
        summary.hands_3d,
        summary.frames as f64 / secs.max(1e-9),
        if crate::interrupted() { " (interrupted)" } else { "" }
    ));
    if let Some(e) = &summary.input_error {
        if summary.frames == 0 {
            bail!("{e}");
        }
        crate::say(&format!(
            "the input ended with an error after {} good frames (the output is complete up to there): {e}",
            summary.frames
        ));
    }
    if summary.frames > 0 && summary.unreadable == summary.frames {
        bail!("none of the {} frames could be read", summary.frames);
    }
    Ok(if crate::interrupted() {
        Outcome::Interrupted
    } else if summary.input_error.is_some() {
        Outcome::InputEndedEarly
    } else {
        Outcome::Complete
    })
}

/// After an output failed: closes the others (the overlay video finalised, the glTF
/// written), saying if that fails too, and marks the error as an output failure.
fn output_failed(e: anyhow::Error, outputs: Outputs) -> anyhow::Error {
    let frames = outputs.frames_written();
    if let Err(more) = outputs.finish() {
        crate::say(&format!("closing the other outputs failed too: {more:#}"));
    }
    e.context(OutputFailed { frames })
}

/// The next frame of every view; `Ok(None)` when the first view ended.
/// Fault injection for the tests of a failing run: `MONOHAND_FAULT=network-panic:N` makes
/// the network thread panic on frame `N` (docs/pipeline.md).
fn injected_network_panic() -> Option<u64> {
    let spec = std::env::var("MONOHAND_FAULT").ok()?;
    spec.strip_prefix("network-panic:")?.parse().ok()
}

fn next_raw(sources: &mut [FrameSource]) -> Result<Option<RawFrame>, String> {
    let Some((first, others)) = sources.split_first_mut() else {
        return Ok(None);
    };
    let Some(f) = first.next_frame().map_err(|e| format!("{e:#}"))? else {
        return Ok(None);
    };
    let mut decode_ms = f.decode_ms;
    let mut images = Vec::with_capacity(1 + others.len());
    images.push(f.image);
    for (k, s) in others.iter_mut().enumerate() {
        let view = k + 2;
        images.push(match s.next_frame() {
            Ok(Some(g)) => {
                decode_ms += g.decode_ms;
                g.image
            }
            Ok(None) => Err(format!("view {view} has no more frames")),
            Err(e) => Err(format!("view {view}: {e:#}")),
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

/// Reads frames until the end, Ctrl-C, `max_frames` or `send` refusing; returns the error
/// that ended the input early, if any.
fn read_all(
    sources: &mut [FrameSource],
    max_frames: Option<u64>,
    mut send: impl FnMut(RawFrame) -> bool,
) -> Option<String> {
    let mut n = 0u64;
    loop {
        if crate::interrupted() || max_frames.is_some_and(|m| n >= m) {
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

/// The session's 3D stage, turning its frames into `run`'s records and its notes into
/// messages.
struct Fit(HandsFitter<FrameExtra>);

impl Fit {
    fn push(&mut self, frame: VisionFrame, extra: FrameExtra) -> Vec<Done> {
        let done = self.0.push(frame, extra);
        self.records(done)
    }

    fn flush(&mut self) -> Vec<Done> {
        let done = self.0.flush();
        self.records(done)
    }

    fn records(&mut self, done: Vec<(monohand::FittedFrame, FrameExtra)>) -> Vec<Done> {
        for note in self.0.take_notes() {
            crate::say(&note);
        }
        done.into_iter()
            .map(|(f, extra)| hands::record(&f, extra))
            .collect()
    }
}

/// Fits and emits every frame that comes out of the networks.
fn fit_all(
    rx: &Receiver<(VisionFrame, FrameExtra)>,
    fit: &mut Fit,
    emit: &mut dyn FnMut(Vec<Done>, &mut Summary) -> Result<()>,
    summary: &mut Summary,
) -> Result<()> {
    for (f, extra) in rx {
        emit(fit.push(f, extra), summary)?;
    }
    emit(fit.flush(), summary)
}
