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
use crate::int8::{ActivationQuant, Int8Kernel, PointwiseConvInt8};
use crate::pointwise::{Activation, Kernel, PointwiseConv};

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

/// [`NhwcConv`] in int8 (issue 46): the image coded in 7 bits with a fixed
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
    shape: StemShape,
    /// The product (its input code, the image's) over rows of `KH·KW·Cin` codes rounded up to a multiple of 4.
    product: PointwiseConvInt8,
    /// Share large outputs between the cores ([`crate::split`]).
    split: bool,
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
mod tests {
    use super::*;

    /// TFLite's convolution written out naively, in f64.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn reference(
        x: &[f32],
        (h, w, cin): (usize, usize, usize),
        k: &[f32],
        (cout, kh, kw): (usize, usize, usize),
        b: &[f32],
        (sy, sx): (usize, usize),
        same: bool,
        act: Activation,
    ) -> Vec<f32> {
        let (oh, pt) = axis_geometry(h, kh, sy, same);
        let (ow, pl) = axis_geometry(w, kw, sx, same);
        let (lo, hi) = act.bounds();
        let mut out = vec![0f32; oh * ow * cout];
        for oy in 0..oh {
            for ox in 0..ow {
                for o in 0..cout {
                    let mut acc = b[o] as f64;
                    for ky in 0..kh {
                        for kx in 0..kw {
                            let iy = (oy * sy + ky) as isize - pt as isize;
                            let ix = (ox * sx + kx) as isize - pl as isize;
                            if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                                continue;
                            }
                            for c in 0..cin {
                                acc += x[(iy as usize * w + ix as usize) * cin + c] as f64
                                    * k[((o * kh + ky) * kw + kx) * cin + c] as f64;
                            }
                        }
                    }
                    out[(oy * ow + ox) * cout + o] = acc.max(lo as f64).min(hi as f64) as f32;
                }
            }
        }
        out
    }

    #[test]
    fn every_kernel_matches_a_naive_reference() {
        let mut seed = 5u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        // (h, w, cin, cout, kh, kw, stride, same): the landmark and palm stems (smaller
        // images), odd sizes where SAME pads one side only or both, VALID, and an image
        // wide enough that a band holds a single output row.
        let cases = [
            (16, 16, 3, 24, 3, 3, 2, true),
            (15, 13, 3, 24, 3, 3, 2, true),
            (12, 12, 3, 32, 5, 5, 2, true),
            (9, 10, 2, 7, 3, 3, 1, true),
            (9, 11, 3, 40, 3, 3, 2, false),
            (4, 700, 3, 16, 3, 3, 1, true),
            (3, 3, 1, 1, 3, 3, 2, true),
        ];
        for kernel in Kernel::supported() {
            for (h, w, cin, cout, kh, kw, s, same) in cases {
                let x: Vec<f32> = (0..h * w * cin).map(|_| next() * 3.0).collect();
                let k: Vec<f32> = (0..cout * kh * kw * cin).map(|_| next()).collect();
                let b: Vec<f32> = (0..cout).map(|_| next()).collect();
                for act in [Activation::None, Activation::Relu6] {
                    let op = NhwcConv::new(
                        &Tensor::from_shape(&[cout, kh, kw, cin], &k).expect("k"),
                        &tensor1(&b),
                        (s, s),
                        same,
                        act,
                    )
                    .expect("op");
                    let (oh, ow, _, _) = op.shape.geometry(h, w);
                    let mut got = vec![f32::NAN; oh * ow * cout];
                    op.compute(&x, (h, w), &mut got, kernel).expect("compute");
                    let want =
                        reference(&x, (h, w, cin), &k, (cout, kh, kw), &b, (s, s), same, act);
                    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert!(
                            (g - w).abs() <= 1e-5 * (1.0 + w.abs()),
                            "{kernel:?} {h}x{w}x{cin} k{kh} s{s} same {same} {act:?} at {i}: \
                             {g} vs {w}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn shared_between_threads_gives_the_same_bits() {
        // The landmark networks' stem (224x224x3, 3x3 stride 2, 24 channels) and a 5x5 one.
        for (h, k, cout) in [(224, 3, 24), (96, 5, 32)] {
            let cin = 3;
            let x: Vec<f32> = (0..h * h * cin)
                .map(|i| ((i * 37 % 255) as f32) / 255.0)
                .collect();
            let kv: Vec<f32> = (0..cout * k * k * cin)
                .map(|i| ((i * 13 % 17) as f32 - 8.0) / 8.0)
                .collect();
            let b: Vec<f32> = (0..cout).map(|i| i as f32 * 0.1 - 1.0).collect();
            let op = |split| {
                NhwcConv::new(
                    &Tensor::from_shape(&[cout, k, k, cin], &kv).expect("k"),
                    &tensor1(&b),
                    (2, 2),
                    true,
                    Activation::Relu6,
                )
                .expect("op")
                .with_split(split)
            };
            let input = Tensor::from_shape(&[1, h, h, cin], &x).expect("x");
            crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
        }
    }

    #[test]
    fn evaluates_as_a_tract_operator() {
        let (h, w, cin, cout) = (6, 5, 3, 8);
        let x: Vec<f32> = (0..h * w * cin).map(|i| (i % 7) as f32 - 3.0).collect();
        let k: Vec<f32> = (0..cout * 9 * cin).map(|i| (i % 5) as f32 * 0.25).collect();
        let b: Vec<f32> = (0..cout).map(|i| i as f32).collect();
        let op = NhwcConv::new(
            &Tensor::from_shape(&[cout, 3, 3, cin], &k).expect("k"),
            &tensor1(&b),
            (2, 2),
            true,
            Activation::Relu,
        )
        .expect("op");
        let out = op
            .eval_out_of_plan(tvec!(Tensor::from_shape(&[1, h, w, cin], &x)
                .expect("x")
                .into_tvalue()))
            .expect("eval")
            .expect("evaluates out of plan");
        assert_eq!(out[0].shape(), &[1, 3, 3, cout]);
        let got = out[0].try_as_plain_ram().expect("ram");
        let got = got.as_slice::<f32>().expect("f32");
        let want = reference(
            &x,
            (h, w, cin),
            &k,
            (cout, 3, 3),
            &b,
            (2, 2),
            true,
            Activation::Relu,
        );
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-4, "{g} vs {w}");
        }
    }
}

#[cfg(test)]
mod versus_tract {
    use super::*;
    use tract_core::ops::cnn::{Conv, KernelFormat, PaddingSpec, PoolSpec};
    use tract_core::ops::nn::DataFormat;

    /// tract's `Conv` (as the importer wired it before this operator) on `x`.
    #[allow(clippy::too_many_arguments)]
    fn tract_conv(
        x: &[f32],
        (h, w, cin): (usize, usize, usize),
        k: &[f32],
        (cout, kh): (usize, usize),
        b: &[f32],
        s: usize,
        same: bool,
    ) -> Vec<f32> {
        let mut m = TypedModel::default();
        let xi = m
            .add_source("x", f32::fact([1, h, w, cin]))
            .expect("source");
        let kt = Tensor::from_shape(&[cout, kh, kh, cin], k).expect("k");
        let kt = m.add_const("k", kt).expect("k");
        let bt = m.add_const("b", tensor1(b)).expect("b");
        let op = Conv {
            pool_spec: PoolSpec {
                data_format: DataFormat::NHWC,
                kernel_shape: tvec!(kh, kh),
                padding: if same {
                    PaddingSpec::SameUpper
                } else {
                    PaddingSpec::Valid
                },
                strides: Some(tvec!(s, s)),
                dilations: Some(tvec!(1, 1)),
                input_channels: cin,
                output_channels: cout,
            },
            kernel_fmt: KernelFormat::OHWI,
            group: 1,
            q_params: None,
        };
        let y = m.wire_node("conv", op, &[xi, kt, bt]).expect("wire");
        m.select_output_outlets(&y).expect("outputs");
        let plan = m
            .into_optimized()
            .expect("optimise")
            .into_runnable()
            .expect("plan");
        let x = Tensor::from_shape(&[1, h, w, cin], x).expect("x");
        let r = plan.run(tvec!(x.into_tvalue())).expect("run");
        let r = r[0].try_as_plain_ram().expect("ram");
        r.as_slice::<f32>().expect("f32").to_vec()
    }

    /// On the stems' shapes (landmark 3x3, palm and face 5x5, stride 2, 3 -> 24/32
    /// channels; smaller images) the operator gives tract's bits with every vectorised
    /// kernel, so swapping it in moves no keypoint.
    #[test]
    fn gives_the_bits_of_tracts_conv() {
        for kernel in Kernel::supported() {
            if kernel == Kernel::PORTABLE {
                // tract's own kernels use FMA where the CPU has it; the portable product
                // multiplies and adds.
                continue;
            }
            for (h, w, cin, cout, kh, s, same) in [
                (32, 32, 3, 24, 3, 2, true),
                (31, 29, 3, 24, 3, 2, true),
                (24, 24, 3, 32, 5, 2, true),
                (17, 19, 3, 24, 5, 2, false),
            ] {
                let x: Vec<f32> = (0..h * w * cin)
                    .map(|i| ((i * 7919 % 1009) as f32 - 504.0) / 97.0)
                    .collect();
                let k: Vec<f32> = (0..cout * kh * kh * cin)
                    .map(|i| ((i * 31 % 59) as f32 - 29.0) / 13.0)
                    .collect();
                let b: Vec<f32> = (0..cout).map(|i| i as f32 * 0.37 - 3.0).collect();
                let want = tract_conv(&x, (h, w, cin), &k, (cout, kh), &b, s, same);
                let op = NhwcConv::new(
                    &Tensor::from_shape(&[cout, kh, kh, cin], &k).expect("k"),
                    &tensor1(&b),
                    (s, s),
                    same,
                    Activation::None,
                )
                .expect("op");
                let mut got = vec![f32::NAN; want.len()];
                op.compute(&x, (h, w), &mut got, kernel).expect("compute");
                let differ = crate::split::testing::differing_bits(&got, &want);
                assert_eq!(differ, 0, "{kernel:?} {h}x{w}x{cin} k{kh} s{s} same {same}");
            }
        }
    }

    /// The int8 stem written out naively: the image coded with `quant` (zero-point codes in
    /// the padding), each window's codes in OHWI order, the int8 weights and epilogue of
    /// the same `PointwiseConvInt8` on those rows with the portable kernel.
    fn int8_reference(op: &NhwcConvInt8, x: &[f32], (h, w): (usize, usize)) -> Vec<f32> {
        let (oh, ow, pt, pl) = op.shape.geometry(h, w);
        let (kh, kw, cin) = (op.shape.kh, op.shape.kw, op.shape.cin);
        let kp = op.product.input_channels();
        let mut cols = vec![op.input_quant().zero_point(); oh * ow * kp];
        for oy in 0..oh {
            for ox in 0..ow {
                for ky in 0..kh {
                    for kx in 0..kw {
                        let iy = (oy * op.shape.strides.0 + ky) as isize - pt as isize;
                        let ix = (ox * op.shape.strides.1 + kx) as isize - pl as isize;
                        if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                            continue;
                        }
                        for c in 0..cin {
                            let v = x[(iy as usize * w + ix as usize) * cin + c];
                            cols[(oy * ow + ox) * kp + (ky * kw + kx) * cin + c] =
                                op.input_quant().quantize(v);
                        }
                    }
                }
            }
        }
        let mut out = vec![0f32; oh * ow * op.product.output_channels()];
        op.product
            .compute_with(&cols[..], None, &mut out, Int8Kernel::PORTABLE, false)
            .expect("product");
        out
    }

    #[test]
    fn the_int8_stem_gives_the_reference_bits_with_every_kernel_and_is_near_f32() {
        let mut seed = 11u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        // (h, w, cin, cout, k, stride, same): the landmark and palm stems on smaller
        // images (windows inside and across every border), odd sizes, VALID, a stride of
        // 1, channels whose windows are no multiple of 4 codes, and a band of one row.
        let cases = [
            (16, 16, 3, 24, 3, 2, true),
            (15, 13, 3, 24, 3, 2, true),
            (12, 12, 3, 32, 5, 2, true),
            (11, 9, 3, 32, 5, 2, false),
            (9, 10, 2, 7, 3, 1, true),
            (6, 700, 3, 24, 3, 2, true),
        ];
        for (h, w, cin, cout, k, s, same) in cases {
            let x: Vec<f32> = (0..h * w * cin).map(|_| next()).collect();
            let wv: Vec<f32> = (0..cout * k * k * cin).map(|_| next() - 0.5).collect();
            let bv: Vec<f32> = (0..cout).map(|_| next() - 0.5).collect();
            let weights = Tensor::from_shape(&[cout, k, k, cin], &wv).expect("w");
            let bias = Tensor::from_shape(&[cout], &bv).expect("b");
            let conv = NhwcConv::new(&weights, &bias, (s, s), same, Activation::Relu6)
                .expect("conv")
                .with_split(false);
            let op = conv
                .to_int8(ActivationQuant::from_min_max(0.0, 1.0))
                .expect("int8");
            let want = int8_reference(&op, &x, (h, w));
            let (oh, ow, _, _) = op.shape.geometry(h, w);
            for kernel in Int8Kernel::supported() {
                let mut got = vec![f32::NAN; oh * ow * cout];
                op.compute(&x, (h, w), &mut got, kernel).expect("compute");
                let differ = crate::split::testing::differing_bits(&got, &want);
                assert_eq!(differ, 0, "{kernel:?} {h}x{w}x{cin} k{k} s{s} same {same}");
            }
            // And it is the f32 convolution, up to the codes' rounding: each of the
            // `k·k·cin` inputs off by at most half a step (1/254) and each weight by half of
            // its channel's step.
            let exact = super::tests::reference(
                &x,
                (h, w, cin),
                &wv,
                (cout, k, k),
                &bv,
                (s, s),
                same,
                Activation::Relu6,
            );
            let taps = (k * k * cin) as f32;
            let worst = exact
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0f32, f32::max);
            assert!(
                worst < taps * (0.5 / 127.0 * 0.5 + 0.5 / 127.0 * 0.5),
                "{worst}"
            );
        }
    }

    #[test]
    fn the_int8_stem_shared_between_threads_gives_the_same_bits() {
        let (h, w, cin, cout) = (96, 96, 3, 24);
        let x: Vec<f32> = (0..h * w * cin)
            .map(|i| (i * 7919 % 256) as f32 / 255.0)
            .collect();
        let wv: Vec<f32> = (0..cout * 27)
            .map(|i| ((i * 37 % 101) as f32 - 50.0) / 200.0)
            .collect();
        let weights = Tensor::from_shape(&[cout, 3, 3, cin], &wv).expect("w");
        let bias = Tensor::from_shape(&[cout], &vec![0.1f32; cout]).expect("b");
        let quant = ActivationQuant::from_min_max(0.0, 1.0);
        let op = |split| {
            NhwcConv::new(&weights, &bias, (2, 2), true, Activation::Relu6)
                .expect("conv")
                .with_split(split)
                .to_int8(quant)
                .expect("int8")
        };
        let input = Tensor::from_shape(&[1, h, w, cin], &x).expect("x");
        crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
    }

    #[test]
    fn the_int8_stem_refuses_a_malformed_input() {
        let weights = Tensor::from_shape(&[4, 3, 3, 3], &[0.5f32; 108]).expect("w");
        let bias = Tensor::from_shape(&[4], &[0f32; 4]).expect("b");
        let op = NhwcConv::new(&weights, &bias, (2, 2), true, Activation::None)
            .expect("conv")
            .to_int8(ActivationQuant::from_min_max(0.0, 1.0))
            .expect("int8");
        let wrong = Tensor::zero::<f32>(&[1, 8, 8, 4]).expect("x");
        assert!(op.eval_out_of_plan(tvec!(wrong.into_tvalue())).is_err());
        let mut out = vec![0f32; 3];
        assert!(op
            .compute(&[0.0; 10], (8, 8), &mut out, Int8Kernel::best())
            .is_err());
    }
}

