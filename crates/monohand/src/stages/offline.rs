//! The offline smoother for files and corpora: frame `t` is refitted with what the frames
//! before and after it say once frame `t + lag` has been fitted, and with one camera written
//! once frame `t + lag + max(lag, distance_lag)` has (the distance's second pass, below).
//!
//! Each hand of frame `t` is fitted again from its causal pose with the paper's pixel
//! cost, the network's cues and a pull of every joint towards the Gaussian-weighted mean of
//! that hand's causal joints over frames `t - lag ..= t + lag` (the same term as tracking's
//! temporal pull, centred instead of predicted). In the image plane the keypoints hold the
//! joints where they are seen; along the viewing rays, where one camera sees little, the
//! neighbours decide. The depth and pixel fusion's offsets (the network's depth and the
//! keypoints' rays, [`monohand_core::fitting::FusionSettings`]) are averaged with the same
//! weights, as repeated measurements of one hand. A hand with no neighbour (a track of one
//! frame) keeps its causal fit; tracks that start or end inside the window use the frames
//! they have. The pose limits hold: every output comes from a fit.
//!
//! With one camera the distance is what the fit knows least (it comes from the hand's size
//! in the image), and what is left of the shake after the refit is mostly there. So a second
//! pass ([`OfflineSettings::depth_pass`]) scales each refitted hand about the camera's centre
//! to the Gaussian mean of its refitted distances over the frames around it, as the causal
//! depth filter ([`monohand_core::filtering::DepthFilter`]) does without seeing ahead: every
//! joint stays on its viewing ray, so the pixels and the shape are the refit's. Where the
//! track's distance was filtered over the frames (the causal
//! [`monohand_core::fitting::DistanceFilter`]), that mean is moved by what the frames ahead
//! say of the distance: the filter's estimates smoothed back over the next
//! [`OfflineSettings::distance_lag`] frames (a Rauch-Tung-Striebel smoother), so a distance the
//! keypoints of later frames contradict is mended before it is written.

use crate::base::errors::{Field, SettingsError};
use crate::base::frame::{FittedFrame, HandId};
use nalgebra::Vector3;
use std::collections::{HashMap, VecDeque};

use monohand_core::hand_model::NUM_JOINTS;

/// How the offline smoother works.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OfflineSettings {
    /// Frames after frame `t` (and before it) that its refit sees; frame `t` is written
    /// once frame `t + lag` is fitted.
    pub lag: usize,
    /// Standard deviation of the Gaussian weights over the neighbouring frames, in frames.
    pub sigma_frames: f64,
    /// Weight of each joint's pull towards the neighbours' mean (mm of residual per mm,
    /// as [`monohand_core::fitting::TrackingSettings::temporal_weight`]).
    pub weight: f64,
    /// With one camera, a second pass on the refitted hands' distances: each hand scaled
    /// about the camera's centre to the Gaussian mean (the same `lag` and σ) of its refitted
    /// distances, so frame `t` is written once frame `t + 2 lag` is fitted. Every joint
    /// stays on its viewing ray: the pixels and the shape stay the refit's.
    pub depth_pass: bool,
    /// With the distance's pass and a distance filtered over the track (one camera,
    /// [`monohand_core::fitting::DistanceSettings`] on): how many frames ahead the filter's
    /// estimates are smoothed back over (Rauch-Tung-Striebel), each hand's distance target
    /// then multiplied by what they move it; frame `t` is written once frame
    /// `t + lag + max(lag, distance_lag)` is fitted (`t + 2 lag` without the distance
    /// filter, [`monohand_core::fitting::DistanceSettings::weight`] 0). 0 turns it off.
    pub distance_lag: usize,
}

impl Default for OfflineSettings {
    fn default() -> OfflineSettings {
        OfflineSettings {
            // Chosen on the dev set, both halves (docs/accuracy.md, "Offline"): 1 when the
            // keypoints were weighed in pixels, 1.08 in milliradians at the dev camera's
            // focal length (923.7 px).
            lag: 3,
            sigma_frames: 1.0,
            weight: 1.08,
            // Both halves of the dev set: absolute error 23.60 → 23.28 and 17.93 → 17.64
            // mm, jitter 11.14 → 10.73 and 11.81 → 11.56 (docs/accuracy.md, "Offline: the
            // distance smoothed after the refit").
            depth_pass: true,
            // Not a tuned value: the smoother has converged by 15 frames on both dev sets
            // (15, 30 and 60 give the same errors to 0.1 mm; docs/absolute-depth.md,
            // "With `--offline`").
            distance_lag: 30,
        }
    }
}

