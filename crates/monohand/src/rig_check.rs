//! A calibrated rig that checks itself: how well each view agreed with each fitted hand
//! (in every multi-view record), and over a run, which view's error stays far above the
//! others' (in the run's summary). A camera bumped after its calibration, or a video a few
//! frames out of sync, would otherwise only make the 3D silently worse.
//!
//! The error of a view is the mean distance in pixels between its keypoints (those the fit
//! uses: confidence at least the fit's minimum) and the recorded 3D joints projected
//! through its camera. The fit spreads a faulty view's disagreement over every view, so a
//! single frame says little; over a run, the faulty view's median stays high while the
//! others' stay low ([`RigCheck::verdict`]).

use crate::frame::{FittedFrame, TrackedHand};
use crate::shape::detected;
use monohand_core::camera::Camera;
use monohand_core::prelude::*;
use monohand_io::jsonl::{FrameRecord, ViewFitRecord};
use nalgebra::{Point2, Vector2, Vector3};

/// A view is named when, in the typical hand-frame, its offset is more than this many
/// times the median of the other views' offsets (the run's median of that per-frame
/// ratio) ...
///
/// Chosen on the table rig (`../shared/data/table_rig_dev`, its 4 views, 148 frames,
/// tracked, the views matched through the cameras with crops from the fitted hand;
/// docs/calibration.md, "A rig that checks itself"): unchanged, each view's ratio is at
/// most 1.10; with one camera's file turned by 2 degrees the turned view's is 2.74, 2.76,
/// 1.43 and 2.00 (each of the 4 cameras in turn), with one video 3 frames ahead 1.97,
/// 1.19, 1.16 and 1.60. 1.5 names 5 of the 8 faults and nothing on the unchanged rig; the
/// fit spreads the other three faults over every view.
pub const SUSPECT_RATIO: f64 = 1.5;

/// ... and its median offset is above this many pixels: a view twice as far off as very
/// good views can still be a good view. On the table rig (640x480) the unchanged views'
/// median offsets are 3.1-4.9 px, the faulty views' that are named 6.3-18.4 px.
pub const SUSPECT_FLOOR_PX: f64 = 5.0;

/// A view is judged only with this many hand-frames seen by it and two other views: a few
/// frames could be a passing mistake of the networks.
pub const MIN_SAMPLES: usize = 10;

/// How each view of `frame` agreed with `hand`'s fit, one entry per camera; `None` with
/// one camera, or when the hand has no 3D.
pub fn view_fits(frame: &FittedFrame, hand: &TrackedHand) -> Option<Vec<ViewFitRecord>> {
    let fit = hand.fit.as_ref()?;
    if frame.cameras.len() < 2 {
        return None;
    }
    let fits = frame
        .cameras
        .iter()
        .enumerate()
        .map(|(v, camera)| {
            let keypoints = hand
                .views
                .iter()
                .find(|&&(w, _)| w == v)
                .and_then(|&(_, k)| detected(&frame.vision, v, k))
                .map(|d| &d.keypoints);
            let agreement = keypoints
                .and_then(|kp| agreement(camera, &fit.joints_3d, &kp.points, frame.min_confidence));
            ViewFitRecord {
                used: agreement.is_some(),
                reprojection_error_px: agreement.map(|a| a.0),
                offset_px: agreement.map(|a| a.1),
            }
        })
        .collect();
    Some(fits)
}

/// Over the keypoints of at least `min_confidence` whose joint is in front of `camera`:
/// the mean distance to `joints` projected through it, and the mean `projected -
/// observed` vector, pixels (`None`: no such keypoint).
fn agreement(
    camera: &Camera,
    joints: &[Vector3<f64>; NUM_JOINTS],
    keypoints: &[[f64; 3]; NUM_JOINTS],
    min_confidence: f64,
) -> Option<(f64, [f64; 2])> {
    let mut distance = 0.0;
    let mut offset = Vector2::zeros();
    let mut n = 0usize;
    for (x, &[u, v, c]) in joints.iter().zip(keypoints) {
        if c < min_confidence || c <= 0.0 {
            continue;
        }
        if let Some(px) = camera.project(x) {
            let d = px - Point2::new(u, v);
            distance += d.norm();
            offset += d;
            n += 1;
        }
    }
    let n = n as f64;
    let found = n > 0.0 && distance.is_finite() && offset.iter().all(|x| x.is_finite());
    found.then(|| (distance / n, [offset.x / n, offset.y / n]))
}

