//! `monohand run`: images, videos, a webcam or a calibrated multi-view rig in; absolute 3D
//! hands out. The arguments are checked and turned into the library's engine
//! ([`monohand::engine`]), its sources and its sinks; the engine runs the pipeline.

mod each;
mod outputs;
#[cfg(feature = "show")]
mod show;
#[cfg(not(feature = "show"))]
#[path = "show_off.rs"]
mod show;

use crate::hand_args::HandModelArgs;
use crate::vision::ModelArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use monohand::engine::{Engine, EngineError, EngineSettings, FrameSource, Input, RunReport};
use monohand::{FitSettings, HandScale, OfflineSettings};
use monohand_core::filtering::OneEuroParams;
use outputs::{GltfStyle, OutputFormat};
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `monohand run`.
#[derive(Debug, Args)]
pub(crate) struct RunArgs {
    /// An image, a folder of images (file-name order), a video file (anything ffmpeg
    /// reads) or `webcam:N` (/dev/videoN). For several calibrated cameras use --view
    /// instead, once per camera.
    #[arg(value_name = "INPUT", required_unless_present_any = ["views", "each"])]
    pub input: Option<String>,
    /// One view of a calibrated multi-camera rig (repeat, with one --camera each, in the
    /// same order); frames are matched by index across views.
    #[arg(long = "view", value_name = "INPUT", conflicts_with = "input")]
    pub views: Vec<String>,
    /// A folder of videos and images, each run as its own input into --output-dir as
    /// `<file name>.jsonl`. Each file is complete or absent (written as `.partial`, renamed at
    /// the end); a rerun skips the complete ones. One line per input, then a summary; exit
    /// status 3 if an input failed (its frames stay in the `.partial` file). --offline and
    /// --smooth apply to its videos.
    #[arg(long, value_name = "DIR", requires = "output_dir", conflicts_with_all = ["input", "views", "overlay", "gltf", "show", "format", "output"])]
    pub each: Option<PathBuf>,
    /// Where --each writes.
    #[arg(long, value_name = "OUT", requires = "each")]
    pub output_dir: Option<PathBuf>,
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
    pub gltf_hand: GltfStyle,
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
    #[arg(long, conflicts_with = "offline")]
    pub smooth: bool,
    /// Files and corpora: refit each frame with the frames after it too (no lag in the
    /// motion, less shake; each frame is written a few frames later). Needs tracking.
    #[arg(long)]
    pub offline: bool,
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

/// An engine error for `main`: a failed output carries [`OutputFailed`] (its own exit
/// status).
pub(crate) fn engine_error(e: EngineError) -> anyhow::Error {
    match e {
        EngineError::Output { frames, source } => {
            anyhow::Error::from_boxed(source).context(OutputFailed { frames })
        }
        e => e.into(),
    }
}

/// The CLI's side of a run: Ctrl-C and the window's Q cancel it, the progress bar follows
/// it, and the engine's notes go to stderr.
struct Terminal {
    progress: crate::progress::Progress,
}

impl monohand::engine::Observer for Terminal {
    fn cancelled(&self) -> bool {
        crate::interrupted()
    }

    fn frame_written(&self, report: &RunReport) {
        self.progress.tick(report.frames, report.hands);
    }

