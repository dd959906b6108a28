use super::lm::{FitResult, HandFitter};
use super::options::{FitOptions, View};
use crate::error::CoreResult;
use crate::hand_model::{HandPose, HandSkeleton, NUM_JOINTS};
use nalgebra::Vector3;

/// The views' mean focal length, pixels (the mean of `fx` and `fy` over the views).
fn mean_focal_px(views: &[View]) -> f64 {
    let sum: f64 = views
        .iter()
        .map(|v| 0.5 * (v.camera.intrinsics.fx + v.camera.intrinsics.fy))
        .sum();
    sum / views.len().max(1) as f64
}

/// Fits a hand frame after frame, starting each fit from the previous solution.
///
/// If the warm-started fit is poor (not converged, or mean reprojection error
/// above [`TrackingSettings::tracking_reset_mrad`]) a fit from scratch is also run and
/// the one with the lower cost kept, so large jumps between frames recover. Frames with too few joints return the error and keep the
/// last pose for the next frame.
///
/// The temporal term ([`TrackingSettings::temporal_weight`]) pulls each joint towards
/// where constant velocity puts it (`2 x(t-1) - x(t-2)`; from the third frame
/// of a track on), so a hand moving steadily is not held back.
///
/// [`TrackingSettings::tracking_reset_mrad`]: crate::fitting::TrackingSettings::tracking_reset_mrad
/// [`TrackingSettings::temporal_weight`]: crate::fitting::TrackingSettings::temporal_weight
#[derive(Debug, Clone)]
pub struct HandTracker {
    fitter: HandFitter,
    last: Option<HandPose>,
    /// Joints of the last two fits, oldest first.
    history: [Option<[Vector3<f64>; NUM_JOINTS]>; 2],
}

impl HandTracker {
    /// A tracker for one hand.
    pub fn new(skeleton: HandSkeleton, options: FitOptions) -> CoreResult<HandTracker> {
        Ok(HandTracker {
            fitter: HandFitter::new(skeleton, options)?,
            last: None,
            history: [None, None],
        })
    }

    /// Fits the next frame.
    pub fn update(&mut self, views: &[View]) -> CoreResult<FitResult> {
        let result = match self.last {
            Some(prev) => {
                // No velocity yet after one frame: no temporal pull then.
                let predicted = match self.history {
                    [Some(a), Some(b)] => Some(std::array::from_fn(|j| 2.0 * b[j] - a[j])),
                    _ => None,
                };
                let warm = self.fitter.fit_from_towards(views, &prev, predicted)?;
                let reset_px = self.fitter.options().tracking.tracking_reset_mrad
                    * mean_focal_px(views)
                    / 1000.0;
                if !warm.converged || warm.reprojection_error_px > reset_px {
                    let cold = self.fitter.fit(views)?;
                    if cold.cost < warm.cost {
                        cold
                    } else {
                        warm
                    }
                } else {
                    warm
                }
            }
            None => self.fitter.fit(views)?,
        };
        self.last = Some(result.pose);
        self.history = [self.history[1], Some(result.model_joints_3d)];
        Ok(result)
    }

    /// Forgets the previous pose (e.g. after a cut in the video).
    pub fn reset(&mut self) {
        self.last = None;
        self.history = [None, None];
    }

    /// The last fitted pose, if any.
    pub fn last_pose(&self) -> Option<&HandPose> {
        self.last.as_ref()
    }

    /// The fitter.
    pub fn fitter(&self) -> &HandFitter {
        &self.fitter
    }

    /// The underlying fitter.
    pub fn fitter_mut(&mut self) -> &mut HandFitter {
        &mut self.fitter
    }
}