/// Each view's errors over a run, gathered from the records as they are written.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RigCheck {
    /// Per view, the reprojection error of every hand-frame it took part in, pixels.
    errors: Vec<Vec<f32>>,
    /// Per view, the length of its offset in the same hand-frames, pixels.
    offsets: Vec<Vec<f32>>,
    /// Per view, its offset over the median of the other views' in the hand-frames that
    /// it and at least two other views took part in.
    ratios: Vec<Vec<f32>>,
}

/// One view over a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSummary {
    /// Hand-frames the view took part in.
    pub samples: usize,
    /// The median of its reprojection errors, pixels (`None` without samples).
    pub median_error_px: Option<f64>,
    /// The median length of its offsets, pixels (`None` without samples).
    pub median_offset_px: Option<f64>,
    /// The median of its offset over the other views' (`None` without a hand-frame seen by
    /// it and two other views).
    pub ratio: Option<f64>,
    /// Whether its offset stays far above the others' ([`SUSPECT_RATIO`],
    /// [`SUSPECT_FLOOR_PX`], [`MIN_SAMPLES`]): its calibration no longer holds, or its
    /// video is out of sync.
    pub suspect: bool,
}

/// What the check found over a run: one summary per view, in the cameras' order.
#[derive(Debug, Clone, PartialEq)]
pub struct RigVerdict {
    /// Per view.
    pub views: Vec<ViewSummary>,
}

impl RigVerdict {
    /// The views named (from 0).
    pub fn suspects(&self) -> Vec<usize> {
        (0..self.views.len())
            .filter(|&v| self.views[v].suspect)
            .collect()
    }
}

impl RigCheck {
    /// Counts the views' agreement of one written frame.
    pub fn add(&mut self, record: &FrameRecord) {
        for views in record.hands.iter().filter_map(|h| h.views.as_ref()) {
            let n = views.len().max(self.errors.len());
            for list in [&mut self.errors, &mut self.offsets, &mut self.ratios] {
                list.resize(n, Vec::new());
            }
            let offsets: Vec<Option<f64>> = views
                .iter()
                .map(|v| v.offset_px.map(|[du, dv]| du.hypot(dv)))
                .collect();
            for (v, view) in views.iter().enumerate() {
                let (Some(e), Some(o)) = (view.reprojection_error_px, offsets[v]) else {
                    continue;
                };
                self.errors[v].push(e as f32);
                self.offsets[v].push(o as f32);
                let others: Vec<f32> = (0..views.len())
                    .filter(|&w| w != v)
                    .filter_map(|w| offsets[w].map(|o| o as f32))
                    .collect();
                if others.len() >= 2 {
                    // A floor of 1 px: views that all agree to a pixel are not compared.
                    let typical = median(&others).unwrap_or(0.0).max(1.0);
                    self.ratios[v].push((o / typical) as f32);
                }
            }
        }
    }

    /// Each view's medians and the views named; `None` when no hand was fitted from
    /// several views.
    pub fn verdict(&self) -> Option<RigVerdict> {
        if self.errors.len() < 2 {
            return None;
        }
        let views = (0..self.errors.len())
            .map(|v| {
                let median_offset_px = median(&self.offsets[v]);
                let ratio = median(&self.ratios[v]);
                let suspect = self.ratios[v].len() >= MIN_SAMPLES
                    && ratio.is_some_and(|r| r > SUSPECT_RATIO)
                    && median_offset_px.is_some_and(|o| o > SUSPECT_FLOOR_PX);
                ViewSummary {
                    samples: self.errors[v].len(),
                    median_error_px: median(&self.errors[v]),
                    median_offset_px,
                    ratio,
                    suspect,
                }
            })
            .collect();
        Some(RigVerdict { views })
    }
}

