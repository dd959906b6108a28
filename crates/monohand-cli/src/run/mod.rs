//! `monohand run`: images, videos, a webcam or a calibrated multi-view rig in; absolute 3D
//! hands out. The arguments are checked and turned into the library's engine
//! ([`monohand::engine`]), its sources and its sinks; the engine runs the pipeline.

mod each;
mod outputs;
mod sync;

use crate::hand_args::HandModelArgs;
use crate::progress::Terminal;
use crate::vision::ModelArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use monohand::engine::{Engine, FrameSource, Input, RunReport};
use monohand::{FitSettings, HandScale, OfflineSettings, RectifyCrops, Settings};
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
    /// With several --view, how their frames are matched: `index` (frame i of every view
    /// together), `auto` (each view's start is found from the hands, then frames are
    /// matched by time: also for different frame rates), or how many seconds each later
    /// view started after the first, `S2,S3,...` (negative: before; what `auto` prints).
    /// docs/calibration.md#videos-that-did-not-start-together.
    #[arg(long, value_name = "index|auto|S2,..", default_value = "index")]
    pub sync: sync::Sync,
    /// A folder of videos and images, each run into --output-dir as `<file name>.jsonl`,
    /// complete or absent; a rerun skips the complete ones (docs/pipeline.md).
    #[arg(long, value_name = "DIR", requires = "output_dir", conflicts_with_all = ["input", "views", "overlay", "gltf", "rerun", "show", "format", "output"])]
    pub each: Option<PathBuf>,
    /// Where --each writes.
    #[arg(long, value_name = "OUT", requires = "each")]
    pub output_dir: Option<PathBuf>,
    /// Camera calibration, one per view (docs/calibration.md). Without it: the photo's
    /// EXIF focal length or the video's QuickTime one (an iPhone's), else a generic 60
    /// degree camera, said once.
    #[arg(long = "camera", value_name = "FILE")]
    pub cameras: Vec<PathBuf>,
    /// Where to write the hands, one record per frame ("-" for standard output).
    #[arg(short, long, value_name = "FILE", default_value = "-")]
    pub output: PathBuf,
    /// Format of --output (openpose: --output is a folder, one file per frame).
    #[arg(long, value_enum, default_value = "jsonl")]
    pub format: OutputFormat,
    /// Draw the hands on the frames: a video (.mp4/.mkv/.avi/.mov/.webm), a folder of PNG
    /// images, or for one input image an image file (.png/.jpg).
    #[arg(long, value_name = "OUT.mp4|DIR|OUT.png")]
    pub overlay: Option<PathBuf>,
    /// What the overlay and --show draw, comma-separated: bones, top, labels, keypoints,
    /// model (docs/visualisation.md).
    #[arg(
        long,
        value_name = "LAYER,..",
        value_delimiter = ',',
        default_value = "bones,top,labels"
    )]
    pub layers: Vec<monohand_media::scene::Layer>,
    /// Show the frames live in a window with the overlay (keys: Space pause, . step, 1-5
    /// layers, Q quit; docs/visualisation.md). Needs a display.
    #[arg(long)]
    pub show: bool,
    /// Write the 3D hands as an animated glTF binary (.glb).
    #[arg(long, value_name = "OUT.glb")]
    pub gltf: Option<PathBuf>,
    /// Also write each fitted hand's 26 OpenXR (XR_EXT_hand_tracking) joints, with poses
    /// and radii, in the JSON Lines records (`xr_joints`, docs/output-format.md).
    #[arg(long)]
    pub xr_joints: bool,
    /// Also write each fitted hand's wrist pose, a 4x4 in metres in MANO's wrist frame as
    /// robot-hand retargeting reads it, in the JSON Lines records (`wrist_pose`,
    /// docs/output-format.md).
    #[arg(long)]
    pub wrist_pose: bool,
    /// Write a Rerun recording (.rrd; open it with `rerun FILE`): every camera's
    /// intrinsics, pose and image, the 2D keypoints, the 3D hands and each hand's distance
    /// over time (docs/visualisation.md). Needs the CLI built with `--features rerun`.
    #[arg(long, value_name = "OUT.rrd")]
    pub rerun: Option<PathBuf>,
    /// Write the run as a LeRobot v3 dataset in this new folder: one episode, each frame's
    /// both hands (21 joints in metres in the first camera's frame, a validity flag, the
    /// wrist pose) as `observation.state`, the next frame's as `action`, each view's frames
    /// as a video (docs/robots-and-xr.md). Complete or absent: a stopped run leaves the
    /// frames written so far. With --each: one dataset of every input's episode (each kept
    /// as `<file name>.lerobot` in --output-dir), made again at each end of the job.
    #[arg(long, value_name = "DIR")]
    pub lerobot: Option<PathBuf>,
    /// The episode's task text in --lerobot's dataset.
    #[arg(
        long,
        value_name = "TEXT",
        default_value = "human hand",
        requires = "lerobot"
    )]
    pub lerobot_task: String,
    /// Scale the images stored in --rerun by this factor in (0, 1] (0.5: a quarter of the
    /// pixels).
    #[arg(long, value_name = "S", default_value_t = 1.0, requires = "rerun")]
    pub rerun_image_scale: f64,
    /// How --gltf draws each hand.
    #[arg(long, value_enum, value_name = "STYLE", default_value = "skinned")]
    pub gltf_hand: GltfStyle,
    /// Track (default for videos and webcams): crops and fits from the last frame, hands
    /// keep their id (docs/pipeline.md).
    #[arg(long, overrides_with = "no_track")]
    pub track: bool,
    /// Treat every frame on its own (default for images).
    #[arg(long)]
    pub no_track: bool,
    /// While tracking, look for new hands every N frames.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub detect_every: usize,
    /// Smooth the 3D joints over time with a One Euro filter (a little lag, less jitter).
    #[arg(long, conflicts_with = "offline")]
    pub smooth: bool,
    /// Refit each frame with the frames after it too (files; less shake). Needs tracking.
    #[arg(long)]
    pub offline: bool,
    /// Do not filter each hand's distance from the camera over time (on by default when
    /// tracking with one camera: less shake in depth, the pixels unchanged; docs/accuracy.md).
    #[arg(long)]
    pub no_depth_filter: bool,
    /// Which calibrated cameras' hands are read in a rectified view (a virtual pinhole
    /// aimed at the hand, drawn through the lens): `off`, `lenses` (distortion or fisheye),
    /// `all` (docs/calibration.md#rectified-crops).
    #[arg(long, value_name = "off|lenses|all", default_value = "off")]
    pub rectify_crops: RectifyCrops,
    /// With several calibrated views: each view finds its hands on its own, instead of
    /// looking for each hand fitted in 3D where it projects (docs/pipeline.md#several-cameras).
    #[arg(long)]
    pub no_fitted_crops: bool,
    /// One Euro filter: minimum cutoff frequency, Hz (lower: smoother when still).
    #[arg(long, value_name = "HZ", default_value_t = OneEuroParams::default().min_cutoff)]
    pub smooth_min_cutoff: f64,
    /// One Euro filter: speed coefficient (higher: less lag when moving fast).
    #[arg(long, value_name = "BETA", default_value_t = OneEuroParams::default().beta)]
    pub smooth_beta: f64,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    pub max_frames: Option<u64>,
    /// A video or webcam that delivers no frame for this many seconds is closed (status 3).
    #[arg(long, value_name = "SECS", default_value_t = monohand_media::video::DEFAULT_STALL_TIMEOUT.as_secs_f64())]
    pub stall_timeout: f64,
    /// Worker threads for independent images (default: all cores; 1: one core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Measure the person's hand with the calibrated views (two or more --view) over the
    /// first --scale-frames frames, fit with it, and write it here for --hand
    /// (docs/absolute-depth.md).
    #[arg(long, value_name = "FILE.json")]
    pub save_hand: Option<PathBuf>,
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

