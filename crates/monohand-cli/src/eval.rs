//! `monohand eval`: accuracy against a 3D hand dataset, as a table and a report folder.

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use monohand::{FitSettings, OfflineSettings, DEPTH_FILTER};
use monohand_core::prelude::*;
use monohand_eval::plan::{self, Plan, Selection};
use monohand_eval::{Dataset, EvalSettings, SkeletonChoice, ViewMode};
use std::path::PathBuf;
use std::sync::Arc;

use crate::vision::ModelArgs;

/// Which stage to evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Stage {
    /// The 3D lifting alone, on ground-truth 2D keypoints (labelled, or the 3D
    /// labels projected) with optional noise and dropped joints. Needs no images.
    Lift,
    /// The whole pipeline on the images: each sequence through the engine of `run`, as
    /// the video it is (crops pasted back into their frames).
    Full,
}

/// Which cameras to fit with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Views {
    /// The first (left) camera alone.
    Left,
    /// All cameras of each frame.
    Stereo,
    /// Both, on the same frames and keypoints (stereo only if the dataset has two cameras).
    Both,
    /// Each camera alone (its own labelled frames, mono), then all together: a rig.
    Each,
}

/// Which hand model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Skeleton {
    /// The model fitted to each sequence's ground-truth 3D joints (oracle hand size).
    Subject,
    /// The default adult hand times --hand-scale.
    Default,
}

/// The evaluation `args` ask for, in view `modes`.
fn plan_of(args: &EvalArgs, modes: Vec<ViewMode>) -> Result<Plan> {
    let (scale, _) = crate::hand_args::hand_size(
        args.hand.as_deref(),
        args.hand_length_mm,
        args.hand_scale.map(monohand::HandScale::Fixed),
    )?;
    let sized = args.hand.is_some() || args.hand_length_mm.is_some();
    Ok(Plan {
        stage: match args.stage {
            Stage::Lift => plan::Stage::Lift {
                noise_px: args.noise_px.clone(),
                drop_joints: args.drop_joints,
                seed: args.seed,
            },
            Stage::Full => plan::Stage::Full,
        },
        selection: Selection {
            step: args.step,
            max_frames: args.max_frames,
        },
        settings: EvalSettings {
            modes,
            skeleton: match args.skeleton {
                Skeleton::Subject if !sized => SkeletonChoice::Subject,
                _ => SkeletonChoice::Default,
            },
            hand_scale: scale.initial(),
            fit: FitSettings {
                options: args.cues.apply(FitOptions::default()),
                tracking: args.track,
                proportion_frames: args.proportion_frames,
                offline: args.offline.then(OfflineSettings::default),
                // `run`'s depth filter is the engine's: the full stage's.
                depth_filter: (args.stage == Stage::Full && !args.no_depth_filter)
                    .then_some(DEPTH_FILTER),
                ..FitSettings::default()
            },
            fitted_crops: !args.no_fitted_crops,
        },
    })
}

/// Arguments of `monohand eval`.
#[derive(Debug, Args)]
pub(crate) struct EvalArgs {
    /// The dataset: a manifest (.jsonl, or a folder with manifest.jsonl) or an STB folder
    /// (labels/*_BB.mat), see docs/evaluation.md.
    #[arg(long, value_name = "PATH")]
    pub dataset: PathBuf,
    /// lift: 3D lifting on ground-truth 2D; full: the whole pipeline on the images.
    #[arg(long, value_enum, default_value_t = Stage::Lift)]
    pub stage: Stage,
    /// Cameras to fit with: left (mono), stereo, both on the same frames, or each camera
    /// alone then all together (a rig).
    #[arg(long, value_enum, default_value_t = Views::Both)]
    pub views: Views,
    /// Lift stage: Gaussian noise (pixels per coordinate) on the 2D keypoints; one run per
    /// comma-separated value (e.g. 0,2,5).
    #[arg(
        long = "noise-px",
        value_name = "S",
        value_delimiter = ',',
        default_value = "0"
    )]
    pub noise_px: Vec<f64>,
    /// Lift stage: this many joints per view, drawn at random, are missing.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub drop_joints: usize,
    /// Seed of the noise and dropped-joint draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Weights of the network's 3D cues and of the temporal term (the fit's defaults).
    #[command(flatten)]
    pub cues: crate::hand_args::CueArgs,
    /// Warm-start each fit from the previous frame (default: every frame from scratch).
    #[arg(long)]
    pub track: bool,
    /// With --track: the offline smoother of `run --offline`.
    #[arg(long, requires = "track")]
    pub offline: bool,
    /// Full stage: without `run`'s depth filter (docs/accuracy.md).
    #[arg(long)]
    pub no_depth_filter: bool,
    /// Full stage, several cameras: each view finds its hands on its own, as `run
    /// --no-fitted-crops`.
    #[arg(long)]
    pub no_fitted_crops: bool,
    /// Learn the hand's proportions from the network's 3D over this many first frames of
    /// each sequence (docs/accuracy.md).
    #[arg(long, value_name = "N")]
    pub proportion_frames: Option<usize>,
    /// Hand model.
    #[arg(long, value_enum, default_value_t = Skeleton::Subject)]
    pub skeleton: Skeleton,
    /// Scale of the default hand model (with --skeleton default). [default: 1.0]
    #[arg(long, value_name = "S")]
    pub hand_scale: Option<f64>,
    /// A hand file (`run --save-hand`): the default hand model at its size (implies
    /// --skeleton default).
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["hand_scale", "hand_length_mm"])]
    pub hand: Option<PathBuf>,
    /// A ruler's hand length, mm: the default hand model at that size (implies --skeleton
    /// default; docs/absolute-depth.md).
    #[arg(long, value_name = "MM", conflicts_with = "hand_scale")]
    pub hand_length_mm: Option<f64>,
    /// Use every N-th frame of each sequence.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub step: usize,
    /// Use at most this many frames in all (after --step).
    #[arg(long, value_name = "N")]
    pub max_frames: Option<usize>,
    /// Also print the table for each half of each sequence (a setting should help on both).
    #[arg(long)]
    pub halves: bool,
    /// Run three fits and print them side by side, per run and per half: the network's cues
    /// with one fit a frame (--distance-weight 0), the paper's 2D cost (every cue, fusion
    /// and the distance off) and the fit the other options give, with the ceiling of the
    /// first two (each frame the better) and each fit's longest run of frames over twice
    /// its median error (docs/absolute-depth.md).
    #[arg(long)]
    pub compare_fits: bool,
    /// Write a report folder: report.md, errors.csv (per-frame errors), PNG plots.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write the frames evaluated as a manifest (to convert e.g. STB).
    #[arg(long, value_name = "OUT.jsonl")]
    pub write_manifest: Option<PathBuf>,
    /// The networks of --stage full.
    #[command(flatten)]
    pub models: ModelArgs,
}

