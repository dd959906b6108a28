//! The hand's distance from one camera, gathered over the frames of a track.
//!
//! With one camera the keypoints leave a family of hands along the viewing rays: a nearer
//! hand more flexed, or a farther one flatter, reproject alike. The network's 3D cues pick
//! one member, and where they are wrong (a hand seen from above or the side) they stay
//! wrong for many frames. The keypoints' own evidence is weaker per frame but unbiased by
//! the view: a palm 70 px across with 5 px of keypoint noise fixes the distance to about
//! 7%. [`DistanceFilter`] combines both over time, in the logarithm of the distance (a
//! relative error is what both sources have): each frame adds the keypoints' distance
//! with the uncertainty its own fit gives ([`crate::fitting::HandFitter::palm_depth_sigma`])
//! and the cues' distance with a fixed relative uncertainty
//! ([`DistanceSettings::cue_sigma`]); between frames the distance may drift by
//! [`DistanceSettings::drift_per_frame`]. It is a one-dimensional Kalman filter with a
//! random walk.
//!
//! ```
//! use monohand_core::fitting::{DistanceFilter, DistanceSettings};
//!
//! let settings = DistanceSettings::default();
//! let mut filter = DistanceFilter::new(settings);
//! // The keypoints pin the distance firmly (2%), the cues say 20% farther: the keypoints win.
//! let first = filter.update(Some((500.0, 10.0)), Some(600.0));
//! assert!(first.fused_mm > 500.0 && first.fused_mm < 510.0);
//! // Where the keypoints leave the distance open (40%), the cues choose it.
//! let mut open = DistanceFilter::new(settings);
//! let second = open.update(Some((500.0, 200.0)), Some(600.0));
//! assert!(second.fused_mm > 590.0);
//! ```

use super::options::DistanceSettings;

/// What one frame told [`DistanceFilter`] about the hand's distance, and what it made of it
/// (mm, the palm's centroid's depth in the camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceEvidence {
    /// The distance of the fit with the keypoints alone (`None`: that fit failed).
    pub keypoints_mm: Option<f64>,
    /// Its standard deviation, from that fit's own Gauss-Newton matrix.
    pub keypoints_sigma_mm: Option<f64>,
    /// The distance of the fit with the network's cues (`None`: none this frame).
    pub cues_mm: Option<f64>,
    /// The filtered distance.
    pub fused_mm: f64,
    /// Its standard deviation.
    pub fused_sigma_mm: f64,
}

/// The hand's distance over a track: a Kalman filter of its logarithm ([module docs](self)).
#[derive(Debug, Clone)]
pub struct DistanceFilter {
    settings: DistanceSettings,
    /// The log distance and its variance.
    state: Option<(f64, f64)>,
}

impl DistanceFilter {
    /// A filter with nothing seen.
    pub fn new(settings: DistanceSettings) -> DistanceFilter {
        DistanceFilter {
            settings,
            state: None,
        }
    }

    /// Forgets the past.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Whether a distance was measured since the filter was made or reset.
    pub fn has_seen(&self) -> bool {
        self.state.is_some()
    }

    /// The next frame: the keypoints' distance and its standard deviation (mm), and the
    /// cues' distance (mm); each `None` where that fit gave none. A measurement that is not
    /// finite and positive is left out. With neither, the distance only drifts (and a
    /// filter that has seen nothing gives NaN).
    pub fn update(
        &mut self,
        keypoints: Option<(f64, f64)>,
        cues_mm: Option<f64>,
    ) -> DistanceEvidence {
        let keypoints = keypoints.filter(|&(d, s)| positive(d) && positive(s));
        let cues_mm = cues_mm.filter(|&d| positive(d));
        let mut measurements = [None, None];
        if let Some((d, s)) = keypoints {
            // The relative deviation of d is s / d: the log's.
            measurements[0] = Some((d.ln(), (s / d).powi(2)));
        }
        if let Some(d) = cues_mm {
            measurements[1] = Some((d.ln(), self.settings.cue_sigma.powi(2)));
        }
        let mut state = self
            .state
            .map(|(x, p)| (x, p + self.settings.drift_per_frame.powi(2)));
        for (z, r) in measurements.into_iter().flatten() {
            state = Some(match state {
                None => (z, r),
                Some((x, p)) => {
                    let k = p / (p + r);
                    (x + k * (z - x), (1.0 - k) * p)
                }
            });
        }
        self.state = state;
        let (x, p) = state.unwrap_or((f64::NAN, f64::NAN));
        let fused_mm = x.exp();
        DistanceEvidence {
            keypoints_mm: keypoints.map(|k| k.0),
            keypoints_sigma_mm: keypoints.map(|k| k.1),
            cues_mm,
            fused_mm,
            fused_sigma_mm: fused_mm * p.sqrt(),
        }
    }
}

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_keypoints_average_out_and_a_steady_cue_bias_is_outweighed() {
        // The keypoints scatter +-6% about 500 mm; the cues say 560 every frame.
        let mut f = DistanceFilter::new(DistanceSettings::default());
        let mut last = None;
        for i in 0..60 {
            let noise = if i % 2 == 0 { 1.06 } else { 0.94 };
            last = Some(f.update(Some((500.0 * noise, 30.0)), Some(560.0)));
        }
        let e = last.unwrap();
        // Inverse variance: keypoints 6%, cues 10% -> 0.735 of the way to the keypoints.
        assert!(e.fused_mm > 505.0 && e.fused_mm < 530.0, "{e:?}");
        assert!(e.fused_sigma_mm < 0.06 * 500.0, "{e:?}");
    }

    #[test]
    fn nothing_seen_gives_nan_and_bad_numbers_are_left_out() {
        let mut f = DistanceFilter::new(DistanceSettings::default());
        assert!(f.update(None, None).fused_mm.is_nan());
        let e = f.update(Some((f64::NAN, 3.0)), Some(400.0));
        assert_eq!(e.keypoints_mm, None);
        assert!((e.fused_mm - 400.0).abs() < 1e-9);
        // Then only drift: the distance stays and its uncertainty grows.
        let later = f.update(None, Some(-1.0));
        assert!((later.fused_mm - 400.0).abs() < 1e-9);
        assert!(later.fused_sigma_mm > e.fused_sigma_mm);
        assert!(f.has_seen());
        f.reset();
        assert!(!f.has_seen());
        assert!(f.update(None, None).fused_mm.is_nan());
    }
}
