//! `monohand`: lift 2D hand keypoints to absolute 3D hand poses.
//!
//! ```text
//! monohand lift --camera cam.json --openpose json_dir/ --output poses.jsonl
//! monohand lift --camera left.yml --openpose L/ --camera right.yml --openpose R/ --output -
//! monohand camera --width 1280 --height 720 > cam.json
//! monohand eval --dataset ../shared/data/stb_b1counting --noise-px 0,2,5 --report stb_report/
//! ```

mod eval;
mod lift;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use monohand_core::prelude::*;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

/// Lift 2D hand keypoints (OpenPose JSON or JSON Lines) from one or more calibrated
/// cameras to absolute 3D hand poses in millimetres, by fitting a 26-DoF hand model
/// (Panteleris et al., WACV 2018).
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
    /// Fit the hand model to 2D keypoints and write 3D poses as JSON Lines.
    ///
    /// Give one --camera per view and, in the same order, one --openpose (or one
    /// --jsonl) per view. Frames are matched by index across views; each hand side
    /// is fitted jointly over all views in which it appears. Output joints are in
    /// the first camera's frame, in millimetres (schema: docs/output-format.md).
    Lift(LiftArgs),
    /// Print the JSON of a generic camera for footage of unknown origin.
    ///
    /// Principal point at the image centre, square pixels, and a 60 degree
    /// horizontal field of view unless --hfov says otherwise (typical of webcams
    /// and phones in video mode). A wrong guess scales the recovered depth by
    /// tan(guess/2) / tan(true/2): calibrate the camera for absolute accuracy.
    Camera(CameraArgs),
    /// Measure accuracy on a 3D hand dataset: print a table, optionally write a report.
    ///
    /// The dataset is a manifest (docs/evaluation.md) or an STB folder. --stage lift
    /// fits ground-truth 2D keypoints (projected labels, optional noise and dropped
    /// joints), mono and stereo on the same frames; the table gives absolute,
    /// root-relative, aligned (Zimmermann & Brox) and Procrustes-aligned errors,
    /// per-axis errors, AUC of the 3D PCK over 20-50 mm, 2D errors, detection rate
    /// and fps. --report DIR writes report.md, errors.csv and PNG plots.
    Eval(eval::EvalArgs),
}

/// Arguments of `monohand lift`.
#[derive(Debug, Args)]
pub(crate) struct LiftArgs {
    /// Camera calibration of a view (repeat once per view, in view order): the
    /// project JSON, the WACV'18 JSON, or OpenCV FileStorage YAML/XML (see
    /// docs/calibration.md). Extrinsics of view i map camera 1's frame into camera
    /// i (X_i = R X_1 + t, mm); camera 1 should have none.
    #[arg(long = "camera", value_name = "FILE", required = true)]
    pub cameras: Vec<PathBuf>,
    /// OpenPose --write_json output of a view: a directory of *_keypoints.json
    /// files (one per frame, natural name order) or a single file (repeat once per
    /// view, in the order of --camera).
    #[arg(
        long = "openpose",
        value_name = "DIR_OR_FILE",
        conflicts_with = "jsonl"
    )]
    pub openpose: Vec<PathBuf>,
    /// 2D keypoints of a view as JSON Lines in the output schema (only "side" and
    /// "keypoints_2d" needed per hand; frames matched by their "frame" field).
    /// Repeat once per view, in the order of --camera.
    #[arg(long = "jsonl", value_name = "IN.jsonl")]
    pub jsonl: Vec<PathBuf>,
    /// Where to write the poses (JSON Lines, one line per frame, flushed as it
    /// goes); "-" for standard output.
    #[arg(short, long, value_name = "OUT.jsonl")]
    pub output: PathBuf,
    /// Track: start each frame's fit from the previous frame's pose (one tracker
    /// per hand side), refitting from scratch when the warm start fits badly.
    /// Faster and steadier on video; leave off for unrelated images.
    #[arg(long)]
    pub track: bool,
    /// Scale the default adult hand model (hand length ~185 mm) by this factor,
    /// e.g. 0.9 for a small hand. The absolute depth scales with it.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub hand_scale: f64,
    /// JSON file with the subject's 20 bone lengths in mm (a plain array or
    /// {"bone_lengths_mm": [...]}, per finger thumb..little: wrist-to-base, then
    /// three phalanges). Applied after --hand-scale.
    #[arg(long, value_name = "FILE.json")]
    pub bone_lengths: Option<PathBuf>,
    /// Keypoints with a confidence below this are ignored (paper: 0.1).
    #[arg(long, value_name = "P", default_value_t = 0.1)]
    pub min_confidence: f64,
    /// Residuals are weighted by confidence^K (paper: 3); 0 weights all kept joints equally.
    #[arg(long, value_name = "K", default_value_t = 3.0)]
    pub confidence_power: f64,
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
    if !(args.hfov.is_finite() && args.hfov > 1.0 && args.hfov < 179.0) {
        anyhow::bail!("--hfov {} must be between 1 and 179 degrees", args.hfov);
    }
    let generic = Camera::generic(args.width, args.height)
        .with_context(|| format!("impossible image size {}x{}", args.width, args.height))?;
    let f = 0.5 * args.width as f64 / (0.5 * args.hfov.to_radians()).tan();
    let mut camera = generic;
    camera.intrinsics.fx = f;
    camera.intrinsics.fy = f;
    camera.validate()?;
    let mut json = monohand_io::calibration::camera_to_json(&camera);
    if let Some(o) = json.as_object_mut() {
        o.insert("hfov_deg".into(), serde_json::json!(args.hfov));
        o.insert(
            "comment".into(),
            serde_json::json!(
                "generic camera: principal point at the image centre, square pixels, no distortion; \
                 depth is only as right as the field of view"
            ),
        );
    }
    println!("{json:#}");
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
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
        Command::Lift(args) => lift::run(args),
        Command::Camera(args) => camera_command(args),
        Command::Eval(args) => eval::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
