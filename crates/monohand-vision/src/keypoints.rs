//! What a keypoint estimator gives for one hand ([`HandKeypoints`]): below the pipeline,
//! which runs the estimators, and the rectified views, which map the keypoints back into
//! the image. Re-exported as `pipeline::HandKeypoints` and at the crate's root.

use monohand_core::hand_model::HandSide;
use monohand_core::observation::NetworkCues;

use crate::landmarks::NUM_LANDMARKS;

/// Keypoints of one hand from a [`KeypointEstimator`](crate::KeypointEstimator), continuous
/// image coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct HandKeypoints {
    /// `[x, y, confidence]` per joint in MediaPipe/OpenPose order.
    pub points: [[f64; 3]; NUM_LANDMARKS],
    /// Probability that the crop shows a hand at all.
    pub presence: f32,
    /// Physical side and its probability, if the network tells.
    pub side: Option<(HandSide, f32)>,
    /// The network's relative 3D (metric landmarks, relative depth) if it gives it.
    pub cues: Option<NetworkCues>,
}