impl OfflineSettings {
    /// Checks the settings: a lag of at least 1, a positive σ, a finite weight `>= 0`.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let bad = |why: String| Err(SettingsError::new(Field::Offline, why));
        if self.lag == 0 {
            return bad("lag must be at least 1 frame".into());
        }
        if !(self.sigma_frames.is_finite() && self.sigma_frames > 0.0) {
            return bad(format!("sigma {} must be > 0", self.sigma_frames));
        }
        if !(self.weight.is_finite() && self.weight >= 0.0) {
            return bad(format!("weight {} must be >= 0", self.weight));
        }
        Ok(())
    }

    /// The weight of the neighbour `k` frames away.
    fn gauss(&self, k: usize) -> f64 {
        let x = k as f64 / self.sigma_frames;
        (-0.5 * x * x).exp()
    }
}

/// A hand's causal fit in one frame: its skeleton's joints and the fusion's offsets.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Causal {
    pub model: [Vector3<f64>; NUM_JOINTS],
    pub offset: [Vector3<f64>; NUM_JOINTS],
}

/// The causal fits of every hand of a frame, by id.
pub(crate) type CausalFrame = HashMap<HandId, Causal>;

/// The causal fits of a fitted frame's hands.
pub(crate) fn causal(frame: &FittedFrame) -> CausalFrame {
    frame
        .hands
        .iter()
        .filter_map(|h| {
            let f = h.fit.as_ref()?;
            let offset = std::array::from_fn(|j| f.joints_3d[j] - f.model_joints_3d[j]);
            Some((
                h.id,
                Causal {
                    model: f.model_joints_3d,
                    offset,
                },
            ))
        })
        .collect()
}

/// The frames around the one being smoothed: `behind` (nearest last) and `ahead` (nearest
/// first), each at most `lag` long. `M` is what is kept of a frame: its causal fits
/// ([`CausalFrame`]) for the refit, its refitted distances ([`DepthFrame`]) after it.
pub(crate) struct Window<'a, M> {
    pub behind: &'a VecDeque<M>,
    pub ahead: Vec<&'a M>,
}

impl<'a, M> Window<'a, M> {
    /// The neighbouring frames within `lag` on either side, each with its Gaussian weight.
    fn weighted(&self, settings: &'a OfflineSettings) -> impl Iterator<Item = (f64, &'a M)> + '_ {
        let sides = self
            .behind
            .iter()
            .rev()
            .enumerate()
            .chain(self.ahead.iter().copied().enumerate());
        sides
            .filter(|(k, _)| *k < settings.lag)
            .map(|(k, frame)| (settings.gauss(k + 1), frame))
    }
}

/// Frames held back until the `lag` frames after them have come, each with what is kept of
/// it (`M`), and what was kept of the last `lag` frames given out: one pass of the offline
/// smoother (the refit, then with one camera the distance's pass).
pub(crate) struct Held<F, M> {
    ahead: VecDeque<(F, M)>,
    behind: VecDeque<M>,
}

impl<F, M> Default for Held<F, M> {
    fn default() -> Self {
        Held {
            ahead: VecDeque::new(),
            behind: VecDeque::new(),
        }
    }
}

impl<F, M> Held<F, M> {
    /// Takes `frames` (each with what is kept of it) and gives back, in order, those the
    /// `lag` following frames have come for (all of them at the `end`), each once `smooth`
    /// has seen it with its window.
    pub(crate) fn release(
        &mut self,
        frames: impl IntoIterator<Item = (F, M)>,
        lag: usize,
        end: bool,
        mut smooth: impl FnMut(&mut F, &M, &Window<'_, M>),
    ) -> Vec<F> {
        self.ahead.extend(frames);
        let mut out = Vec::new();
        while self.ahead.len() > lag || (end && !self.ahead.is_empty()) {
            let Some((mut frame, own)) = self.ahead.pop_front() else {
                break;
            };
            let window = Window {
                behind: &self.behind,
                ahead: self.ahead.iter().take(lag).map(|(_, m)| m).collect(),
            };
            smooth(&mut frame, &own, &window);
            self.behind.push_back(own);
            if self.behind.len() > lag {
                self.behind.pop_front();
            }
            out.push(frame);
        }
        out
    }
}

/// What the neighbours say of hand `id` whose causal fit in the frame is `own`: the target
/// of its joints and the averaged fusion offsets, `None` without any neighbour.
pub(crate) fn neighbours(
    settings: &OfflineSettings,
    window: &Window<'_, CausalFrame>,
    id: HandId,
    own: &Causal,
) -> Option<Neighbours> {
    let g0 = settings.gauss(0);
    let mut total = g0;
    let mut model = own.model.map(|p| p * g0);
    let mut offset = own.offset.map(|p| p * g0);
    let mut seen = false;
    for (g, frame) in window.weighted(settings) {
        let Some(c) = frame.get(&id) else {
            continue;
        };
        for j in 0..NUM_JOINTS {
            model[j] += c.model[j] * g;
            offset[j] += c.offset[j] * g;
        }
        total += g;
        seen = true;
    }
    seen.then(|| Neighbours {
        target: model.map(|p| p / total),
        offset: offset.map(|p| p / total),
        own_share: g0 / total,
    })
}

/// What the distance's pass keeps of each refitted hand of a frame, by id.
pub(crate) type DepthFrame = HashMap<HandId, Depth>;

/// One refitted hand's distance, and what the causal filter of its track made of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Depth {
    /// The mean distance of its joints from the camera
    /// ([`monohand_core::filtering::mean_depth`], mm).
    pub mean_mm: f64,
    /// The causal distance filter's estimate of its palm's distance and its standard
    /// deviation (mm; [`monohand_core::fitting::DistanceEvidence`]), `None` without one.
    pub filtered: Option<(f64, f64)>,
}

