//! Videos of a calibrated rig that did not start together: each view's time offset against
//! the first view, from the hands' 2D keypoints alone.
//!
//! For a candidate offset, each frame of the first view is paired with the other view's
//! frame taken at the same moment. Each pair of hands is triangulated joint by joint from
//! the two calibrated cameras and reprojected; the candidate's cost is the mean of those
//! reprojection errors over the pairs of frames ([`view_offset`]). At the true offset both
//! views see the same hand at the same moment and agree to within the keypoints' noise; at
//! any other, a moving hand has moved between the two frames. A hand that stays still, or
//! that the two views never see together, leaves the offset open: [`ViewOffset::Open`]
//! says so, and nothing is guessed.
//!
//! Offsets are searched on the finer of the two views' frame spacings, so a 30 fps view
//! against a 15 fps first view is placed to half of the first view's frame, and refined
//! between the candidates. The rig is solved as a whole ([`rig_offsets`]): every pair of
//! views gives its refined offset and the views' start times are fitted to all of them.
//! Each view is then shifted by the whole frames of its start, rounded towards zero: the
//! fraction of a frame is left. Cameras started together can be a fraction of a frame
//! apart, and the keypoints do not measure that fraction well: on the table rig of
//! `../shared/data` the network's keypoints put its views +0.56, +0.56 and -0.09 frames
//! after the master, its own labels +0.65, +0.89 and +0.94; and each one-frame shift of
//! those views tried raises the 3D error against the rig's reference from 11.98 mm to
//! 12.33-19.57 (docs/calibration.md).
//!
//! ```
//! use monohand_core::sync::{view_offset, SyncSettings, ViewFrames};
//!
//! // No frame with a hand: nothing can be said.
//! let none: Vec<ViewFrames> = (0..30).map(|i| ViewFrames::new(i as f64 / 30.0, vec![])).collect();
//! let cam = monohand_core::camera::Camera::generic(640, 480).unwrap();
//! let found = view_offset((&cam, &none), (&cam, &none), &SyncSettings::default());
//! assert!(found.found().is_none());
//! ```

use crate::camera::Camera;
use crate::hand_model::NUM_JOINTS;
use crate::observation::Keypoints2d;
use nalgebra::{Point2, Vector3};

/// One frame of one view: when it was taken (the view's own clock, seconds from its first
/// frame or any fixed origin) and the hands its keypoint detector found.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewFrames {
    /// The frame's time, seconds, on the view's own clock.
    pub time_s: f64,
    /// The hands found in it (any number, any order).
    pub hands: Vec<Keypoints2d>,
}

impl ViewFrames {
    /// A frame at `time_s` with `hands`.
    pub fn new(time_s: f64, hands: Vec<Keypoints2d>) -> ViewFrames {
        ViewFrames { time_s, hands }
    }
}

/// How offsets are searched and when one is trusted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncSettings {
    /// The largest offset searched, either way, seconds.
    pub max_offset_s: f64,
    /// A keypoint counts with at least this confidence.
    pub min_confidence: f64,
    /// A pair of hands counts with at least this many joints seen by both views.
    pub min_joints: usize,
    /// A candidate offset is judged only on at least this many pairs of frames that both
    /// have a hand.
    pub min_pairs: usize,
    /// The best offset's cost must be at most this fraction of the typical cost of the
    /// offsets more than [`SyncSettings::valley`] steps away: a still hand costs the
    /// same at every offset.
    pub max_contrast: f64,
    /// Another local minimum, more than [`SyncSettings::valley`] steps away, within this
    /// factor of the best one's cost makes the offset ambiguous (a hand that moves to and
    /// fro at a steady rhythm).
    pub rival_factor: f64,
    /// Steps either side of the best offset that belong to its own valley.
    pub valley: usize,
    /// A pair of frames costs at most this many pixels: a hand matched to another person's
    /// hand, or a network's wrong hand, weighs no more than a fast motion.
    pub clip_px: f64,
}

impl Default for SyncSettings {
    /// Set beforehand, not tuned; what they leave on the table rig is in docs/calibration.md,
    /// "Videos that did not start together".
    fn default() -> Self {
        SyncSettings {
            max_offset_s: 3.0,
            min_confidence: 0.3,
            min_joints: 8,
            min_pairs: 15,
            max_contrast: 0.5,
            rival_factor: 1.25,
            valley: 3,
            clip_px: 30.0,
        }
    }
}

