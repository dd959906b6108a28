//! `monohand`: hands in images, video and 2D keypoint files to absolute 3D hand poses
//! (README.md and docs/pipeline.md show each command). Argument parsing, the choice of
//! sinks and the exit statuses; the work is the library's.

mod calibrate;
mod detect;
mod eval;
mod hand_args;
mod lift;
mod models;
mod progress;
mod run;
mod vision;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use monohand::engine::EngineError;
use monohand_core::prelude::*;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock};

/// Absolute 3D hand poses (21 joints, millimetres, camera frame) from ordinary RGB
/// cameras: hands are detected, 21 2D keypoints found by MediaPipe's networks, and a
/// 26-DoF hand model fitted to them (Panteleris et al., WACV 2018).
#[derive(Debug, Parser)]
#[command(name = "monohand", version, about, long_about = None)]
struct Cli {
    /// More messages on stderr (-v: progress, -vv: per-frame details). Warnings are always shown.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// Only errors on stderr, no warnings.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Find hands (box, score, left/right, 21 keypoints with confidences) and heads in
    /// images; write one JSON Lines record per image (docs/output-format.md).
    Detect(detect::DetectArgs),
    /// Hands in images, a video, a webcam or a calibrated multi-camera rig to absolute 3D
    /// joints: detection, 21 keypoints and the 3D fit for every hand in every frame
    /// (videos tracked, images one by one; docs/pipeline.md).
    Run(Box<run::RunArgs>),
    /// Fetch or list the MediaPipe networks (downloaded with pip, checked, cached).
    Models(models::ModelsArgs),
    /// Fit the hand model to 2D keypoints and write 3D poses as JSON Lines: one --camera
    /// and, in the same order, one --openpose (or --jsonl) per view; frames matched by index.
    Lift(LiftArgs),
    /// Print the JSON of a generic camera for footage of unknown origin (centred, square
    /// pixels, --hfov; a wrong guess scales the depth: docs/calibration.md).
    Camera(CameraArgs),
    /// Calibrate a camera, or a rig's cameras, from photos, a video or a webcam of a
    /// printed chessboard; --print-board makes one (docs/calibration.md).
    Calibrate(Box<calibrate::CalibrateArgs>),
    /// Measure accuracy on a 3D hand dataset (a manifest or an STB folder): print a table,
    /// optionally write a report (docs/evaluation.md).
    Eval(eval::EvalArgs),
}

/// Arguments of `monohand lift`.
#[derive(Debug, Args)]
pub(crate) struct LiftArgs {
    /// Camera calibration of a view, once per view in view order (formats and extrinsics:
    /// docs/calibration.md).
    #[arg(long = "camera", value_name = "FILE", required = true)]
    pub cameras: Vec<PathBuf>,
    /// OpenPose --write_json output of a view (a folder of *_keypoints.json or one file),
    /// once per view in the order of --camera.
    #[arg(
        long = "openpose",
        value_name = "DIR_OR_FILE",
        conflicts_with = "jsonl"
    )]
    pub openpose: Vec<PathBuf>,
    /// 2D keypoints of a view as JSON Lines in the output schema ("side" and
    /// "keypoints_2d" per hand), once per view in the order of --camera.
    #[arg(long = "jsonl", value_name = "IN.jsonl")]
    pub jsonl: Vec<PathBuf>,
    /// Where to write the poses (JSON Lines, one line per frame); "-" for standard output.
    #[arg(short, long, value_name = "OUT.jsonl")]
    pub output: PathBuf,
    /// Start each frame's fit from the previous frame's pose (video; not for unrelated
    /// images).
    #[arg(long)]
    pub track: bool,
    /// Also write each fitted hand as OpenXR's 26 hand joints, with their orientations and
    /// radii (`xr_joints`, docs/output-format.md).
    #[arg(long)]
    pub xr_joints: bool,
    /// Also write each fitted hand's wrist pose, a 4x4 in metres in MANO's wrist frame as
    /// robot-hand retargeting reads it (`wrist_pose`, docs/output-format.md).
    #[arg(long)]
    pub wrist_pose: bool,
    #[command(flatten)]
    pub hand: hand_args::HandModelArgs,
}

/// Arguments of `monohand camera`.
#[derive(Debug, Args)]
struct CameraArgs {
    /// Image width in pixels.
    #[arg(long, value_name = "W")]
    width: u32,
    /// Image height in pixels.
    #[arg(long, value_name = "H")]
    height: u32,
    /// Horizontal field of view in degrees.
    #[arg(long, value_name = "DEG", default_value_t = monohand_core::camera::GENERIC_HFOV_DEG)]
    hfov: f64,
}

fn camera_command(args: &CameraArgs) -> Result<()> {
    let camera = Camera::with_hfov(args.width, args.height, args.hfov).with_context(|| {
        format!(
            "--width {} --height {} --hfov {}",
            args.width, args.height, args.hfov
        )
    })?;
    let json = monohand_io::calibration::generic_camera_json(&camera, args.hfov);
    println!("{json:#}");
    Ok(())
}

