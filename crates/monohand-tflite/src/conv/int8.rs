//! The stem in int8 ([`NhwcConvInt8`]).

use tract_core::internal::*;

use super::{StemShape, BAND_CODES, CODES};
use crate::int8::{ActivationQuant, Int8Kernel, PointwiseConvInt8};

/// [`NhwcConv`](super::NhwcConv) in int8 (issue 46): the image coded in 7 bits with a fixed
/// [`ActivationQuant`] (the networks' input, calibrated as the 1x1 convolutions' inputs
/// are), the weights int8 per output channel, and the product and epilogue of
/// [`PointwiseConvInt8`] (its kernels, run-time dispatch and bits). A few output rows at a
/// time: the input rows their windows cover are coded into a buffer of the thread's own,
/// then each output pixel's window is gathered as `KH` runs of `KW·Cin` contiguous codes
/// (columns in (kernel row, column, channel) order, TFLite's OHWI order, padded with the
/// code of 0.0 to a multiple of 4 and at the image's borders) into an im2col band of
/// codes in L1, which the int8 product reads as coded rows. The sums are exact, so the
/// column order changes nothing; every kernel gives the same bits, and so does any split
/// of the rows between the cores.
#[derive(Debug, Clone, PartialEq)]
pub struct NhwcConvInt8 {
    pub(super) shape: StemShape,
    /// The product (its input code, the image's) over rows of `KH·KW·Cin` codes rounded up to a multiple of 4.
    pub(super) product: PointwiseConvInt8,
    /// Share large outputs between the cores ([`crate::split`]).
    pub(super) split: bool,
}

// `ActivationQuant` and the product compare their floats by bits: equality is reflexive.
impl Eq for NhwcConvInt8 {}

impl NhwcConvInt8 {
    /// Ends the epilogue with a PRELU of per-channel slopes `alpha` (`[Cout]`): the palm
    /// detectors' stem, whose PRELU follows it.
    pub fn with_prelu(mut self, alpha: &Tensor) -> TractResult<Self> {
        self.product = self.product.with_prelu(alpha)?;
        Ok(self)
    }

    /// The code of the input.
    pub fn input_quant(&self) -> ActivationQuant {
        self.product.input_quant()
    }

    /// The convolution of `src` (`h x w x Cin`) into `out` (`oh x ow x Cout`) with `kernel`.
    pub(crate) fn compute(
        &self,
        src: &[f32],
        hw: (usize, usize),
        out: &mut [f32],
        kernel: Int8Kernel,
    ) -> TractResult<()> {
        let cout = self.product.output_channels();
        self.shape
            .compute(src, hw, out, (cout, self.split), |first, o| {
                self.compute_rows(src, hw, first, o, kernel)
            })
    }

