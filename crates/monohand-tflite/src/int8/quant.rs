//! The int8 codes: activations in 7 bits per tensor ([`ActivationQuant`], from the range a
//! calibration observed, [`MinMax`]), weights in int8 per output channel ([`quantize_weights`]).

use tract_core::internal::*;

use super::{ACTIVATION_QMAX, WEIGHT_QMAX};

/// `a` if it is greater than `b`, else `b` (x86's `maxps` rule: `b` where either is NaN or
/// both are zeros), so that the portable and SIMD kernels give the same bits.
#[inline(always)]
pub(super) fn max_ps(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `a` if it is less than `b`, else `b` (x86's `minps` rule).
#[inline(always)]
pub(super) fn min_ps(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// How an f32 activation tensor is coded in 7 bits: `x ≈ scale · (q - zero_point)` with
/// `q` in `[0, 127]` ([`ACTIVATION_QMAX`]).
#[derive(Debug, Clone, Copy)]
pub struct ActivationQuant {
    pub(super) scale: f32,
    /// `1 / scale`, the factor the quantizer multiplies by.
    pub(super) inv_scale: f32,
    pub(super) zero_point: u8,
}

impl PartialEq for ActivationQuant {
    fn eq(&self, other: &Self) -> bool {
        self.scale.to_bits() == other.scale.to_bits() && self.zero_point == other.zero_point
    }
}

impl Eq for ActivationQuant {}

impl ActivationQuant {
    /// A code of step `scale` (finite, > 0) with `zero_point` (at most 127) coding 0.0.
    pub fn new(scale: f32, zero_point: u8) -> TractResult<Self> {
        ensure!(
            scale.is_finite() && scale > 0.0 && (1.0 / scale).is_finite(),
            "activation scale {scale} is not a finite positive number"
        );
        ensure!(
            zero_point <= ACTIVATION_QMAX,
            "activation zero point {zero_point} above {ACTIVATION_QMAX}"
        );
        Ok(ActivationQuant {
            scale,
            inv_scale: 1.0 / scale,
            zero_point,
        })
    }

    /// The code spanning observed values from `min` to `max` (widened to include 0.0, which
    /// is then coded exactly, as zero padding and RELU outputs need): the step is
    /// `(max - min) / 127` and the zero point the code nearest to 0.0. Non-finite or empty
    /// ranges give the step 1.
    pub fn from_min_max(min: f32, max: f32) -> Self {
        let (lo, hi) = (min.min(0.0), max.max(0.0));
        let mut scale = (hi - lo) / ACTIVATION_QMAX as f32;
        if !(scale.is_finite() && scale > 0.0 && (1.0 / scale).is_finite()) {
            scale = 1.0;
        }
        let zero = (-lo / scale)
            .round_ties_even()
            .clamp(0.0, ACTIVATION_QMAX as f32) as u8;
        ActivationQuant {
            scale,
            inv_scale: 1.0 / scale,
            zero_point: zero,
        }
    }

    /// The step between codes.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The code of 0.0.
    pub fn zero_point(&self) -> u8 {
        self.zero_point
    }

    /// The code of `x`: `round(x / scale) + zero_point` (ties to even, the division a
    /// multiplication by `1 / scale`), clamped to `[0, 127]`; NaN gives 0.
    #[inline(always)]
    pub fn quantize(&self, x: f32) -> u8 {
        let z = self.zero_point as f32;
        let t = (x * self.inv_scale).round_ties_even();
        let t = min_ps(max_ps(t, -z), ACTIVATION_QMAX as f32 - z);
        (t as i32 + self.zero_point as i32) as u8
    }

    /// The value code `q` stands for.
    pub fn dequantize(&self, q: u8) -> f32 {
        self.scale * (q as f32 - self.zero_point as f32)
    }
}

/// The smallest and largest finite values seen in a tensor over some runs: what
/// [`ActivationQuant::from_min_max`] is computed from (the calibration of a later step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinMax {
    /// The smallest finite value seen (`+inf` before any).
    pub min: f32,
    /// The largest finite value seen (`-inf` before any).
    pub max: f32,
}

impl Default for MinMax {
    fn default() -> Self {
        MinMax {
            min: f32::INFINITY,
            max: f32::NEG_INFINITY,
        }
    }
}

impl MinMax {
    /// Widens the range to the finite values of `values`.
    pub fn observe(&mut self, values: &[f32]) {
        for &v in values.iter().filter(|v| v.is_finite()) {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
        }
    }

    /// The code for the range seen so far (see [`ActivationQuant::from_min_max`]).
    pub fn quant(&self) -> ActivationQuant {
        ActivationQuant::from_min_max(self.min, self.max)
    }
}

/// Symmetric int8 codes of one output channel's weights and their scale `max|w| / 127`
/// (1 for an all-zero channel).
pub fn quantize_weights(w: &[f32]) -> (Vec<i8>, f32) {
    let max = w
        .iter()
        .filter(|v| v.is_finite())
        .fold(0f32, |m, v| m.max(v.abs()));
    let scale = if max > 0.0 && (max / WEIGHT_QMAX as f32) > 0.0 {
        max / WEIGHT_QMAX as f32
    } else {
        1.0
    };
    let q = w
        .iter()
        .map(|&v| {
            (v / scale)
                .round_ties_even()
                .clamp(-(WEIGHT_QMAX as f32), WEIGHT_QMAX as f32) as i8
        })
        .collect();
    (q, scale)
}
