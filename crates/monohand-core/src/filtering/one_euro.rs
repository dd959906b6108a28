//! The One Euro filter (Casiez, Roussel, Vogel: "1€ Filter: A Simple
//! Speed-based Low-pass Filter for Noisy Input in Interactive Systems", CHI 2012)
//! for arrays of 3D points such as the 21 fitted joints.
//!
//! Each sample is smoothed by an exponential low-pass filter whose cutoff
//! frequency grows with the speed of the point:
//!
//! ```text
//! alpha(fc, dt) = 1 / (1 + tau / dt),   tau = 1 / (2 pi fc)
//! dx_hat = lowpass(d_cutoff)( (x - x_hat_prev) / dt )          (velocity, smoothed)
//! fc     = min_cutoff + beta * |dx_hat|
//! x_hat  = lowpass(fc)(x)
//! ```
//!
//! Units: timestamps in **seconds**, positions in the caller's unit — for
//! joints in the camera frame, **millimetres**, so speeds are mm/s and `beta`
//! is in Hz per (mm/s). The speed of a joint is the norm of its 3D velocity
//! (one cutoff per joint, the same for x, y and z), so smoothing does not depend
//! on the orientation of the camera.
//!
//! Defaults ([`OneEuroParams::default`]): `min_cutoff = 1.0` Hz (a still hand
//! at 30 fps is averaged over about 5 frames), `beta = 0.01` Hz per mm/s (a
//! joint moving at 500 mm/s is filtered at about 6 Hz, i.e. with little lag),
//! `d_cutoff = 1.0` Hz. Lower `min_cutoff` for less jitter, raise `beta` for
//! less lag on fast moves.
//!
//! ```
//! use monohand_core::filtering::{JointFilter, OneEuroParams};
//! let mut f = JointFilter::new(OneEuroParams::default());
//! let joints = [[10.0, -5.0, 450.0]; 21];
//! let out = f.filter(0.0, &joints);
//! assert_eq!(out, joints); // the first sample passes unchanged
//! ```

use crate::hand_model::NUM_JOINTS;

/// The parameters of a [`OneEuroFilter`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneEuroParams {
    /// Cutoff frequency at zero speed, Hz. Lower: less jitter when still, more lag.
    pub min_cutoff: f64,
    /// Increase of the cutoff per unit of speed, Hz per (unit/s) (per mm/s for joints in mm).
    pub beta: f64,
    /// Cutoff frequency of the velocity estimate, Hz.
    pub d_cutoff: f64,
}

impl Default for OneEuroParams {
    /// `min_cutoff = 1.0` Hz, `beta = 0.01` Hz per mm/s, `d_cutoff = 1.0` Hz.
    fn default() -> OneEuroParams {
        OneEuroParams {
            min_cutoff: 1.0,
            beta: 0.01,
            d_cutoff: 1.0,
        }
    }
}

/// Smoothing factor of an exponential filter with cutoff `fc` (Hz) at time step `dt` (s).
fn alpha(fc: f64, dt: f64) -> f64 {
    let tau = 1.0 / (2.0 * std::f64::consts::PI * fc.max(1e-9));
    1.0 / (1.0 + tau / dt)
}

/// The state of one point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PointState {
    x: [f64; 3],
    dx: [f64; 3],
}

/// A One Euro filter over `N` 3D points, driven by timestamps.
///
/// The first sample (and the first after [`OneEuroFilter::reset`]) passes
/// unchanged. A timestamp that does not increase (a seek backwards, or a
/// repeated frame) restarts the filter at that sample. Non-finite input
/// coordinates are returned as given and leave that point's state untouched,
/// so one bad joint cannot poison later frames.
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuroFilter<const N: usize> {
    params: OneEuroParams,
    last_t: Option<f64>,
    state: [Option<PointState>; N],
}

/// A One Euro filter for the 21 hand joints.
pub type JointFilter = OneEuroFilter<NUM_JOINTS>;