#[cfg(test)]
mod speed {
    use super::*;

    /// Microseconds per call of the stems in f32 ([`NhwcConv`]) and int8 ([`NhwcConvInt8`]),
    /// one thread, side by side (best of 9 rounds, the two alternating):
    /// `cargo test --release -p monohand-tflite conv::speed -- --ignored --nocapture`.
    #[test]
    #[ignore = "a measurement, not a test"]
    fn stems() {
        // (input size, kernel, Cout, activation): the landmark networks' and the palm
        // detectors' first layers.
        for (size, k, cout, act) in [
            (224, 3, 24, Activation::Relu6),
            (192, 5, 32, Activation::None),
        ] {
            let w: Vec<f32> = (0..cout * k * k * 3)
                .map(|i| ((i * 37 % 101) as f32 - 50.0) / 200.0)
                .collect();
            let w = Tensor::from_shape(&[cout, k, k, 3], &w).expect("w");
            let b = Tensor::from_shape(&[cout], &vec![0.1f32; cout]).expect("b");
            let f32_conv = NhwcConv::new(&w, &b, (2, 2), true, act)
                .expect("conv")
                .with_split(false);
            let quant = ActivationQuant::from_min_max(0.0, 1.0);
            let int8 = f32_conv.to_int8(quant).expect("int8");
            let x: Vec<f32> = (0..size * size * 3)
                .map(|i| (i * 7919 % 256) as f32 / 255.0)
                .collect();
            let (oh, ow, _, _) = f32_conv.shape.geometry(size, size);
            let mut out = vec![0f32; oh * ow * cout];
            let (mut a, mut q) = (f64::MAX, f64::MAX);
            for _ in 0..9 {
                let t = std::time::Instant::now();
                for _ in 0..20 {
                    f32_conv
                        .compute(&x, (size, size), &mut out, Kernel::best())
                        .expect("f32");
                }
                a = a.min(t.elapsed().as_secs_f64() / 20.0);
                let t = std::time::Instant::now();
                for _ in 0..20 {
                    int8.compute(&x, (size, size), &mut out, Int8Kernel::best())
                        .expect("int8");
                }
                q = q.min(t.elapsed().as_secs_f64() / 20.0);
            }
            println!(
                "{size}x{size}x3 k{k} -> {cout}: f32 {:7.1} us, int8 {:7.1} us ({})",
                a * 1e6,
                q * 1e6,
                Int8Kernel::best().name()
            );
        }
    }
}
