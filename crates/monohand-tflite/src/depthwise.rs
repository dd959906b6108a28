//! A channels-last depthwise convolution operator for tract.
//!
//! tract 0.23's `DepthWiseConv` walks channels in its outer loop with scalar code; it is the
//! largest single cost of the palm detector (≈ 40 % of the time). This operator keeps
//! TFLite's NHWC layout and puts the channels in the innermost loop, so each kernel tap is a
//! contiguous multiply-add over all channels that the compiler vectorises — with AVX2 + FMA
//! when the CPU has them (checked at run time), SSE2 otherwise. On CPUs with AVX2 + FMA or
//! AVX-512F, register-blocked kernels sum each output pixel's taps in registers (see
//! [`NhwcDepthwise::register_blocked`]); the kernel is chosen as for
//! [`crate::PointwiseConv`], `MONOHAND_KERNEL` included.

use tract_core::internal::*;

use crate::int8::ActivationQuant;
use crate::pointwise::Activation;

/// Depthwise `KH x KW` convolution, depth multiplier 1, on `[1, H, W, C]` f32 tensors, with
/// TFLite's padding rule (SAME: extra padding at the bottom/right), a bias per channel and a
/// fused activation (TFLite's `RELU`/`RELU6`, applied to each output row while it is in
/// cache).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NhwcDepthwise {
    /// Weights `[KH, KW, C]`.
    pub kernel: Arc<Tensor>,
    /// Bias `[C]`.
    pub bias: Arc<Tensor>,
    /// Strides (y, x).
    pub strides: (usize, usize),
    /// TFLite SAME padding (else VALID).
    pub same: bool,
    /// Activation applied to the result.
    pub activation: Activation,
    /// Use the register-blocked AVX-512 or AVX2 + FMA kernel where the CPU has those
    /// features (the same results, bit for bit); false keeps the portable loop, to compare.
    pub register_blocked: bool,
    /// Share large outputs between the cores when the network runs alone (the same
    /// results, bit for bit; see `ImportOptions::split_rows`).
    pub split: bool,
}

/// Output size and leading padding of one axis under TFLite's rules.
pub(crate) fn axis_geometry(input: usize, k: usize, stride: usize, same: bool) -> (usize, usize) {
    if same {
        let out = input.div_ceil(stride);
        let total = ((out - 1) * stride + k).saturating_sub(input);
        (out, total / 2)
    } else {
        ((input + 1).saturating_sub(k).div_ceil(stride), 0)
    }
}

impl NhwcDepthwise {
    fn dims(&self) -> (usize, usize, usize) {
        let s = self.kernel.shape();
        (s[0], s[1], s[2])
    }

    fn output_shape(&self, h: usize, w: usize) -> (usize, usize, usize, usize) {
        let (kh, kw, _) = self.dims();
        let (oh, pt) = axis_geometry(h, kh, self.strides.0, self.same);
        let (ow, pl) = axis_geometry(w, kw, self.strides.1, self.same);
        (oh, ow, pt, pl)
    }
}

impl Op for NhwcDepthwise {
    fn name(&self) -> StaticName {
        "MonohandNhwcDepthwise".into()
    }

    op_as_typed_op!();
}

