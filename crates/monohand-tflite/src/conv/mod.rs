//! A `K x K` convolution over few input channels (the networks' stems), channels last.
//!
//! The first layer of MediaPipe's hand networks is a 3x3 stride-2 convolution of the RGB
//! crop (palm: 5x5), followed by RELU6 (palm: PRELU). tract 0.23 runs it as a `Pad` that
//! copies the whole image, an im2col matrix product, and the activation as a third pass over
//! the output; in hand_landmark_lite that was about a fifth of the time for 5 % of the
//! multiply-adds. This operator gathers the im2col rows of a few output rows at a time into
//! a buffer that stays in cache, writing zeros for the padding (TFLite's rule: SAME pads at
//! the bottom/right first), and multiplies them with [`PointwiseConv`]'s packed weights and
//! micro-kernels, bias and activation applied in registers. The columns are in tract's
//! order (channel, then kernel row, then column) and the bias is added after the sum, as
//! tract does, so the results are the same bits as tract's `Conv` (checked in a test
//! against tract's own operator).

use tract_core::internal::*;

use crate::depthwise::axis_geometry;
use crate::int8::{ActivationQuant, PointwiseConvInt8};
use crate::pointwise::{Kernel, PointwiseConv};
use crate::pointwise_common::Activation;

/// Floats of im2col rows gathered per product (64 KiB: the buffer stays in L2 while the
/// product runs over it).
const BAND_FLOATS: usize = 16 * 1024;

thread_local! {
    /// Each thread's im2col band, grown to the largest needed and reused.
    static BAND: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
    /// Each thread's coded input rows and im2col band of codes ([`NhwcConvInt8`]), as `BAND`.
    static CODES: std::cell::RefCell<(Vec<u8>, Vec<u8>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// im2col codes gathered per product of [`NhwcConvInt8`] (16 KiB: in L1 while the product
/// runs over it).
const BAND_CODES: usize = 16 * 1024;

/// The window of a stem ([`NhwcConv`], [`NhwcConvInt8`]): `KH x KW` over `Cin` channels,
/// strides `(sy, sx)`, TFLite's SAME (or VALID) padding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct StemShape {
    kh: usize,
    kw: usize,
    cin: usize,
    strides: (usize, usize),
    same: bool,
}

impl StemShape {
    /// Output height, width and leading padding (top, left) for an `h x w` input.
    fn geometry(&self, h: usize, w: usize) -> (usize, usize, usize, usize) {
        let (oh, pt) = axis_geometry(h, self.kh, self.strides.0, self.same);
        let (ow, pl) = axis_geometry(w, self.kw, self.strides.1, self.same);
        (oh, ow, pt, pl)
    }

    /// The convolution of `src` (`h x w x Cin`) into `out` (`oh x ow x cout`): checks the
    /// sizes and has `rows(first, out_rows)` compute disjoint pieces of the output rows that
    /// together cover them, shared between the cores with `split` ([`crate::split`]).
    fn compute(
        &self,
        src: &[f32],
        (h, w): (usize, usize),
        out: &mut [f32],
        (cout, split): (usize, bool),
        rows: impl Fn(usize, &mut [f32]) -> TractResult<()> + Sync,
    ) -> TractResult<()> {
        let (oh, ow, _, _) = self.geometry(h, w);
        ensure!(
            src.len() == h * w * self.cin && out.len() == oh * ow * cout,
            "convolution: inconsistent buffer sizes"
        );
        if oh == 0 || ow == 0 || cout == 0 {
            return Ok(());
        }
        let work = out.len() * self.kh * self.kw * self.cin;
        crate::split::team().rows(out, ow * cout, 1, work, split, &rows)
    }

    /// The `eval` of a stem: checks the input (`[1, H, W, Cin]`), makes the output (`[1, oh,
    /// ow, cout]`) and has `compute(input, (H, W), output)` write every one of its values.
    fn eval(
        &self,
        inputs: TVec<TValue>,
        cout: usize,
        compute: impl FnOnce(&[f32], (usize, usize), &mut [f32]) -> TractResult<()>,
    ) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let shape = input.shape();
        let cin = self.cin;
        ensure!(
            shape.len() == 4 && shape[0] == 1 && shape[3] == cin,
            "convolution over {cin} channels expects [1, H, W, {cin}], got {shape:?}"
        );
        let (h, w) = (shape[1], shape[2]);
        let (oh, ow, _, _) = self.geometry(h, w);
        // SAFETY: the tensor's values are left unwritten, and nothing reads one before it is
        // written: `compute` (each stem's) has the product's epilogue store every output value
        // (every row goes to exactly one piece, each piece's bands cover its rows, and the
        // product writes all of a band's rows and channels), and an error drops the tensor
        // without reading it (f32 has no drop).
        let mut output = unsafe { Tensor::uninitialized::<f32>(&[1, oh, ow, cout])? };
        {
            let src = input.try_as_plain_ram()?;
            let mut dst = output.try_as_plain_ram_mut()?;
            compute(src.as_slice::<f32>()?, (h, w), dst.as_slice_mut::<f32>()?)?;
        }
        Ok(tvec!(output.into_tvalue()))
    }

    /// The output fact of a stem with `cout` outputs.
    fn facts(&self, inputs: &[&TypedFact], cout: usize) -> TractResult<TVec<TypedFact>> {
        let shape = inputs[0]
            .shape
            .as_concrete()
            .context("convolution needs a concrete input shape")?;
        ensure!(
            shape.len() == 4 && shape[3] == self.cin,
            "convolution over {} channels, input {shape:?}",
            self.cin
        );
        let (oh, ow, _, _) = self.geometry(shape[1], shape[2]);
        Ok(tvec!(f32::fact([shape[0], oh, ow, cout])))
    }
}

