//! `RESIZE_BILINEAR` on channels-last tensors in one pass, the same bits as tract's
//! [`Resize`].
//!
//! tract's `Resize` copies its input, then resamples one axis at a time into a new
//! buffer each (rows, then columns), an element at a time over the inner axes. The palm
//! detectors' two upsamplings (6x6 and 12x12 to twice their size, 256 channels) took
//! 0.1-0.25 ms of palm_detection_full's 3.3-4.6 ms in `profile_net`. Here each output row
//! is interpolated between its two input rows into a buffer of one row, then between
//! columns into the output, with the same plans (tract's [`Resize::plan_axis`]) and the same
//! sums in the same order, `(0 + w0·a) + w1·b` with zero weights skipped: the same bits.

use std::cell::RefCell;

use tract_core::internal::*;
use tract_core::ops::nn::resize::AxisPlan;
use tract_core::ops::nn::{CoordTransformer, Interpolator, Nearest, Resize};

/// Bilinear resampling of an `[N, H, W, C]` f32 tensor to `[N, OH, OW, C]`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NhwcResizeBilinear {
    /// How an output coordinate maps to the input (from the TFLite options).
    pub coord_transformer: CoordTransformer,
    /// The output's height and width.
    pub size: (usize, usize),
}

impl NhwcResizeBilinear {
    /// The plan of one axis, as tract's [`Resize`] makes it in `eval`: the scale is the
    /// ratio of the lengths, in f32.
    fn plan(&self, len_in: usize, len_out: usize) -> AxisPlan {
        let op = Resize {
            coord_transformer: self.coord_transformer.clone(),
            interpolator: Interpolator::Linear,
            nearest: Nearest::Floor,
            optional_scales_input: None,
            optional_sizes_input: None,
        };
        op.plan_axis(len_out as f32 / len_in as f32, len_in, len_out)
    }
}

impl Op for NhwcResizeBilinear {
    fn name(&self) -> StaticName {
        "MonohandNhwcResizeBilinear".into()
    }

    op_as_typed_op!();
}