impl EvalOp for NhwcDepthwise {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let g = self.geometry(input.shape())?;
        // SAFETY: the tensor's values are left unwritten, and nothing reads one before it is
        // written: `run` writes every output value (the portable loop sets each to its bias
        // before accumulating into it; the SIMD kernels only store), over all the rows
        // (`rows` gives every row to exactly one piece), and when `ow` or `c` is 0 the tensor
        // has no values. An error drops the tensor without reading it (f32 has no drop).
        let mut output = unsafe { Tensor::uninitialized::<f32>(&[1, g.oh, g.ow, g.c])? };
        {
            let src = input.try_as_plain_ram()?;
            let src = src.as_slice::<f32>()?;
            let k = self.kernel.try_as_plain_ram()?;
            let k = k.as_slice::<f32>()?;
            let b = self.bias.try_as_plain_ram()?;
            let b = b.as_slice::<f32>()?;
            let mut dst = output.try_as_plain_ram_mut()?;
            let dst = dst.as_slice_mut::<f32>()?;
            if g.ow > 0 && g.c > 0 {
                let work = g.oh * g.ow * g.c * g.kh * g.kw;
                let row = g.ow * g.c;
                crate::split::team().rows(dst, row, 1, work, self.split, &|first, dst| {
                    let g = Geometry {
                        rows: (first, first + dst.len() / row),
                        ..g
                    };
                    run(
                        &g,
                        src,
                        k,
                        b,
                        dst,
                        self.activation.bounds(),
                        self.register_blocked,
                    );
                    Ok(())
                })?;
            }
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

impl NhwcDepthwise {
    /// The geometry of an evaluation on an input of `shape` (all the output rows).
    fn geometry(&self, shape: &[usize]) -> TractResult<Geometry> {
        ensure!(
            shape.len() == 4 && shape[0] == 1,
            "depthwise expects [1, H, W, C], got {shape:?}"
        );
        let (h, w, c) = (shape[1], shape[2], shape[3]);
        let (kh, kw, kc) = self.dims();
        ensure!(kc == c, "depthwise kernel has {kc} channels, input {c}");
        let (oh, ow, pt, pl) = self.output_shape(h, w);
        Ok(Geometry {
            h,
            w,
            c,
            kh,
            kw,
            sy: self.strides.0,
            sx: self.strides.1,
            pt,
            pl,
            oh,
            ow,
            rows: (0, oh),
        })
    }
}

/// Output values (f32) a [`NhwcDepthwiseCodes`] computes at a time into its thread's buffer
/// before coding them: 32 KiB, in L1 while they are coded (at least one output row).
const CODED_CHUNK: usize = 8 * 1024;

thread_local! {
    /// Each thread's buffer for the f32 rows of [`NhwcDepthwiseCodes`] before they are coded
    /// (allocated on the thread's first call, reused).
    static CHUNK: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A [`NhwcDepthwise`] whose result is written as the 7-bit codes of an
/// [`ActivationQuant`] (a `u8` tensor of the same shape) instead of f32: what a
/// [`PointwiseConvInt8`](crate::PointwiseConvInt8) that reads it
/// ([`with_coded_input`](crate::PointwiseConvInt8::with_coded_input)) would otherwise make
/// from the f32 tensor as its first step. [`quantize_pointwise`](crate::quantize_pointwise)
/// puts one in where a depthwise convolution's only reader is an int8 1x1 convolution.
///
/// A few output rows at a time (about 32 KiB of f32) are computed by the depthwise kernel
/// into a buffer of the thread's own, then coded by the int8 kernels' quantizer while they
/// are in cache: the codes are those the 1x1 convolution would make, bit for bit, but the
/// f32 tensor is never written to memory nor read back.
#[derive(Debug, Clone, PartialEq)]
pub struct NhwcDepthwiseCodes {
    conv: NhwcDepthwise,
    quant: ActivationQuant,
}

// `ActivationQuant` compares its scale by bits: equality is reflexive.
impl Eq for NhwcDepthwiseCodes {}

impl NhwcDepthwiseCodes {
    /// `conv`, its result coded with `quant`.
    pub fn new(conv: NhwcDepthwise, quant: ActivationQuant) -> Self {
        NhwcDepthwiseCodes { conv, quant }
    }

    /// The convolution.
    pub fn conv(&self) -> &NhwcDepthwise {
        &self.conv
    }

    /// The code of the result.
    pub fn quant(&self) -> ActivationQuant {
        self.quant
    }
}

impl Op for NhwcDepthwiseCodes {
    fn name(&self) -> StaticName {
        "MonohandNhwcDepthwiseCodes".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        Ok(vec![format!(
            "codes: scale {} zero {}",
            self.quant.scale(),
            self.quant.zero_point()
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for NhwcDepthwiseCodes {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let g = self.conv.geometry(input.shape())?;
        // SAFETY: the tensor's values are left unwritten, and nothing reads one before it is
        // written: every output row is given to exactly one piece (`rows`), whose chunks
        // cover its rows, and each chunk's codes are all stored by `quantize_values` (the
        // depthwise kernel writes every value of the chunk's f32 buffer first, as in
        // `NhwcDepthwise::eval`); when `ow` or `c` is 0 the tensor has no values. An error
        // drops the tensor without reading it (u8 has no drop).
        let mut output = unsafe { Tensor::uninitialized::<u8>(&[1, g.oh, g.ow, g.c])? };
        {
            let src = input.try_as_plain_ram()?;
            let src = src.as_slice::<f32>()?;
            let k = self.conv.kernel.try_as_plain_ram()?;
            let k = k.as_slice::<f32>()?;
            let b = self.conv.bias.try_as_plain_ram()?;
            let b = b.as_slice::<f32>()?;
            let mut dst = output.try_as_plain_ram_mut()?;
            let dst = dst.as_slice_mut::<u8>()?;
            if g.ow > 0 && g.c > 0 {
                let work = g.oh * g.ow * g.c * g.kh * g.kw;
                let row = g.ow * g.c;
                let chunk = (CODED_CHUNK / row).max(1);
                let act = self.conv.activation.bounds();
                crate::split::team().rows(dst, row, 1, work, self.conv.split, &|first, dst| {
                    with_chunk(chunk * row, |buf| {
                        let rows = dst.len() / row;
                        let mut r = 0;
                        while r < rows {
                            let m = chunk.min(rows - r);
                            let g = Geometry {
                                rows: (first + r, first + r + m),
                                ..g
                            };
                            let values = &mut buf[..m * row];
                            run(&g, src, k, b, values, act, self.conv.register_blocked);
                            crate::int8::quantize_values(
                                values,
                                &mut dst[r * row..(r + m) * row],
                                self.quant,
                            );
                            r += m;
                        }
                    });
                    Ok(())
                })?;
            }
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

/// Calls `f` with this thread's f32 buffer for [`NhwcDepthwiseCodes`], at least `n` long
/// (a new one if it is in use).
fn with_chunk<R>(n: usize, f: impl FnOnce(&mut [f32]) -> R) -> R {
    CHUNK.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => {
            if s.len() < n {
                s.resize(n, 0.0);
            }
            f(&mut s[..n])
        }
        // Re-entered on this thread (not expected): a buffer of its own.
        Err(_) => f(&mut vec![0.0; n]),
    })
}

impl TypedOp for NhwcDepthwiseCodes {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let f = self.conv.output_facts(inputs)?;
        Ok(tvec!(u8::fact(f[0].shape.clone())))
    }
}

impl TypedOp for NhwcDepthwise {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = inputs[0]
            .shape
            .as_concrete()
            .context("depthwise needs a concrete input shape")?;
        ensure!(shape.len() == 4, "depthwise expects rank 4");
        let (oh, ow, _, _) = self.output_shape(shape[1], shape[2]);
        Ok(tvec!(f32::fact([shape[0], oh, ow, shape[3]])))
    }
}

/// Sizes of one evaluation.
#[derive(Clone, Copy)]
struct Geometry {
    h: usize,
    w: usize,
    c: usize,
    kh: usize,
    kw: usize,
    sy: usize,
    sx: usize,
    pt: usize,
    pl: usize,
    oh: usize,
    ow: usize,
    /// The output rows `[first, end)` computed, which the output slice holds (all
    /// `(0, oh)`, or one piece of them).
    rows: (usize, usize),
}

/// Clamp bounds of the activation, `(low, high)`.
type Bounds = (f32, f32);

fn run(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    act: Bounds,
    blocked: bool,
) {
    #[cfg(target_arch = "x86_64")]
    {
        use crate::pointwise::{Isa, Kernel};
        let kernel = Kernel::best();
        if kernel != Kernel::PORTABLE {
            let sized = sized(g, src, k, b, dst);
            match kernel.isa() {
                // SAFETY: a `Kernel` has `Avx512` only on a CPU with AVX-512F (and VL),
                // detected at run time, which is what `avx512::run` is compiled for, and `sized` checked the
                // slices against the geometry as its contract asks.
                Isa::Avx512 if blocked && sized => unsafe { avx512::run(g, src, k, b, dst, act) },
                // SAFETY: the kernel is `Avx2Fma` here (`Portable` returned above, `Avx512`
                // took the arm above), which a `Kernel` is only on a CPU with AVX2 and FMA;
                // the slices are `sized` as above.
                _ if blocked && sized => unsafe { avx2::run(g, src, k, b, dst, act) },
                // SAFETY: `run_avx2_fma` needs AVX2 and FMA only. The kernel is `Avx2Fma`
                // (detected with AVX2 and FMA) or `Avx512`, detected with AVX-512F, which
                // implies AVX2 and FMA (as Rust's `avx512f` target feature does).
                _ => unsafe { run_avx2_fma(g, src, k, b, dst, act) },
            }
            return;
        }
    }
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    if blocked && sized(g, src, k, b, dst) {
        // SAFETY: `sized` checked the slices against the geometry, as `simd128::run`'s
        // contract asks (the module is built with `simd128`: nothing to detect).
        unsafe { simd128::run(g, src, k, b, dst, act) };
        return;
    }
    // Only the SIMD kernels have a register-blocked variant to choose.
    #[cfg(not(any(
        target_arch = "x86_64",
        all(target_arch = "wasm32", target_feature = "simd128")
    )))]
    let _ = blocked;
    kernel::<false>(g, src, k, b, dst, act);
}

/// Whether the slices hold what the geometry reads and writes (the register-blocked
/// kernels' contract).
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
fn sized(g: &Geometry, src: &[f32], k: &[f32], b: &[f32], dst: &[f32]) -> bool {
    src.len() >= g.h * g.w * g.c
        && k.len() >= g.kh * g.kw * g.c
        && b.len() >= g.c
        && g.rows.0 <= g.rows.1
        && g.rows.1 <= g.oh
        && dst.len() >= (g.rows.1 - g.rows.0) * g.ow * g.c
}

/// Valid kernel rows (or columns) `[k0, k1)` of an output pixel whose window starts at
/// input coordinate `start` on an axis of `size` pixels.
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
#[inline(always)]
fn valid(start: isize, size: usize, k: usize) -> (usize, usize) {
    let k0 = (-start).max(0) as usize;
    let k1 = ((size as isize - start).max(0) as usize).min(k);
    (k0, k1)
}

/// The window of one output pixel, for the register-blocked kernels.
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
#[derive(Clone, Copy)]
struct Window {
    /// Index of the output pixel (`oy · ow + ox`).
    pixel: usize,
    /// Input coordinates of the window's top left tap (may be negative: padding).
    y0: isize,
    x0: isize,
    /// Kernel rows `[ky0, ky1)` and columns `[kx0, kx1)` inside the image.
    ky: (usize, usize),
    kx: (usize, usize),
}

#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
impl Window {
    /// Offset in the input of channel 0 of tap `(ky, kx)`, which must be a valid tap
    /// (`ky >= ky0` and `kx >= kx0` keep the coordinates >= 0).
    #[inline(always)]
    fn input(&self, g: &Geometry, ky: usize, kx: usize) -> usize {
        ((self.y0 + ky as isize) as usize * g.w + (self.x0 + kx as isize) as usize) * g.c
    }
}

/// Calls `f` with each output pixel's window, row by row.
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
#[inline(always)]
fn each_window(g: &Geometry, mut f: impl FnMut(Window)) {
    for oy in g.rows.0..g.rows.1 {
        let y0 = (oy * g.sy) as isize - g.pt as isize;
        let ky = valid(y0, g.h, g.kh);
        for ox in 0..g.ow {
            let x0 = (ox * g.sx) as isize - g.pl as isize;
            let kx = valid(x0, g.w, g.kw);
            f(Window {
                pixel: (oy - g.rows.0) * g.ow + ox,
                y0,
                x0,
                ky,
                kx,
            });
        }
    }
}

/// The register-blocked kernels' last channels `ch0 .. c`, one at a time, summed in the
/// portable loop's order: with fused multiply-adds (`FMA`, as the x86 kernels and
/// `kernel::<true>`) or a product then a sum (as `kernel::<false>` and the `simd128` kernel).
///
/// # Safety
/// As the kernels' `run`: `g` describes the slices that `src`, `k`, `b` and `dst` point to
/// the starts of (read and written without bounds checks at channels `ch0 .. c`; none if
/// `ch0 >= c`).
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
#[inline(always)]
unsafe fn channel_tail<const FMA: bool>(
    g: &Geometry,
    src: *const f32,
    k: *const f32,
    b: *const f32,
    dst: *mut f32,
    ch0: usize,
    (low, high): Bounds,
) {
    let c = g.c;
    let clamp = low > f32::NEG_INFINITY || high < f32::INFINITY;
    each_window(g, |win| {
        for ch in ch0..c {
            // SAFETY: channel ch < c of the biases, of valid taps and of the pixel.
            unsafe {
                let mut a = *b.add(ch);
                for ky in win.ky.0..win.ky.1 {
                    for kx in win.kx.0..win.kx.1 {
                        let i = *src.add(win.input(g, ky, kx) + ch);
                        let w = *k.add((ky * g.kw + kx) * c + ch);
                        a = if FMA { i.mul_add(w, a) } else { a + i * w };
                    }
                }
                if clamp {
                    a = a.max(low).min(high);
                }
                *dst.add(win.pixel * c + ch) = a;
            }
        }
    });
}

/// The portable loop nest compiled for AVX2 + FMA (the kernel before the register-blocked
/// one; kept to compare, and for slices shorter than the geometry, which never happen).
///
/// # Safety
/// The CPU must support AVX2 and FMA. Nothing else: the loop nest indexes the slices with
/// bounds checks (a slice shorter than the geometry panics, it is not read past its end).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2_fma(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    act: Bounds,
) {
    kernel::<true>(g, src, k, b, dst, act);
}

/// The AVX2 + FMA kernel: register-blocked like XNNPACK's depthwise kernels. For each block
/// of 32 (then 8) channels, and each output pixel, the accumulators stay in registers over
/// all of the pixel's kernel taps and are stored once, with the activation applied; the
/// block's weights (at most 25 taps x 32 channels, 3.2 kB) stay in L1 while the block
/// sweeps the image. The portable loop nest instead reads and writes the output row once
/// per tap. The taps are summed in the same order (bias, then row by row, column by column)
/// with the same fused multiply-adds, so the results are bit-identical to it.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{each_window, Bounds, Geometry};
    use std::arch::x86_64::*;

