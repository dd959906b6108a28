//! A frame and its hands after the 3D stage: what the fitter ([`crate::HandsFitter`])
//! gives, the offline smoother ([`crate::offline`]) refines and the records are written
//! from. Data only, so that each of them depends on it and not on the others.

use crate::crops::{HandId, VisionFrame};
use monohand_core::prelude::*;
use monohand_io::jsonl::CameraSource;

/// One hand of a frame, with its 3D.
#[derive(Debug, Clone)]
pub struct TrackedHand {
    /// Identity over the frames.
    pub id: HandId,
    /// Side, as voted over the hand's frames (it can differ from this frame's network).
    pub side: HandSide,
    /// The `(view, index into that view's detections)` pairs that see this hand, its
    /// anchor first: the first view, unless only later views see the hand.
    pub views: Vec<(usize, usize)>,
    /// The fitted hand, `None` when it could not be fitted this frame.
    pub fit: Option<FitResult>,
}

/// One frame after the 3D stage.
#[derive(Debug, Clone)]
pub struct FittedFrame {
    /// What the networks found.
    pub vision: VisionFrame,
    /// The hands ([`crate::association::associate`]): the first view's, in the order of its detections, then
    /// those only later views see.
    pub hands: Vec<TrackedHand>,
    /// Why the frame has no 3D at all (the first view failed, or its image size does not
    /// match the calibration).
    pub error: Option<String>,
    /// Time the fits took, ms.
    pub fit_ms: f64,
    /// The camera of each view the frame was fitted with (empty when it was not fitted).
    /// Every drawing of the frame uses these.
    pub cameras: Vec<Camera>,
    /// Where each of [`FittedFrame::cameras`] came from, and why, in the same order.
    pub camera_origins: Vec<CameraOrigin>,
    /// The hand size the frame was fitted with (`None` when it was not fitted).
    pub hand_size: Option<monohand_io::jsonl::HandSizeRecord>,
    /// The keypoint confidence below which the fit leaves a joint out (its
    /// [`CostSettings::min_confidence`](monohand_core::fitting::CostSettings)): the
    /// per-view errors of the records ([`crate::rig_check`]) count the same joints.
    pub min_confidence: f64,
}

/// Why a frame's cameras could not be made: it gets no 3D ([`FittedFrame::error`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A view's calibration does not fit its image size.
    #[error("view {view}: {source}; no 3D for this frame")]
    Calibration {
        /// The view, from 1.
        view: usize,
        /// Why it cannot be scaled.
        source: monohand_core::camera::ScaleError,
    },
    /// The camera of a photo's size is not possible.
    #[error(transparent)]
    Photo(#[from] CoreError),
}

/// Where a camera in use came from, and why that source and not a better one.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraOrigin {
    /// The source, as the records name it.
    pub source: CameraSource,
    /// Why: a stated EXIF focal length that failed its checks, a calibration scaled from
    /// another size, a field of view outside 5-150 degrees that the user's calibration
    /// gives (`None`: nothing to say).
    pub reason: Option<String>,
}

impl CameraOrigin {
    pub(crate) fn new(source: CameraSource, reason: Option<String>) -> CameraOrigin {
        CameraOrigin { source, reason }
    }
}
