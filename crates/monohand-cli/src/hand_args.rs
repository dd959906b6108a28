//! The hand model and fitting options shared by `lift` and `run`.

use anyhow::{bail, Context, Result};
use clap::Args;
use monohand::{HandScale, HandSizeSource};
use monohand_core::prelude::*;
use std::path::PathBuf;

/// Hand model and fitting options.
#[derive(Debug, Clone, Args)]
pub(crate) struct HandModelArgs {
    /// Size of the hand: a factor on the default adult hand (~185 mm; the depth scales with
    /// it), or "auto" to measure it with two or more calibrated views (docs/accuracy.md).
    /// [default: 1.0]
    #[arg(long, value_name = "S|auto")]
    pub hand_scale: Option<HandScale>,
    /// Frames used by --hand-scale auto and --save-hand.
    #[arg(long, value_name = "N", default_value_t = 30)]
    pub scale_frames: usize,
    /// The person's hand, measured once by a calibrated rig (`run --save-hand`): its size,
    /// for both hands (docs/absolute-depth.md).
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["hand_scale", "hand_length_mm"])]
    pub hand: Option<PathBuf>,
    /// The hand's length by ruler, mm: the hand flat, from the wrist crease to the end of
    /// the middle finger (docs/absolute-depth.md).
    #[arg(long, value_name = "MM", conflicts_with = "hand_scale")]
    pub hand_length_mm: Option<f64>,
    /// JSON file with the subject's 20 bone lengths in mm (docs/accuracy.md), applied after
    /// --hand-scale.
    #[arg(long, value_name = "FILE.json")]
    pub bone_lengths: Option<PathBuf>,
    /// Learn each hand's proportions (size kept) from the network's 3D over this many first
    /// frames (off by default: it made the 3D worse, docs/accuracy.md).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub proportion_frames: Option<u64>,
    /// Keypoints with a confidence below this are ignored (paper: 0.1).
    #[arg(long, value_name = "P", default_value_t = 0.1)]
    pub min_confidence: f64,
    /// Residuals are weighted by confidence^K (paper: 3); 0 weights all kept joints equally.
    #[arg(long, value_name = "K", default_value_t = 3.0)]
    pub confidence_power: f64,
    /// Weights of the network's 3D cues and of the temporal term.
    #[command(flatten)]
    pub cues: CueArgs,
}

/// Weights of the terms the fit adds to the paper's 2D cost (docs/accuracy.md).
#[derive(Debug, Clone, Copy, Args)]
pub(crate) struct CueArgs {
    /// Weight of the network's metric 3D (world landmarks) as bone directions; 0: off.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().cost.world_weight)]
    pub world_weight: f64,
    /// Weight of the network's relative depth (landmark z) as bone directions; 0: off.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().cost.depth_weight)]
    pub depth_weight: f64,
    /// Weight of the network's finger directions in the hand's own frame (its tilt of the
    /// hand undone: the articulation only); 0: off.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().cost.hand_frame_weight)]
    pub hand_frame_weight: f64,
    /// Weight of the pull of a tracked fit towards constant velocity; 0: off.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().tracking.temporal_weight)]
    pub temporal_weight: f64,
    /// One camera: move each joint along its ray this share of the way to its depth in
    /// the network's metric 3D; 0: the skeleton's depths.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().fusion.fuse_world)]
    pub fuse_world: f64,
    /// The same with the relative depth (landmark z); the two shares sum to at most 1.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().fusion.fuse_depth)]
    pub fuse_depth: f64,
    /// One camera: then move each joint this share of the way to its keypoint's ray.
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().fusion.fuse_pixels)]
    pub fuse_pixels: f64,
    /// One camera, tracking: how hard each frame's fit holds the hand's distance gathered
    /// over the frames from the keypoints' own fit and the cues' (docs/absolute-depth.md);
    /// 0: off, one fit per frame with the cues' distance (the behaviour before).
    #[arg(long, value_name = "W", default_value_t = FitOptions::default().distance.weight)]
    pub distance_weight: f64,
    /// One camera, tracking: the relative uncertainty of the cues' distance in one frame.
    #[arg(long, value_name = "R", default_value_t = FitOptions::default().distance.cue_sigma)]
    pub distance_cue_sigma: f64,
    /// One camera, tracking: how much the distance may change from frame to frame (relative).
    #[arg(long, value_name = "R", default_value_t = FitOptions::default().distance.drift_per_frame)]
    pub distance_drift: f64,
    /// One camera, tracking: the least keypoint noise (pixels) the keypoints' distance
    /// uncertainty assumes.
    #[arg(long, value_name = "PX", default_value_t = FitOptions::default().distance.keypoint_sigma_px)]
    pub distance_keypoint_px: f64,
}

