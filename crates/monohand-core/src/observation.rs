//! 2D keypoint observations: what a keypoint detector gives the fitter.

use crate::bbox::BBox;
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

    /// The box around all 21 points, whatever their confidence (the network places every
    /// joint, seen or not).
    pub fn bounds(&self) -> BBox {
        BBox::around(self.points.iter().map(|p| [p[0], p[1]]))
    }
}

/// The 3D a keypoint network gives beside its 2D keypoints, for one hand in one view.
///
/// Both parts are *relative*: they describe the hand's shape and orientation,
/// not where it is. The fitter turns each into a target direction per bone
/// ([`crate::hand_model::BONES`]) and adds `L (d_model - d_target)` residuals,
/// weighted by [`crate::fitting::CostSettings::world_weight`] and
/// [`crate::fitting::CostSettings::depth_weight`]: only directions are used, so
/// neither the network's metric scale nor its bone proportions have to agree
/// with the skeleton's.
///
/// Axes are the image's as the network saw its crop: x right, y down, z away
/// from the camera. The fitter turns them by the rotation from the optical
/// axis to the viewing ray through the hand (the network sees a crop as if it
/// looked straight at the hand; see `docs/accuracy.md`).
///
/// ```
/// use monohand_core::observation::NetworkCues;
/// let cues = NetworkCues { world_mm: Some([[0.0; 3]; 21]), depth_px: None };
/// assert!(cues.validate().is_ok());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NetworkCues {
    /// Per-joint 3D positions in millimetres relative to any point of the hand
    /// (MediaPipe's "world" landmarks, turned from the crop's axes to the
    /// image's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub world_mm: Option<[[f64; 3]; NUM_JOINTS]>,
    /// Per-joint depth relative to the wrist in image pixels, negative towards
    /// the camera (MediaPipe's landmark `z`, scaled from the crop to the image).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_px: Option<[f64; NUM_JOINTS]>,
}

impl NetworkCues {
    /// Checks for NaN or infinite values.
    pub fn validate(&self) -> CoreResult<()> {
        let finite = self
            .world_mm
            .iter()
            .flat_map(|w| w.iter().flatten())
            .chain(self.depth_px.iter().flatten())
            .all(|v| v.is_finite());
        if finite {
            Ok(())
        } else {
            Err(CoreError::InvalidKeypoints(
                "network 3D cues hold a non-finite value".into(),
            ))
        }
    }

    /// True if neither cue is present.
    pub fn is_empty(&self) -> bool {
        self.world_mm.is_none() && self.depth_px.is_none()
    }
}

/// One hand's 2D keypoints with its side, as detected in one image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandObservation {
    /// Left or right hand.
    pub side: HandSide,
    /// The keypoints.
    pub keypoints: Keypoints2d,
    /// The network's own relative 3D, if it gives one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cues: Option<NetworkCues>,
}