/// A view's offset, found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoundOffset {
    /// How late the view started, seconds: its frame at its own time `τ` shows the moment
    /// of the first view's time `τ + offset_s`. Negative: it started early. A whole number
    /// of [`FoundOffset::step_s`].
    pub offset_s: f64,
    /// The spacing of the candidates searched: the finer of the two views' frame spacings.
    pub step_s: f64,
    /// The offset in steps (`offset_s / step_s`).
    pub steps: i64,
    /// The offset in steps refined between the candidates by a parabola through the best
    /// one's cost and its neighbours': within half a step of [`FoundOffset::steps`].
    pub refined_steps: f64,
    /// The best candidate's cost: the mean over the pairs of frames of the median two-view
    /// reprojection error of the joints (each pair at most [`SyncSettings::clip_px`]), pixels.
    pub cost_px: f64,
    /// The typical cost away from it (the median over the candidates past its valley).
    pub typical_px: f64,
    /// Pairs of frames with a hand in both at the best candidate.
    pub pairs: usize,
}

/// Why a view's offset was left open.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OpenReason {
    /// The two views saw a hand together in too few frames at every candidate offset.
    TooFewPairs {
        /// The most pairs of frames any candidate had.
        pairs: usize,
        /// [`SyncSettings::min_pairs`].
        needed: usize,
    },
    /// Every offset fits about as well: the hand hardly moved.
    Flat {
        /// The best candidate's cost, pixels.
        best_px: f64,
        /// The typical cost away from it, pixels.
        typical_px: f64,
    },
    /// Two offsets far apart fit about as well.
    Ambiguous {
        /// The best candidate, seconds.
        best_s: f64,
        /// The other one, seconds.
        rival_s: f64,
        /// Their costs, pixels.
        best_px: f64,
        /// The rival's cost, pixels.
        rival_px: f64,
    },
}

impl std::fmt::Display for OpenReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            OpenReason::TooFewPairs { pairs, needed } => write!(
                f,
                "the two views saw a hand together in at most {pairs} frames (at least {needed} are needed)"
            ),
            OpenReason::Flat {
                best_px,
                typical_px,
            } => write!(
                f,
                "the hand hardly moved: every offset fits about as well ({best_px:.1} px at best, \
                 {typical_px:.1} px typically)"
            ),
            OpenReason::Ambiguous {
                best_s,
                rival_s,
                best_px,
                rival_px,
            } => write!(
                f,
                "two offsets fit about as well: {best_s:+.3} s ({best_px:.1} px) and {rival_s:+.3} s \
                 ({rival_px:.1} px)"
            ),
        }
    }
}

/// A view's offset against the first view: found, or why not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ViewOffset {
    /// Found.
    Found(FoundOffset),
    /// Left open.
    Open(OpenReason),
}

impl ViewOffset {
    /// The offset found, if any.
    pub fn found(&self) -> Option<&FoundOffset> {
        match self {
            ViewOffset::Found(f) => Some(f),
            ViewOffset::Open(_) => None,
        }
    }
}

/// Each joint's ray `(camera centre, unit direction)` in the reference frame, where the
/// keypoint is confident enough.
type HandRays = [Option<(Point2<f64>, Vector3<f64>)>; NUM_JOINTS];

/// The rays of every hand of every frame of a view.
fn rays_of(camera: &Camera, frames: &[ViewFrames], min_confidence: f64) -> Vec<Vec<HandRays>> {
    let to_ref = camera.extrinsics.rotation.inverse();
    frames
        .iter()
        .map(|f| {
            f.hands
                .iter()
                .map(|h| {
                    std::array::from_fn(|j| {
                        let [u, v, c] = h.points[j];
                        let confident = c >= min_confidence && c > 0.0;
                        if !confident {
                            return None;
                        }
                        let px = Point2::new(u, v);
                        camera.ray(px).map(|d| (px, to_ref * d))
                    })
                })
                .collect()
        })
        .collect()
}