    /// # Safety
    /// The CPU must support AVX2 and FMA. `g` must describe the slices, which are read and
    /// written through raw pointers at offsets computed from it, without bounds checks:
    /// `src` holds at least `h·w·c` values, `k` at least `kh·kw·c` and `b` at least `c`;
    /// `g.rows.0 <= g.rows.1 <= g.oh`, and `dst` holds at least `(rows.1 - rows.0)·ow·c`
    /// values (the output rows `g.rows`). The strides and padding need no check: only the
    /// taps inside the `h x w` image are read.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn run(
        g: &Geometry,
        src: &[f32],
        k: &[f32],
        b: &[f32],
        dst: &mut [f32],
        act: Bounds,
    ) {
        let (src, k, b, dst) = (src.as_ptr(), k.as_ptr(), b.as_ptr(), dst.as_mut_ptr());
        let mut ch = 0;
        while ch + 32 <= g.c {
            block::<4>(g, src, k, b, dst, ch, act);
            ch += 32;
        }
        while ch + 8 <= g.c {
            block::<1>(g, src, k, b, dst, ch, act);
            ch += 8;
        }
        if ch < g.c {
            // The last 1-7 channels, one at a time (fused multiply-adds: this function has FMA).
            super::channel_tail::<true>(g, src, k, b, dst, ch, act);
        }
    }

    /// Channels `ch .. ch + 8·N` of the whole output.
    ///
    /// # Safety
    /// As [`run`], with `src`, `k`, `b` and `dst` pointing to the starts of its slices, and
    /// `ch + 8·N <= c` (the 8·N channels from `ch` are read and written, at every pixel).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn block<const N: usize>(
        g: &Geometry,
        src: *const f32,
        k: *const f32,
        b: *const f32,
        dst: *mut f32,
        ch: usize,
        (low, high): Bounds,
    ) {
        let c = g.c;
        let clamp = low > f32::NEG_INFINITY || high < f32::INFINITY;
        let (lo, hi) = (_mm256_set1_ps(low), _mm256_set1_ps(high));
        let mut bias = [_mm256_setzero_ps(); N];
        for (r, v) in bias.iter_mut().enumerate() {
            // SAFETY: biases ch + 8·r .. ch + 8·r + 8, and ch + 8·N <= c values of `b`.
            *v = unsafe { _mm256_loadu_ps(b.add(ch + 8 * r)) };
        }
        each_window(g, |win| {
            let mut acc = bias;
            for ky in win.ky.0..win.ky.1 {
                for kx in win.kx.0..win.kx.1 {
                    // SAFETY: (ky, kx) is a valid tap of the window, so its input pixel is
                    // inside the image (`Window::input`); channels ch .. ch + 8·N <= c of that
                    // pixel and of the tap's weights are read.
                    unsafe {
                        let i = src.add(win.input(g, ky, kx) + ch);
                        let w = k.add((ky * g.kw + kx) * c + ch);
                        for (r, a) in acc.iter_mut().enumerate() {
                            *a = _mm256_fmadd_ps(
                                _mm256_loadu_ps(i.add(8 * r)),
                                _mm256_loadu_ps(w.add(8 * r)),
                                *a,
                            );
                        }
                    }
                }
            }
            // SAFETY: `win.pixel` is a pixel of the output rows `dst` holds (`each_window`);
            // its channels ch .. ch + 8·N <= c are written below.
            let out = unsafe { dst.add(win.pixel * c + ch) };
            for (r, a) in acc.iter().enumerate() {
                // max(x, low) then min(., high), as the portable loop.
                let v = if clamp {
                    _mm256_min_ps(_mm256_max_ps(*a, lo), hi)
                } else {
                    *a
                };
                // SAFETY: as above: channels ch + 8·r .. ch + 8·r + 8 <= c of the pixel.
                unsafe { _mm256_storeu_ps(out.add(8 * r), v) };
            }
        });
    }
}

