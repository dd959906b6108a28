//! A frame and its hands as the stages pass them on: what the networks found
//! ([`VisionFrame`], from the crop stage, [`crate::CropTracker`]), the hands fitted in 3D
//! ([`FittedFrame`], from the fitter, [`crate::HandsFitter`]), which the offline smoother
//! ([`crate::offline`]) refines and the records are written from, and the fitted hands that
//! seed the next crops ([`FittedGuide`]). Data only, so that each stage depends on it and
//! not on the others.

use super::camera::{CameraOrigin, StatedCamera};
use super::errors::SourceError;
use monohand_core::prelude::*;
use monohand_vision::{DetectedHand, Detections};
use nalgebra::Vector3;

/// Identity of a tracked hand, unique within a session.
pub type HandId = u64;

/// Why a view gave no hands in a frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ViewError {
    /// Its image could not be read.
    #[error(transparent)]
    Unreadable(#[from] SourceError),
    /// The networks failed on it (their message).
    #[error("{0}")]
    Networks(String),
}

impl From<monohand_vision::VisionError> for ViewError {
    fn from(e: monohand_vision::VisionError) -> ViewError {
        ViewError::Networks(e.to_string())
    }
}

/// One view's hands in one frame: the networks' detections and each one's identity.
#[derive(Debug, Clone)]
pub struct ViewHands {
    /// What the networks found.
    pub detections: Detections,
    /// The identity of each of `detections.hands`, in order.
    pub ids: Vec<HandId>,
}

/// What the networks found in one frame of every view.
#[derive(Debug, Clone)]
pub struct VisionFrame {
    /// Frame number, from 0.
    pub index: u64,
    /// Time of the frame, seconds.
    pub time_s: f64,
    /// Per view: its hands, or why the view gave none this frame (an unreadable image, a
    /// network failure).
    pub views: Vec<Result<ViewHands, ViewError>>,
    /// Time the networks took, ms.
    pub vision_ms: f64,
    /// What the first view's file states about its camera (a photo's EXIF focal length, a
    /// video's QuickTime metadata), set by whoever read the file. Without calibrated
    /// cameras, the 3D stage builds that view's camera from it instead of the generic guess
    /// ([`crate::HandsFitter::new`]).
    pub focal: StatedCamera,
}

/// A hand fitted in 3D, for the next frame's crops in every view: its identity and its
/// joints predicted for that frame, mm, in the first camera's frame
/// ([`crate::HandsFitter::guides`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FittedGuide {
    /// The hand's identity.
    pub id: HandId,
    /// Its 21 joints, predicted for the next frame.
    pub joints: [Vector3<f64>; NUM_JOINTS],
}

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
    /// With one camera, tracking and [`DistanceSettings`](monohand_core::fitting::DistanceSettings)
    /// on: what this frame's fits said of the hand's distance and what the filter over the
    /// track made of it (`None` otherwise).
    pub distance: Option<monohand_core::fitting::DistanceEvidence>,
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

/// Hand `k` of view `v` of a frame.
pub(crate) fn detected(frame: &VisionFrame, v: usize, k: usize) -> Option<&DetectedHand> {
    frame.views.get(v)?.as_ref().ok()?.detections.hands.get(k)
}
