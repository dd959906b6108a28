//! One hand's fit over its views, shared by the video session and the 2D-only lifter.

use monohand_core::prelude::*;

/// How one fit ended.
#[derive(Debug)]
pub enum FitOutcome {
    /// A usable fit (every number finite).
    Fitted(Box<FitResult>),
    /// The solver returned non-finite numbers; the tracker was reset.
    Diverged,
    /// The fit was refused (too few usable joints, ...).
    Failed(CoreError),
}

/// Whether a fit is usable (no NaN or infinity anywhere).
pub fn is_finite(fit: &FitResult) -> bool {
    fit.pose.is_finite()
        && fit.reprojection_error_px.is_finite()
        && fit
            .joints_3d
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()))
}

/// Fits `views` with `tracker` (warm-started from its last pose); a diverged fit resets it.
pub fn fit_views(tracker: &mut HandTracker, views: &[View]) -> FitOutcome {
    match tracker.update(views) {
        Ok(fit) if is_finite(&fit) => FitOutcome::Fitted(Box::new(fit)),
        Ok(_) => {
            tracker.reset();
            FitOutcome::Diverged
        }
        Err(e) => FitOutcome::Failed(e),
    }
}
