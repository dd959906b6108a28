use crate::camera::Camera;
use crate::error::{CoreError, CoreResult};
use crate::observation::{Keypoints2d, NetworkCues};

/// One calibrated view of the hand: a camera, the keypoints seen in it and,
/// optionally, the keypoint network's own relative 3D.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The camera (its extrinsics map the reference frame into it).
    pub camera: &'a Camera,
    /// The 2D keypoints in this camera's image, pixels.
    pub keypoints: &'a Keypoints2d,
    /// The network's relative 3D for the same hand in this view.
    pub cues: Option<&'a NetworkCues>,
}

impl<'a> View<'a> {
    /// A view with 2D keypoints only (the paper's cost).
    pub fn new(camera: &'a Camera, keypoints: &'a Keypoints2d) -> View<'a> {
        View {
            camera,
            keypoints,
            cues: None,
        }
    }

    /// The same view with the network's relative 3D added.
    pub fn with_cues(mut self, cues: Option<&'a NetworkCues>) -> View<'a> {
        self.cues = cues;
        self
    }
}

/// Settings of the fitter, in four groups: the Levenberg-Marquardt solver's, the
/// cost's (which keypoints count, how much, and the network's 3D cues), tracking's
/// and the fusion of the network's depth and the keypoints into the output joints.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FitOptions {
    /// The Levenberg-Marquardt solver: iteration caps, stopping rule, damping.
    pub solver: SolverSettings,
    /// The cost: which keypoints are used, their weights, the network's 3D cues.
    pub cost: CostSettings,
    /// Tracking: when a warm-started fit is redone from scratch, the temporal term.
    pub tracking: TrackingSettings,
    /// With one view, after the fit: the output joints moved towards the network's
    /// depth and the keypoints.
    pub fusion: FusionSettings,
    /// With one view, in tracking: the hand's distance gathered over the frames from the
    /// keypoints' own evidence and the cues' ([`crate::fitting::DistanceFilter`]).
    pub distance: DistanceSettings,
}

impl FitOptions {
    /// Checks the numbers of every group.
    pub fn validate(&self) -> CoreResult<()> {
        self.solver.validate()?;
        self.cost.validate()?;
        self.tracking.validate()?;
        self.fusion.validate()?;
        self.distance.validate()
    }
}

/// Settings of the Levenberg-Marquardt solver ([`FitOptions::solver`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Iteration cap for a fit from scratch (per starting hypothesis).
    pub max_iterations: usize,
    /// Iteration cap for a warm-started (tracking) fit.
    pub max_iterations_tracking: usize,
    /// Stop when the cost decreases by less than this fraction.
    pub cost_tolerance: f64,
    /// Stop when the largest step component is below this (mm or rad).
    pub step_tolerance: f64,
    /// Initial Levenberg-Marquardt damping (relative to the diagonal).
    pub initial_damping: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            max_iterations: 100,
            max_iterations_tracking: 30,
            cost_tolerance: 1e-9,
            step_tolerance: 1e-7,
            initial_damping: 1e-3,
        }
    }
}

impl SolverSettings {
    /// Checks the numbers.
    pub fn validate(&self) -> CoreResult<()> {
        let bad = |m: &str| Err(CoreError::InvalidOptions(m.to_string()));
        if self.max_iterations == 0 || self.max_iterations_tracking == 0 {
            return bad("iteration caps must be positive");
        }
        if !(self.cost_tolerance >= 0.0 && self.step_tolerance >= 0.0 && self.initial_damping > 0.0)
        {
            return bad("tolerances must be >= 0 and damping > 0");
        }
        Ok(())
    }
}

