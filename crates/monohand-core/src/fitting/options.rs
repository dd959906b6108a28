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

/// Settings of the fitter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Joints with a confidence below this are dropped (paper: 0.1).
    pub min_confidence: f64,
    /// Residuals are weighted by `confidence ^ confidence_power` (paper: 3).
    pub confidence_power: f64,
    /// Fewest usable joints (over all views) for a fit to be attempted.
    pub min_joints: usize,
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
    /// In tracking, refit from scratch when the warm-started fit's mean
    /// reprojection error exceeds this (pixels).
    pub tracking_reset_px: f64,
    /// Weight of the network's metric 3D ([`NetworkCues::world_mm`]): each
    /// bone adds `w p^k L (d_model - d_world)` (mm, `L` the bone's length, `d`
    /// unit directions, `p^k` the smaller confidence weight of its two joints)
    /// beside the pixel residuals. 0 turns the cue off. Chosen on the
    /// development set, see `docs/accuracy.md`.
    pub world_weight: f64,
    /// Weight of the network's relative depth ([`NetworkCues::depth_px`]),
    /// the same bone-direction residual with the direction taken from
    /// `(du, dv, dz)` in pixels. 0 turns the cue off.
    pub depth_weight: f64,
    /// Weight of the pull towards the previous frame in tracking: every joint
    /// adds `w (X - X_previous)` (mm). 0 turns it off.
    pub temporal_weight: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            min_confidence: 0.1,
            confidence_power: 3.0,
            min_joints: 4,
            max_iterations: 100,
            max_iterations_tracking: 30,
            cost_tolerance: 1e-9,
            step_tolerance: 1e-7,
            initial_damping: 1e-3,
            tracking_reset_px: 5.0,
            // Chosen on the development set (hand_graph_cnn_dev, 292 frames, tracked):
            // docs/accuracy.md has the table that chose them.
            world_weight: 1.0,
            depth_weight: 0.3,
            temporal_weight: 0.1,
        }
    }
}

impl FitOptions {
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
        if self.max_iterations == 0 || self.max_iterations_tracking == 0 {
            return bad("iteration caps must be positive");
        }
        if !(self.cost_tolerance >= 0.0 && self.step_tolerance >= 0.0 && self.initial_damping > 0.0)
        {
            return bad("tolerances must be >= 0 and damping > 0");
        }
        for (name, w) in [
            ("world_weight", self.world_weight),
            ("depth_weight", self.depth_weight),
            ("temporal_weight", self.temporal_weight),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return Err(CoreError::InvalidOptions(format!(
                    "{name} must be finite and >= 0"
                )));
            }
        }
        Ok(())
    }
}
