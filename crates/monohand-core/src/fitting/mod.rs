//! Fitting the hand model to 2D keypoints in one or more calibrated views.
//!
//! The cost is the paper's: for every view and every joint whose confidence
//! `p` is at least [`CostSettings::min_confidence`],
//! `(p^k (x - u))^2 + (p^k (y - v))^2` with `k = 3` by default, where `(x, y)`
//! is the projection of the model joint and `(u, v)` the observed keypoint
//! (undistorted once up front, so the solver works on ideal pinhole pixels).
//!
//! Beyond the paper, two more terms (each with a weight in [`FitOptions`], 0
//! turns it off): the keypoint network's own relative 3D
//! ([`crate::observation::NetworkCues`]) as bone directions, which resolves
//! the depth ambiguity of the 2D cost with one camera, and in tracking a pull
//! of every joint towards its constant-velocity prediction. After the fit, with
//! one camera, the network's depth is fused into the output joints along their
//! viewing rays ([`fuse_network_depth`]), then its keypoints across them
//! ([`fuse_keypoints`]). `docs/accuracy.md` has the measurements that chose the
//! weights.
//!
//! The solver ([`lm`]) is a Levenberg-Marquardt over 26 degrees of freedom:
//! translation, a rotation increment on the unit-quaternion manifold (the
//! quaternion is never off unit length, unlike the paper's 4 free numbers),
//! and 20 joint angles kept inside their limits by projection with an active
//! set. Jacobians are analytic ([`crate::kinematics`]). The single-frame
//! start ([`init`]) solves for the rigid palm first from a closed-form
//! weak-perspective estimate with both of its mirror solutions.
//! What both work on (the masks of joints and degrees of freedom, and the views
//! prepared for the solver) is in `problem`; the starts reach the solver only
//! through a small trait that [`HandFitter`] implements, so that `init` does not
//! depend on `lm`.

pub mod distance;
mod fusion;
pub mod init;
pub mod lm;
mod options;
mod problem;
mod proportions;
mod scale;
mod tracker;

pub use distance::{DistanceEvidence, DistanceFilter};
pub use fusion::{fuse_keypoints, fuse_network_depth};
pub use lm::{FitResult, HandFitter};
pub use options::{
    CostSettings, DistanceSettings, FitOptions, FusionSettings, SolverSettings, TrackingSettings,
    View,
};
pub use proportions::{estimate_proportions, ProportionEstimate, MIN_FRAMES, SETTLED_CHANGE};
pub use scale::{estimate_hand_scale, ScaleEstimate, MIN_COST_CONTRAST};
pub use tracker::HandTracker;