pub(crate) fn run(args: &RunArgs) -> Result<Outcome> {
    if let (Some(dir), Some(out)) = (&args.each, &args.output_dir) {
        return each::run(args, dir, out);
    }
    // Everything that can be checked is checked before any output is created (the views
    // against the cameras: `Engine::check_sources`).
    let specs: Vec<String> = match &args.input {
        Some(i) => vec![i.clone()],
        None => args.views.clone(),
    };
    let inputs: Vec<Input> = specs
        .iter()
        .enumerate()
        .map(|(v, s)| Input::parse(s).with_context(|| format!("view {}", v + 1)))
        .collect::<Result<_>>()?;
    if args.save_hand.is_some() && inputs.len() < 2 {
        bail!(
            "--save-hand measures the hand with two or more calibrated views (--view FILE \
             --camera CAM.json, once per camera); one camera cannot tell a hand's size"
        );
    }
    let cameras = crate::read_cameras(&args.cameras)?;
    let video = inputs.iter().any(Input::is_video);
    let tracking = (video || args.track) && !args.no_track;
    let settings = crate::resolve(settings(args, tracking)?)?;
    if args.models.precision == crate::vision::PrecisionArg::Auto
        && settings.pipeline().precision != monohand_vision::Precision::F32
    {
        crate::say(&format!(
            "{} views: the networks run in {} (--precision auto from {} views on; \
             --precision f32 keeps f32)",
            inputs.len(),
            settings.pipeline().precision.name(),
            monohand::INT8_FROM_VIEWS
        ));
    }
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
    let pipeline = Arc::new(args.models.pipeline(settings.pipeline())?);
    let engine = Engine::new(pipeline, cameras.clone(), settings)?;
    engine.check_sources(&sources)?;
    let engine = sync::apply(
        &args.sync, engine, &specs, &inputs, &cameras, &sources, stall,
    )?;
    let single_image = matches!(inputs.as_slice(), [i] if i.is_single_image());
    let mut sinks = outputs::create(args, fps, single_image)?;
    let terminal = Terminal {
        progress: crate::progress::Progress::new(total),
    };
    let report = engine.run(sources, &mut sinks, &terminal)?;
    terminal.progress.finish();
    let outcome = summarise(&report, &specs, &args.cameras)?;
    if let Some(path) = &args.save_hand {
        save_hand(path, &report)?;
    }
    Ok(outcome)
}

