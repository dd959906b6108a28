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

use crate::base::frame::{detected, FittedFrame, TrackedHand};
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

/// ... and only when its offsets are what a fault makes of them. Over the run, each view's
/// offsets are fitted as `o = c + s m` (`m`: the hand's motion in the view since the frame
/// before, pixels): a moved or turned camera shifts every joint alike whatever the hand
/// does (a steady `|c|`), a video out of sync is off by its lag times the motion (`s`
/// frames; compared with the other views' median lag, as the fit shares a late view's
/// motion with every view). The network's own error at a view's angle follows the hand's
/// pose: neither. A view is named when its steady part is at least this many pixels ...
///
/// Chosen on the table rig (docs/calibration.md, "A rig that checks itself"). With the
/// rig's reference 3D as the fit (the case of a view held closer to the truth by more
/// views), the unchanged views' steady parts are 0.2, 6.5, 3.2 and 2.9 px (view 2, seen
/// from the side, has an offset of 8.8 px, 2.75x the others': the 8-view false alarm);
/// in the rig's own fit a file turned by 2 degrees leaves 16.8, 8.4, 11.0 and 14.0 px
/// (views 1-4), and 17.2 px for view 2 held to the reference.
pub const MOVED_PX: f64 = 7.5;

/// ... or its lag against the other views' median is at least this many frames: with the
/// reference 3D as the fit the unchanged views' are +0.6, -0.4, -0.6 and +0.4 (the
/// master's own labels put it 0.6-0.9 frames off the others: docs/calibration.md, "Videos
/// that did not start together"); in the rig's own fit, unchanged within 0.5, a video 3
/// frames ahead -0.9, -1.0, -0.9 and -1.0 (the fit takes two thirds of its lag).
pub const LAG_FRAMES: f64 = 0.85;

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
                centre_px: agreement.map(|a| a.2),
            }
        })
        .collect();
    Some(fits)
}

/// Over the keypoints of at least `min_confidence` whose joint is in front of `camera`:
/// the mean distance to `joints` projected through it, the mean `projected - observed`
/// vector and the mean projected point, pixels (`None`: no such keypoint).
fn agreement(
    camera: &Camera,
    joints: &[Vector3<f64>; NUM_JOINTS],
    keypoints: &[[f64; 3]; NUM_JOINTS],
    min_confidence: f64,
) -> Option<(f64, [f64; 2], [f64; 2])> {
    let mut distance = 0.0;
    let mut offset = Vector2::zeros();
    let mut centre = Vector2::zeros();
    let mut n = 0usize;
    for (x, &[u, v, c]) in joints.iter().zip(keypoints) {
        if c < min_confidence || c <= 0.0 {
            continue;
        }
        if let Some(px) = camera.project(x) {
            let d = px - Point2::new(u, v);
            distance += d.norm();
            offset += d;
            centre += px.coords;
            n += 1;
        }
    }
    let n = n as f64;
    let finite = |v: &Vector2<f64>| v.iter().all(|x| x.is_finite());
    let found = n > 0.0 && distance.is_finite() && finite(&offset) && finite(&centre);
    found.then(|| {
        (
            distance / n,
            [offset.x / n, offset.y / n],
            [centre.x / n, centre.y / n],
        )
    })
}