/// `KH x KW` convolution with strides `(sy, sx)` on `[1, H, W, Cin]` f32 tensors, TFLite's
/// SAME (or VALID) padding, a bias per output channel and a fused activation.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NhwcConv {
    shape: StemShape,
    /// The product `[pixels, KH·KW·Cin] x [KH·KW·Cin, Cout]` with the epilogue.
    product: PointwiseConv,
    /// TFLite's OHWI weights, the bias and the activation, for [`to_int8`](Self::to_int8).
    weights: Arc<Tensor>,
    bias: Arc<Tensor>,
    activation: Activation,
    /// Share large outputs between the cores ([`crate::split`]).
    split: bool,
}

impl NhwcConv {
    /// From TFLite's OHWI `weights` (`[Cout, KH, KW, Cin]`), `bias` (`[Cout]`), strides
    /// `(y, x)`, SAME (else VALID) padding and the convolution's activation.
    pub fn new(
        weights: &Tensor,
        bias: &Tensor,
        strides: (usize, usize),
        same: bool,
        activation: Activation,
    ) -> TractResult<Self> {
        let s = weights.shape();
        ensure!(
            s.len() == 4 && s.iter().all(|&d| d > 0),
            "convolution weights must be a non-empty [Cout, KH, KW, Cin], got {s:?}"
        );
        ensure!(
            strides.0 > 0 && strides.1 > 0,
            "convolution strides {strides:?}"
        );
        let (cout, kh, kw, cin) = (s[0], s[1], s[2], s[3]);
        // The im2col columns in (channel, ky, kx) order, the order in which tract's im2col
        // product sums (so the results are the bits tract's `Conv` gave).
        let flat = weights
            .clone()
            .permute_axes(&[0, 3, 1, 2])?
            .into_shape(&[cout, kh * kw * cin])?;
        Ok(NhwcConv {
            shape: StemShape {
                kh,
                kw,
                cin,
                strides,
                same,
            },
            product: PointwiseConv::new(&flat, bias, activation)?,
            weights: Arc::new(weights.clone()),
            bias: Arc::new(bias.clone()),
            activation,
            split: true,
        })
    }

    /// The same convolution in int8 ([`NhwcConvInt8`]), its input coded with `input`.
    pub fn to_int8(&self, input: ActivationQuant) -> TractResult<NhwcConvInt8> {
        let s = self.weights.shape();
        let (cout, kdim) = (s[0], s[1] * s[2] * s[3]);
        let kp = kdim.div_ceil(4) * 4;
        // OHWI rows, (ky, kx, c) order: the order of the image's bytes in a window row.
        let w = self.weights.try_as_plain_ram()?;
        let w = w.as_slice::<f32>()?;
        let mut padded = vec![0f32; cout * kp];
        for (o, row) in padded.chunks_exact_mut(kp).enumerate() {
            row[..kdim].copy_from_slice(&w[o * kdim..(o + 1) * kdim]);
        }
        let padded = Tensor::from_shape(&[cout, kp], &padded)?;
        let product = PointwiseConvInt8::new(&padded, &self.bias, self.activation, input)?
            .with_split(false)
            .with_coded_input()?;
        Ok(NhwcConvInt8 {
            shape: self.shape,
            product,
            split: self.split,
        })
    }

    /// Whether large outputs are shared between the cores when the network runs alone
    /// (default: true; see `ImportOptions::split_rows`). The results are the same bits.
    pub fn with_split(mut self, split: bool) -> Self {
        self.split = split;
        self
    }

    /// The convolution of `src` (`h x w x Cin`) into `out` (`oh x ow x Cout`).
    fn compute(
        &self,
        src: &[f32],
        hw: (usize, usize),
        out: &mut [f32],
        kernel: Kernel,
    ) -> TractResult<()> {
        let cout = self.product.output_channels();
        self.shape
            .compute(src, hw, out, (cout, self.split), |first, o| {
                self.compute_rows(src, hw, first, o, kernel)
            })
    }