/// The Gaussian-weighted mean of hand `id`'s refitted distance over the window, its own
/// `depth` included: the distance it is scaled to. `None` without any neighbour.
pub(crate) fn depth_target(
    settings: &OfflineSettings,
    window: &Window<'_, DepthFrame>,
    id: HandId,
    depth: f64,
) -> Option<f64> {
    let g0 = settings.gauss(0);
    let (mut sum, mut total, mut seen) = (depth * g0, g0, false);
    for (g, frame) in window.weighted(settings) {
        if let Some(d) = frame.get(&id) {
            sum += d.mean_mm * g;
            total += g;
            seen = true;
        }
    }
    seen.then(|| sum / total)
}

/// How much the frames ahead move hand `id`'s distance target ([`depth_target`]): the
/// ratio of its smoothed palm distance to the Gaussian mean (the same weights) of the causal
/// filter's estimates over the window; 1 without a filtered distance of its own (`own`).
///
/// The causal filter ([`monohand_core::fitting::DistanceFilter`]) is a Kalman filter of the
/// log distance with a random walk of `drift` a frame; its estimates (`(mm, σ mm)`) over the
/// frames ahead are all a Rauch-Tung-Striebel smoother needs: from the last frame ahead back
/// to this one, `x_s(k) = x_f(k) + C (x_s(k+1) - x_f(k))` with `C = P_f(k) / (P_f(k) +
/// drift²)`. It goes as far ahead as the frames have the hand with a filtered distance (at
/// most `distance_lag` frames of the window), so a gap or a track's end stops it. The target
/// is a mean over neighbouring frames, so the smoothed distance is set against the same mean
/// of the filtered ones, not this frame's own: the filter's own frame-to-frame shake is not
/// put back.
pub(crate) fn distance_correction(
    settings: &OfflineSettings,
    window: &Window<'_, DepthFrame>,
    id: HandId,
    own: (f64, f64),
    drift: f64,
) -> f64 {
    let valid =
        |&(mm, sigma): &(f64, f64)| mm.is_finite() && mm > 0.0 && sigma.is_finite() && sigma > 0.0;
    let filtered = |frame: &DepthFrame| frame.get(&id).and_then(|d| d.filtered).filter(valid);
    if !valid(&own) || settings.distance_lag == 0 {
        return 1.0;
    }
    // The smoothed log distance of this frame.
    let mut chain = vec![own];
    chain.extend(
        window
            .ahead
            .iter()
            .take(settings.distance_lag)
            .map_while(|frame| filtered(frame)),
    );
    let q = drift * drift;
    let mut smoothed = chain[chain.len() - 1].0.ln();
    for &(mm, sigma) in chain.iter().rev().skip(1) {
        let (x, p) = (mm.ln(), (sigma / mm).powi(2));
        smoothed = x + p / (p + q) * (smoothed - x);
    }
    // The Gaussian mean of the filtered log distances, as depth_target's.
    let g0 = settings.gauss(0);
    let (mut sum, mut total) = (own.0.ln() * g0, g0);
    for (g, frame) in window.weighted(settings) {
        if let Some((mm, _)) = filtered(frame) {
            sum += mm.ln() * g;
            total += g;
        }
    }
    let ratio = (smoothed - sum / total).exp();
    if ratio.is_finite() {
        ratio
    } else {
        1.0
    }
}

