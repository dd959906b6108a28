use super::lm::{FitResult, HandFitter};
use super::options::{FitOptions, View};
use crate::error::CoreResult;
use crate::hand_model::{HandPose, HandSkeleton};

/// Fits a hand frame after frame, starting each fit from the previous solution.
///
/// If the warm-started fit is poor (not converged, or mean reprojection error
/// above [`FitOptions::tracking_reset_px`]) a fit from scratch is also run and
/// the one with the lower cost kept, so large jumps between frames recover. Frames with too few joints return the error and keep the
/// last pose for the next frame.
#[derive(Debug, Clone)]
pub struct HandTracker {
    fitter: HandFitter,
    last: Option<HandPose>,
}

impl HandTracker {
    /// A tracker for one hand.
    pub fn new(skeleton: HandSkeleton, options: FitOptions) -> CoreResult<HandTracker> {
        Ok(HandTracker {
            fitter: HandFitter::new(skeleton, options)?,
            last: None,
        })
    }

    /// Fits the next frame.
    pub fn update(&mut self, views: &[View]) -> CoreResult<FitResult> {
        let result = match self.last {
            Some(prev) => {
                let warm = self.fitter.fit_from(views, &prev)?;
                if !warm.converged
                    || warm.reprojection_error_px > self.fitter.options().tracking_reset_px
                {
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
        Ok(result)
    }

    /// Forgets the previous pose (e.g. after a cut in the video).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The last fitted pose, if any.
    pub fn last_pose(&self) -> Option<&HandPose> {
        self.last.as_ref()
    }

    /// The underlying fitter.
    pub fn fitter_mut(&mut self) -> &mut HandFitter {
        &mut self.fitter
    }
}
