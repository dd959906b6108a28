//! `MAX_POOL_2D` on channels-last tensors, with the palm detectors' channel padding folded
//! in: the same bits as tract's `MaxPool` (and `Pad`).
//!
//! tract's `MaxPool` on NHWC fills its output with `f32::MIN`, then folds each of the
//! window's taps into it, a pass over the output row per tap; the palm detectors then pad
//! the result with zero channels (`PAD`) into a second tensor. Here each output pixel's
//! window is folded in registers and stored once, the zero channels after it. The fold is
//! tract's, `if v > m { m = v }` from `f32::MIN` over the taps inside the image in the same
//! order (a NaN never replaces, of two equal values the first stays): the same bits.

use tract_core::internal::*;

use crate::depthwise::axis_geometry;

/// Max pooling of an `[N, H, W, C]` f32 tensor with TFLite's padding rule (SAME: windows
/// clipped to the image), followed by `pad_channels` channels of zeros.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NhwcMaxPool {
    /// Window height and width.
    pub kernel: (usize, usize),
    /// Strides (y, x).
    pub strides: (usize, usize),
    /// TFLite SAME padding (else VALID).
    pub same: bool,
    /// Zero channels written after the pooled ones (a `PAD` of the channel axis folded in).
    pub pad_channels: usize,
}

impl NhwcMaxPool {
    fn output_shape(&self, h: usize, w: usize) -> (usize, usize, usize, usize) {
        let (oh, pt) = axis_geometry(h, self.kernel.0, self.strides.0, self.same);
        let (ow, pl) = axis_geometry(w, self.kernel.1, self.strides.1, self.same);
        (oh, ow, pt, pl)
    }
}

impl Op for NhwcMaxPool {
    fn name(&self) -> StaticName {
        "MonohandNhwcMaxPool".into()
    }

    op_as_typed_op!();
}