    fn note(&self, note: &monohand::Note) {
        crate::say(&crate::flagged(note));
    }
}

pub(crate) fn run(args: &RunArgs) -> Result<Outcome> {
    if let (Some(dir), Some(out)) = (&args.each, &args.output_dir) {
        return each::run(args, dir, out);
    }
    // Everything that can be checked is checked before any output is created.
    let specs: Vec<String> = match &args.input {
        Some(i) => vec![i.clone()],
        None => args.views.clone(),
    };
    let inputs: Vec<Input> = specs
        .iter()
        .enumerate()
        .map(|(v, s)| Input::parse(s).with_context(|| format!("view {}", v + 1)))
        .collect::<Result<_>>()?;
    if !args.cameras.is_empty() && args.cameras.len() != inputs.len() {
        bail!(
            "{} --camera for {} view(s): give one calibration per view, in the same order",
            args.cameras.len(),
            inputs.len()
        );
    }
    if inputs.len() > 1 && args.cameras.is_empty() {
        bail!(
            "several views need their calibrations: one --camera per --view (docs/calibration.md)"
        );
    }
    let cameras = crate::read_cameras(&args.cameras)?;
    let video = inputs.iter().any(Input::is_video);
    let tracking = (video || args.track) && !args.no_track;
    let settings = engine_settings(args, tracking)?;
    let stall = stall_timeout(args)?;
    let sources: Vec<Box<dyn FrameSource>> = inputs
        .iter()
        .enumerate()
        .map(|(v, k)| k.open(stall).with_context(|| format!("view {}", v + 1)))
        .collect::<Result<_>>()?;
    let fps = sources[0].fps();
    let total = sources[0]
        .len_hint()
        .map(|n| args.max_frames.map_or(n, |m| n.min(m)));
    let pipeline = Arc::new(args.models.pipeline(monohand::refine_passes(tracking))?);
    let engine = Engine::new(pipeline, cameras, settings)?;
    engine.check_sources(&sources)?;
    let single_image = matches!(inputs.as_slice(), [i] if i.is_single_image());
    let mut sinks = outputs::create(args, fps, single_image)?;
    let terminal = Terminal {
        progress: crate::progress::Progress::new(total),
    };
    let report = engine
        .run(sources, &mut sinks, &terminal)
        .map_err(engine_error)?;
    terminal.progress.finish();
    summarise(&report)
}

/// The engine's settings from the arguments, checked, for an input tracked or not.
fn engine_settings(args: &RunArgs, tracking: bool) -> Result<EngineSettings> {
    let options = args.hand.fit_options()?;
    let skeletons = args.hand.skeletons(args.hand.hand_scale.initial())?;
    if args.detect_every == 0 {
        bail!("--detect-every must be at least 1");
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let cutoff_ok = args.smooth_min_cutoff.is_finite() && args.smooth_min_cutoff > 0.0;
    let beta_ok = args.smooth_beta.is_finite() && args.smooth_beta >= 0.0;
    if !(cutoff_ok && beta_ok) {
        bail!("--smooth-min-cutoff must be positive and --smooth-beta not negative");
    }
    if (args.smooth || args.offline) && !tracking {
        bail!("--smooth and --offline need tracking (a video, or --track on an image sequence)");
    }
    let auto_frames = (args.hand.hand_scale == HandScale::Auto).then_some(args.hand.scale_frames);
    Ok(EngineSettings {
        fit: FitSettings {
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
            offline: args.offline.then(OfflineSettings::default),
        },
        detect_every: args.detect_every,
        max_frames: args.max_frames,
        threads: args.threads,
    })
}

/// How long a video may deliver no frame before it counts as stalled.
fn stall_timeout(args: &RunArgs) -> Result<std::time::Duration> {
    if !(args.stall_timeout.is_finite() && args.stall_timeout > 0.0) {
        bail!("--stall-timeout must be a positive number of seconds");
    }
    Ok(std::time::Duration::from_secs_f64(
        args.stall_timeout.min(1e6),
    ))
}

/// Says what the run did, and how it ended.
fn summarise(report: &RunReport) -> Result<Outcome> {
    let mean_rep = match report.mean_reprojection_px() {
        Some(e) => format!("{e:.2} px"),
        None => "-".into(),
    };
    crate::say(&format!(
        "{} frames ({} with hands, {} unreadable), {} hands ({} in 3D), mean reprojection error {mean_rep}, {:.1} fps{}",
        report.frames,
        report.frames_with_hands,
        report.unreadable,
        report.hands,
        report.hands_3d,
        report.frames as f64 / report.seconds.max(1e-9),
        if report.cancelled { " (interrupted)" } else { "" }
    ));
    if let Some(e) = &report.input_error {
        if report.frames == 0 {
            bail!("{e}");
        }
        crate::say(&format!(
            "the input ended with an error after {} good frames (the output is complete up to there): {e}",
            report.frames
        ));
    }
    if report.frames > 0 && report.unreadable == report.frames {
        bail!("none of the {} frames could be read", report.frames);
    }
    Ok(if report.cancelled {
        Outcome::Interrupted
    } else if report.input_error.is_some() {
        Outcome::InputEndedEarly
    } else {
        Outcome::Complete
    })
}