impl<const N: usize> OneEuroFilter<N> {
    /// A filter with these parameters (non-positive or non-finite frequencies
    /// are replaced by the defaults, a negative or non-finite `beta` by 0).
    pub fn new(params: OneEuroParams) -> OneEuroFilter<N> {
        let d = OneEuroParams::default();
        let freq = |f: f64, def: f64| if f.is_finite() && f > 0.0 { f } else { def };
        OneEuroFilter {
            params: OneEuroParams {
                min_cutoff: freq(params.min_cutoff, d.min_cutoff),
                beta: if params.beta.is_finite() && params.beta >= 0.0 {
                    params.beta
                } else {
                    0.0
                },
                d_cutoff: freq(params.d_cutoff, d.d_cutoff),
            },
            last_t: None,
            state: [None; N],
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> OneEuroParams {
        self.params
    }

    /// Forgets the past: the next sample passes unchanged (use when a track is lost).
    pub fn reset(&mut self) {
        self.last_t = None;
        self.state = [None; N];
    }

    /// Filters the sample `x` taken at time `t_s` (seconds) and returns the smoothed points.
    pub fn filter(&mut self, t_s: f64, x: &[[f64; 3]; N]) -> [[f64; 3]; N] {
        let dt = match self.last_t {
            Some(last) if t_s.is_finite() && t_s > last => Some(t_s - last),
            _ => None,
        };
        if dt.is_none() {
            self.reset();
        }
        if t_s.is_finite() {
            self.last_t = Some(t_s);
        }
        let p = self.params;
        let mut out = *x;
        for (j, xj) in x.iter().enumerate() {
            if xj.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let (Some(dt), Some(prev)) = (dt, self.state[j]) else {
                self.state[j] = Some(PointState {
                    x: *xj,
                    dx: [0.0; 3],
                });
                continue;
            };
            let ad = alpha(p.d_cutoff, dt);
            let mut dx = [0.0; 3];
            for k in 0..3 {
                let raw = (xj[k] - prev.x[k]) / dt;
                dx[k] = ad * raw + (1.0 - ad) * prev.dx[k];
            }
            let speed = (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt();
            let a = alpha(p.min_cutoff + p.beta * speed, dt);
            let mut xs = [0.0; 3];
            for k in 0..3 {
                xs[k] = a * xj[k] + (1.0 - a) * prev.x[k];
            }
            self.state[j] = Some(PointState { x: xs, dx });
            out[j] = xs;
        }
        out
    }
}

impl<const N: usize> Default for OneEuroFilter<N> {
    fn default() -> Self {
        OneEuroFilter::new(OneEuroParams::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};
    use rand_distr::Normal;

    const FPS: f64 = 30.0;

    #[test]
    fn constant_signal_passes_unchanged() {
        let mut f = JointFilter::default();
        let x: [[f64; 3]; NUM_JOINTS] =
            std::array::from_fn(|j| [j as f64, -2.0 * j as f64, 400.0 + j as f64]);
        for i in 0..100 {
            let y = f.filter(i as f64 / FPS, &x);
            for j in 0..NUM_JOINTS {
                for k in 0..3 {
                    assert!((y[j][k] - x[j][k]).abs() < 1e-9, "frame {i}");
                }
            }
        }
    }

    #[test]
    fn noise_on_a_still_hand_is_reduced() {
        let mut rng = StdRng::seed_from_u64(7);
        let noise = Normal::new(0.0, 2.0).unwrap();
        let truth = [0.0, 0.0, 500.0];
        let mut f = OneEuroFilter::<1>::default();
        let (mut e_in, mut e_out) = (0.0, 0.0);
        for i in 0..600 {
            let x = [[
                truth[0] + rng.sample(noise),
                truth[1] + rng.sample(noise),
                truth[2] + rng.sample(noise),
            ]];
            let y = f.filter(i as f64 / FPS, &x);
            if i >= 30 {
                for k in 0..3 {
                    e_in += (x[0][k] - truth[k]).powi(2);
                    e_out += (y[0][k] - truth[k]).powi(2);
                }
            }
        }
        let ratio = (e_out / e_in).sqrt();
        assert!(
            ratio < 0.5,
            "rms noise only reduced to {ratio:.2} of the input"
        );
    }

    #[test]
    fn a_step_is_followed_with_bounded_lag() {
        let mut f = OneEuroFilter::<1>::default();
        let mut last = 0.0;
        let mut settled_at = None;
        for i in 0..60 {
            let t = i as f64 / FPS;
            let target = if t >= 1.0 { 100.0 } else { 0.0 };
            let y = f.filter(t, &[[target, 0.0, 500.0]])[0][0];
            assert!(y >= last - 1e-9 && y <= 100.0 + 1e-9, "no overshoot: {y}");
            last = y;
            if t >= 1.0 && settled_at.is_none() && (100.0 - y) < 5.0 {
                settled_at = Some(t - 1.0);
            }
        }
        let lag = settled_at.expect("the step is never reached");
        // Within 5 % of a 100 mm step in at most 0.2 s (6 frames at 30 fps);
        // a fixed 1 Hz low-pass would take about 0.5 s.
        assert!(lag <= 0.2 + 1e-9, "settled after {lag} s");
        assert!(lag > 0.0, "some smoothing is expected");
    }

    #[test]
    fn reset_time_going_back_and_bad_values() {
        let mut f = OneEuroFilter::<2>::default();
        f.filter(0.0, &[[0.0; 3], [0.0; 3]]);
        let y = f.filter(0.1, &[[10.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0]]);
        assert!(y[0][0] > 0.0 && y[0][0] < 10.0);
        assert!(y[1][0].is_nan());
        // Point 1's state survived the NaN: a zero sample is still zero.
        let y = f.filter(0.2, &[[10.0, 0.0, 0.0], [0.0; 3]]);
        assert_eq!(y[1], [0.0; 3]);
        // Going back in time restarts: the sample passes unchanged.
        let y = f.filter(0.05, &[[42.0, 1.0, 2.0], [3.0; 3]]);
        assert_eq!(y, [[42.0, 1.0, 2.0], [3.0; 3]]);
        f.reset();
        let y = f.filter(5.0, &[[-7.0; 3], [7.0; 3]]);
        assert_eq!(y, [[-7.0; 3], [7.0; 3]]);
        // Bad parameters fall back to usable ones.
        let g = JointFilter::new(OneEuroParams {
            min_cutoff: 0.0,
            beta: f64::NAN,
            d_cutoff: -1.0,
        });
        assert_eq!(g.params().min_cutoff, 1.0);
        assert_eq!(g.params().beta, 0.0);
        assert_eq!(g.params().d_cutoff, 1.0);
    }
}