impl std::fmt::Display for RigVerdict {
    /// `views' median reprojection error: 1: 7.3 px (offset 4.3 px, 0.99x the others'),
    /// ...`, then the views named and why (views from 1).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let each: Vec<String> = self
            .views
            .iter()
            .enumerate()
            .map(|(v, s)| {
                let px = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.1} px"));
                let ratio = s
                    .ratio
                    .map_or(String::new(), |r| format!(", {r:.2}x the others'"));
                let (e, o) = (px(s.median_error_px), px(s.median_offset_px));
                format!("{}: {e} (offset {o}{ratio})", v + 1)
            })
            .collect();
        write!(f, "views' median reprojection error {}", each.join(", "))?;
        for v in self.suspects() {
            write!(
                f,
                "; view {} stays far off the fitted hand, where the others agree: its \
                 calibration no longer holds (the camera moved) or its video is out of sync",
                v + 1
            )?;
        }
        Ok(())
    }
}

/// The median of `values` (`None` when empty).
fn median(values: &[f32]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f32::total_cmp);
    let n = v.len();
    let m = if n % 2 == 1 {
        f64::from(v[n / 2])
    } else {
        (f64::from(v[n / 2 - 1]) + f64::from(v[n / 2])) / 2.0
    };
    Some(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use monohand_io::jsonl::HandRecord;

    /// A frame whose one hand has these offsets (along u) per view (`None`: not seen).
    fn record(offsets: &[Option<f64>]) -> FrameRecord {
        let mut hand = HandRecord::from_keypoints(HandSide::Right, &Default::default());
        hand.views = Some(
            offsets
                .iter()
                .map(|&o| ViewFitRecord {
                    used: o.is_some(),
                    reprojection_error_px: o.map(|o| o + 3.0),
                    offset_px: o.map(|o| [o, 0.0]),
                })
                .collect(),
        );
        FrameRecord {
            hands: vec![hand],
            ..FrameRecord::default()
        }
    }

    fn check(frames: usize, offsets: &[Option<f64>]) -> RigVerdict {
        let mut c = RigCheck::default();
        for _ in 0..frames {
            c.add(&record(offsets));
        }
        c.verdict().unwrap()
    }

    #[test]
    fn a_view_far_above_the_others_is_named() {
        let v = check(20, &[Some(3.0), Some(2.5), Some(12.0), Some(4.0)]);
        assert_eq!(v.suspects(), vec![2]);
        assert_eq!(v.views[2].ratio, Some(4.0));
        assert_eq!(v.views[2].median_error_px, Some(15.0));
        let text = v.to_string();
        assert!(text.contains("3: 15.0 px (offset 12.0 px, 4.00x"), "{text}");
        assert!(text.contains("view 3 stays far off"), "{text}");
    }

    #[test]
    fn below_the_floor_or_the_ratio_nothing_is_named() {
        // 4.5 px is 3x the others but a good view still.
        let v = check(20, &[Some(1.5), Some(1.5), Some(4.5), Some(1.5)]);
        assert!(v.suspects().is_empty());
        let v = check(20, &[Some(6.0), Some(7.0), Some(9.0), Some(6.5)]);
        assert!(v.suspects().is_empty());
    }

    #[test]
    fn too_few_frames_or_views_name_nothing() {
        let few = check(MIN_SAMPLES - 1, &[Some(2.0), Some(2.0), Some(20.0)]);
        assert!(few.suspects().is_empty());
        // Two views: which of them is wrong cannot be told.
        let two = check(20, &[Some(2.0), Some(20.0)]);
        assert!(two.suspects().is_empty() && two.views[1].ratio.is_none());
        // A view that never sees the hand is not judged, nor counted among the others.
        let v = check(20, &[Some(2.0), None, Some(20.0)]);
        assert!(v.suspects().is_empty() && v.views[1].median_error_px.is_none());
        assert!(RigCheck::default().verdict().is_none());
    }
}