thread_local! {
    /// One row interpolated between two input rows (`W·C` values), reused.
    static ROW: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

impl EvalOp for NhwcResizeBilinear {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let shape = input.shape();
        let (n, h, w, c) = crate::nhwc(shape, "resize")?;
        let (oh, ow) = self.size;
        ensure!(
            h > 0 && w > 0 && oh > 0 && ow > 0,
            "resize: empty axis ({shape:?} to {oh}x{ow})"
        );
        let plain = input.try_as_plain_ram()?;
        let src = plain.as_slice::<f32>()?;
        // tract skips an axis whose length does not change (scale 1): the identity plan
        // gives the same values, `0 + 1·a`.
        let rows = self.plan(h, oh);
        let cols = self.plan(w, ow);
        // SAFETY: every value is written before anything reads it: each output row of each
        // image is one `chunks_exact_mut` piece, each of its pixels one piece whose values
        // `interpolate` all writes (a copy, a fill, or the first tap's pass).
        let mut output = unsafe { Tensor::uninitialized::<f32>(&[n, oh, ow, c])? };
        {
            let mut out = output.try_as_plain_ram_mut()?;
            let dst = out.as_slice_mut::<f32>()?;
            ROW.with(|row| {
                let mut row = row.borrow_mut();
                row.resize(w * c, 0.0);
                for (image, dst) in src
                    .chunks_exact(h * w * c)
                    .zip(dst.chunks_exact_mut(oh * ow * c))
                {
                    for (y, dst) in dst.chunks_exact_mut(ow * c).enumerate() {
                        interpolate(&rows, y, image, w * c, h != oh, &mut row);
                        for (x, dst) in dst.chunks_exact_mut(c).enumerate() {
                            interpolate(&cols, x, &row, c, w != ow, dst);
                        }
                    }
                }
            });
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

/// Output index `i` of an axis with `plan`, over `inner` values a step: `dst` =
/// `(0 + w0·src[i0]) + w1·src[i1]` with zero weights skipped (0 where all are), as tract's
/// `resample_axis` sums into a zeroed row, in one pass; or a copy of `src[i]` where the axis
/// keeps its length (tract skips it).
#[inline(always)]
fn interpolate(
    plan: &AxisPlan,
    i: usize,
    src: &[f32],
    inner: usize,
    resampled: bool,
    dst: &mut [f32],
) {
    if !resampled {
        dst.copy_from_slice(&src[i * inner..][..inner]);
        return;
    }
    if plan.extrapolated[i] {
        dst.fill(0.0);
        return;
    }
    let taps = &plan.indices[i * plan.window..][..plan.window];
    let weights = &plan.weights[i * plan.window..][..plan.window];
    let mut written = false;
    for (&t, &wt) in taps.iter().zip(weights) {
        if wt == 0.0 {
            continue;
        }
        let s = &src[t * inner..][..inner];
        if written {
            for (d, s) in dst.iter_mut().zip(s) {
                *d += wt * s;
            }
        } else {
            // `0 + w·s`, not `w·s`: the sum tract starts from 0 turns -0 into +0.
            for (d, s) in dst.iter_mut().zip(s) {
                *d = 0.0 + wt * s;
            }
            written = true;
        }
    }
    if !written {
        dst.fill(0.0);
    }
}

impl TypedOp for NhwcResizeBilinear {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = &inputs[0].shape;
        ensure!(shape.len() == 4, "resize: a rank-4 input is needed");
        ensure!(
            inputs[0].datum_type == f32::datum_type(),
            "resize: f32 only"
        );
        Ok(tvec!(f32::fact([
            shape[0].clone(),
            self.size.0.into(),
            self.size.1.into(),
            shape[3].clone()
        ])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split::testing::tensor_bits as bits;

    fn tract_resize(x: &Tensor, size: (usize, usize), ct: CoordTransformer) -> Tensor {
        let s = x.shape();
        let sizes = tensor1(&[s[0] as i64, size.0 as i64, size.1 as i64, s[3] as i64]);
        let op = Resize {
            coord_transformer: ct,
            interpolator: Interpolator::Linear,
            nearest: Nearest::Floor,
            optional_scales_input: None,
            optional_sizes_input: Some(1),
        };
        op.eval(
            &EvalContext::out_of_plan(),
            tvec!(x.clone().into_tvalue(), sizes.into_tvalue()),
        )
        .expect("tract resize")
        .remove(0)
        .into_tensor()
    }

    /// The palm detectors' shapes (6x6 and 12x12 doubled, 256 channels, half-pixel
    /// centres as their options say), odd and shrinking sizes, one axis unchanged, and
    /// every coordinate mode the importer maps: the same bits as tract's `Resize`.
    #[test]
    fn same_bits_as_tract() {
        let cases = [
            ((1, 6, 6, 256), (12, 12)),
            ((1, 12, 12, 256), (24, 24)),
            ((2, 5, 7, 3), (11, 4)),
            ((1, 9, 4, 17), (9, 13)),
            ((1, 1, 3, 2), (4, 1)),
        ];
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for (shape, size) in cases {
            let len = shape.0 * shape.1 * shape.2 * shape.3;
            let values: Vec<f32> = (0..len)
                .map(|_| {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    (seed >> 40) as f32 / (1u64 << 23) as f32 - 1.0
                })
                .collect();
            let x =
                Tensor::from_shape(&[shape.0, shape.1, shape.2, shape.3], &values).expect("input");
            for ct in [
                CoordTransformer::HalfPixel,
                CoordTransformer::AlignCorners,
                CoordTransformer::Asymmetric,
            ] {
                let ours = NhwcResizeBilinear {
                    coord_transformer: ct.clone(),
                    size,
                }
                .eval(&EvalContext::out_of_plan(), tvec!(x.clone().into_tvalue()))
                .expect("resize")
                .remove(0)
                .into_tensor();
                let theirs = tract_resize(&x, size, ct.clone());
                assert_eq!(
                    ours.shape(),
                    theirs.shape(),
                    "{shape:?} -> {size:?}, {ct:?}"
                );
                assert_eq!(bits(&ours), bits(&theirs), "{shape:?} -> {size:?}, {ct:?}");
            }
        }
    }

    #[test]
    fn malformed_inputs_are_errors() {
        let op = NhwcResizeBilinear {
            coord_transformer: CoordTransformer::HalfPixel,
            size: (4, 4),
        };
        let rank3 = Tensor::zero::<f32>(&[2, 2, 3]).expect("t");
        assert!(op
            .eval(&EvalContext::out_of_plan(), tvec!(rank3.into_tvalue()))
            .is_err());
        let empty = Tensor::zero::<f32>(&[1, 0, 2, 3]).expect("t");
        assert!(op
            .eval(&EvalContext::out_of_plan(), tvec!(empty.into_tvalue()))
            .is_err());
        let ints = Tensor::zero::<i32>(&[1, 2, 2, 3]).expect("t");
        assert!(op
            .eval(&EvalContext::out_of_plan(), tvec!(ints.into_tvalue()))
            .is_err());
    }
}
