//! One hand's fit over its views, shared by the video session and the 2D-only lifter.

use crate::notes::{Note, NoteTopic};
use monohand_core::fitting::{estimate_proportions, ProportionEstimate};
use monohand_core::observation::NetworkCues;
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

/// Each side's proportions, the size kept, from the network's metric 3D `cues` of that
/// side ([`estimate_proportions`]): the skeleton to fit with, and what to tell the user.
/// The one policy of the engine, the session and the lifting job.
pub fn learn_proportions(
    template: &HandSkeleton,
    side: HandSide,
    cues: &[NetworkCues],
) -> (Option<ProportionEstimate>, Note) {
    match estimate_proportions(template, cues) {
        Ok(est) => {
            let note = Note::new(
                NoteTopic::Proportions,
                format!("{side} hand proportions {est}"),
            );
            (Some(est), note)
        }
        Err(e) => (
            None,
            Note::new(
                NoteTopic::Proportions,
                format!("{side} hand proportions not learnt ({e}); keeping the model's"),
            ),
        ),
    }
}