/// The point midway between the nearest points of two rays, `None` for rays nearly
/// parallel (less than about a tenth of a degree apart).
fn midpoint(
    (o1, d1): (Vector3<f64>, Vector3<f64>),
    (o2, d2): (Vector3<f64>, Vector3<f64>),
) -> Option<Vector3<f64>> {
    let w = o1 - o2;
    let (b, d, e) = (d1.dot(&d2), d1.dot(&w), d2.dot(&w));
    let denom = 1.0 - b * b;
    if denom < 3e-6 {
        return None;
    }
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    Some(((o1 + d1 * s) + (o2 + d2 * t)) * 0.5)
}

/// The two cameras of a pair with their centres.
struct Pair<'a> {
    cams: [&'a Camera; 2],
    centres: [Vector3<f64>; 2],
}

impl Pair<'_> {
    /// The median over the joints both hands have of the two views' mean reprojection
    /// error of the joint triangulated from them; `None` below `min_joints` joints.
    fn agreement(
        &self,
        a: &HandRays,
        b: &HandRays,
        min_joints: usize,
        buf: &mut Vec<f64>,
    ) -> Option<f64> {
        buf.clear();
        for (ra, rb) in a.iter().zip(b) {
            let (Some((pa, da)), Some((pb, db))) = (ra, rb) else {
                continue;
            };
            let Some(x) = midpoint((self.centres[0], *da), (self.centres[1], *db)) else {
                continue;
            };
            let (Some(qa), Some(qb)) = (self.cams[0].project(&x), self.cams[1].project(&x)) else {
                continue;
            };
            buf.push(((qa - *pa).norm() + (qb - *pb).norm()) * 0.5);
        }
        (buf.len() >= min_joints).then(|| median(buf))
    }
}

/// The median of `xs` (reordered); NaN when empty.
fn median(xs: &mut [f64]) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    let mid = xs.len() / 2;
    xs.select_nth_unstable_by(mid, f64::total_cmp);
    xs[mid]
}

/// The median spacing of a view's frames, seconds (1/30 with fewer than two frames).
fn spacing(frames: &[ViewFrames]) -> f64 {
    let mut d: Vec<f64> = frames
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .filter(|d| *d > 0.0 && d.is_finite())
        .collect();
    let s = median(&mut d);
    if s.is_finite() {
        s
    } else {
        1.0 / 30.0
    }
}

/// The index of `frames`' frame nearest to `t`, if one is within `tolerance` seconds.
fn nearest(frames: &[ViewFrames], t: f64, tolerance: f64) -> Option<usize> {
    let i = frames.partition_point(|f| f.time_s < t);
    let candidates = [i.checked_sub(1), (i < frames.len()).then_some(i)];
    candidates
        .into_iter()
        .flatten()
        .min_by(|&a, &b| {
            (frames[a].time_s - t)
                .abs()
                .total_cmp(&(frames[b].time_s - t).abs())
        })
        .filter(|&k| (frames[k].time_s - t).abs() <= tolerance)
}

/// The cost of each candidate offset `k · step` for `k` in `-n..=n`: the mean over the
/// pairs of frames of their agreement, each at most [`SyncSettings::clip_px`] (a median
/// would miss the moments a hand moves fast, which tell the offset best); with its pairs
/// of frames (`None`: fewer than [`SyncSettings::min_pairs`]).
fn costs(
    first: (&Camera, &[ViewFrames]),
    view: (&Camera, &[ViewFrames]),
    step: f64,
    n: i64,
    settings: &SyncSettings,
) -> Vec<(Option<f64>, usize)> {
    let pair = Pair {
        cams: [first.0, view.0],
        centres: [first.0.centre(), view.0.centre()],
    };
    let rays = [
        rays_of(first.0, first.1, settings.min_confidence),
        rays_of(view.0, view.1, settings.min_confidence),
    ];
    let (mut joints, mut pairs) = (Vec::with_capacity(NUM_JOINTS), Vec::new());
    (-n..=n)
        .map(|k| {
            pairs.clear();
            let shift = k as f64 * step;
            for (i, f) in first.1.iter().enumerate() {
                let Some(m) = nearest(view.1, f.time_s - shift, 0.5 * step) else {
                    continue;
                };
                let best = rays[0][i]
                    .iter()
                    .flat_map(|a| rays[1][m].iter().map(move |b| (a, b)))
                    .filter_map(|(a, b)| pair.agreement(a, b, settings.min_joints, &mut joints))
                    .min_by(f64::total_cmp);
                pairs.extend(best);
            }
            let count = pairs.len();
            let clip = settings.clip_px;
            let mean = pairs.iter().map(|c| c.min(clip)).sum::<f64>() / count.max(1) as f64;
            ((count >= settings.min_pairs).then_some(mean), count)
        })
        .collect()
}