/// Exit statuses of `monohand` (docs/pipeline.md#exit-status). (2 is clap's, for a command
/// line it cannot parse.)
pub(crate) mod exit {
    /// Everything was read and written.
    pub const OK: u8 = 0;
    /// Bad arguments or input found before anything was written, or a failure inside.
    pub const FAILED: u8 = 1;
    /// `run`: the input ended with an error after some good frames.
    pub const INPUT_ENDED_EARLY: u8 = 3;
    /// `run`: an output could not be written; every file holds whole frames only.
    pub const OUTPUT_FAILED: u8 = 4;
    /// Stopped by SIGINT (Ctrl-C), SIGTERM or SIGHUP after closing every file (128 + 2).
    pub const INTERRUPTED: u8 = 130;
}

/// Set by Ctrl-C (or the `--show` window closed): long runs finish the current frame,
/// close their files and stop.
static INTERRUPTED: LazyLock<Arc<AtomicBool>> = LazyLock::new(Arc::default);
/// Whether `--quiet` was given.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Whether `--quiet` was given.
pub(crate) fn is_quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// True once Ctrl-C was pressed.
pub(crate) fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// The flag Ctrl-C raises, for a library part that stops the run too (the `--show`
/// window).
pub(crate) fn stop_flag() -> Arc<AtomicBool> {
    Arc::clone(&INTERRUPTED)
}

/// Prints a message for the user on stderr unless `--quiet`.
pub(crate) fn say(msg: &str) {
    if !QUIET.load(Ordering::Relaxed) {
        eprintln!("{msg}");
    }
}

/// The cameras of calibration files, one per view.
pub(crate) fn read_cameras(paths: &[PathBuf]) -> Result<Vec<Camera>> {
    let read = |(i, p): (usize, &PathBuf)| {
        monohand_io::calibration::read_camera(p)
            .with_context(|| format!("camera of view {}", i + 1))
    };
    paths.iter().enumerate().map(read).collect()
}

/// The library's resolved settings, a refused one said with its flag.
pub(crate) fn resolve(settings: monohand::Settings) -> Result<monohand::ResolvedSettings> {
    settings.resolve().map_err(|e| refused(&e))
}

/// A setting the library refused, said with its flag.
pub(crate) fn refused(e: &monohand::SettingsError) -> anyhow::Error {
    use monohand::Field;
    let flag = match e.field {
        Field::Tracking => "--track",
        Field::DetectEvery => "--detect-every",
        Field::Threads => "--threads",
        Field::MaxHands => "--hands",
        Field::MinPresence => "--min-presence",
        Field::MirrorPass => "--no-mirror-pass",
        Field::Heads => "--no-heads",
        Field::Precision => "--precision",
        Field::Pipeline => "the networks' options",
        Field::FitOptions => "the fit's options",
        Field::HandScale => "--hand-scale",
        Field::Smoothing => "--smooth",
        Field::SmoothMinCutoff => "--smooth-min-cutoff",
        Field::SmoothBeta => "--smooth-beta",
        Field::Offline => "--offline",
        Field::DepthFilter => "the depth filter",
    };
    anyhow::anyhow!("{flag} {}", e.why)
}

/// A note of the library, with the flag it is about in front (the library names none).
pub(crate) fn flagged(note: &monohand::Note) -> String {
    let flag = match note.topic {
        monohand::NoteTopic::Camera => "no --camera: ",
        monohand::NoteTopic::Calibration => "--camera: ",
        monohand::NoteTopic::HandScale => "--hand-scale auto: ",
        monohand::NoteTopic::Proportions => "--proportion-frames: ",
        monohand::NoteTopic::Output => "",
    };
    format!("{flag}{}", note.message)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    QUIET.store(cli.quiet, Ordering::Relaxed);
    // The first Ctrl-C (or SIGTERM, SIGHUP) asks long runs to stop cleanly; a second one
    // kills the process.
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::Relaxed) {
            std::process::exit(exit::INTERRUPTED.into());
        }
        eprintln!("\ninterrupted: finishing the current frame (Ctrl-C again to kill)");
    });
    let level = if cli.quiet {
        tracing::Level::ERROR
    } else {
        match cli.verbose {
            0 => tracing::Level::WARN,
            1 => tracing::Level::INFO,
            _ => tracing::Level::DEBUG,
        }
    };
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .without_time()
        .with_max_level(level)
        .init();
    let result = match &cli.command {
        Command::Detect(args) => detect::run(args).map(|()| exit::OK),
        Command::Models(args) => models::run(args).map(|()| exit::OK),
        Command::Run(args) => run::run(args).map(|outcome| match outcome {
            run::Outcome::Complete => exit::OK,
            run::Outcome::InputEndedEarly => exit::INPUT_ENDED_EARLY,
            run::Outcome::Interrupted => exit::INTERRUPTED,
        }),
        Command::Lift(args) => lift::run(args).map(|()| exit::OK),
        Command::Camera(args) => camera_command(args).map(|()| exit::OK),
        Command::Eval(args) => eval::run(args).map(|()| exit::OK),
        Command::Calibrate(args) => calibrate::run(args).map(|()| exit::OK),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("error: {e:#}");
            // A failed output has its own status (the library's error says what was kept).
            if matches!(e.downcast_ref(), Some(EngineError::Output { .. })) {
                ExitCode::from(exit::OUTPUT_FAILED)
            } else {
                ExitCode::from(exit::FAILED)
            }
        }
    }
}