/// Writes the hand the views measured to `path` (`--save-hand`), or says why none was.
fn save_hand(path: &std::path::Path, report: &RunReport) -> Result<()> {
    let Some(hand) = &report.measured_hand else {
        bail!(
            "--save-hand: no hand was measured (no hand was seen by two views in the first \
             frames, or they did not tell its size: see the notes above); {} not written",
            path.display()
        );
    };
    monohand_io::hand::write_hand(path, hand)?;
    let sigma = hand
        .scale_sigma
        .map(|s| format!(" ± {s:.3}"))
        .unwrap_or_default();
    crate::say(&format!(
        "hand measured by {} views on {} frames: {:.3}{sigma} x the default hand, {:.0} mm \
         (the model's wrist to middle fingertip); written to {}",
        hand.views.unwrap_or(0),
        hand.frames.len(),
        hand.scale,
        hand.hand_length_mm,
        path.display()
    ));
    Ok(())
}

/// The plain settings of the arguments, for an input tracked or not (the library
/// checks them: [`crate::resolve`]).
fn settings(args: &RunArgs, tracking: bool) -> Result<Settings> {
    let (scale, hand_size) = args.hand.size()?;
    let auto_frames =
        (scale == HandScale::Auto || args.save_hand.is_some()).then_some(args.hand.scale_frames);
    Ok(Settings {
        pipeline: args.models.options_for(args.views.len().max(1)).1,
        fit: FitSettings {
            skeletons: args.hand.skeletons(scale.initial())?,
            hand_size,
            options: args.hand.fit_options()?,
            tracking,
            auto_scale_frames: auto_frames,
            proportion_frames: args.hand.proportion_frames.map(|n| n as usize),
            smoothing: args.smooth.then(|| OneEuroParams {
                min_cutoff: args.smooth_min_cutoff,
                beta: args.smooth_beta,
                ..Default::default()
            }),
            depth_filter: (!args.no_depth_filter).then_some(monohand::DEPTH_FILTER),
            offline: args.offline.then(OfflineSettings::default),
        },
        detect_every: args.detect_every,
        max_frames: args.max_frames,
        threads: args.threads,
        rectify: args.rectify_crops,
        fitted_crops: !args.no_fitted_crops,
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

/// Says what the run did (with several cameras, how each view agreed with the hands, and
/// the files of a view that did not: `views`, `cameras`), and how it ended.
fn summarise(report: &RunReport, views: &[String], cameras: &[PathBuf]) -> Result<Outcome> {
    crate::say(&report.summary());
    if let Some(verdict) = report.rig.verdict() {
        crate::say(&verdict.to_string());
        for v in verdict.suspects() {
            let (Some(view), Some(camera)) = (views.get(v), cameras.get(v)) else {
                continue;
            };
            crate::say(&format!(
                "view {}: --view {view} --camera {}: check its calibration and its sync",
                v + 1,
                camera.display()
            ));
        }
    }
    if let Some(e) = &report.input_error {
        if report.frames == 0 {
            bail!("{e}");
        }
        crate::say(&format!(
            "the input ended with an error after {} good frames (the output is complete up to there): {e}",
            report.frames
        ));
    }
    if report.nothing_readable() {
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