/// The WebAssembly `simd128` kernel: [`avx2`]'s register blocking with 4-lane vectors, 16
/// channels per block, then blocks of 4, then the last 1-3 channels one at a time. Each
/// tap is one [`wasm_madd`](crate::isa::wasm_madd) in the portable loop's order (bias, then
/// row by row, column by column). In a module built with `simd128` alone that is a product
/// then a sum, as the portable loop does on this target (`kernel::<false>`): the results
/// are the same bits. With `relaxed-simd` the engine fuses it where its CPU has FMA (the
/// bits of `kernel::<true>`, but for the last 1-3 channels, which are the portable loop's)
/// or not (those of `kernel::<false>`).
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod simd128 {
    use super::{each_window, Bounds, Geometry};
    use core::arch::wasm32::*;

    /// # Safety
    /// `g` must describe the slices, which are read and written through raw pointers at
    /// offsets computed from it, without bounds checks: `src` holds at least `h·w·c` values,
    /// `k` at least `kh·kw·c` and `b` at least `c`; `g.rows.0 <= g.rows.1 <= g.oh`, and `dst`
    /// holds at least `(rows.1 - rows.0)·ow·c` values (the output rows `g.rows`). Only the
    /// taps inside the `h x w` image are read.
    pub(super) unsafe fn run(
        g: &Geometry,
        src: &[f32],
        k: &[f32],
        b: &[f32],
        dst: &mut [f32],
        act: Bounds,
    ) {
        let (src, k, b, dst) = (src.as_ptr(), k.as_ptr(), b.as_ptr(), dst.as_mut_ptr());
        let mut ch = 0;
        while ch + 16 <= g.c {
            // SAFETY: this function's contract, and channels ch .. ch + 16 <= c.
            unsafe { block::<4>(g, src, k, b, dst, ch, act) };
            ch += 16;
        }
        while ch + 4 <= g.c {
            // SAFETY: as above, channels ch .. ch + 4 <= c.
            unsafe { block::<1>(g, src, k, b, dst, ch, act) };
            ch += 4;
        }
        if ch < g.c {
            // SAFETY: as above, channels ch .. c.
            unsafe { super::channel_tail::<false>(g, src, k, b, dst, ch, act) };
        }
    }

    /// Channels `ch .. ch + 4·N` of the whole output.
    ///
    /// # Safety
    /// As [`run`], with `src`, `k`, `b` and `dst` pointing to the starts of its slices, and
    /// `ch + 4·N <= c` (the 4·N channels from `ch` are read and written, at every pixel).
    #[inline]
    unsafe fn block<const N: usize>(
        g: &Geometry,
        src: *const f32,
        k: *const f32,
        b: *const f32,
        dst: *mut f32,
        ch: usize,
        (low, high): Bounds,
    ) {
        let c = g.c;
        let clamp = low > f32::NEG_INFINITY || high < f32::INFINITY;
        let (lo, hi) = (f32x4_splat(low), f32x4_splat(high));
        let mut bias = [f32x4_splat(0.0); N];
        for (r, v) in bias.iter_mut().enumerate() {
            // SAFETY: biases ch + 4·r .. ch + 4·r + 4, and ch + 4·N <= c values of `b`;
            // WebAssembly loads need no alignment.
            *v = unsafe { v128_load(b.add(ch + 4 * r) as *const v128) };
        }
        each_window(g, |win| {
            let mut acc = bias;
            for ky in win.ky.0..win.ky.1 {
                for kx in win.kx.0..win.kx.1 {
                    // SAFETY: (ky, kx) is a valid tap of the window, so its input pixel is
                    // inside the image (`Window::input`); channels ch .. ch + 4·N <= c of that
                    // pixel and of the tap's weights are read.
                    unsafe {
                        let i = src.add(win.input(g, ky, kx) + ch);
                        let w = k.add((ky * g.kw + kx) * c + ch);
                        for (r, a) in acc.iter_mut().enumerate() {
                            let x = v128_load(i.add(4 * r) as *const v128);
                            let y = v128_load(w.add(4 * r) as *const v128);
                            *a = crate::isa::wasm_madd(x, y, *a);
                        }
                    }
                }
            }
            // SAFETY: `win.pixel` is a pixel of the output rows `dst` holds (`each_window`);
            // its channels ch .. ch + 4·N <= c are written below.
            let out = unsafe { dst.add(win.pixel * c + ch) };
            for (r, a) in acc.iter().enumerate() {
                // max(x, low) then min(., high), as the portable loop.
                let v = if clamp {
                    f32x4_min(f32x4_max(*a, lo), hi)
                } else {
                    *a
                };
                // SAFETY: as above: channels ch + 4·r .. ch + 4·r + 4 <= c of the pixel.
                unsafe { v128_store(out.add(4 * r) as *mut v128, v) };
            }
        });
    }
}