impl CueArgs {
    /// `options` with these weights.
    pub fn apply(&self, mut options: FitOptions) -> FitOptions {
        options.cost.world_weight = self.world_weight;
        options.cost.depth_weight = self.depth_weight;
        options.cost.hand_frame_weight = self.hand_frame_weight;
        options.tracking.temporal_weight = self.temporal_weight;
        options.fusion.fuse_world = self.fuse_world;
        options.fusion.fuse_depth = self.fuse_depth;
        options.fusion.fuse_pixels = self.fuse_pixels;
        options.distance.weight = self.distance_weight;
        options.distance.cue_sigma = self.distance_cue_sigma;
        options.distance.drift_per_frame = self.distance_drift;
        options.distance.keypoint_sigma_px = self.distance_keypoint_px;
        options
    }
}

impl HandModelArgs {
    /// The hand's size and where it comes from: --hand, --hand-length-mm or --hand-scale.
    pub fn size(&self) -> Result<(HandScale, HandSizeSource)> {
        hand_size(self.hand.as_deref(), self.hand_length_mm, self.hand_scale)
    }

    /// The left and right hand models at scale `scale`, with --bone-lengths applied.
    pub fn skeletons(&self, scale: f64) -> Result<[HandSkeleton; 2]> {
        let lengths = match &self.bone_lengths {
            Some(p) => Some(monohand_io::skeleton::read_bone_lengths(p)?),
            None => None,
        };
        monohand::hand_skeletons(scale, lengths.as_ref()).with_context(|| {
            match &self.bone_lengths {
                Some(p) => format!("{}: impossible bone lengths", p.display()),
                None => "--hand-scale".into(),
            }
        })
    }

    /// The fitter's options, checked.
    pub fn fit_options(&self) -> Result<FitOptions> {
        let mut options = FitOptions::default();
        options.cost.min_confidence = self.min_confidence;
        options.cost.confidence_power = self.confidence_power;
        let options = self.cues.apply(options);
        options.validate().context(
            "--min-confidence / --confidence-power / --world-weight / --depth-weight / --hand-frame-weight / --temporal-weight / --fuse-world / --fuse-depth / --fuse-pixels / --distance-*",
        )?;
        if self.hand_scale == Some(HandScale::Auto) && self.scale_frames == 0 {
            bail!("--scale-frames must be at least 1");
        }
        Ok(options)
    }
}

/// The hand size of `--hand FILE`, `--hand-length-mm L` or `--hand-scale S|auto` (one of
/// them; none: the default hand), and where it comes from: the file is read here, the
/// choice is the library's ([`monohand::GivenHandSize`]).
pub(crate) fn hand_size(
    hand: Option<&std::path::Path>,
    ruler_mm: Option<f64>,
    scale: Option<HandScale>,
) -> Result<(HandScale, HandSizeSource)> {
    let file = match hand {
        Some(path) => Some(monohand_io::hand::read_hand(path)?),
        None => None,
    };
    let given = monohand::GivenHandSize {
        file: file.as_ref(),
        ruler_mm,
        scale,
    };
    given.choose().with_context(|| match (hand, ruler_mm) {
        (Some(path), _) => format!("--hand {}", path.display()),
        (None, Some(_)) => "--hand-length-mm".to_string(),
        (None, None) => "--hand-scale".to_string(),
    })
}