/// Settings of the cost ([`FitOptions::cost`]): which keypoints are used, how much
/// each weighs, and the weights of the network's 3D cues.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostSettings {
    /// Joints with a confidence below this are dropped (paper: 0.1).
    pub min_confidence: f64,
    /// Residuals are weighted by `confidence ^ confidence_power` (paper: 3).
    pub confidence_power: f64,
    /// Fewest usable joints (over all views) for a fit to be attempted.
    pub min_joints: usize,
    /// Weight of the network's metric 3D ([`NetworkCues::world_mm`]): each
    /// bone adds `w p^k L (d_model - d_world)` (mm, `L` the bone's length, `d`
    /// unit directions, `p^k` the smaller confidence weight of its two joints)
    /// beside the keypoint residuals `p^k (x - u) 1000 / f` (milliradians, so
    /// that the balance does not depend on the resolution). 0 turns the cue
    /// off. Chosen on the development set, see `docs/accuracy.md`.
    pub world_weight: f64,
    /// Weight of the network's relative depth ([`NetworkCues::depth_px`]),
    /// the same bone-direction residual with the direction taken from
    /// `(du, dv, dz)` in pixels. 0 turns the cue off.
    pub depth_weight: f64,
    /// Relative weight of each cue's bone residuals by the bone's place in its
    /// finger (`[cue][segment]`, cue 0 world landmarks, 1 relative depth; segment 0
    /// the wrist-to-base bone, 1 proximal, 2 middle, 3 distal): how far the
    /// network's bone directions can be trusted there. Multiplies
    /// [`world_weight`](Self::world_weight) / [`depth_weight`](Self::depth_weight).
    /// Default: the inverse of the measured angular error, `CUE_BONE_ERROR_DEG`.
    pub cue_segment_weights: [[f64; 4]; 2],
    /// Weight of the network's finger bone directions in the hand's own frame (both
    /// cues, each with its [`cue_segment_weights`](Self::cue_segment_weights)): each
    /// cue's tilt of the whole hand (the rotation that best places the skeleton's palm on
    /// its palm) is undone, so that these residuals inform the fingers' articulation
    /// only, and leave the hand's tilt and distance to the keypoints. Each finger bone adds
    /// `w p^k L (R^T d_model - d_cue)` (mm, `R` the fitted hand's rotation). 0 turns it off.
    pub hand_frame_weight: f64,
}

impl Default for CostSettings {
    fn default() -> Self {
        CostSettings {
            min_confidence: 0.1,
            confidence_power: 3.0,
            min_joints: 4,
            // Chosen on the development set (hand_graph_cnn_dev, 292 frames, tracked):
            // docs/accuracy.md has the table that chose them. They were chosen as 1 and
            // 1.5 with the keypoints weighed in pixels; the keypoints are now weighed in
            // milliradians, and 1000 / 923.7 (the dev camera's focal length) converts the
            // weights without changing the fit there (docs/accuracy.md, "The frame's
            // resolution").
            world_weight: 1.08,
            depth_weight: 1.62,
            cue_segment_weights: cue_segment_weights_from(&CUE_BONE_ERROR_DEG),
            // Chosen on both dev sets and both halves of each (docs/accuracy.md, "Depth from
            // every viewpoint").
            hand_frame_weight: 2.0,
        }
    }
}

impl CostSettings {
    /// Checks the numbers.
    pub fn validate(&self) -> CoreResult<()> {
        let bad = |m: &str| Err(CoreError::InvalidOptions(m.to_string()));
        if !(0.0..=1.0).contains(&self.min_confidence) {
            return bad("min_confidence must be in [0, 1]");
        }
        if !(self.confidence_power.is_finite() && self.confidence_power >= 0.0) {
            return bad("confidence_power must be finite and >= 0");
        }
        if self.min_joints < 3 {
            return bad("min_joints must be at least 3");
        }
        for (name, w) in [
            ("world_weight", self.world_weight),
            ("depth_weight", self.depth_weight),
            ("hand_frame_weight", self.hand_frame_weight),
        ]
        .into_iter()
        .chain(
            self.cue_segment_weights
                .iter()
                .flatten()
                .map(|&w| ("cue_segment_weights", w)),
        ) {
            check_weight(name, w)?;
        }
        Ok(())
    }
}

/// Settings of tracking ([`FitOptions::tracking`]: [`HandTracker`] and
/// [`HandFitter::fit_from`]).
///
/// [`HandTracker`]: crate::fitting::HandTracker
/// [`HandFitter::fit_from`]: crate::fitting::HandFitter::fit_from
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingSettings {
    /// In tracking, refit from scratch when the warm-started fit's mean
    /// reprojection error exceeds this angle (milliradians: pixels times 1000 over
    /// the focal length, so that the rule does not change with the resolution).
    pub tracking_reset_mrad: f64,
    /// Weight of the pull in tracking towards where constant velocity puts the
    /// joints (from the last two frames): every joint adds `w (X - X_predicted)`
    /// (mm). 0 turns it off.
    pub temporal_weight: f64,
}