pub(crate) fn run(args: &EvalArgs) -> Result<()> {
    if args.stage == Stage::Full
        && (args.noise_px.iter().any(|&n| n != 0.0) || args.drop_joints > 0)
    {
        bail!("--noise-px and --drop-joints apply to --stage lift only");
    }
    let mut ds = Dataset::load(&args.dataset)?;
    let stereo_ok = ds.max_cameras() >= 2;
    let modes = match args.views {
        Views::Left => vec![ViewMode::Mono],
        Views::Stereo => vec![ViewMode::Stereo],
        _ if !stereo_ok => {
            tracing::warn!("the dataset has one camera: evaluating mono only");
            vec![ViewMode::Mono]
        }
        // With --views each, Plan::run_views sets the modes per view.
        Views::Both | Views::Each => vec![ViewMode::Mono, ViewMode::Stereo],
    };
    let each = args.views == Views::Each && stereo_ok;
    let plan = plan_of(args, modes)?;
    let left_out = plan.select(&mut ds)?;
    if left_out > 0 {
        eprintln!(
            "--stage full: {} of {} frames have their images on disk; evaluating those",
            ds.frames.len(),
            ds.frames.len() + left_out
        );
    }
    if let Some(out) = &args.write_manifest {
        monohand_eval::manifest::write_manifest(out, &ds)?;
        tracing::info!("manifest written to {}", out.display());
    }
    eprintln!(
        "evaluating {} ({} frames) ...",
        args.dataset.display(),
        ds.frames.len()
    );
    let networks = match plan.stage {
        plan::Stage::Full => {
            let pipeline = args.models.pipeline_for(args.track)?;
            let (models, options) = args.models.options();
            Some((Arc::new(pipeline), models.describe(&options)))
        }
        plan::Stage::Lift { .. } => None,
    };
    let networks = networks.as_ref().map(|(p, d)| (p, d.as_str()));
    let run_plan = |plan: &Plan| -> Result<monohand_eval::report::Report> {
        match each {
            true => plan.run_views(&ds, networks),
            false => plan.run(&ds, networks),
        }
        .map_err(|e| match e.refused_setting() {
            Some(refused) => crate::refused(refused),
            None => e.into(),
        })
    };
    if args.compare_fits {
        let fits = monohand_eval::compare::fits_compared(plan.settings.fit.options);
        let mut runs: [Vec<monohand_eval::RunResult>; 3] = Default::default();
        let mut mask = None;
        for (options, out) in fits.into_iter().zip(runs.iter_mut()) {
            let mut one = plan.clone();
            one.settings.fit.options = options;
            let report = run_plan(&one)?;
            mask = Some(report.mask);
            *out = report.runs;
        }
        println!(
            "monohand {} eval --compare-fits: {} ({}), stage {}",
            env!("CARGO_PKG_VERSION"),
            ds.name,
            args.dataset.display(),
            plan.stage.as_str()
        );
        print!(
            "{}",
            monohand_eval::compare::table(&runs, &mask.unwrap_or([true; NUM_JOINTS]))
        );
        return Ok(());
    }
    let report = run_plan(&plan)?;
    println!(
        "monohand {} eval: {} ({}), stage {}, root {}, {} evaluated joints",
        env!("CARGO_PKG_VERSION"),
        ds.name,
        args.dataset.display(),
        plan.stage.as_str(),
        ds.root.as_str(),
        report.mask.iter().filter(|&&m| m).count()
    );
    print!("{}", report.table());
    if args.halves {
        print!("\nBy half of each sequence:\n{}", report.halves_table());
    }
    if let Some(dir) = &args.report {
        report.write(dir)?;
        println!("report: {}", dir.join("report.md").display());
    }
    Ok(())
}