/// `view`'s offset against `first`, each a camera (in the same reference frame) with its
/// frames in time order.
pub fn view_offset(
    first: (&Camera, &[ViewFrames]),
    view: (&Camera, &[ViewFrames]),
    settings: &SyncSettings,
) -> ViewOffset {
    let step = spacing(first.1).min(spacing(view.1));
    let n = (settings.max_offset_s / step).floor().max(0.0) as i64;
    let costs = costs(first, view, step, n, settings);
    choose(&costs, step, n, settings)
}

/// The best candidate of `costs` (candidate `k` at index `k + n`), if it is trusted.
fn choose(costs: &[(Option<f64>, usize)], step: f64, n: i64, s: &SyncSettings) -> ViewOffset {
    let c = |i: usize| costs.get(i).and_then(|x| x.0);
    let Some(best) = (0..costs.len())
        .filter(|&i| c(i).is_some())
        .min_by(|&a, &b| {
            c(a).unwrap_or(f64::INFINITY)
                .total_cmp(&c(b).unwrap_or(f64::INFINITY))
        })
    else {
        let pairs = costs.iter().map(|x| x.1).max().unwrap_or(0);
        return ViewOffset::Open(OpenReason::TooFewPairs {
            pairs,
            needed: s.min_pairs,
        });
    };
    let best_px = c(best).unwrap_or(f64::NAN);
    let far = |i: usize| i.abs_diff(best) > s.valley;
    let mut away: Vec<f64> = (0..costs.len()).filter(|&i| far(i)).filter_map(c).collect();
    let typical_px = median(&mut away);
    // NaN (no candidate past the valley) is not a contrast either.
    let contrasted = best_px <= s.max_contrast * typical_px;
    if !contrasted {
        return ViewOffset::Open(OpenReason::Flat {
            best_px,
            typical_px,
        });
    }
    let at = |i: usize| (i as i64 - n) as f64 * step;
    // Another valley's floor: a candidate past the best one's valley, lower than its
    // neighbours.
    let local_min = |i: usize| {
        let ci = c(i).unwrap_or(f64::INFINITY);
        let lower = |j: Option<usize>| j.and_then(c).is_none_or(|cj| ci <= cj);
        lower(i.checked_sub(1)) && lower(Some(i + 1))
    };
    let rival = (0..costs.len())
        .filter(|&i| far(i) && c(i).is_some() && local_min(i))
        .min_by(|&a, &b| {
            c(a).unwrap_or(f64::INFINITY)
                .total_cmp(&c(b).unwrap_or(f64::INFINITY))
        });
    if let Some(r) = rival.filter(|&r| c(r).is_some_and(|cr| cr < s.rival_factor * best_px)) {
        return ViewOffset::Open(OpenReason::Ambiguous {
            best_s: at(best),
            rival_s: at(r),
            best_px,
            rival_px: c(r).unwrap_or(f64::NAN),
        });
    }
    let steps = best as i64 - n;
    let refined = match (best.checked_sub(1).and_then(c), c(best + 1)) {
        (Some(lo), Some(hi)) => {
            let curve = lo - 2.0 * best_px + hi;
            let d = if curve > 0.0 {
                0.5 * (lo - hi) / curve
            } else {
                0.0
            };
            steps as f64 + d.clamp(-0.5, 0.5)
        }
        _ => steps as f64,
    };
    ViewOffset::Found(FoundOffset {
        offset_s: at(best),
        step_s: step,
        steps,
        refined_steps: refined,
        cost_px: best_px,
        typical_px,
        pairs: costs[best].1,
    })
}