impl Default for TrackingSettings {
    fn default() -> Self {
        TrackingSettings {
            tracking_reset_mrad: RESET_MRAD,
            // Chosen on the development set, as the cue weights (docs/accuracy.md): 0.1
            // in pixels, converted alike.
            temporal_weight: 0.108,
        }
    }
}

impl TrackingSettings {
    /// Checks the numbers.
    pub fn validate(&self) -> CoreResult<()> {
        check_weight("tracking_reset_mrad", self.tracking_reset_mrad)?;
        check_weight("temporal_weight", self.temporal_weight)
    }
}

/// Settings of the fusion of the network's depth and the keypoints into the
/// output joints, with one view, after the fit ([`FitOptions::fusion`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusionSettings {
    /// With one view carrying the network's 3D, the share of each output joint's
    /// depth taken from the metric 3D ([`NetworkCues::world_mm`], placed rigidly
    /// on the fit): the joint moves along its viewing ray ([`fuse_network_depth`]).
    /// The pose and [`FitResult::model_joints_3d`] stay the skeleton's. 0 turns it
    /// off; with [`fuse_depth`](Self::fuse_depth) at most 1.
    ///
    /// [`fuse_network_depth`]: crate::fitting::fuse_network_depth
    /// [`FitResult::model_joints_3d`]: crate::fitting::FitResult::model_joints_3d
    pub fuse_world: f64,
    /// The same for the relative depth ([`NetworkCues::depth_px`], scaled to mm at
    /// the fit's mean depth).
    pub fuse_depth: f64,
    /// With one view, after the depth fusion: the share of the way each output joint
    /// moves towards the point at its depth on its keypoint's viewing ray (the pixels
    /// the fit used; [`fuse_keypoints`]). The skeleton cannot reach every keypoint, and
    /// the keypoints are a second estimate of where the joints are seen. 0 keeps the
    /// skeleton's pixels; 1 puts every used joint on its keypoint's ray.
    ///
    /// [`fuse_keypoints`]: crate::fitting::fuse_keypoints
    pub fuse_pixels: f64,
}

impl Default for FusionSettings {
    fn default() -> Self {
        FusionSettings {
            // Chosen on the development set (docs/accuracy.md, "depth fusion").
            fuse_world: 0.5,
            // 0.2 since the relative depth is MediaPipe's own (normalize_z, 2026-11-25).
            fuse_depth: 0.2,
            fuse_pixels: 0.5,
        }
    }
}

impl FusionSettings {
    /// Checks the numbers.
    pub fn validate(&self) -> CoreResult<()> {
        let bad = |m: &str| Err(CoreError::InvalidOptions(m.to_string()));
        if !((0.0..=1.0).contains(&self.fuse_world)
            && (0.0..=1.0).contains(&self.fuse_depth)
            && self.fuse_world + self.fuse_depth <= 1.0)
        {
            return bad("fuse_world and fuse_depth must be in [0, 1], with a sum of at most 1");
        }
        if !(0.0..=1.0).contains(&self.fuse_pixels) {
            return bad("fuse_pixels must be in [0, 1]");
        }
        Ok(())
    }
}

/// Settings of the hand's distance over time with one camera ([`FitOptions::distance`],
/// [`crate::fitting::DistanceFilter`], used by [`crate::fitting::HandTracker`]).
///
/// Each frame is fitted twice: with the network's cues (the fit of the other settings)
/// and with the keypoints alone (the paper's cost, with the articulation cues in the
/// hand's frame, which do not move the hand's distance). The keypoints' fit gives the
/// palm's distance with its own uncertainty (how firmly the pixels pin it:
/// [`crate::fitting::HandFitter::palm_depth_sigma`]); the cues' fit gives another, of a
/// fixed relative uncertainty. A filter over the frames combines both, and the frame is
/// fitted once more with the cues, its distance held at the filter's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceSettings {
    /// Weight of the pull of the final fit's palm distance towards the filtered one, on
    /// the filter's own uncertainty: the residual `w σ_kp (d - d_filtered) / σ_filtered`
    /// (`σ_kp` the keypoints' noise in milliradians), so that at 1 the filtered distance
    /// weighs as its uncertainty says. 0 turns the whole mechanism off (one fit per
    /// frame, the cues' distance: the behaviour before).
    pub weight: f64,
    /// The keypoints' noise per coordinate, pixels, at confidence weight 1: the least
    /// noise [`crate::fitting::HandFitter::palm_depth_sigma`] assumes (the fit's own mean
    /// reprojection error is used where larger).
    pub keypoint_sigma_px: f64,
    /// The relative uncertainty of the cues' distance in one frame (0.1: 10%).
    pub cue_sigma: f64,
    /// How much the distance may change from one frame to the next, relative (the
    /// filter's process noise per frame).
    pub drift_per_frame: f64,
}