/// The AVX-512 kernel: [`avx2`]'s register blocking with 16-lane vectors, 64 channels per
/// block, then the remaining 1-63 channels in one block whose last vector is under a lane
/// mask (instead of one channel at a time). Same order of the same fused multiply-adds per lane, so
/// the results are bit-identical to the portable loop's.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{each_window, valid, Bounds, Geometry, Window};
    use std::arch::x86_64::*;

    /// # Safety
    /// The CPU must support AVX-512F. `g` must describe the slices, which are read and
    /// written through raw pointers at offsets computed from it, without bounds checks:
    /// `src` holds at least `h·w·c` values, `k` at least `kh·kw·c` and `b` at least `c`;
    /// `g.rows.0 <= g.rows.1 <= g.oh`, and `dst` holds at least `(rows.1 - rows.0)·ow·c`
    /// values (the output rows `g.rows`). The strides and padding need no check: only the
    /// taps inside the `h x w` image are read.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn run(
        g: &Geometry,
        src: &[f32],
        k: &[f32],
        b: &[f32],
        dst: &mut [f32],
        act: Bounds,
    ) {
        let (src, k, b, dst) = (src.as_ptr(), k.as_ptr(), b.as_ptr(), dst.as_mut_ptr());
        // SAFETY: this function's contract is `sweep`'s, with the slices' pointers; `K` is 3
        // or 5 only when the kernel is that size in both directions, else 0.
        unsafe {
            match (g.kh, g.kw) {
                (3, 3) => sweep::<3>(g, src, k, b, dst, act),
                (5, 5) => sweep::<5>(g, src, k, b, dst, act),
                _ => sweep::<0>(g, src, k, b, dst, act),
            }
        }
    }

    /// [`run`] for square `K x K` kernels (`K = 0`: any size).
    ///
    /// # Safety
    /// As [`run`], with `src`, `k`, `b` and `dst` pointing to the starts of its slices; `K`
    /// is 0 or `kh == kw == K` (the unrolled path indexes the weights with `K`).
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn sweep<const K: usize>(
        g: &Geometry,
        src: *const f32,
        k: *const f32,
        b: *const f32,
        dst: *mut f32,
        act: Bounds,
    ) {
        let mut ch = 0;
        while ch + 64 <= g.c {
            // SAFETY: this function's contract, and the block's 4 whole vectors are channels
            // ch .. ch + 64 <= c.
            unsafe { block::<4, false, K, 2>(g, src, k, b, dst, ch, 0xffff, act) };
            ch += 64;
        }
        // The rest in one sweep of the image (24 channels: one block of a whole and a
        // half-masked vector, not two sweeps).
        let rest = g.c - ch;
        let mask = match rest % 16 {
            0 => 0xffff,
            r => (1u16 << r) - 1,
        };
        let masked = !rest.is_multiple_of(16);
        // SAFETY: this function's contract, and the block's lanes are channels ch .. c: its
        // `rest.div_ceil(16)` vectors cover the `rest = c - ch` channels, the last one under
        // `mask` (its `rest % 16` first lanes) where `rest` is not a multiple of 16.
        unsafe {
            match (rest.div_ceil(16), masked) {
                (0, _) => {}
                (1, false) => block::<1, false, K, 4>(g, src, k, b, dst, ch, mask, act),
                (1, true) => block::<1, true, K, 4>(g, src, k, b, dst, ch, mask, act),
                (2, false) => block::<2, false, K, 4>(g, src, k, b, dst, ch, mask, act),
                (2, true) => block::<2, true, K, 4>(g, src, k, b, dst, ch, mask, act),
                (3, false) => block::<3, false, K, 2>(g, src, k, b, dst, ch, mask, act),
                (3, true) => block::<3, true, K, 2>(g, src, k, b, dst, ch, mask, act),
                // rest < 64: four vectors only with a partial last one.
                (_, _) => block::<4, true, K, 2>(g, src, k, b, dst, ch, mask, act),
            }
        }
    }

    /// Channels `ch .. ch + 16·N` of the whole output; with `MASKED`, the last vector's
    /// lanes outside `mask` are neither read nor written. With `K > 0` (a `K x K` kernel)
    /// the windows inside the image take a fully unrolled path (the same taps in the same
    /// order), `P` neighbouring output pixels of a row at a time where all their windows
    /// are inside: `P·N` independent chains of multiply-adds (one pixel's `N` alone wait on
    /// the multiply-add's latency), each tap's weights loaded once for the `P` pixels. Every
    /// value is summed as alone: the same bits.
    ///
    /// # Safety
    /// As [`sweep`] (the CPU, the slices behind the pointers, `K`), and the lanes read and
    /// written are channels below `c`: `ch + 16·N <= c`, or with `MASKED`,
    /// `ch + 16·(N - 1) + (the highest lane set in mask, plus 1) <= c`.
    #[target_feature(enable = "avx512f")]
    #[inline]
    #[allow(clippy::too_many_arguments)]
    unsafe fn block<const N: usize, const MASKED: bool, const K: usize, const P: usize>(
        g: &Geometry,
        src: *const f32,
        k: *const f32,
        b: *const f32,
        dst: *mut f32,
        ch: usize,
        mask: __mmask16,
        (low, high): Bounds,
    ) {
        let c = g.c;
        let clamp = low > f32::NEG_INFINITY || high < f32::INFINITY;
        let (lo, hi) = (_mm512_set1_ps(low), _mm512_set1_ps(high));
        // SAFETY: `load` is called only with `p` at channel `ch` of a bias, weight or input
        // pixel row of `c` values inside its slice, and `r < N`: vector `r` (masked for the
        // last one with `MASKED`) holds channels below `c` (this function's contract).
        let load = |p: *const f32, r: usize| unsafe {
            if MASKED && r + 1 == N {
                _mm512_maskz_loadu_ps(mask, p.add(16 * r))
            } else {
                _mm512_loadu_ps(p.add(16 * r))
            }
        };
        let mut bias = [_mm512_setzero_ps(); N];
        for (r, v) in bias.iter_mut().enumerate() {
            // SAFETY: ch <= c, the number of biases `b` holds; `load` reads channels below c.
            *v = load(unsafe { b.add(ch) }, r);
        }
        // The activation and the store of one pixel's accumulators.
        let store = |pixel: usize, acc: &[__m512; N]| {
            // SAFETY: `pixel` is a pixel of the output rows `dst` holds; its channels from
            // ch on, below c, are written below.
            let out = unsafe { dst.add(pixel * c + ch) };
            for (r, a) in acc.iter().enumerate() {
                // max(x, low) then min(., high), as the portable loop.
                let v = if clamp {
                    _mm512_min_ps(_mm512_max_ps(*a, lo), hi)
                } else {
                    *a
                };
                // SAFETY: as above: vector r of the pixel's channels from ch, under `mask` for
                // the last one with `MASKED`, holds channels below c (the contract).
                unsafe {
                    if MASKED && r + 1 == N {
                        _mm512_mask_storeu_ps(out.add(16 * r), mask, v);
                    } else {
                        _mm512_storeu_ps(out.add(16 * r), v);
                    }
                }
            }
        };
        let row = g.w * c;
        let one = |win: Window| {
            let mut acc = bias;
            if K > 0 && win.ky == (0, K) && win.kx == (0, K) {
                // SAFETY: the window's K x K taps are all inside the image (its valid rows and
                // columns are (0, K)), the top-left one included.
                let i0 = unsafe { src.add(win.input(g, 0, 0) + ch) };
                for ky in 0..K {
                    for kx in 0..K {
                        // SAFETY: as above, tap (ky, kx) is inside the image; and of the
                        // K x K weights (kh == kw == K).
                        let (i, w) =
                            unsafe { (i0.add(ky * row + kx * c), k.add((ky * K + kx) * c + ch)) };
                        for (r, a) in acc.iter_mut().enumerate() {
                            *a = _mm512_fmadd_ps(load(i, r), load(w, r), *a);
                        }
                    }
                }
            } else {
                for ky in win.ky.0..win.ky.1 {
                    for kx in win.kx.0..win.kx.1 {
                        // SAFETY: (ky, kx) is a valid tap of the window, so its input pixel is
                        // inside the image (`Window::input`), and ky < kh, kx < kw.
                        let (i, w) = unsafe {
                            (
                                src.add(win.input(g, ky, kx) + ch),
                                k.add((ky * g.kw + kx) * c + ch),
                            )
                        };
                        for (r, a) in acc.iter_mut().enumerate() {
                            *a = _mm512_fmadd_ps(load(i, r), load(w, r), *a);
                        }
                    }
                }
            }
            store(win.pixel, &acc);
        };
        if K == 0 || P < 2 {
            each_window(g, one);
            return;
        }
        for oy in g.rows.0..g.rows.1 {
            let y0 = (oy * g.sy) as isize - g.pt as isize;
            let ky = valid(y0, g.h, g.kh);
            let mut ox = 0;
            while ox < g.ow {
                let x0 = (ox * g.sx) as isize - g.pl as isize;
                let kx = valid(x0, g.w, g.kw);
                let pixel = (oy - g.rows.0) * g.ow + ox;
                // The windows of pixels ox .. ox + P all inside the image: the first's and
                // the last's are (the ones between lie between them).
                let last = x0 + ((P - 1) * g.sx) as isize;
                if ky == (0, K) && kx == (0, K) && ox + P <= g.ow && valid(last, g.w, K) == (0, K) {
                    let mut acc = [bias; P];
                    // SAFETY: the P windows' K x K taps are all inside the image (checked
                    // above: rows (0, K) of each, columns (0, K) of the first and the last),
                    // the first one's top-left tap included.
                    let i0 = unsafe { src.add((y0 as usize * g.w + x0 as usize) * c + ch) };
                    for ky in 0..K {
                        for kx in 0..K {
                            // SAFETY: of the K x K weights (kh == kw == K).
                            let w = unsafe { k.add((ky * K + kx) * c + ch) };
                            let mut wv = [_mm512_setzero_ps(); N];
                            for (r, v) in wv.iter_mut().enumerate() {
                                *v = load(w, r);
                            }
                            for (p, acc) in acc.iter_mut().enumerate() {
                                // SAFETY: tap (ky, kx) of pixel ox + p's window, inside the
                                // image as above.
                                let i = unsafe { i0.add(ky * row + (kx + p * g.sx) * c) };
                                for (r, a) in acc.iter_mut().enumerate() {
                                    *a = _mm512_fmadd_ps(load(i, r), wv[r], *a);
                                }
                            }
                        }
                    }
                    for (p, acc) in acc.iter().enumerate() {
                        // Pixels ox .. ox + P <= ow of output row oy, one of `dst`'s rows.
                        store(pixel + p, acc);
                    }
                    ox += P;
                } else {
                    one(Window {
                        pixel,
                        y0,
                        x0,
                        ky,
                        kx,
                    });
                    ox += 1;
                }
            }
        }
    }
}

