//! 2D keypoint observations: what a keypoint detector gives the fitter.

use crate::error::{CoreError, CoreResult};
use crate::hand_model::{HandSide, NUM_JOINTS};
use serde::{Deserialize, Serialize};

/// 21 keypoints in image pixels with a confidence each, `[u, v, p]`, in the
/// order of [`crate::hand_model::JOINT_NAMES`]. A confidence of 0 marks a
/// missing joint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Keypoints2d {
    /// `[u, v, confidence]` per joint.
    pub points: [[f64; 3]; NUM_JOINTS],
}

impl Default for Keypoints2d {
    fn default() -> Self {
        Keypoints2d {
            points: [[0.0; 3]; NUM_JOINTS],
        }
    }
}

impl Keypoints2d {
    /// Builds keypoints from `[u, v, p]` triples, checking every number.
    pub fn new(points: [[f64; 3]; NUM_JOINTS]) -> CoreResult<Keypoints2d> {
        let k = Keypoints2d { points };
        k.validate()?;
        Ok(k)
    }

    /// Checks for NaN/infinite values and confidences outside [0, 1].
    pub fn validate(&self) -> CoreResult<()> {
        for (j, p) in self.points.iter().enumerate() {
            if p.iter().any(|v| !v.is_finite()) {
                return Err(CoreError::InvalidKeypoints(format!(
                    "joint {j} has a non-finite value {p:?}"
                )));
            }
            if !(0.0..=1.0 + 1e-9).contains(&p[2]) {
                return Err(CoreError::InvalidKeypoints(format!(
                    "joint {j} confidence {} is outside [0, 1]",
                    p[2]
                )));
            }
        }
        Ok(())
    }

    /// Number of joints with confidence at least `threshold`.
    pub fn count_usable(&self, threshold: f64) -> usize {
        self.points
            .iter()
            .filter(|p| p[2] >= threshold && p[2] > 0.0)
            .count()
    }

    /// True if no joint has a positive confidence.
    pub fn is_empty(&self) -> bool {
        self.points.iter().all(|p| p[2] <= 0.0)
    }
}

/// One hand's 2D keypoints with its side, as detected in one image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandObservation {
    /// Left or right hand.
    pub side: HandSide,
    /// The keypoints.
    pub keypoints: Keypoints2d,
}
