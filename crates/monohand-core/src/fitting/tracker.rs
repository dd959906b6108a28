use super::distance::{DistanceEvidence, DistanceFilter};
use super::lm::{FitResult, HandFitter};
use super::options::{FitOptions, FusionSettings, View};
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
    /// With one view and [`FitOptions::distance`] on: the fit of the keypoints alone and
    /// the distance over the frames.
    distance: Option<DistanceTrack>,
}

/// The second fit of each frame and the filter of the distance ([`DistanceSettings`](crate::fitting::DistanceSettings)).
#[derive(Debug, Clone)]
struct DistanceTrack {
    /// The keypoints' fit: the paper's cost, with the articulation cues in the hand's frame.
    keypoints: HandFitter,
    last: Option<HandPose>,
    filter: DistanceFilter,
    evidence: Option<DistanceEvidence>,
}

impl DistanceTrack {
    fn new(skeleton: HandSkeleton, options: FitOptions) -> CoreResult<DistanceTrack> {
        let mut keypoints = options;
        keypoints.cost.world_weight = 0.0;
        keypoints.cost.depth_weight = 0.0;
        keypoints.fusion = FusionSettings {
            fuse_world: 0.0,
            fuse_depth: 0.0,
            fuse_pixels: 0.0,
        };
        Ok(DistanceTrack {
            keypoints: HandFitter::new(skeleton, keypoints)?,
            last: None,
            filter: DistanceFilter::new(options.distance),
            evidence: None,
        })
    }

    fn reset(&mut self) {
        self.last = None;
        self.filter.reset();
        self.evidence = None;
    }

    /// The frame's final fit: `cue` (the fit with the cues, by `main`) fitted again with
    /// its palm's distance held at the filter's, which has taken this frame's keypoints'
    /// distance and the cues'. `cue` itself on a track's first frame, and where the
    /// keypoints' fit or the refit fails.
    fn refine(
        &mut self,
        main: &mut HandFitter,
        views: &[View],
        cue: FitResult,
        predicted: Option<[Vector3<f64>; NUM_JOINTS]>,
    ) -> FitResult {
        let settings = main.options().distance;
        let cues_mm = main.palm_depth(&cue.pose);
        let start = self.last.unwrap_or(cue.pose);
        let keypoints = step(&mut self.keypoints, Some(start), None, views).ok();
        self.last = keypoints.map(|k| k.pose);
        let sigma_px = keypoints.map_or(settings.keypoint_sigma_px, |k| {
            k.reprojection_error_px.max(settings.keypoint_sigma_px)
        });
        let measured = keypoints.and_then(|k| {
            let d = self.keypoints.palm_depth(&k.pose)?;
            Some((d, self.keypoints.palm_depth_sigma(&k.pose, sigma_px)?))
        });
        let first = !self.filter.has_seen();
        let evidence = self.filter.update(measured, cues_mm);
        self.evidence = Some(evidence);
        if first {
            // The distance gathers frames: the first of a track (and every image fitted
            // on its own) keeps the cues' fit, and the filter starts from both.
            return cue;
        }
        let focal = views[0].camera.intrinsics.fx;
        let weight = settings.weight * sigma_px * 1000.0 / focal / evidence.fused_sigma_mm;
        main.fit_from_at_distance(
            views,
            &cue.pose,
            predicted,
            Some((evidence.fused_mm, weight)),
        )
        .ok()
        .filter(|f| f.pose.is_finite())
        .unwrap_or(cue)
    }
}

/// One tracked fit with `fitter`: warm-started from `last` and pulled towards `predicted`,
/// refitted from scratch when that is poor (the lower cost kept); from scratch without
/// `last`.
fn step(
    fitter: &mut HandFitter,
    last: Option<HandPose>,
    predicted: Option<[Vector3<f64>; NUM_JOINTS]>,
    views: &[View],
) -> CoreResult<FitResult> {
    let Some(prev) = last else {
        return fitter.fit(views);
    };
    let warm = fitter.fit_from_towards(views, &prev, predicted)?;
    let reset_px = fitter.options().tracking.tracking_reset_mrad * mean_focal_px(views) / 1000.0;
    if !warm.converged || warm.reprojection_error_px > reset_px {
        let cold = fitter.fit(views)?;
        if cold.cost < warm.cost {
            return Ok(cold);
        }
    }
    Ok(warm)
}

impl HandTracker {
    /// A tracker for one hand.
    pub fn new(skeleton: HandSkeleton, options: FitOptions) -> CoreResult<HandTracker> {
        let distance = options
            .distance
            .enabled()
            .then(|| DistanceTrack::new(skeleton, options))
            .transpose()?;
        Ok(HandTracker {
            fitter: HandFitter::new(skeleton, options)?,
            last: None,
            history: [None, None],
            distance,
        })
    }

    /// Fits the next frame.
    ///
    /// With one view that carries the network's cues and [`FitOptions::distance`] on, the
    /// frame is fitted with the cues, then with the keypoints alone, and once more with
    /// the cues and the palm's distance held at the filtered one ([`DistanceSettings`](crate::fitting::DistanceSettings)),
    /// from a track's second frame on (the first, and a frame fitted on its own after
    /// [`HandTracker::reset`], is the cues' fit); [`HandTracker::distance_evidence`] says
    /// what each gave.
    pub fn update(&mut self, views: &[View]) -> CoreResult<FitResult> {
        // No velocity yet after one frame: no temporal pull then.
        let predicted = match (self.last, self.history) {
            (Some(_), [Some(a), Some(b)]) => Some(std::array::from_fn(|j| 2.0 * b[j] - a[j])),
            _ => None,
        };
        let fit = step(&mut self.fitter, self.last, predicted, views);
        let fit = match (fit, self.distance.as_mut(), views) {
            (Ok(cue), Some(track), [view]) if view.cues.is_some() => {
                Ok(track.refine(&mut self.fitter, views, cue, predicted))
            }
            (fit, track, _) => {
                if let Some(track) = track {
                    track.evidence = None;
                }
                fit
            }
        };
        let result = fit?;
        self.last = Some(result.pose);
        self.history = [self.history[1], Some(result.model_joints_3d)];
        Ok(result)
    }

    /// What the last frame's fits said of the hand's distance (one view with cues and
    /// [`FitOptions::distance`] on; `None` otherwise).
    pub fn distance_evidence(&self) -> Option<&DistanceEvidence> {
        self.distance.as_ref()?.evidence.as_ref()
    }

    /// Forgets the previous pose (e.g. after a cut in the video).
    pub fn reset(&mut self) {
        self.last = None;
        self.history = [None, None];
        if let Some(track) = self.distance.as_mut() {
            track.reset();
        }
    }

    /// The last fitted pose, if any.
    pub fn last_pose(&self) -> Option<&HandPose> {
        self.last.as_ref()
    }

    /// The fitter.
    pub fn fitter(&self) -> &HandFitter {
        &self.fitter
    }

    /// Replaces the skeleton of every fit the tracker makes (e.g. after measuring the
    /// hand's size).
    pub fn set_skeleton(&mut self, skeleton: HandSkeleton) -> CoreResult<()> {
        self.fitter.set_skeleton(skeleton)?;
        if let Some(track) = self.distance.as_mut() {
            track.keypoints.set_skeleton(skeleton)?;
        }
        Ok(())
    }

    /// The underlying fitter (its skeleton is changed with [`HandTracker::set_skeleton`]).
    pub fn fitter_mut(&mut self) -> &mut HandFitter {
        &mut self.fitter
    }
}