/// The loop nest: output row, kernel tap, output column, channels (innermost, contiguous).
/// For one tap the valid output columns are computed once, so the two inner loops run over
/// contiguous chunks without per-pixel bounds tests.
#[inline(always)]
fn kernel<const FMA: bool>(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    (low, high): Bounds,
) {
    let clamp = low > f32::NEG_INFINITY || high < f32::INFINITY;
    let c = g.c;
    let row_in = g.w * c;
    let row_out = g.ow * c;
    let rows = g.rows.0..g.rows.1.min(g.oh);
    for (oy, orow) in rows.zip(dst.chunks_exact_mut(row_out)) {
        for o in orow.chunks_exact_mut(c) {
            o.copy_from_slice(&b[..c]);
        }
        for ky in 0..g.kh {
            let iy = (oy * g.sy + ky) as isize - g.pt as isize;
            if iy < 0 || iy >= g.h as isize {
                continue;
            }
            let irow = &src[iy as usize * row_in..][..row_in];
            for kx in 0..g.kw {
                // Output columns whose input column ox·sx + kx − pl lies inside the image.
                let last = g.w - 1 + g.pl;
                if last < kx {
                    continue;
                }
                let ox0 = g.pl.saturating_sub(kx).div_ceil(g.sx);
                let ox1 = ((last - kx) / g.sx + 1).min(g.ow);
                if ox0 >= ox1 {
                    continue;
                }
                let ix0 = ox0 * g.sx + kx - g.pl;
                let kk = &k[(ky * g.kw + kx) * c..][..c];
                let outs = orow[ox0 * c..ox1 * c].chunks_exact_mut(c);
                let ins = irow[ix0 * c..].chunks_exact(c).step_by(g.sx);
                match c {
                    // Narrow layers: a compile-time width lets the channel loop unroll.
                    16 => taps::<FMA, 16>(outs, ins, kk),
                    24 => taps::<FMA, 24>(outs, ins, kk),
                    32 => taps::<FMA, 32>(outs, ins, kk),
                    _ => {
                        for (o, i) in outs.zip(ins) {
                            for ((o, &i), &kk) in o.iter_mut().zip(i).zip(kk) {
                                *o = if FMA { i.mul_add(kk, *o) } else { *o + i * kk };
                            }
                        }
                    }
                }
            }
        }
        if clamp {
            // As tract's `Max` then `Min` did: max(x, low), then min(., high).
            for v in orow.iter_mut() {
                *v = v.max(low).min(high);
            }
        }
    }
}

/// One kernel tap over a run of output pixels, for a channel count `C` known at compile time.
#[inline(always)]
fn taps<'a, const FMA: bool, const C: usize>(
    outs: impl Iterator<Item = &'a mut [f32]>,
    ins: impl Iterator<Item = &'a [f32]>,
    kk: &[f32],
) {
    let Ok(kk) = <&[f32; C]>::try_from(kk) else {
        return;
    };
    for (o, i) in outs.zip(ins) {
        let (Ok(o), Ok(i)) = (<&mut [f32; C]>::try_from(o), <&[f32; C]>::try_from(i)) else {
            return;
        };
        for ch in 0..C {
            o[ch] = if FMA {
                i[ch].mul_add(kk[ch], o[ch])
            } else {
                o[ch] + i[ch] * kk[ch]
            };
        }
    }
}