impl Default for DistanceSettings {
    fn default() -> Self {
        // Chosen on both dev sets, both halves of each, and the rig's views one left out
        // at a time (docs/absolute-depth.md, "One camera from any viewpoint").
        DistanceSettings {
            weight: 10.0,
            keypoint_sigma_px: 2.0,
            cue_sigma: 0.1,
            drift_per_frame: 0.02,
        }
    }
}

impl DistanceSettings {
    /// Checks the numbers.
    pub fn validate(&self) -> CoreResult<()> {
        check_weight("distance weight", self.weight)?;
        for (name, v) in [
            ("keypoint_sigma_px", self.keypoint_sigma_px),
            ("cue_sigma", self.cue_sigma),
            ("drift_per_frame", self.drift_per_frame),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CoreError::InvalidOptions(format!(
                    "{name} must be finite and > 0"
                )));
            }
        }
        Ok(())
    }

    /// Whether the mechanism is on.
    pub fn enabled(&self) -> bool {
        self.weight > 0.0
    }
}

/// Default of [`TrackingSettings::tracking_reset_mrad`]: 5 pixels, as before the
/// fit measured angles, at the dev camera's focal length (923.7 px).
const RESET_MRAD: f64 = 5.4;

/// A weight must be finite and not negative.
fn check_weight(name: &str, w: f64) -> CoreResult<()> {
    if !(w.is_finite() && w >= 0.0) {
        return Err(CoreError::InvalidOptions(format!(
            "{name} must be finite and >= 0"
        )));
    }
    Ok(())
}

/// Angular error (RMS, degrees) of the landmark network's bone directions against
/// the 3D labels of the development set (hand_graph_cnn_dev, 288 detected frames,
/// `[cue][segment]` as [`CostSettings::cue_segment_weights`]): world landmarks, then
/// relative depth, pooled over the five fingers and all confidences
/// (`bench/cue_reliability/cue_reliability.py` prints them). The default weights
/// are the smallest of them over each (inverse-variance weighting: one residual's
/// standard deviation is the bone's length times its angular error). Confidence
/// predicts the error only on the fingers' outer bones, which the confidence
/// factor of each bone's weight already covers (docs/accuracy.md).
pub const CUE_BONE_ERROR_DEG: [[f64; 4]; 2] = [[13.0, 17.1, 20.3, 25.5], [12.4, 26.9, 28.3, 27.2]];

/// Inverse-error weights from [`CUE_BONE_ERROR_DEG`], relative to the most
/// reliable entry.
fn cue_segment_weights_from(errors: &[[f64; 4]; 2]) -> [[f64; 4]; 2] {
    let best = errors
        .iter()
        .flatten()
        .copied()
        .fold(f64::INFINITY, f64::min);
    errors.map(|cue| cue.map(|e| best / e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_checks_every_group() {
        assert!(FitOptions::default().validate().is_ok());
        type Spoil = fn(&mut FitOptions);
        let bad: [(&str, Spoil); 7] = [
            ("iteration caps", |o| o.solver.max_iterations_tracking = 0),
            ("damping", |o| o.solver.initial_damping = 0.0),
            ("min_joints", |o| o.cost.min_joints = 2),
            ("cue_segment_weights", |o| {
                o.cost.cue_segment_weights[1][3] = -1.0
            }),
            ("temporal_weight", |o| o.tracking.temporal_weight = f64::NAN),
            ("fuse_world", |o| o.fusion.fuse_depth = 0.6),
            ("fuse_pixels", |o| o.fusion.fuse_pixels = 1.5),
        ];
        for (message, spoil) in bad {
            let mut o = FitOptions::default();
            spoil(&mut o);
            let e = o.validate().unwrap_err();
            assert!(
                matches!(e, CoreError::InvalidOptions(_)) && e.to_string().contains(message),
                "{message}: {e}"
            );
        }
    }
}
