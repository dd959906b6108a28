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
use crate::pointwise_common::Activation;

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
                _ => unsafe { avx2::run_avx2_fma(g, src, k, b, dst, act) },
            }
            return;
        }
    }
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    if blocked && sized(g, src, k, b, dst) {
        // SAFETY: `sized` checked the slices against the geometry, as `wasm::run`'s
        // contract asks (the module is built with `simd128`: nothing to detect).
        unsafe { wasm::run(g, src, k, b, dst, act) };
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

mod portable;
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
mod window;

use portable::kernel;
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
use window::{channel_tail, each_window, sized};
#[cfg(target_arch = "x86_64")]
use window::{valid, Window};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod wasm;
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
#[cfg(all(test, target_arch = "x86_64"))]
mod speed;
#[cfg(test)]
mod tests;
