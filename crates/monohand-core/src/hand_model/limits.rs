//! Anatomical joint limits for the 20 joint angles.
//!
//! Ranges follow clinical active range-of-motion tables (AAOS norms, Hume et al.
//! 1990, Kapandji): MCP flexion to about 90 degrees with some hyperextension, PIP to
//! about 110, DIP to about 90 with a little hyperextension; finger spread of
//! roughly +-20 degrees around the relaxed fan; thumb IP hyperextends up to
//! about 20 degrees. The paper (WACV 2018) used [0, 90] flexion and +-30
//! abduction everywhere; real hands need the hyperextension ranges here, which
//! the STB labels also contain.

use crate::hand_model::joints::Finger;
use crate::hand_model::params::{ANGLES_PER_FINGER, NUM_ANGLES};
use serde::{Deserialize, Serialize};

/// Lower and upper bound of every joint angle, radians.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointLimits {
    /// Lower bounds.
    pub lower: [f64; NUM_ANGLES],
    /// Upper bounds.
    pub upper: [f64; NUM_ANGLES],
}

/// Default ranges in degrees per finger: (base flexion, base abduction, middle flexion, distal flexion).
const DEFAULT_DEG: [[(f64, f64); ANGLES_PER_FINGER]; 5] = [
    // thumb: CMC flexion, CMC abduction, MCP flexion, IP flexion
    [(-30.0, 55.0), (-30.0, 55.0), (-15.0, 80.0), (-25.0, 90.0)],
    // index: MCP flexion, MCP abduction, PIP, DIP
    [(-30.0, 95.0), (-25.0, 25.0), (-5.0, 115.0), (-15.0, 90.0)],
    // middle
    [(-30.0, 95.0), (-20.0, 20.0), (-5.0, 115.0), (-15.0, 90.0)],
    // ring
    [(-30.0, 95.0), (-20.0, 20.0), (-5.0, 115.0), (-15.0, 90.0)],
    // little
    [(-30.0, 95.0), (-30.0, 30.0), (-5.0, 115.0), (-15.0, 90.0)],
];

impl Default for JointLimits {
    fn default() -> Self {
        let mut lower = [0.0; NUM_ANGLES];
        let mut upper = [0.0; NUM_ANGLES];
        for f in Finger::ALL {
            for k in 0..ANGLES_PER_FINGER {
                let (lo, hi) = DEFAULT_DEG[f.index()][k];
                lower[f.index() * ANGLES_PER_FINGER + k] = lo.to_radians();
                upper[f.index() * ANGLES_PER_FINGER + k] = hi.to_radians();
            }
        }
        JointLimits { lower, upper }
    }
}

impl JointLimits {
    /// Clamps every angle into its range.
    pub fn clamp(&self, angles: &mut [f64; NUM_ANGLES]) {
        for (i, a) in angles.iter_mut().enumerate() {
            *a = a.clamp(self.lower[i], self.upper[i]);
        }
    }

    /// True if every angle is inside its range (with a tolerance in radians).
    pub fn contains(&self, angles: &[f64; NUM_ANGLES], tol: f64) -> bool {
        angles
            .iter()
            .enumerate()
            .all(|(i, &a)| a >= self.lower[i] - tol && a <= self.upper[i] + tol)
    }

    /// The middle of every range, clamped to contain zero where possible: a neutral pose.
    pub fn neutral(&self) -> [f64; NUM_ANGLES] {
        std::array::from_fn(|i| 0.0f64.clamp(self.lower[i], self.upper[i]))
    }

    /// Checks that every range is finite and non-empty.
    pub fn validate(&self) -> crate::CoreResult<()> {
        for i in 0..NUM_ANGLES {
            let (lo, hi) = (self.lower[i], self.upper[i]);
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(crate::CoreError::InvalidSkeleton(format!(
                    "angle {i}: bad range [{lo}, {hi}]"
                )));
            }
        }
        Ok(())
    }
}
