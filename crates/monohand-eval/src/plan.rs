//! What one evaluation runs: the frames of the dataset it uses, its stage with that stage's
//! inputs, and the settings lines its report shows.

use crate::dataset::Dataset;
use crate::error::{EvalError, EvalResult};
use crate::evaluate::{
    evaluate, evaluated_joints, EvalSettings, ProjectedLabels, SkeletonChoice, ViewMode,
    NETWORK_RUN_LABEL,
};
use crate::report::Report;
use monohand::HandPipeline;
use std::sync::Arc;

/// The keypoints the fits get.
#[derive(Debug, Clone, PartialEq)]
pub enum Stage {
    /// The ground-truth 2D keypoints, once per noise level ([`crate::ProjectedLabels`]).
    Lift {
        /// Gaussian noise, standard deviation per pixel coordinate: one run per value.
        noise_px: Vec<f64>,
        /// Joints per view given confidence 0, drawn at random.
        drop_joints: usize,
        /// Seed of the noise and the dropped joints.
        seed: u64,
    },
    /// The whole pipeline on the images ([`crate::full`]).
    Full,
}

impl Stage {
    /// `"lift"` or `"full"`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Stage::Lift { .. } => "lift",
            Stage::Full => "full",
        }
    }

    /// What the stage is, for the report.
    pub const fn describe(&self) -> &'static str {
        match self {
            Stage::Lift { .. } => "lift (ground-truth 2D keypoints)",
            Stage::Full => "full (the engine of `monohand run` on the images)",
        }
    }
}

/// Which frames of a dataset an evaluation uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Selection {
    /// Every this many-th frame of each sequence.
    pub step: usize,
    /// At most this many frames in all (after the step).
    pub max_frames: Option<usize>,
}

/// An evaluation's plan: the stage, the frames and the fits' settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The stage and its inputs.
    pub stage: Stage,
    /// The frames.
    pub selection: Selection,
    /// The fits' settings.
    pub settings: EvalSettings,
}

impl Plan {
    /// Checks the plan and keeps the frames of `dataset` it uses; for the full stage only
    /// frames with all their images on disk. Returns how many frames the full stage left
    /// out for want of images (the caller may say so).
    pub fn select(&self, dataset: &mut Dataset) -> EvalResult<usize> {
        if self.selection.step == 0 {
            return Err(EvalError::Settings(
                "the frame step must be at least 1".into(),
            ));
        }
        if let Stage::Lift { noise_px, .. } = &self.stage {
            if noise_px.is_empty() {
                return Err(EvalError::Settings("no noise level to evaluate".into()));
            }
        }
        dataset.subsample(self.selection.step, self.selection.max_frames);
        if dataset.frames.is_empty() {
            return Err(EvalError::dataset(&dataset.source, "no frames to evaluate"));
        }
        if self.stage != Stage::Full {
            return Ok(0);
        }
        let before = dataset.frames.len();
        dataset
            .frames
            .retain(|f| !f.images.is_empty() && f.images.iter().all(|p| p.is_file()));
        if dataset.frames.is_empty() {
            return Err(EvalError::dataset(
                &dataset.source,
                format!(
                    "the full stage needs the images, and none of the {before} frames has all \
                     of its images on disk"
                ),
            ));
        }
        Ok(before - dataset.frames.len())
    }

    /// Runs the plan over `dataset` (after [`Plan::select`]) into a report with its settings
    /// lines: each noise level of the lift stage, or the full stage through the engine with
    /// `networks` (the pipeline, and its description for the report; the full stage only).
    pub fn run(
        &self,
        dataset: &Dataset,
        networks: Option<(&Arc<HandPipeline>, &str)>,
    ) -> EvalResult<Report> {
        let mask = evaluated_joints(dataset.root);
        let mut report = Report::new(dataset, self.stage.describe(), mask);
        report.settings = self.settings_rows(dataset);
        let settings = &self.settings;
        match (&self.stage, networks) {
            (
                Stage::Lift {
                    noise_px,
                    drop_joints,
                    seed,
                },
                _,
            ) => {
                for &noise in noise_px {
                    let mut source = ProjectedLabels::new(noise, *drop_joints, *seed)?;
                    let (runs, notes) = evaluate(dataset, &mut source, settings, Some(noise))
                        .map_err(|e| e.context(format!("evaluating with {noise} px noise")))?;
                    report.runs.extend(runs);
                    report.skeletons = notes;
                }
            }
            (Stage::Full, Some((pipeline, description))) => {
                let (runs, notes) =
                    crate::full::evaluate_full(dataset, pipeline, description, settings)
                        .map_err(|e| e.context("evaluating the full pipeline"))?;
                report.runs.extend(runs);
                report.skeletons = notes;
            }
            (Stage::Full, None) => {
                return Err(EvalError::Settings(
                    "the full stage needs the networks".into(),
                ))
            }
        }
        Ok(report)
    }