/// Each view's offset against the first (`views[0]`, whose own is zero), the rig solved as
/// a whole: every pair of views is matched ([`view_offset`]); the views' start times are
/// the least-squares fit to the pairs' refined offsets; and each view's offset is the
/// whole steps (of the finest frame spacing of the views) of its start, rounded towards
/// zero. [`FoundOffset::refined_steps`] is the fitted start; cost, typical cost and pairs
/// are those of the view's pair with the first view, or else of its best pair. A view no
/// pair connects to the first is left open, with the reason of its pair with the first.
pub fn rig_offsets(views: &[(&Camera, &[ViewFrames])], settings: &SyncSettings) -> Vec<ViewOffset> {
    let n = views.len();
    let mut pairs: Vec<(usize, usize, ViewOffset)> = Vec::new();
    for v in 0..n {
        for w in v + 1..n {
            pairs.push((v, w, view_offset(views[v], views[w], settings)));
        }
    }
    let found: Vec<(usize, usize, FoundOffset)> = pairs
        .iter()
        .filter_map(|(v, w, o)| o.found().map(|f| (*v, *w, *f)))
        .collect();
    let linked = linked_to_first(n, &found);
    let starts = fitted_starts(n, &found, &linked);
    let step = views
        .iter()
        .map(|(_, f)| spacing(f))
        .fold(f64::INFINITY, f64::min);
    // The whole steps of each start, its fraction left (rounded towards zero).
    let steps: Vec<i64> = starts
        .iter()
        .map(|s| (s / step + 1e-6 * s.signum()).trunc() as i64)
        .collect();
    (0..n)
        .map(|v| {
            if v == 0 {
                return ViewOffset::Found(FoundOffset {
                    offset_s: 0.0,
                    step_s: step,
                    steps: 0,
                    refined_steps: 0.0,
                    cost_px: 0.0,
                    typical_px: 0.0,
                    pairs: 0,
                });
            }
            let with_first = &pairs[v - 1].2;
            if !linked[v] {
                return *with_first;
            }
            let own = with_first.found().copied().or_else(|| {
                found
                    .iter()
                    .filter(|(a, b, _)| *a == v || *b == v)
                    .map(|(_, _, f)| *f)
                    .min_by(|a, b| a.cost_px.total_cmp(&b.cost_px))
            });
            let own = own.unwrap_or(FoundOffset {
                offset_s: 0.0,
                step_s: step,
                steps: 0,
                refined_steps: 0.0,
                cost_px: f64::NAN,
                typical_px: f64::NAN,
                pairs: 0,
            });
            ViewOffset::Found(FoundOffset {
                offset_s: steps[v] as f64 * step,
                step_s: step,
                steps: steps[v],
                refined_steps: starts[v] / step,
                ..own
            })
        })
        .collect()
}

/// Which views the found pairs connect to view 0.
fn linked_to_first(n: usize, found: &[(usize, usize, FoundOffset)]) -> Vec<bool> {
    let mut linked = vec![false; n];
    if n > 0 {
        linked[0] = true;
    }
    loop {
        let mut more = false;
        for (v, w, _) in found {
            if linked[*v] != linked[*w] {
                linked[*v] = true;
                linked[*w] = true;
                more = true;
            }
        }
        if !more {
            return linked;
        }
    }
}