/// The geometry of a square `k x k` kernel with stride `s` on an `h x w x c` input (tests).
#[cfg(test)]
fn square_geometry(h: usize, w: usize, c: usize, k: usize, s: usize, same: bool) -> Geometry {
    let (oh, pt) = axis_geometry(h, k, s, same);
    let (ow, pl) = axis_geometry(w, k, s, same);
    Geometry {
        h,
        w,
        c,
        kh: k,
        kw: k,
        sy: s,
        sx: s,
        pt,
        pl,
        oh,
        ow,
        rows: (0, oh),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct reference: TFLite semantics written out naively.
    fn reference(
        x: &[f32],
        (h, w, c): (usize, usize, usize),
        k: &[f32],
        (kh, kw): (usize, usize),
        b: &[f32],
        s: usize,
        same: bool,
    ) -> (Vec<f32>, usize, usize) {
        let (oh, pt) = axis_geometry(h, kh, s, same);
        let (ow, pl) = axis_geometry(w, kw, s, same);
        let mut out = vec![0.0; oh * ow * c];
        for oy in 0..oh {
            for ox in 0..ow {
                for ch in 0..c {
                    let mut acc = b[ch] as f64;
                    for ky in 0..kh {
                        for kx in 0..kw {
                            let iy = (oy * s + ky) as isize - pt as isize;
                            let ix = (ox * s + kx) as isize - pl as isize;
                            if iy >= 0 && ix >= 0 && (iy as usize) < h && (ix as usize) < w {
                                acc += x[((iy as usize) * w + ix as usize) * c + ch] as f64
                                    * k[(ky * kw + kx) * c + ch] as f64;
                            }
                        }
                    }
                    out[(oy * ow + ox) * c + ch] = acc as f32;
                }
            }
        }
        (out, oh, ow)
    }

    #[test]
    fn matches_naive_reference_for_same_and_valid_strides_1_and_2() {
        // 5 channels: the scalar tail only; 45: a block of 32, one of 8 and a tail of 5.
        for c in [5, 45] {
            matches_naive_reference_with_channels(c);
        }
    }

    /// Fixed inputs (`n` values), weights (`nk`) and biases (`c`) for the kernels' tests.
    fn data(n: usize, nk: usize, c: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let x = (0..n)
            .map(|i| ((i * 7919 % 1009) as f32 - 504.0) / 97.0)
            .collect();
        let k = (0..nk)
            .map(|i| ((i * 31 % 59) as f32 - 29.0) / 13.0)
            .collect();
        let b = (0..c).map(|i| i as f32 * 0.37 - 3.0).collect();
        (x, k, b)
    }

    /// A `k x k` "same" depthwise convolution of `c` channels with stride `s`, weights and
    /// biases `(kernel, bias)` and a fused ReLU6 (the splitting and coding tests' layer).
    fn relu6_square(
        k: usize,
        c: usize,
        s: usize,
        (kernel, bias): (&[f32], &[f32]),
        register_blocked: bool,
        split: bool,
    ) -> NhwcDepthwise {
        NhwcDepthwise {
            kernel: Tensor::from_shape(&[k, k, c], kernel)
                .expect("k")
                .into_arc_tensor(),
            bias: tensor1(bias).into_arc_tensor(),
            strides: (s, s),
            same: true,
            activation: Activation::Relu6,
            register_blocked,
            split,
        }
    }

    #[test]
    fn shared_between_threads_gives_the_same_bits() {
        // The landmark networks' 112x112x24 3x3 layer, a 5x5 stride-2 one, and the portable
        // loop (not register-blocked).
        for (h, c, k, s, blocked) in [
            (112, 24, 3, 1, true),
            (56, 64, 5, 2, true),
            (56, 40, 3, 1, false),
        ] {
            let (x, kv, b) = data(h * h * c, k * k * c, c);
            let op = |split| relu6_square(k, c, s, (&kv, &b), blocked, split);
            let input = Tensor::from_shape(&[1, h, h, c], &x).expect("x");
            crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
        }
    }

    #[test]
    fn coded_results_are_the_codes_of_the_f32_results() {
        // (h, c, k, stride, register-blocked): the landmark networks' 112x112x24 layer (one
        // output row per chunk), several rows per chunk, channels off the vectors and the
        // group of 4, the portable loop; a code range narrower than the results (clamped).
        for (h, c, k, s, blocked) in [
            (112, 24, 3, 1, true),
            (14, 480, 5, 1, true),
            (9, 37, 3, 2, true),
            (7, 5, 5, 1, true),
            (13, 40, 3, 1, false),
        ] {
            let (x, kv, b) = data(h * h * c, k * k * c, c);
            let conv = |split| relu6_square(k, c, s, (&kv, &b), blocked, split);
            let quant = ActivationQuant::from_min_max(0.0, 5.0);
            let input = Tensor::from_shape(&[1, h, h, c], &x).expect("x");
            let values = crate::split::testing::bits(&conv(false), std::slice::from_ref(&input));
            let want: Vec<u32> = values
                .iter()
                .map(|&v| quant.quantize(f32::from_bits(v)) as u32)
                .collect();
            let coded = |split| NhwcDepthwiseCodes::new(conv(split), quant);
            let got = crate::split::testing::bits(&coded(false), std::slice::from_ref(&input));
            assert_eq!(got, want, "h {h} c {c} k {k} s {s}");
            if h >= 56 {
                crate::split::testing::same_bits_split(&coded(true), &coded(false), &[input]);
            }
        }
    }

    fn matches_naive_reference_with_channels(c: usize) {
        let (h, w) = (7, 6);
        let x: Vec<f32> = (0..h * w * c)
            .map(|i| ((i * 37 % 101) as f32 - 50.0) / 25.0)
            .collect();
        let (mut below, mut above) = (false, false);
        for ((kh, kw, s, same), activation) in [
            (3, 3, 1, true),
            (5, 5, 2, true),
            (3, 3, 2, false),
            (1, 1, 1, true),
        ]
        .into_iter()
        .flat_map(|g| [Activation::None, Activation::Relu, Activation::Relu6].map(|a| (g, a)))
        {
            let k: Vec<f32> = (0..kh * kw * c)
                .map(|i| ((i * 13 % 17) as f32 - 8.0) / 8.0)
                .collect();
            let b: Vec<f32> = (0..c).map(|i| i as f32 * 0.1).collect();
            let op = NhwcDepthwise {
                kernel: Tensor::from_shape(&[kh, kw, c], &k)
                    .expect("k")
                    .into_arc_tensor(),
                bias: Tensor::from_shape(&[c], &b).expect("b").into_arc_tensor(),
                strides: (s, s),
                same,
                activation,
                register_blocked: true,
                split: true,
            };
            let input = Tensor::from_shape(&[1, h, w, c], &x).expect("x");
            let out = op
                .eval_out_of_plan(tvec!(input.into_tvalue()))
                .expect("eval")
                .expect("evaluates out of plan");
            let (want, oh, ow) = reference(&x, (h, w, c), &k, (kh, kw), &b, s, same);
            assert_eq!(out[0].shape(), &[1, oh, ow, c]);
            let got = out[0].try_as_plain_ram().expect("ram");
            let got = got.as_slice::<f32>().expect("f32");
            let (low, high) = match activation {
                Activation::None => (f32::NEG_INFINITY, f32::INFINITY),
                Activation::Relu => (0.0, f32::INFINITY),
                Activation::Relu6 => (0.0, 6.0),
            };
            below |= want.iter().any(|&v| v < 0.0);
            above |= want.iter().any(|&v| v > 6.0);
            for (g, w) in got.iter().zip(&want) {
                let w = w.max(low).min(high);
                assert!(
                    (g - w).abs() < 1e-5,
                    "k{kh} s{s} same {same} {activation:?}: {g} vs {w}"
                );
            }
        }
        // The references reach past both bounds, so each clamp is exercised.
        assert!(below && above);
    }

    /// `(h, w, c, k, stride, same)` of the register-blocked kernels' tests: channel counts
    /// that cover AVX2's blocks of 32 and 8 and its scalar tail, AVX-512's blocks of 64 and
    /// its last blocks of 1, 2 and 3 vectors with and without a masked last vector and of 4
    /// with one, and `simd128`'s blocks of 32 and 4 and its tail.
    #[cfg(any(
        target_arch = "x86_64",
        all(target_arch = "wasm32", target_feature = "simd128")
    ))]
    /// (h, w, c, k, stride, same), the last five wide enough for the AVX-512 kernel's runs
    /// of 4 (16 and 32 channels) and 2 (40 and 64) pixels, with single pixels after them.
    const BLOCK_SHAPES: [(usize, usize, usize, usize, usize, bool); 16] = [
        (9, 8, 72, 3, 1, true),
        (10, 11, 45, 5, 2, true),
        (8, 8, 40, 3, 2, false),
        (7, 9, 100, 3, 1, true),
        (6, 5, 3, 5, 1, true),
        (9, 9, 24, 3, 1, true),
        (6, 7, 96, 3, 2, true),
        (5, 5, 16, 3, 1, false),
        (6, 6, 48, 5, 1, true),
        (7, 6, 56, 3, 1, true),
        (6, 7, 120, 5, 2, true),
        (7, 14, 32, 5, 1, true),
        (6, 21, 24, 3, 2, true),
        (5, 13, 16, 3, 1, false),
        (5, 12, 64, 5, 1, true),
        (4, 15, 40, 5, 2, false),
    ];

    /// The `simd128` kernel sums in the portable loop's order, a product then a sum per tap
    /// as the portable loop does on WebAssembly: its results are the same bits. Built with
    /// `relaxed-simd`, each tap's product and sum is fused or not as the engine decides, the
    /// same way for every tap: the bits of the fused portable loop or of the plain one. (Run
    /// by `scripts/web-test.sh` under Node's WASI.)
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    #[test]
    fn the_simd128_kernel_is_bit_identical_to_the_portable_loop() {
        for (h, w, c, kh, s, same) in BLOCK_SHAPES {
            let (x, k, b) = data(h * w * c, kh * kh * c, c);
            let g = square_geometry(h, w, c, kh, s, same);
            let (oh, ow) = (g.oh, g.ow);
            for act in [(f32::NEG_INFINITY, f32::INFINITY), (0.0, 6.0)] {
                let mut portable = vec![0.0; oh * ow * c];
                kernel::<false>(&g, &x, &k, &b, &mut portable, act);
                let mut fast = vec![f32::NAN; oh * ow * c];
                // SAFETY: the buffers have the geometry's sizes, all of its rows
                // (`square_geometry`).
                unsafe { simd128::run(&g, &x, &k, &b, &mut fast, act) };
                let mut differ = crate::split::testing::differing_bits(&fast, &portable);
                if cfg!(target_feature = "relaxed-simd") && differ != 0 {
                    // The engine fused the blocks' taps; the last 1-3 channels (after the
                    // blocks of 4) are the portable loop's, a product then a sum.
                    let mut fused = vec![0.0; oh * ow * c];
                    kernel::<true>(&g, &x, &k, &b, &mut fused, act);
                    let blocks = c / 4 * 4;
                    for (i, (p, f)) in portable.iter_mut().zip(&fused).enumerate() {
                        if i % c < blocks {
                            *p = *f;
                        }
                    }
                    differ = crate::split::testing::differing_bits(&fast, &portable);
                }
                assert_eq!(differ, 0, "{h}x{w}x{c} k{kh} s{s} same {same} {act:?}");
            }
        }
    }

    /// The AVX2 and AVX-512 kernels sum in the portable loop's order with the same fused
    /// multiply-adds: their results are the same bits. The channel counts cover AVX2's blocks
    /// of 32 and 8 and its scalar tail, and AVX-512's blocks of 64 and its last blocks of 1,
    /// 2 and 3 vectors with and without a masked last vector, and of 4 with one.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_simd_kernels_are_bit_identical_to_the_portable_loop() {
        use crate::pointwise::{Isa, Kernel};
        let kernels = Kernel::supported();
        if !kernels.iter().any(|k| k.isa() == Isa::Avx2Fma) {
            eprintln!("no AVX2 + FMA on this CPU: only the portable loop runs here");
            return;
        }
        for (h, w, c, kh, s, same) in BLOCK_SHAPES {
            let (x, k, b) = data(h * w * c, kh * kh * c, c);
            let g = square_geometry(h, w, c, kh, s, same);
            let (oh, ow) = (g.oh, g.ow);
            for act in [(f32::NEG_INFINITY, f32::INFINITY), (0.0, 6.0)] {
                let mut portable = vec![0.0; oh * ow * c];
                // SAFETY: AVX2 and FMA were detected (`Kernel::supported` has `Avx2Fma`).
                unsafe { run_avx2_fma(&g, &x, &k, &b, &mut portable, act) };
                for &kernel in &kernels {
                    let mut fast = vec![f32::NAN; oh * ow * c];
                    match kernel.isa() {
                        Isa::Portable => continue,
                        // SAFETY: the CPU has the kernel's features (`supported`); the
                        // buffers have the geometry's sizes, all of its rows (`square_geometry`).
                        Isa::Avx2Fma => unsafe { avx2::run(&g, &x, &k, &b, &mut fast, act) },
                        // SAFETY: as above.
                        Isa::Avx512 => unsafe { avx512::run(&g, &x, &k, &b, &mut fast, act) },
                    }
                    let differ = crate::split::testing::differing_bits(&fast, &portable);
                    assert_eq!(
                        differ, 0,
                        "{kernel:?} {h}x{w}x{c} k{kh} s{s} same {same} {act:?}"
                    );
                }
            }
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod speed {
    use super::*;
    use crate::pointwise::{Isa, Kernel};

    /// Microseconds per call of each SIMD kernel the CPU runs, side by side, on the
    /// hand-landmark lite shapes and three of palm_detection_full's (best of 7):
    /// `cargo test --release -p monohand-tflite depthwise::speed -- --ignored --nocapture`.
    #[test]
    #[ignore = "a measurement, not a test"]
    fn landmark_shapes() {
        // (h, w, c, k, stride) of the input.
        let shapes = [
            (112, 112, 24, 3, 1),
            (112, 112, 64, 3, 2),
            (56, 56, 96, 3, 1),
            (56, 56, 96, 3, 2),
            (28, 28, 144, 5, 2),
            (14, 14, 288, 5, 1),
            (14, 14, 384, 3, 1),
            (7, 7, 672, 5, 1),
            // palm_detection_full's.
            (96, 96, 32, 5, 1),
            (48, 48, 64, 5, 1),
            (24, 24, 128, 5, 1),
        ];
        for (h, w, c, kh, s) in shapes {
            let g = square_geometry(h, w, c, kh, s, true);
            let (oh, ow) = (g.oh, g.ow);
            let x = vec![0.5f32; h * w * c];
            let k = vec![0.25f32; kh * kh * c];
            let b = vec![0.1f32; c];
            let mut out = vec![0f32; oh * ow * c];
            let mut line = format!("{h:>4}x{w:<4}x{c:>4} k{kh} s{s}:");
            for kernel in Kernel::supported() {
                let n = (2e7 / (oh * ow * c * kh * kh) as f64).max(3.0) as usize;
                let mut best = f64::MAX;
                for _ in 0..7 {
                    let t = std::time::Instant::now();
                    for _ in 0..n {
                        match kernel.isa() {
                            Isa::Portable => continue,
                            // SAFETY: the CPU has the kernel's features (`supported`); the
                            // buffers have the geometry's sizes, all of its rows.
                            Isa::Avx2Fma => unsafe {
                                avx2::run(&g, &x, &k, &b, &mut out, (0.0, 6.0))
                            },
                            // SAFETY: as above.
                            Isa::Avx512 => unsafe {
                                avx512::run(&g, &x, &k, &b, &mut out, (0.0, 6.0))
                            },
                        }
                    }
                    best = best.min(t.elapsed().as_secs_f64() / n as f64);
                }
                if kernel != Kernel::PORTABLE {
                    line += &format!("  {}: {:7.1} us", kernel.name(), best * 1e6);
                }
            }
            println!("{line}");
        }
    }
}
