//! `monohand eval`: accuracy against a 3D hand dataset, as a table and a report folder.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use monohand_core::prelude::*;
use monohand_eval::evaluate::evaluated_joints;
use monohand_eval::report::Report;
use monohand_eval::{
    evaluate, Dataset, Detected, EvalSettings, ImageDetector, ProjectedLabels, SkeletonChoice,
    ViewMode,
};
use monohand_vision::HandPipeline;
use std::path::{Path, PathBuf};

use crate::vision::ModelArgs;

/// Which stage to evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Stage {
    /// The 3D lifting alone, on ground-truth 2D keypoints (labelled, or the 3D
    /// labels projected) with optional noise and dropped joints. Needs no images.
    Lift,
    /// The whole pipeline on the images (detector + lifting).
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
}

/// Which hand model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Skeleton {
    /// The model fitted to each sequence's ground-truth 3D joints (oracle hand size).
    Subject,
    /// The default adult hand times --hand-scale.
    Default,
}

/// Arguments of `monohand eval`.
#[derive(Debug, Args)]
pub(crate) struct EvalArgs {
    /// The dataset: a manifest (.jsonl, or a folder holding manifest.jsonl; format in
    /// docs/evaluation.md) or an STB folder (labels/*_BB.mat; every sequence found is
    /// evaluated).
    #[arg(long, value_name = "PATH")]
    pub dataset: PathBuf,
    /// lift: 3D lifting on ground-truth 2D; full: the whole pipeline on the images.
    #[arg(long, value_enum, default_value_t = Stage::Lift)]
    pub stage: Stage,
    /// Cameras to fit with: left (mono), stereo, or both on the same frames.
    #[arg(long, value_enum, default_value_t = Views::Both)]
    pub views: Views,
    /// Gaussian noise (standard deviation, pixels per coordinate) added to the
    /// ground-truth 2D keypoints in the lift stage; several values separated by
    /// commas give one run each (e.g. 0,2,5).
    #[arg(
        long = "noise-px",
        value_name = "S",
        value_delimiter = ',',
        default_value = "0"
    )]
    pub noise_px: Vec<f64>,
    /// Lift stage: this many joints per view, chosen at random, are given
    /// confidence 0 (missing).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub drop_joints: usize,
    /// Seed of the noise and dropped-joint draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Weights of the network's 3D cues and of the temporal term (the fit's defaults).
    #[command(flatten)]
    pub cues: crate::hand_args::CueArgs,
    /// Warm-start each fit from the previous frame of the sequence (default:
    /// every frame from scratch, as single-image methods are evaluated).
    #[arg(long)]
    pub track: bool,
    /// Learn the hand's proportions (size kept) from the network's 3D over this many first
    /// frames of each sequence, then fit the rest with them (docs/accuracy.md).
    #[arg(long, value_name = "N")]
    pub proportion_frames: Option<usize>,
    /// Hand model: subject (fitted to each sequence's ground truth: an oracle
    /// hand size) or default (average adult hand times --hand-scale).
    #[arg(long, value_enum, default_value_t = Skeleton::Subject)]
    pub skeleton: Skeleton,
    /// Scale of the default hand model (with --skeleton default).
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub hand_scale: f64,
    /// Use every N-th frame of each sequence.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub step: usize,
    /// Use at most this many frames in all (after --step).
    #[arg(long, value_name = "N")]
    pub max_frames: Option<usize>,
    /// Write a report folder: report.md (settings, table, plots), errors.csv (raw
    /// per-frame errors), PNG plots.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write the dataset (after --step/--max-frames) as a manifest, to convert
    /// a natively read dataset such as STB.
    #[arg(long, value_name = "OUT.jsonl")]
    pub write_manifest: Option<PathBuf>,
    /// The networks of --stage full.
    #[command(flatten)]
    pub models: ModelArgs,
}

/// The vision front end as the evaluation's detector.
struct VisionDetector {
    pipeline: HandPipeline,
    description: String,
}

impl ImageDetector for VisionDetector {
    fn describe(&self) -> String {
        self.description.clone()
    }

    fn detect(&mut self, image: &Path, _camera: &Camera) -> Result<Vec<HandObservation>, String> {
        let found = self
            .pipeline
            .detect_file(image)
            .map_err(|e| e.to_string())?;
        Ok(found.hands.iter().map(|h| h.observation()).collect())
    }
}

