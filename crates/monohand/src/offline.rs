//! The offline smoother for files and corpora: frame `t` is written once frame `t + lag`
//! has been fitted, and refitted with what the frames before and after it say.
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

use crate::crops::HandId;
use crate::hands::FittedFrame;
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
        }
    }
}

impl OfflineSettings {
    /// Checks the settings: a lag of at least 1, a positive σ, a finite weight `>= 0`.
    pub fn validate(&self) -> Result<(), String> {
        if self.lag == 0 {
            return Err("the offline lag must be at least 1 frame".into());
        }
        if !(self.sigma_frames.is_finite() && self.sigma_frames > 0.0) {
            return Err(format!("offline sigma {} must be > 0", self.sigma_frames));
        }
        if !(self.weight.is_finite() && self.weight >= 0.0) {
            return Err(format!("offline weight {} must be >= 0", self.weight));
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

/// The frames around the one being refitted: `behind` (nearest last) and `ahead` (nearest
/// first), each at most `lag` long.
pub(crate) struct Window<'a> {
    pub behind: &'a VecDeque<CausalFrame>,
    pub ahead: Vec<&'a CausalFrame>,
}

/// What the neighbours say of hand `id` whose causal fit in the frame is `own`: the target
/// of its joints and the averaged fusion offsets, `None` without any neighbour.
pub(crate) fn neighbours(
    settings: &OfflineSettings,
    window: &Window<'_>,
    id: HandId,
    own: &Causal,
) -> Option<Neighbours> {
    let g0 = settings.gauss(0);
    let mut total = g0;
    let mut model = own.model.map(|p| p * g0);
    let mut offset = own.offset.map(|p| p * g0);
    let mut seen = false;
    let sides = window
        .behind
        .iter()
        .rev()
        .enumerate()
        .chain(window.ahead.iter().copied().enumerate());
    for (k, frame) in sides.filter(|(k, _)| *k < settings.lag) {
        let Some(c) = frame.get(&id) else {
            continue;
        };
        let g = settings.gauss(k + 1);
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