    /// Runs the plan on each view of `dataset` alone ([`Dataset::view`]: that camera, its
    /// images and its labelled hands, a mono fit), then, with two or more views, on all of
    /// them together, into one report: the runs of view `v` are labelled with its name
    /// ([`Dataset::view_name`]), the network's 3D of that view `NAME: network 3D ...`, the
    /// runs of every view `all N views`. The settings' view modes are replaced.
    pub fn run_views(
        &self,
        dataset: &Dataset,
        networks: Option<(&Arc<HandPipeline>, &str)>,
    ) -> EvalResult<Report> {
        let n = dataset.max_cameras();
        let with_modes = |modes: Vec<ViewMode>| Plan {
            settings: EvalSettings {
                modes,
                ..self.settings.clone()
            },
            ..self.clone()
        };
        let mut report = Report::new(
            dataset,
            self.stage.describe(),
            evaluated_joints(dataset.root),
        );
        report.settings = self.settings_rows(dataset);
        if let Some(row) = report.settings.iter_mut().find(|(k, _)| k == "views") {
            row.1 = format!("each of {n} alone (mono), then all together");
        }
        let mono = with_modes(vec![ViewMode::Mono]);
        for v in 0..n {
            let name = dataset.view_name(v);
            let one = dataset.view(v)?;
            let part = mono
                .run(&one, networks)
                .map_err(|e| e.context(format!("evaluating {name} alone")))?;
            for mut run in part.runs {
                run.label = match run.relative_only {
                    true => format!("{name}: {NETWORK_RUN_LABEL}"),
                    false => run.label.replacen(ViewMode::Mono.as_str(), &name, 1),
                };
                report.runs.push(run);
            }
            report.skeletons.extend(part.skeletons);
        }
        if n >= 2 {
            let part = with_modes(vec![ViewMode::Stereo]).run(dataset, networks)?;
            for mut run in part.runs.into_iter().filter(|r| !r.relative_only) {
                run.label =
                    run.label
                        .replacen(ViewMode::Stereo.as_str(), &format!("all {n} views"), 1);
                report.runs.push(run);
            }
        }
        Ok(report)
    }

    /// The settings lines of the report, for `dataset` (after [`Plan::select`]).
    pub fn settings_rows(&self, dataset: &Dataset) -> Vec<(String, String)> {
        let seqs = dataset.sequences();
        let s = &self.settings;
        let mut rows = vec![
            (
                "frames".into(),
                format!(
                    "{} frames, {} labelled hands, {} sequence(s): {}",
                    dataset.frames.len(),
                    dataset.num_hands(),
                    seqs.len(),
                    seqs.join(", ")
                ),
            ),
            (
                "views".into(),
                s.modes
                    .iter()
                    .map(|m| m.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
        ];
        if let Stage::Lift {
            noise_px,
            drop_joints,
            seed,
        } = &self.stage
        {
            let noise: Vec<String> = noise_px.iter().map(f64::to_string).collect();
            rows.push((
                "2D noise (px, sigma per coordinate)".into(),
                noise.join(", "),
            ));
            rows.push(("dropped joints per view".into(), drop_joints.to_string()));
            rows.push(("seed".into(), seed.to_string()));
        }
        rows.push((
            "fitting".into(),
            if s.fit.tracking {
                "tracking (warm start from the previous frame)".into()
            } else {
                "every frame from scratch".into()
            },
        ));
        rows.push((
            "skeleton".into(),
            match s.skeleton {
                SkeletonChoice::Subject => "subject: fitted to each sequence's ground truth".into(),
                SkeletonChoice::Default => format!("default adult hand x {}", s.hand_scale),
            },
        ));
        rows.push((
            "frame step / limit".into(),
            format!("{} / {:?}", self.selection.step, self.selection.max_frames),
        ));
        rows
    }
}