pub(crate) fn run(args: &EvalArgs) -> Result<()> {
    let ds = load_dataset(args)?;
    let stereo_ok = ds.max_cameras() >= 2;
    let modes = match args.views {
        Views::Left => vec![ViewMode::Mono],
        Views::Stereo => vec![ViewMode::Stereo],
        Views::Both if stereo_ok => vec![ViewMode::Mono, ViewMode::Stereo],
        Views::Both => {
            tracing::warn!("the dataset has one camera: evaluating mono only");
            vec![ViewMode::Mono]
        }
    };
    let settings = EvalSettings {
        modes: modes.clone(),
        track: args.track,
        skeleton: match args.skeleton {
            Skeleton::Subject => SkeletonChoice::Subject,
            Skeleton::Default => SkeletonChoice::Default,
        },
        hand_scale: args.hand_scale,
        fit_options: args.cues.apply(FitOptions::default()),
        proportion_frames: args.proportion_frames,
    };
    let mask = evaluated_joints(ds.root);
    let stage_name = match args.stage {
        Stage::Lift => "lift (ground-truth 2D keypoints)",
        Stage::Full => "full (detector + keypoints + lifting on the images)",
    };
    let mut report = Report::new(&ds, stage_name, mask);
    report.settings = settings_rows(args, &ds, &modes);
    eprintln!(
        "evaluating {} ({} frames) ...",
        args.dataset.display(),
        ds.frames.len()
    );
    match args.stage {
        Stage::Lift => {
            for &noise in &args.noise_px {
                let mut source = ProjectedLabels::new(noise, args.drop_joints, args.seed)?;
                let (runs, notes) = evaluate(&ds, &mut source, &settings, Some(noise))
                    .with_context(|| format!("evaluating with {noise} px noise"))?;
                report.runs.extend(runs);
                report.skeletons = notes;
            }
        }
        Stage::Full => {
            let pipeline = args.models.pipeline(1)?;
            let description = format!(
                "MediaPipe 0.10.14 palm detector ({:?}) + hand landmarks ({:?}{}) in tract",
                args.models.palm_model,
                args.models.landmark_model,
                if args.models.no_mirror_pass {
                    ", one pass per crop"
                } else {
                    ", mean of each crop and its mirror image"
                }
            );
            let mut source = Detected(VisionDetector {
                pipeline,
                description,
            });
            let (runs, notes) = evaluate(&ds, &mut source, &settings, None)
                .context("evaluating the full pipeline")?;
            report.runs.extend(runs);
            report.skeletons = notes;
        }
    }
    println!(
        "monohand {} eval: {} ({}), stage {}, root {}, {} evaluated joints",
        env!("CARGO_PKG_VERSION"),
        ds.name,
        args.dataset.display(),
        match args.stage {
            Stage::Lift => "lift",
            Stage::Full => "full",
        },
        ds.root.as_str(),
        mask.iter().filter(|&&m| m).count()
    );
    print!("{}", report.table());
    if let Some(dir) = &args.report {
        report.write(dir)?;
        println!("report: {}", dir.join("report.md").display());
    }
    Ok(())
}

/// The settings rows of the report.
fn settings_rows(args: &EvalArgs, ds: &Dataset, modes: &[ViewMode]) -> Vec<(String, String)> {
    let seqs = ds.sequences();
    vec![
        (
            "frames".into(),
            format!(
                "{} frames, {} labelled hands, {} sequence(s): {}",
                ds.frames.len(),
                ds.num_hands(),
                seqs.len(),
                seqs.join(", ")
            ),
        ),
        (
            "views".into(),
            modes
                .iter()
                .map(|m| m.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        ),
        (
            "2D noise (px, sigma per coordinate)".into(),
            args.noise_px
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", "),
        ),
        (
            "dropped joints per view".into(),
            args.drop_joints.to_string(),
        ),
        ("seed".into(), args.seed.to_string()),
        (
            "fitting".into(),
            if args.track {
                "tracking (warm start from the previous frame)".into()
            } else {
                "every frame from scratch".into()
            },
        ),
        (
            "skeleton".into(),
            match args.skeleton {
                Skeleton::Subject => "subject: fitted to each sequence's ground truth".into(),
                Skeleton::Default => format!("default adult hand x {}", args.hand_scale),
            },
        ),
        (
            "frame step / limit".into(),
            format!("{} / {:?}", args.step, args.max_frames),
        ),
    ]
}

/// The dataset of the arguments, subsampled, with the frames `--stage full` can run.
fn load_dataset(args: &EvalArgs) -> Result<Dataset> {
    if args.step == 0 {
        bail!("--step must be at least 1");
    }
    if args.noise_px.is_empty() {
        bail!("--noise-px needs a value");
    }
    let mut ds = Dataset::load(&args.dataset)?;
    ds.subsample(args.step, args.max_frames);
    if ds.frames.is_empty() {
        bail!("{}: no frames to evaluate", args.dataset.display());
    }
    if let Some(out) = &args.write_manifest {
        monohand_eval::manifest::write_manifest(out, &ds)?;
        tracing::info!("manifest written to {}", out.display());
    }
    if args.stage == Stage::Full {
        // Only frames whose images are all on disk can be run through the networks.
        let before = ds.frames.len();
        ds.frames
            .retain(|f| !f.images.is_empty() && f.images.iter().all(|p| p.is_file()));
        if ds.frames.is_empty() {
            bail!(
                "{}: --stage full needs the images, and none of the {before} frames has all of its images on disk",
                args.dataset.display()
            );
        }
        if ds.frames.len() < before {
            eprintln!(
                "--stage full: {} of {before} frames have their images on disk; evaluating those",
                ds.frames.len()
            );
        }
        if args.noise_px.iter().any(|&n| n != 0.0) || args.drop_joints > 0 {
            bail!("--noise-px and --drop-joints apply to --stage lift only");
        }
    }
    Ok(ds)
}