/// The neighbours' verdict on one hand of the frame being refitted.
pub(crate) struct Neighbours {
    /// Where the joints are pulled (reference frame, mm).
    pub target: [Vector3<f64>; NUM_JOINTS],
    /// The weighted mean of the fusion's offsets, the frame's own included.
    pub offset: [Vector3<f64>; NUM_JOINTS],
    /// The frame's own weight in those means.
    pub own_share: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hand(x: f64) -> Causal {
        Causal {
            model: [Vector3::new(x, 0.0, 500.0); NUM_JOINTS],
            offset: [Vector3::new(0.0, 0.0, x); NUM_JOINTS],
        }
    }

    fn frame(id: HandId, x: f64) -> CausalFrame {
        HashMap::from([(id, hand(x))])
    }

    #[test]
    fn the_target_is_the_gaussian_mean_of_the_hands_own_track() {
        let settings = OfflineSettings {
            lag: 2,
            sigma_frames: 1.0,
            weight: 1.0,
            depth_pass: true,
            distance_lag: 0,
        };
        // Frames t-2, t-1 behind (oldest first) and t+1, t+2, t+3 ahead; hand 7 at x = the
        // frame's offset from t, except in t+2 (hand 8 only); t+3 is beyond the lag.
        let behind = VecDeque::from([frame(7, -2.0), frame(7, -1.0)]);
        let ahead = [frame(7, 1.0), frame(8, 100.0), frame(7, 3.0)];
        let window = Window {
            behind: &behind,
            ahead: ahead.iter().collect(),
        };
        let n = neighbours(&settings, &window, 7, &hand(0.0)).expect("neighbours");
        // Weights exp(-k²/2): 1 for t, e^-0.5 at t-1 and t+1, e^-2 at t-2.
        let (g1, g2) = ((-0.5f64).exp(), (-2.0f64).exp());
        let total = 1.0 + 2.0 * g1 + g2;
        let want = (-2.0 * g2 - g1 + g1) / total; // t-2, t-1, t+1

        assert!(
            (n.target[0].x - want).abs() < 1e-12,
            "{} vs {want}",
            n.target[0].x
        );
        assert!((n.offset[5].z - want).abs() < 1e-12);
        assert!((n.own_share - 1.0 / total).abs() < 1e-12);
        assert!((n.target[3].z - 500.0).abs() < 1e-12);
        // A hand no neighbour sees keeps its own fit.
        assert!(neighbours(&settings, &window, 9, &hand(0.0)).is_none());
    }

    #[test]
    fn the_depth_target_is_the_gaussian_mean_of_the_hands_own_distances() {
        let settings = OfflineSettings {
            lag: 2,
            ..OfflineSettings::default()
        };
        let depths = |d: &[(HandId, f64)]| {
            d.iter()
                .map(|&(id, mean_mm)| {
                    let filtered = None;
                    (id, Depth { mean_mm, filtered })
                })
                .collect::<DepthFrame>()
        };
        // t-3 (beyond the lag), t-2, t-1 behind; t+1 (hand 4 only), t+2, t+3 ahead.
        let behind = VecDeque::from([
            depths(&[(3, 0.0)]),
            depths(&[(3, 400.0)]),
            depths(&[(3, 410.0)]),
        ]);
        let ahead = [
            depths(&[(4, 900.0)]),
            depths(&[(3, 440.0)]),
            depths(&[(3, 1e6)]),
        ];
        let window = Window {
            behind: &behind,
            ahead: ahead.iter().collect(),
        };
        let target = depth_target(&settings, &window, 3, 420.0).expect("neighbours");
        let (g1, g2) = ((-0.5f64).exp(), (-2.0f64).exp());
        let want = (420.0 + 410.0 * g1 + (400.0 + 440.0) * g2) / (1.0 + g1 + 2.0 * g2);
        assert!((target - want).abs() < 1e-9, "{target} vs {want}");
        // A hand no neighbour sees keeps its distance.
        assert!(depth_target(&settings, &window, 5, 420.0).is_none());
    }

    /// The frames' evidence of one hand's distance, run through the causal filter: each
    /// frame's keypoints' distance (with its σ) and cues' distance, and the filter's
    /// estimate after it.
    fn filtered_track(
        distance: &monohand_core::fitting::DistanceSettings,
        measured: &[(f64, f64, f64)],
    ) -> Vec<(f64, f64)> {
        let mut filter = monohand_core::fitting::DistanceFilter::new(*distance);
        measured
            .iter()
            .map(|&(d, s, cue)| {
                let e = filter.update(Some((d, s)), Some(cue));
                (e.fused_mm, e.fused_sigma_mm)
            })
            .collect()
    }

