//! The user's hand size from the first frames of a sequence (the paper's stated future work).
//!
//! One global factor `s` multiplies every bone of a template skeleton. For each candidate
//! `s` the frames are tracked with [`HandTracker`] and the final costs summed; the `s` with
//! the lowest total wins (a coarse grid over the range, then golden-section refinement).
//!
//! **Observability.** With one camera the size is not observable at all: a hand `s` times
//! larger and `s` times further away projects to exactly the same pixels, so every `s`
//! fits equally well. [`ScaleEstimate::observable`] is `false` then and the template scale
//! should be kept. With two or more calibrated views the baseline fixes the depth and the
//! size follows (see `docs/accuracy.md` for the measurement on STB).

use super::options::{FitOptions, TrackingSettings, View};
use super::tracker::HandTracker;
use crate::error::{CoreError, CoreResult};
use crate::hand_model::HandSkeleton;

/// Result of [`estimate_hand_scale`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleEstimate {
    /// The best factor for the template skeleton.
    pub scale: f64,
    /// Total cost over the frames at `scale`.
    pub cost: f64,
    /// Frames that could be fitted.
    pub frames_used: usize,
    /// `(worst − best) / worst` total cost over the grid: near 0 means the frames do not
    /// tell the size.
    pub cost_contrast: f64,
    /// Whether the frames determine the size (`cost_contrast` above
    /// [`MIN_COST_CONTRAST`]).
    pub observable: bool,
}

/// Below this relative cost contrast over the search range the size counts as unobservable.
/// Measured on STB (30 frames): stereo 0.94-0.96; mono 0.003 without noise and 0.02 with
/// 2 px noise (different local minima, not information about the size).
pub const MIN_COST_CONTRAST: f64 = 0.2;

/// Estimates one global scale of `template` from `frames` (each frame: the views of the
/// same hand), searching `[min_scale, max_scale]`.
///
/// ```
/// use monohand_core::fitting::{estimate_hand_scale, FitOptions, View};
/// use monohand_core::prelude::*;
/// use nalgebra::{UnitQuaternion, Vector3};
///
/// // A hand 10 % larger than the template, seen by a stereo pair 120 mm apart.
/// let template = HandSkeleton::default_for(HandSide::Right);
/// let truth = template.scaled(1.1)?;
/// let left = Camera::pinhole(600.0, 600.0, 320.0, 240.0, 640, 480)?;
/// let mut right = left;
/// right.extrinsics.translation = Vector3::new(-120.0, 0.0, 0.0);
/// let mut frames = Vec::new();
/// for k in 0..3 {
///     let mut pose = HandPose::default();
///     pose.translation = Vector3::new(10.0 * k as f64, 0.0, 450.0);
///     pose.rotation = UnitQuaternion::from_euler_angles(2.6, 0.2 * k as f64, 0.3);
///     let joints = forward_kinematics(&truth, &pose);
///     let kp = |c: &Camera| {
///         let mut kp = Keypoints2d::default();
///         for (p, x) in kp.points.iter_mut().zip(&joints) {
///             let px = c.project(x).expect("in front");
///             *p = [px.x, px.y, 1.0];
///         }
///         kp
///     };
///     frames.push([kp(&left), kp(&right)]);
/// }
/// let views: Vec<Vec<View>> = frames
///     .iter()
///     .map(|[a, b]| vec![View::new(&left, a), View::new(&right, b)])
///     .collect();
/// let est = estimate_hand_scale(&template, &FitOptions::default(), &views, 0.7, 1.4)?;
/// assert!(est.observable);
/// assert!((est.scale - 1.1).abs() < 0.01, "{est:?}");
/// # Ok::<(), monohand_core::CoreError>(())
/// ```
pub fn estimate_hand_scale(
    template: &HandSkeleton,
    options: &FitOptions,
    frames: &[Vec<View<'_>>],
    min_scale: f64,
    max_scale: f64,
) -> CoreResult<ScaleEstimate> {
    if !(min_scale.is_finite() && max_scale.is_finite() && 0.0 < min_scale && min_scale < max_scale)
    {
        return Err(CoreError::InvalidOptions(format!(
            "hand scale range [{min_scale}, {max_scale}] must be positive and increasing"
        )));
    }
    let total = |s: f64| -> CoreResult<(f64, usize)> {
        // The temporal pull would make each scale's fits differ by how they track, not by
        // how well they explain the views: the comparison uses the views' cost alone.
        let options = FitOptions {
            tracking: TrackingSettings {
                temporal_weight: 0.0,
                ..options.tracking
            },
            ..*options
        };
        let mut tracker = HandTracker::new(template.scaled(s)?, options)?;
        let (mut cost, mut used) = (0.0, 0);
        for views in frames {
            // Frames with too few joints carry no information about the size.
            if let Ok(fit) = tracker.update(views) {
                cost += fit.cost;
                used += 1;
            }
        }
        Ok((cost, used))
    };
    // Coarse grid in log scale, then golden-section search around the best grid point.
    const GRID: usize = 9;
    let (lo, hi) = (min_scale.ln(), max_scale.ln());
    let at = |k: usize| lo + (hi - lo) * k as f64 / (GRID - 1) as f64;
    let mut grid = Vec::with_capacity(GRID);
    for k in 0..GRID {
        grid.push(total(at(k).exp())?);
    }
    let used = grid.iter().map(|g| g.1).max().unwrap_or(0);
    if used == 0 {
        return Err(CoreError::InvalidKeypoints(
            "no frame has enough joints to estimate the hand size".into(),
        ));
    }
    let best_k = (0..GRID)
        .min_by(|&a, &b| grid[a].0.total_cmp(&grid[b].0))
        .unwrap_or(0);
    let worst = grid.iter().map(|g| g.0).fold(f64::NEG_INFINITY, f64::max);
    let cost_contrast = if worst > 0.0 {
        (worst - grid[best_k].0) / worst
    } else {
        0.0
    };
    let (mut a, mut b) = (at(best_k.saturating_sub(1)), at((best_k + 1).min(GRID - 1)));
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = b - phi * (b - a);
    let mut x2 = a + phi * (b - a);
    let mut f1 = total(x1.exp())?.0;
    let mut f2 = total(x2.exp())?.0;
    for _ in 0..20 {
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - phi * (b - a);
            f1 = total(x1.exp())?.0;
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + phi * (b - a);
            f2 = total(x2.exp())?.0;
        }
    }
    let (mut scale, mut cost) = if f1 <= f2 {
        (x1.exp(), f1)
    } else {
        (x2.exp(), f2)
    };
    if grid[best_k].0 < cost {
        scale = at(best_k).exp();
        cost = grid[best_k].0;
    }
    Ok(ScaleEstimate {
        scale,
        cost,
        frames_used: used,
        cost_contrast,
        observable: cost_contrast > MIN_COST_CONTRAST,
    })
}