/// The views' start times, seconds after view 0's: the least-squares fit to the pairs'
/// refined offsets (`start[w] - start[v] = offset of w against v`); 0 for views not linked.
fn fitted_starts(n: usize, found: &[(usize, usize, FoundOffset)], linked: &[bool]) -> Vec<f64> {
    let mut starts = vec![0.0; n];
    // The unknowns: the linked views after the first.
    let unknown: Vec<usize> = (1..n).filter(|&v| linked[v]).collect();
    if unknown.is_empty() {
        return starts;
    }
    let at = |v: usize| unknown.iter().position(|&u| u == v);
    let m = unknown.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(m, m);
    let mut b = nalgebra::DVector::<f64>::zeros(m);
    for (v, w, f) in found {
        let d = f.refined_steps * f.step_s;
        // The row of `start[w] - start[v] = d`.
        let (iv, iw) = (at(*v), at(*w));
        for (i, si) in [(iw, 1.0), (iv, -1.0)] {
            let Some(i) = i else { continue };
            b[i] += si * d;
            for (j, sj) in [(iw, 1.0), (iv, -1.0)] {
                if let Some(j) = j {
                    a[(i, j)] += si * sj;
                }
            }
        }
    }
    if let Some(x) = a.lu().solve(&b) {
        for (k, &v) in unknown.iter().enumerate() {
            starts[v] = x[k];
        }
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Extrinsics;
    use crate::hand_model::{HandPose, HandSide, HandSkeleton};
    use crate::kinematics::forward_kinematics;
    use nalgebra::{Rotation3, UnitQuaternion};

    /// Two cameras 400 mm apart, both looking at a point 600 mm in front of the first.
    fn cameras() -> [Camera; 2] {
        let a = Camera::pinhole(600.0, 600.0, 320.0, 240.0, 640, 480).unwrap();
        let rotation = Rotation3::from_euler_angles(0.0, -0.6, 0.0);
        let centre = Vector3::new(400.0, 0.0, 100.0);
        let b = a.with_extrinsics(Extrinsics {
            rotation,
            translation: -(rotation * centre),
        });
        [a, b]
    }

    /// The hand at time `t`: moving about 0.3 m/s on a loop that does not repeat within
    /// the run, its fingers flexing.
    fn pose(t: f64) -> HandPose {
        let t = 3.0 * t;
        let mut p = HandPose {
            translation: Vector3::new(
                60.0 * (1.3 * t).sin(),
                40.0 * (0.7 * t).cos(),
                600.0 + 50.0 * t.sin(),
            ),
            rotation: UnitQuaternion::from_euler_angles(
                0.4 * (0.9 * t).sin(),
                0.3 * t.cos(),
                0.2 * t,
            ),
            ..HandPose::default()
        };
        for (k, a) in p.angles.iter_mut().enumerate() {
            *a = 0.3 * (0.5 * (1.0 + (1.1 * t + k as f64).sin()));
        }
        p
    }

    /// A view's frames at `fps` for `secs` seconds, starting at `start_s` on the true
    /// clock, its own clock from 0; `None` pose: no hand seen. Noise: `noise_px` added in a
    /// fixed pattern.
    fn frames(
        cam: &Camera,
        fps: f64,
        start_s: f64,
        secs: f64,
        still: bool,
        noise_px: f64,
    ) -> Vec<ViewFrames> {
        let skeleton = HandSkeleton::default_for(HandSide::Right);
        let count = (secs * fps).round() as usize;
        (0..count)
            .map(|i| {
                let local = i as f64 / fps;
                let t = if still { 0.0 } else { start_s + local };
                let joints = forward_kinematics(&skeleton, &pose(t));
                let mut kp = Keypoints2d::default();
                for (j, x) in joints.iter().enumerate() {
                    let px = cam.project(x).unwrap();
                    let e = noise_px * ((i * 31 + j * 7) as f64).sin();
                    kp.points[j] = [px.x + e, px.y - e, 0.9];
                }
                ViewFrames::new(local, vec![kp])
            })
            .collect()
    }

    #[test]
    fn a_late_and_an_early_view_are_found_to_the_frame() {
        let [a, b] = cameras();
        let s = SyncSettings::default();
        let first = frames(&a, 30.0, 0.0, 5.0, false, 1.0);
        for late in [5i64, -3, 0, 40] {
            let view = frames(&b, 30.0, late as f64 / 30.0, 5.0, false, 1.0);
            let found = *view_offset((&a, &first), (&b, &view), &s)
                .found()
                .expect("found");
            assert_eq!(found.steps, late, "{found:?}");
            assert!((found.offset_s - late as f64 / 30.0).abs() < 1e-9);
            assert!((found.refined_steps - late as f64).abs() <= 0.5);
            assert!(found.cost_px < 3.0 && found.typical_px > 10.0, "{found:?}");
        }
    }

    #[test]
    fn a_view_at_half_the_rate_is_placed_on_the_finer_clock() {
        let [a, b] = cameras();
        let s = SyncSettings::default();
        // The first view at 15 fps, the other at 30 starting 7/30 s late; and the other
        // way round.
        let slow = frames(&a, 15.0, 0.0, 5.0, false, 0.5);
        let fast = frames(&b, 30.0, 7.0 / 30.0, 5.0, false, 0.5);
        let found = *view_offset((&a, &slow), (&b, &fast), &s)
            .found()
            .expect("found");
        assert!((found.offset_s - 7.0 / 30.0).abs() < 1e-9, "{found:?}");
        let fast_first = frames(&a, 30.0, 0.0, 5.0, false, 0.5);
        let slow_late = frames(&b, 15.0, 4.0 / 30.0, 5.0, false, 0.5);
        let found = *view_offset((&a, &fast_first), (&b, &slow_late), &s)
            .found()
            .expect("found");
        assert!((found.offset_s - 4.0 / 30.0).abs() < 1e-9, "{found:?}");
    }

    #[test]
    fn a_still_hand_and_a_hand_seen_by_one_view_leave_the_offset_open() {
        let [a, b] = cameras();
        let s = SyncSettings::default();
        let still_a = frames(&a, 30.0, 0.0, 4.0, true, 1.0);
        let still_b = frames(&b, 30.0, 0.2, 4.0, true, 1.0);
        let open = view_offset((&a, &still_a), (&b, &still_b), &s);
        assert!(
            matches!(open, ViewOffset::Open(OpenReason::Flat { .. })),
            "{open:?}"
        );
        let moving = frames(&a, 30.0, 0.0, 4.0, false, 1.0);
        let unseen: Vec<ViewFrames> = (0..120)
            .map(|i| ViewFrames::new(i as f64 / 30.0, vec![]))
            .collect();
        let open = view_offset((&a, &moving), (&b, &unseen), &s);
        assert!(
            matches!(
                open,
                ViewOffset::Open(OpenReason::TooFewPairs {
                    pairs: 0,
                    needed: 15
                })
            ),
            "{open:?}"
        );
        assert!(open_text(&open).contains("at most 0 frames"));
    }

    fn open_text(o: &ViewOffset) -> String {
        match o {
            ViewOffset::Open(r) => r.to_string(),
            ViewOffset::Found(f) => format!("{f:?}"),
        }
    }

    #[test]
    fn a_rig_is_solved_as_a_whole_and_each_view_keeps_its_fraction_of_a_frame() {
        let [a, b] = cameras();
        // A third camera above the first, looking down at the hand.
        let rotation = Rotation3::from_euler_angles(0.5, 0.0, 0.0);
        let centre = Vector3::new(0.0, -300.0, 150.0);
        let c = a.with_extrinsics(Extrinsics {
            rotation,
            translation: -(rotation * centre),
        });
        let s = SyncSettings::default();
        let f0 = frames(&a, 30.0, 0.0, 5.0, false, 0.5);
        // 5.4 frames late, and 3.3 frames early.
        let f1 = frames(&b, 30.0, 5.4 / 30.0, 5.0, false, 0.5);
        let f2 = frames(&c, 30.0, -3.3 / 30.0, 5.0, false, 0.5);
        let rig = [
            (&a, f0.as_slice()),
            (&b, f1.as_slice()),
            (&c, f2.as_slice()),
        ];
        let found: Vec<FoundOffset> = rig_offsets(&rig, &s)
            .iter()
            .map(|o| *o.found().expect("found"))
            .collect();
        assert_eq!(
            found.iter().map(|f| f.steps).collect::<Vec<_>>(),
            vec![0, 5, -3],
            "{found:?}"
        );
        assert!((found[1].refined_steps - 5.4).abs() < 0.3, "{found:?}");
        assert!((found[2].refined_steps + 3.3).abs() < 0.3, "{found:?}");
        assert!((found[2].offset_s + 0.1).abs() < 1e-9);
        // A view that never sees the hand is left open, the others found.
        let unseen: Vec<ViewFrames> = (0..150)
            .map(|i| ViewFrames::new(i as f64 / 30.0, vec![]))
            .collect();
        let rig = [
            (&a, f0.as_slice()),
            (&b, f1.as_slice()),
            (&c, unseen.as_slice()),
        ];
        let out = rig_offsets(&rig, &s);
        assert_eq!(out[1].found().map(|f| f.steps), Some(5));
        assert!(
            matches!(out[2], ViewOffset::Open(OpenReason::TooFewPairs { .. })),
            "{:?}",
            out[2]
        );
    }

    #[test]
    fn the_midpoint_of_two_crossing_rays_is_their_crossing() {
        let x = Vector3::new(10.0, -20.0, 500.0);
        let (o1, o2) = (Vector3::zeros(), Vector3::new(-300.0, 10.0, 40.0));
        let m = midpoint((o1, (x - o1).normalize()), (o2, (x - o2).normalize())).unwrap();
        assert!((m - x).norm() < 1e-9);
        assert!(midpoint((o1, Vector3::z()), (o2, Vector3::z())).is_none());
    }
}