impl EvalOp for NhwcMaxPool {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let shape = input.shape();
        let (n, h, w, c) = crate::nhwc(shape, "max pool")?;
        let (kh, kw) = self.kernel;
        let (sy, sx) = self.strides;
        ensure!(
            kh > 0 && kw > 0 && sy > 0 && sx > 0,
            "max pool: empty window or stride"
        );
        let (oh, ow, pt, pl) = self.output_shape(h, w);
        let co = c + self.pad_channels;
        let mut output = Tensor::zero::<f32>(&[n, oh, ow, co])?;
        let src = input.try_as_plain_ram()?;
        let src = src.as_slice::<f32>()?;
        {
            let mut dst = output.try_as_plain_ram_mut()?;
            let dst = dst.as_slice_mut::<f32>()?;
            if c > 0 && oh * ow > 0 && h * w > 0 {
                for (image, out) in src
                    .chunks_exact(h * w * c)
                    .zip(dst.chunks_exact_mut(oh * ow * co))
                {
                    pool(image, (h, w, c), self, (oh, ow, pt, pl), out);
                }
            }
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

/// One image: `src` `h x w x c`, `dst` `oh x ow x (c + pad)` (its pad channels left as
/// they are: zeros).
fn pool(
    src: &[f32],
    (h, w, c): (usize, usize, usize),
    op: &NhwcMaxPool,
    (oh, ow, pt, pl): (usize, usize, usize, usize),
    dst: &mut [f32],
) {
    let co = c + op.pad_channels;
    let (kh, kw) = op.kernel;
    let (sy, sx) = op.strides;
    // The taps inside the image of an output coordinate: [k0, k1).
    let valid = |o: usize, s: usize, p: usize, k: usize, len: usize| {
        let start = (o * s) as isize - p as isize;
        let k0 = (-start).max(0) as usize;
        let k1 = ((len as isize - start).max(0) as usize).min(k);
        (start, k0, k1)
    };
    for oy in 0..oh {
        let (y0, ky0, ky1) = valid(oy, sy, pt, kh, h);
        for ox in 0..ow {
            let (x0, kx0, kx1) = valid(ox, sx, pl, kw, w);
            let out = &mut dst[(oy * ow + ox) * co..][..c];
            out.fill(f32::MIN);
            for ky in ky0..ky1 {
                let y = (y0 + ky as isize) as usize;
                for kx in kx0..kx1 {
                    let x = (x0 + kx as isize) as usize;
                    let tap = &src[(y * w + x) * c..][..c];
                    for (m, &v) in out.iter_mut().zip(tap) {
                        // tract's fold: a NaN never replaces, of equal values the first
                        // stays.
                        *m = if v > *m { v } else { *m };
                    }
                }
            }
        }
    }
}

impl TypedOp for NhwcMaxPool {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = inputs[0]
            .shape
            .as_concrete()
            .context("max pool needs a concrete input shape")?;
        ensure!(
            shape.len() == 4 && inputs[0].datum_type == f32::datum_type(),
            "max pool: an f32 [N, H, W, C] input is needed"
        );
        let (oh, ow, _, _) = self.output_shape(shape[1], shape[2]);
        Ok(tvec!(f32::fact([
            shape[0],
            oh,
            ow,
            shape[3] + self.pad_channels
        ])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split::testing::tensor_bits as bits;
    use tract_core::ops::array::{Pad, PadMode};
    use tract_core::ops::cnn::{MaxPool, PaddingSpec, PoolSpec};
    use tract_core::ops::nn::DataFormat;

    /// tract's `MaxPool` (then `Pad` of the channel axis), as the importer wired them.
    fn tract_pool(x: &Tensor, op: &NhwcMaxPool) -> Tensor {
        let c = x.shape()[3];
        let mut model = TypedModel::default();
        let src = model.add_source("x", f32::fact(x.shape())).expect("source");
        let spec = PoolSpec {
            data_format: DataFormat::NHWC,
            kernel_shape: tvec!(op.kernel.0, op.kernel.1),
            padding: if op.same {
                PaddingSpec::SameUpper
            } else {
                PaddingSpec::Valid
            },
            strides: Some(tvec!(op.strides.0, op.strides.1)),
            dilations: None,
            input_channels: c,
            output_channels: c,
        };
        let mut y = model
            .wire_node(
                "pool",
                MaxPool {
                    pool_spec: spec,
                    with_index_outputs: None,
                },
                &[src],
            )
            .expect("pool")[0];
        if op.pad_channels > 0 {
            let pad = Pad {
                pads: vec![(0, 0), (0, 0), (0, 0), (0, op.pad_channels)],
                mode: PadMode::Constant(Arc::new(tensor0(0f32))),
            };
            y = model.wire_node("pad", pad, &[y]).expect("pad")[0];
        }
        model.select_output_outlets(&[y]).expect("outputs");
        let plan = model
            .into_optimized()
            .expect("optimised")
            .into_runnable()
            .expect("plan");
        plan.run(tvec!(x.clone().into_tvalue()))
            .expect("run")
            .remove(0)
            .into_tensor()
    }

    /// The palm detectors' pools (2x2, stride 2, VALID, channels doubled by the pad) and
    /// the landmark network's, odd sizes with SAME and VALID, 3x3 windows with stride 1
    /// and 2; values with ties, signed zeros, infinities and NaN: tract's bits.
    #[test]
    fn same_bits_as_tract() {
        let cases = [
            ((1, 96, 96, 32), (2, 2), (2, 2), false, 32),
            ((1, 12, 12, 256), (2, 2), (2, 2), false, 0),
            ((1, 112, 112, 16), (2, 2), (2, 2), false, 0),
            ((2, 7, 9, 5), (3, 3), (2, 2), true, 3),
            ((1, 7, 9, 5), (3, 3), (2, 2), false, 0),
            ((1, 6, 5, 4), (3, 2), (1, 1), true, 0),
            ((1, 5, 5, 3), (2, 2), (2, 2), true, 1),
        ];
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for (shape, kernel, strides, same, pad_channels) in cases {
            let len = shape.0 * shape.1 * shape.2 * shape.3;
            let specials = [
                0.0f32,
                -0.0,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NAN,
                1.0,
            ];
            let values: Vec<f32> = (0..len)
                .map(|i| {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    if i % 17 == 3 {
                        specials[(seed % 6) as usize]
                    } else {
                        ((seed >> 44) % 64) as f32 / 8.0 - 4.0
                    }
                })
                .collect();
            let x =
                Tensor::from_shape(&[shape.0, shape.1, shape.2, shape.3], &values).expect("input");
            let op = NhwcMaxPool {
                kernel,
                strides,
                same,
                pad_channels,
            };
            let ours = op
                .eval(&EvalContext::out_of_plan(), tvec!(x.clone().into_tvalue()))
                .expect("pool")
                .remove(0)
                .into_tensor();
            let theirs = tract_pool(&x, &op);
            assert_eq!(ours.shape(), theirs.shape(), "{shape:?} {kernel:?}");
            assert_eq!(
                bits(&ours),
                bits(&theirs),
                "{shape:?} {kernel:?} {strides:?}"
            );
        }
    }

    #[test]
    fn malformed_inputs_are_errors() {
        let op = NhwcMaxPool {
            kernel: (2, 2),
            strides: (2, 2),
            same: false,
            pad_channels: 0,
        };
        let rank3 = Tensor::zero::<f32>(&[2, 2, 3]).expect("t");
        assert!(op
            .eval(&EvalContext::out_of_plan(), tvec!(rank3.into_tvalue()))
            .is_err());
        let ints = Tensor::zero::<i32>(&[1, 2, 2, 3]).expect("t");
        assert!(op
            .eval(&EvalContext::out_of_plan(), tvec!(ints.into_tvalue()))
            .is_err());
        let empty = Tensor::zero::<f32>(&[1, 0, 4, 3]).expect("t");
        let out = op
            .eval(&EvalContext::out_of_plan(), tvec!(empty.into_tvalue()))
            .expect("an empty image pools to an empty image");
        assert_eq!(out[0].shape(), &[1, 0, 2, 3]);
    }
}