/// A view's offset in one hand-frame and the hand's motion in the view since the frame
/// before (`None`: not seen by it then), pixels.
type Move = ([f64; 2], Option<[f64; 2]>);

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
    /// Per view, each hand-frame's offset vector and the hand's motion in the view since
    /// the frame before (when the hand was fitted there with this view then too).
    moves: Vec<Vec<Move>>,
    /// The last frame's hands: `(frame, hand id, view)` and where the hand projected.
    last: Vec<(u64, u64, usize, [f64; 2])>,
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
    /// The steady part of its offsets, pixels ([`MOVED_PX`]; `None` without samples).
    pub steady_px: Option<f64>,
    /// How many frames its offsets lag the hand's motion, against the other views' median
    /// ([`LAG_FRAMES`]; negative: its video shows later moments than the others'; `None`
    /// without [`MIN_SAMPLES`] frames with motion, in it or in the others).
    pub lag_frames: Option<f64>,
    /// Whether its offset stays far above the others' ([`SUSPECT_RATIO`],
    /// [`SUSPECT_FLOOR_PX`], [`MIN_SAMPLES`]) and is what a fault makes of it
    /// ([`MOVED_PX`], [`LAG_FRAMES`]): its calibration no longer holds, or its video is out
    /// of sync.
    pub suspect: bool,
    /// Its offset stays far above the others' but follows the hand, not the camera: the
    /// networks' own error at its angle (not named).
    pub network_bias: bool,
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
        let mut seen = Vec::new();
        for hand in &record.hands {
            let Some(views) = hand.views.as_ref() else {
                continue;
            };
            let n = views.len().max(self.errors.len());
            for list in [&mut self.errors, &mut self.offsets, &mut self.ratios] {
                list.resize(n, Vec::new());
            }
            self.moves.resize(n, Vec::new());
            for (v, view) in views.iter().enumerate() {
                let (Some(o), Some(c)) = (view.offset_px, view.centre_px) else {
                    continue;
                };
                let id = hand.id.unwrap_or(u64::MAX);
                let before = self.last.iter().find(|&&(f, h, w, _)| {
                    f + 1 == record.frame && h == id && w == v && id != u64::MAX
                });
                let motion = before.map(|&(_, _, _, p)| [c[0] - p[0], c[1] - p[1]]);
                self.moves[v].push((o, motion));
                seen.push((record.frame, id, v, c));
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
        self.last = seen;
    }

    /// Each view's medians and the views named; `None` when no hand was fitted from
    /// several views.
    pub fn verdict(&self) -> Option<RigVerdict> {
        if self.errors.len() < 2 {
            return None;
        }
        let fits: Vec<(Option<f64>, Option<f64>)> =
            self.moves.iter().map(|m| steady_and_lag(m)).collect();
        let relative = |v: usize| -> Option<f64> {
            let own = fits.get(v)?.1?;
            let others: Vec<f32> = (0..fits.len())
                .filter(|&w| w != v)
                .filter_map(|w| fits[w].1.map(|l| l as f32))
                .collect();
            Some(own - median(&others)?)
        };
        let views = (0..self.errors.len())
            .map(|v| {
                let median_offset_px = median(&self.offsets[v]);
                let ratio = median(&self.ratios[v]);
                let far = self.ratios[v].len() >= MIN_SAMPLES
                    && ratio.is_some_and(|r| r > SUSPECT_RATIO)
                    && median_offset_px.is_some_and(|o| o > SUSPECT_FLOOR_PX);
                let steady_px = fits.get(v).and_then(|f| f.0);
                let lag_frames = relative(v);
                let fault = steady_px.is_some_and(|c| c >= MOVED_PX)
                    || lag_frames.is_some_and(|s| s.abs() >= LAG_FRAMES);
                ViewSummary {
                    samples: self.errors[v].len(),
                    median_error_px: median(&self.errors[v]),
                    median_offset_px,
                    ratio,
                    steady_px,
                    lag_frames,
                    suspect: far && fault,
                    network_bias: far && !fault,
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
                let steady = s
                    .steady_px
                    .map_or(String::new(), |c| format!(", steady {c:.1} px"));
                let lag = s
                    .lag_frames
                    .map_or(String::new(), |l| format!(", lag {l:+.1} frames"));
                let (e, o) = (px(s.median_error_px), px(s.median_offset_px));
                format!("{}: {e} (offset {o}{ratio}{steady}{lag})", v + 1)
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
        for (v, s) in self
            .views
            .iter()
            .enumerate()
            .filter(|(_, s)| s.network_bias)
        {
            let steady = s.steady_px.unwrap_or(0.0);
            let lag = s
                .lag_frames
                .map_or(String::new(), |l| format!(" or {l:+.1} frames"));
            write!(
                f,
                "; view {}'s offset is above the others' but follows the hand, not its camera \
                 or its clock (steady {steady:.1} px{lag}): the networks' own error at its \
                 angle, nothing to mend",
                v + 1
            )?;
        }
        Ok(())
    }
}

/// The least-squares fit `o = c + s m` of a view's offsets `o` to the hand's motion `m`:
/// `(|c|, s)`. With fewer than [`MIN_SAMPLES`] offsets with a motion, or a hand that
/// hardly moved (under 1 px a frame on average), `c` is the mean offset and `s` is `None`.
fn steady_and_lag(moves: &[Move]) -> (Option<f64>, Option<f64>) {
    if moves.is_empty() {
        return (None, None);
    }
    let mean = |xs: &mut dyn Iterator<Item = [f64; 2]>| {
        let (mut s, mut n) = ([0.0, 0.0], 0.0);
        for x in xs {
            s = [s[0] + x[0], s[1] + x[1]];
            n += 1.0;
        }
        [s[0] / n, s[1] / n]
    };
    let with: Vec<([f64; 2], [f64; 2])> = moves
        .iter()
        .filter_map(|(o, m)| m.map(|m| (*o, m)))
        .collect();
    let spread: f64 = with.iter().map(|(_, m)| m[0] * m[0] + m[1] * m[1]).sum();
    if with.len() < MIN_SAMPLES || spread < with.len() as f64 {
        let c = mean(&mut moves.iter().map(|(o, _)| *o));
        return (Some(c[0].hypot(c[1])), None);
    }
    // Centred on the means, s = Σ (o - ō)·(m - m̄) / Σ |m - m̄|², then c = ō - s m̄.
    let o_bar = mean(&mut with.iter().map(|(o, _)| *o));
    let m_bar = mean(&mut with.iter().map(|(_, m)| *m));
    let (mut num, mut den) = (0.0, 0.0);
    for (o, m) in &with {
        let (dm, d_o) = (
            [m[0] - m_bar[0], m[1] - m_bar[1]],
            [o[0] - o_bar[0], o[1] - o_bar[1]],
        );
        num += d_o[0] * dm[0] + d_o[1] * dm[1];
        den += dm[0] * dm[0] + dm[1] * dm[1];
    }
    if den <= 0.0 {
        return (Some(o_bar[0].hypot(o_bar[1])), None);
    }
    let s = num / den;
    let c = [o_bar[0] - s * m_bar[0], o_bar[1] - s * m_bar[1]];
    (Some(c[0].hypot(c[1])), Some(s))
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
                    centre_px: o.map(|_| [320.0, 240.0]),
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

    /// A run of `frames` frames of one hand (id 0) moving on a circle of 40 px a frame in
    /// every view; view 3's offset is `fault(frame, motion)`, the others' 2 px along u.
    fn moving(frames: u64, fault: impl Fn(u64, [f64; 2]) -> [f64; 2]) -> RigVerdict {
        let mut c = RigCheck::default();
        let at = |i: u64| {
            let a = i as f64 * 0.4;
            [320.0 + 100.0 * a.cos(), 240.0 + 100.0 * a.sin()]
        };
        for i in 0..frames {
            let (p, q) = (at(i), at(i.saturating_sub(1)));
            let m = [p[0] - q[0], p[1] - q[1]];
            let mut hand = HandRecord::from_keypoints(HandSide::Right, &Default::default());
            hand.id = Some(0);
            hand.views = Some(
                (0..4)
                    .map(|v| ViewFitRecord {
                        used: true,
                        reprojection_error_px: Some(5.0),
                        offset_px: Some(if v == 2 { fault(i, m) } else { [2.0, 0.0] }),
                        centre_px: Some(p),
                    })
                    .collect(),
            );
            c.add(&FrameRecord {
                frame: i,
                hands: vec![hand],
                ..FrameRecord::default()
            });
        }
        c.verdict().unwrap()
    }

    #[test]
    fn a_steady_offset_or_a_lag_is_named_and_an_offset_that_follows_the_pose_is_not() {
        // A turned camera: 12 px along v whatever the hand does.
        let turned = moving(40, |_, _| [0.0, 12.0]);
        assert_eq!(turned.suspects(), vec![2], "{turned}");
        assert!((turned.views[2].steady_px.unwrap() - 12.0).abs() < 1e-6);
        // A video 3 frames ahead: its hand is where the others' will be, -3 x the motion.
        let late = moving(40, |_, m| [-3.0 * m[0], -3.0 * m[1]]);
        assert_eq!(late.suspects(), vec![2], "{late}");
        assert!((late.views[2].lag_frames.unwrap() + 3.0).abs() < 1e-6);
        assert!(late.to_string().contains("lag -3.0 frames"), "{late}");
        // The network's error at the view's angle: 9 px in a direction that turns with
        // the hand's pose (here, with the frame), steady part about 0, no lag.
        let bias = moving(40, |i, _| {
            let a = i as f64 * 1.3;
            [9.0 * a.cos(), 9.0 * a.sin()]
        });
        assert!(bias.suspects().is_empty(), "{bias}");
        assert!(bias.views[2].network_bias, "{bias}");
        assert!(
            bias.to_string()
                .contains("view 3's offset is above the others' but follows the hand"),
            "{bias}"
        );
    }
}