    /// Output rows `first ..` (as many as `out` holds), sizes checked by
    /// [`compute`](Self::compute).
    fn compute_rows(
        &self,
        src: &[f32],
        (h, w): (usize, usize),
        first: usize,
        out: &mut [f32],
        kernel: Int8Kernel,
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
        let kp = self.product.input_channels();
        let run = kw * cin;
        let input = self.product.input_quant();
        let zero = input.zero_point();
        let oh = out.len() / (ow * cout);
        let band = (BAND_CODES / (ow * kp)).max(1).min(oh);
        // The buffers are this thread's, kept between calls as `BAND` is (an error below drops
        // them; the next call makes new ones). Every code is written before it is read.
        let (mut rows_buf, mut cols_buf) = CODES.take();
        {
            let in_rows = ((band - 1) * sy + kh).min(h);
            rows_buf.resize(rows_buf.len().max(in_rows * w * cin), 0);
            cols_buf.resize(cols_buf.len().max(band * ow * kp), 0);
            let mut oy0 = 0;
            while oy0 < oh {
                let rows = band.min(oh - oy0);
                // The input rows y0 .. y1 of these output rows' windows, coded.
                let top = ((first + oy0) * sy) as isize - pt as isize;
                let y0 = (top.max(0) as usize).min(h);
                let y1 = ((top + ((rows - 1) * sy + kh) as isize).max(0) as usize).clamp(y0, h);
                let coded = &mut rows_buf[..(y1 - y0) * w * cin];
                crate::int8::quantize_run(&src[y0 * w * cin..y1 * w * cin], coded, input, kernel);
                let coded = &*coded;
                let cols = &mut cols_buf[..rows * ow * kp];
                for (p, col) in cols.chunks_exact_mut(kp).enumerate() {
                    let (oy, ox) = (first + oy0 + p / ow, p % ow);
                    let iy0 = (oy * sy) as isize - pt as isize;
                    let ix0 = (ox * sx) as isize - pl as isize;
                    let inside = ix0 >= 0 && ix0 as usize + kw <= w;
                    if inside && iy0 >= 0 && iy0 as usize + kh <= y1 {
                        // The whole window inside the image: `kh` runs, the stems' sizes
                        // known to the compiler (moves, no call to `memcpy` for a few bytes).
                        let at = (iy0 as usize - y0) * w * cin + ix0 as usize * cin;
                        let (window, stride) = (&coded[at..], w * cin);
                        match (run, kh, kp) {
                            (9, 3, 28) => gather_window(window, stride, col, (9, 3, 28), zero),
                            (15, 5, 76) => gather_window(window, stride, col, (15, 5, 76), zero),
                            _ => gather_window(window, stride, col, (run, kh, kp), zero),
                        }
                        continue;
                    }
                    for ky in 0..kh {
                        let iy = iy0 + ky as isize;
                        let dst = &mut col[ky * run..(ky + 1) * run];
                        if iy < 0 || iy >= h as isize {
                            dst.fill(zero);
                            continue;
                        }
                        let row = &coded[(iy as usize - y0) * w * cin..][..w * cin];
                        for (kx, tap) in dst.chunks_exact_mut(cin).enumerate() {
                            let ix = ix0 + kx as isize;
                            if ix < 0 || ix >= w as isize {
                                tap.fill(zero);
                            } else {
                                let at = ix as usize * cin;
                                tap.copy_from_slice(&row[at..at + cin]);
                            }
                        }
                    }
                    col[kh * run..].fill(zero);
                }
                let o = &mut out[oy0 * ow * cout..(oy0 + rows) * ow * cout];
                self.product.compute_with(&*cols, None, o, kernel, false)?;
                oy0 += rows;
            }
        }
        CODES.set((rows_buf, cols_buf));
        Ok(())
    }
}

impl Op for NhwcConvInt8 {
    fn name(&self) -> StaticName {
        "MonohandNhwcConvInt8".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        Ok(vec![format!(
            "{}x{} stride {:?} same {} {}->{} input scale {} zero {} prelu {}",
            self.shape.kh,
            self.shape.kw,
            self.shape.strides,
            self.shape.same,
            self.shape.cin,
            self.product.output_channels(),
            self.input_quant().scale(),
            self.input_quant().zero_point(),
            self.product.has_prelu()
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for NhwcConvInt8 {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        self.shape
            .eval(inputs, self.product.output_channels(), |src, hw, dst| {
                self.compute(src, hw, dst, Int8Kernel::best())
            })
    }
}

impl TypedOp for NhwcConvInt8 {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        self.shape.facts(inputs, self.product.output_channels())
    }
}

/// The im2col codes of a window inside the image: `kh` runs of `run` codes (`window`
/// starts at the top left tap, rows `stride` codes apart), then `zero` up to `kp`. Always
/// inlined: called with the stems' sizes as constants, the copies become moves, not calls
/// to `memcpy` for a few bytes.
#[inline(always)]
fn gather_window(
    window: &[u8],
    stride: usize,
    col: &mut [u8],
    (run, kh, kp): (usize, usize, usize),
    zero: u8,
) {
    let col = &mut col[..kp];
    for ky in 0..kh {
        col[ky * run..(ky + 1) * run].copy_from_slice(&window[ky * stride..ky * stride + run]);
    }
    col[kh * run..].fill(zero);
}
