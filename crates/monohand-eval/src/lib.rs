//! # monohand-eval
//!
//! Evaluating monohand against 3D hand-pose datasets, so that its numbers can
//! be put next to published ones in one step (`monohand eval`).
//!
//! - [`dataset`]: the in-memory form of every dataset; [`manifest`]: the JSON
//!   Lines manifest any dataset can be converted to; [`datasets::stb`]: the
//!   Stereo Hand Pose Benchmark read natively, from its label files ([`stb`]:
//!   labels and stereo camera, [`mat`]: a minimal MATLAB v5 `.mat` reader and
//!   writer); [`datasets::hand_graph_cnn`]: the hand-graph-cnn real-world set.
//! - [`metrics`]: absolute, root-relative, Zimmermann-Brox aligned and
//!   Procrustes-aligned errors, per-axis errors, PCK and its AUC, 2D errors.
//! - [`evaluate`](mod@evaluate): the lift stage (ground-truth 2D, noise, dropped joints), mono and stereo
//!   on the same frames; [`full`]: the full stage, each sequence run through the engine of
//!   `monohand run` (the `monohand` crate) and its records scored.
//! - [`plan`]: the frames, stage and settings of one evaluation, and its report's settings.
//! - [`report`]: the printed table and the report folder (Markdown, CSV, PNG plots).
//!
//! Definitions of every metric and convention: `docs/evaluation.md`.

#![deny(missing_docs)]

pub mod compare;
pub mod dataset;
pub mod datasets;
pub mod error;
pub mod evaluate;
pub mod full;
pub mod manifest;
pub mod mat;
pub mod metrics;
pub mod plan;
pub mod report;
pub mod stb;

pub use dataset::{CropOrigin, Dataset, Frame, GtHand, RootJoint};
pub use error::{EvalError, EvalResult};
pub use evaluate::{
    evaluate, EvalSettings, KeypointSource, ProjectedLabels, RunResult, RunSummary, SkeletonChoice,
    ViewMode,
};
pub use full::evaluate_full;
