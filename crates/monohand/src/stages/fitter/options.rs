//! How the 3D stage fits ([`FitSettings`]): the options its parts (the hands followed, the
//! shape learnt, the fit itself) take, below all of them.

use crate::stages::fitter::fit::HandSizeSource;
use crate::stages::offline::OfflineSettings;
use monohand_core::filtering::OneEuroParams;
use monohand_core::prelude::*;

/// A hand is forgotten (its tracker, side vote and filter dropped) after this many frames
/// unseen.
pub const FORGET_AFTER_FRAMES: u64 = 30;

/// How the 3D stage fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSettings {
    /// The hand models, left then right.
    pub skeletons: [HandSkeleton; 2],
    /// Where their size came from, for the records (measured once `auto_scale_frames` has
    /// measured it).
    pub hand_size: HandSizeSource,
    /// The fitter's settings.
    pub options: FitOptions,
    /// Each fit starts from the hand's previous one (video).
    pub tracking: bool,
    /// With two or more cameras, keep this many first frames back to measure the hand's
    /// size before fitting them (`None`: keep the skeletons' size).
    pub auto_scale_frames: Option<usize>,
    /// Keep this many first frames back to learn each side's hand proportions from the
    /// network's metric 3D ([`crate::learn_proportions`]; the size stays the skeleton's), then
    /// fit every frame with them (`None`: keep the skeletons' proportions). Off by
    /// default: on the development set it makes the 3D worse, because the network marks
    /// the joints in another convention than anatomical labels (docs/accuracy.md).
    pub proportion_frames: Option<usize>,
    /// Smooth each hand's 3D joints over time with a One Euro filter.
    pub smoothing: Option<OneEuroParams>,
    /// Tracking with one camera: each hand's distance from the camera through a One Euro
    /// filter, the joints scaled about the camera's centre to it ([`monohand_core::filtering::DepthFilter`]: the
    /// pixels and the shape stay the fit's; the pose stays the fit's too). Default
    /// [`DEPTH_FILTER`]; `None` turns it off. Not used offline, where the refit with the
    /// frames around each frame steadies the hand itself.
    pub depth_filter: Option<OneEuroParams>,
    /// Refit each frame with the frames after it too, writing it `lag` frames later (`2 lag`
    /// with one camera and [`OfflineSettings::depth_pass`]; [`crate::offline`]; needs
    /// tracking, and replaces `smoothing`).
    pub offline: Option<OfflineSettings>,
}

impl Default for FitSettings {
    fn default() -> FitSettings {
        FitSettings {
            skeletons: [
                HandSkeleton::default_for(HandSide::Left),
                HandSkeleton::default_for(HandSide::Right),
            ],
            hand_size: HandSizeSource::Default,
            options: FitOptions::default(),
            tracking: true,
            auto_scale_frames: None,
            proportion_frames: None,
            smoothing: None,
            depth_filter: Some(DEPTH_FILTER),
            offline: None,
        }
    }
}

/// Default of [`FitSettings::depth_filter`]: minimum cutoff 2 Hz, 0.005 Hz per mm/s.
/// Chosen on the development set, both halves (docs/accuracy.md, "The depth filter"):
/// 18% less jitter, 0.5 mm less absolute error, the same PA.
pub const DEPTH_FILTER: OneEuroParams = OneEuroParams {
    min_cutoff: 2.0,
    beta: 0.005,
    d_cutoff: 1.0,
};