    #[test]
    fn the_distance_is_smoothed_as_the_whole_tracks_least_squares_would_have_it() {
        // A hand whose keypoints say 500 mm, then 600 from frame 4 on (the cues lag behind):
        // the causal filter at frame 2 has seen none of it, the smoother all of it.
        let distance = monohand_core::fitting::DistanceSettings::default();
        let measured: Vec<(f64, f64, f64)> = (0..10)
            .map(|k| {
                let d = if k < 4 { 500.0 } else { 600.0 };
                (
                    d * (1.0 + 0.01 * (k % 3) as f64),
                    0.05 * d,
                    520.0 + 5.0 * k as f64,
                )
            })
            .collect();
        let track = filtered_track(&distance, &measured);
        // The reference: the log distances x_0..x_9 that minimise the measurements' and the
        // random walk's squared residuals, each over its variance (a linear least squares).
        let n = measured.len();
        let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut b = nalgebra::DVector::<f64>::zeros(n);
        for (k, &(d, s, cue)) in measured.iter().enumerate() {
            for (z, r) in [
                (d.ln(), (s / d).powi(2)),
                (cue.ln(), distance.cue_sigma.powi(2)),
            ] {
                a[(k, k)] += 1.0 / r;
                b[k] += z / r;
            }
        }
        let q = distance.drift_per_frame.powi(2);
        for k in 0..n - 1 {
            a[(k, k)] += 1.0 / q;
            a[(k + 1, k + 1)] += 1.0 / q;
            a[(k, k + 1)] -= 1.0 / q;
            a[(k + 1, k)] -= 1.0 / q;
        }
        let best = a.lu().solve(&b).expect("solvable");
        // Frame 2 with every later frame ahead, and a Gaussian window of 1 frame each side.
        let settings = OfflineSettings {
            lag: 1,
            distance_lag: n,
            ..OfflineSettings::default()
        };
        let frame = |&(mm, sigma): &(f64, f64)| {
            let depth = Depth {
                mean_mm: 0.0,
                filtered: Some((mm, sigma)),
            };
            DepthFrame::from([(7, depth)])
        };
        let behind = VecDeque::from([frame(&track[1])]);
        let ahead: Vec<DepthFrame> = track[3..].iter().map(frame).collect();
        let window = Window {
            behind: &behind,
            ahead: ahead.iter().collect(),
        };
        let ratio = distance_correction(&settings, &window, 7, track[2], distance.drift_per_frame);
        // The ratio is the smoothed distance over the Gaussian mean of the filtered ones.
        let g1 = (-0.5f64).exp();
        let mean = (track[2].0.ln() + g1 * (track[1].0.ln() + track[3].0.ln())) / (1.0 + 2.0 * g1);
        let smoothed = ratio.ln() + mean;
        assert!(
            (smoothed - best[2]).abs() < 1e-9,
            "{smoothed} against {}",
            best[2]
        );
        // The later frames pull frame 2 towards 600 mm, past its causal estimate.
        assert!(
            smoothed.exp() > track[2].0 + 5.0,
            "{} against {:?}",
            smoothed.exp(),
            track[2]
        );
        // A gap stops the smoother; off, nothing ahead, or a hand not filtered: 1.
        let gap = [frame(&track[3]), DepthFrame::new(), frame(&track[5])];
        let short = [frame(&track[3])];
        let cut = |ahead: &[DepthFrame]| {
            let window = Window {
                behind: &behind,
                ahead: ahead.iter().collect(),
            };
            distance_correction(&settings, &window, 7, track[2], distance.drift_per_frame)
        };
        assert_eq!(cut(&gap), cut(&short));
        let off = OfflineSettings {
            distance_lag: 0,
            ..settings
        };
        assert_eq!(distance_correction(&off, &window, 7, track[2], 0.02), 1.0);
        assert_eq!(
            distance_correction(&settings, &window, 8, track[2], 0.02),
            1.0
        );
        assert_eq!(
            distance_correction(&settings, &window, 7, (f64::NAN, 1.0), 0.02),
            1.0
        );
    }

    #[test]
    fn settings_are_checked() {
        let ok = OfflineSettings::default();
        assert!(ok.validate().is_ok());
        for bad in [
            OfflineSettings { lag: 0, ..ok },
            OfflineSettings {
                sigma_frames: 0.0,
                ..ok
            },
            OfflineSettings {
                weight: f64::NAN,
                ..ok
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