    /// Output rows `first ..` of the convolution (as many as `out` holds), sizes checked by
    /// [`compute`](Self::compute).
    fn compute_rows(
        &self,
        src: &[f32],
        (h, w): (usize, usize),
        first: usize,
        out: &mut [f32],
        kernel: Kernel,
    ) -> TractResult<()> {
        let (_, ow, pt, pl) = self.shape.geometry(h, w);
        let StemShape {
            kh,
            kw,
            cin,
            strides: (sy, sx),
            ..
        } = self.shape;
        let cout = self.product.output_channels();
        let kdim = kh * kw * cin;
        let oh = out.len() / (ow * cout);
        let band = (BAND_FLOATS / (ow * kdim)).max(1);
        // The band is this thread's, kept between calls: no allocation per network call
        // once it has grown to the largest band (64 KiB unless one output row is wider).
        // Every column is written before the product reads it. (An error below drops the
        // buffer; the next call makes a new one.)
        let mut buf = BAND.take();
        if buf.len() < band.min(oh) * ow * kdim {
            buf.resize(band.min(oh) * ow * kdim, 0.0);
        }
        let mut oy0 = 0;
        while oy0 < oh {
            let rows = band.min(oh - oy0);
            let cols = &mut buf[..rows * ow * kdim];
            for (p, col) in cols.chunks_exact_mut(kdim).enumerate() {
                let (oy, ox) = (first + oy0 + p / ow, p % ow);
                let iy0 = (oy * sy) as isize - pt as isize;
                let ix0 = (ox * sx) as isize - pl as isize;
                // Column (c, ky, kx) at (c·KH + ky)·KW + kx.
                if iy0 >= 0 && ix0 >= 0 && iy0 as usize + kh <= h && ix0 as usize + kw <= w {
                    // The whole window is inside the image.
                    let window = &src[(iy0 as usize * w + ix0 as usize) * cin..];
                    match (cin, kh, kw) {
                        // The landmark networks' stem, with the sizes known to the compiler.
                        (3, 3, 3) => {
                            gather_inside::<3, 3, 3>(window, w * cin, col);
                            continue;
                        }
                        (3, 5, 5) => {
                            gather_inside::<3, 5, 5>(window, w * cin, col);
                            continue;
                        }
                        _ => {}
                    }
                    let mut taps = col.iter_mut();
                    for c in 0..cin {
                        for ky in 0..kh {
                            let row = &window[ky * w * cin + c..];
                            // The row's `kw` taps first: `zip` then stops without taking
                            // one more column.
                            for (&v, t) in row.iter().step_by(cin).take(kw).zip(taps.by_ref()) {
                                *t = v;
                            }
                        }
                    }
                    continue;
                }
                for ky in 0..kh {
                    let iy = iy0 + ky as isize;
                    let row = (iy >= 0 && iy < h as isize)
                        .then(|| &src[iy as usize * w * cin..][..w * cin]);
                    for kx in 0..kw {
                        let ix = ix0 + kx as isize;
                        let tap = row
                            .filter(|_| ix >= 0 && ix < w as isize)
                            .map(|row| &row[ix as usize * cin..][..cin]);
                        for c in 0..cin {
                            col[(c * kh + ky) * kw + kx] = tap.map_or(0.0, |t| t[c]);
                        }
                    }
                }
            }
            let o = &mut out[oy0 * ow * cout..(oy0 + rows) * ow * cout];
            self.product.compute(cols, None, o, kernel, false)?;
            oy0 += rows;
        }
        BAND.set(buf);
        Ok(())
    }
}

impl Op for NhwcConv {
    fn name(&self) -> StaticName {
        "MonohandNhwcConv".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        Ok(vec![format!(
            "{}x{} stride {:?} same {} {}->{}",
            self.shape.kh,
            self.shape.kw,
            self.shape.strides,
            self.shape.same,
            self.shape.cin,
            self.product.output_channels()
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for NhwcConv {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        self.shape
            .eval(inputs, self.product.output_channels(), |src, hw, dst| {
                self.compute(src, hw, dst, Kernel::best())
            })
    }
}

impl TypedOp for NhwcConv {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        self.shape.facts(inputs, self.product.output_channels())
    }
}

mod int8;

pub use int8::NhwcConvInt8;

/// The im2col columns of a window inside the image (`window` starts at its top left tap,
/// rows `stride` floats apart), in (channel, kernel row, column) order, for sizes known at
/// compile time: the same values as the general loop.
#[inline(always)]
fn gather_inside<const C: usize, const KH: usize, const KW: usize>(
    window: &[f32],
    stride: usize,
    col: &mut [f32],
) {
    let window = &window[..(KH - 1) * stride + KW * C];
    let col = &mut col[..C * KH * KW];
    for c in 0..C {
        for ky in 0..KH {
            for kx in 0..KW {
                col[(c * KH + ky) * KW + kx] = window[ky * stride + kx * C + c];
            }
        }
    }
}

#[cfg(test)]
mod speed;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod versus_tract;
