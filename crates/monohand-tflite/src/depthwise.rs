//! A channels-last depthwise convolution operator for tract.
//!
//! tract 0.23's `DepthWiseConv` walks channels in its outer loop with scalar code; it is the
//! largest single cost of the palm detector (≈ 40 % of the time). This operator keeps
//! TFLite's NHWC layout and puts the channels in the innermost loop, so each kernel tap is a
//! contiguous multiply-add over all channels that the compiler vectorises — with AVX2 + FMA
//! when the CPU has them (checked at run time), SSE2 otherwise.

use tract_core::internal::*;

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
    /// Use the register-blocked AVX2 + FMA kernel where the CPU has those features (the
    /// same results, bit for bit); false keeps the portable loop, to compare.
    pub register_blocked: bool,
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
        let shape = input.shape();
        ensure!(
            shape.len() == 4 && shape[0] == 1,
            "depthwise expects [1, H, W, C], got {shape:?}"
        );
        let (h, w, c) = (shape[1], shape[2], shape[3]);
        let (kh, kw, kc) = self.dims();
        ensure!(kc == c, "depthwise kernel has {kc} channels, input {c}");
        let (oh, ow, pt, pl) = self.output_shape(h, w);
        // Every element is set to its bias before any accumulation reads it.
        let mut output = unsafe { Tensor::uninitialized::<f32>(&[1, oh, ow, c])? };
        {
            let src = input.try_as_plain_ram()?;
            let src = src.as_slice::<f32>()?;
            let k = self.kernel.try_as_plain_ram()?;
            let k = k.as_slice::<f32>()?;
            let b = self.bias.try_as_plain_ram()?;
            let b = b.as_slice::<f32>()?;
            let mut dst = output.try_as_plain_ram_mut()?;
            let dst = dst.as_slice_mut::<f32>()?;
            let g = Geometry {
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
        }
        Ok(tvec!(output.into_tvalue()))
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
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            if blocked
                && src.len() >= g.h * g.w * g.c
                && k.len() >= g.kh * g.kw * g.c
                && b.len() >= g.c
                && dst.len() >= g.oh * g.ow * g.c
            {
                // SAFETY: the CPU supports the features the function is compiled for, and
                // the slices hold the sizes the geometry says (checked just above).
                unsafe { avx2::run(g, src, k, b, dst, act) };
            } else {
                // SAFETY: the CPU supports the features the function is compiled for.
                unsafe { run_avx2_fma(g, src, k, b, dst, act) };
            }
            return;
        }
    }
    kernel::<false>(g, src, k, b, dst, act);
}

/// The portable loop nest compiled for AVX2 + FMA (the kernel before the register-blocked
/// one; kept to compare, and for slices shorter than the geometry, which never happen).
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
    use super::{Bounds, Geometry};
    use std::arch::x86_64::*;

    /// # Safety
    /// The CPU must support AVX2 and FMA; `src`, `k`, `b` and `dst` must hold at least
    /// `h·w·c`, `kh·kw·c`, `c` and `oh·ow·c` elements.
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
            tail(g, src, k, b, dst, ch, act);
        }
    }

    /// Valid kernel rows (or columns) `[k0, k1)` of an output pixel whose window starts at
    /// input coordinate `start` on an axis of `size` pixels.
    #[inline(always)]
    fn valid(start: isize, size: usize, k: usize) -> (usize, usize) {
        let k0 = (-start).max(0) as usize;
        let k1 = ((size as isize - start).max(0) as usize).min(k);
        (k0, k1)
    }

    /// Channels `ch .. ch + 8·N` of the whole output.
    #[inline(always)]
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
            *v = _mm256_loadu_ps(b.add(ch + 8 * r));
        }
        for oy in 0..g.oh {
            let y0 = (oy * g.sy) as isize - g.pt as isize;
            let (ky0, ky1) = valid(y0, g.h, g.kh);
            for ox in 0..g.ow {
                let x0 = (ox * g.sx) as isize - g.pl as isize;
                let (kx0, kx1) = valid(x0, g.w, g.kw);
                let mut acc = bias;
                for ky in ky0..ky1 {
                    // ky >= ky0 and kx >= kx0 keep the input coordinates >= 0.
                    let row = src.add((y0 + ky as isize) as usize * g.w * c + ch);
                    let wrow = k.add(ky * g.kw * c + ch);
                    for kx in kx0..kx1 {
                        let i = row.add((x0 + kx as isize) as usize * c);
                        let w = wrow.add(kx * c);
                        for (r, a) in acc.iter_mut().enumerate() {
                            *a = _mm256_fmadd_ps(
                                _mm256_loadu_ps(i.add(8 * r)),
                                _mm256_loadu_ps(w.add(8 * r)),
                                *a,
                            );
                        }
                    }
                }
                let out = dst.add((oy * g.ow + ox) * c + ch);
                for (r, a) in acc.iter().enumerate() {
                    // max(x, low) then min(., high), as the portable loop.
                    let v = if clamp {
                        _mm256_min_ps(_mm256_max_ps(*a, lo), hi)
                    } else {
                        *a
                    };
                    _mm256_storeu_ps(out.add(8 * r), v);
                }
            }
        }
    }

    /// The last `c - ch0` (< 8) channels, one at a time.
    #[inline(always)]
    unsafe fn tail(
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
        for oy in 0..g.oh {
            let y0 = (oy * g.sy) as isize - g.pt as isize;
            let (ky0, ky1) = valid(y0, g.h, g.kh);
            for ox in 0..g.ow {
                let x0 = (ox * g.sx) as isize - g.pl as isize;
                let (kx0, kx1) = valid(x0, g.w, g.kw);
                for ch in ch0..c {
                    let mut a = *b.add(ch);
                    for ky in ky0..ky1 {
                        let iy = (y0 + ky as isize) as usize;
                        for kx in kx0..kx1 {
                            let ix = (x0 + kx as isize) as usize;
                            let i = *src.add((iy * g.w + ix) * c + ch);
                            a = i.mul_add(*k.add((ky * g.kw + kx) * c + ch), a);
                        }
                    }
                    if clamp {
                        a = a.max(low).min(high);
                    }
                    *dst.add((oy * g.ow + ox) * c + ch) = a;
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
    for (oy, orow) in dst.chunks_exact_mut(row_out).take(g.oh).enumerate() {
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

    /// The AVX2 kernel sums in the portable loop's order with the same fused
    /// multiply-adds: its results are the same bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_kernel_is_bit_identical_to_the_portable_loop() {
        if !(std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma"))
        {
            eprintln!("no AVX2 + FMA on this CPU: only the portable loop runs here");
            return;
        }
        for (h, w, c, kh, s, same) in [
            (9, 8, 72, 3, 1, true),
            (10, 11, 45, 5, 2, true),
            (8, 8, 40, 3, 2, false),
        ] {
            let x: Vec<f32> = (0..h * w * c)
                .map(|i| ((i * 7919 % 1009) as f32 - 504.0) / 97.0)
                .collect();
            let k: Vec<f32> = (0..kh * kh * c)
                .map(|i| ((i * 31 % 59) as f32 - 29.0) / 13.0)
                .collect();
            let b: Vec<f32> = (0..c).map(|i| i as f32 * 0.37 - 3.0).collect();
            let (oh, pt) = axis_geometry(h, kh, s, same);
            let (ow, pl) = axis_geometry(w, kh, s, same);
            let g = Geometry {
                h,
                w,
                c,
                kh,
                kw: kh,
                sy: s,
                sx: s,
                pt,
                pl,
                oh,
                ow,
            };
            for act in [(f32::NEG_INFINITY, f32::INFINITY), (0.0, 6.0)] {
                let mut fast = vec![0.0; oh * ow * c];
                let mut portable = vec![0.0; oh * ow * c];
                // SAFETY: AVX2 and FMA were detected; the buffers have the geometry's sizes.
                unsafe { avx2::run(&g, &x, &k, &b, &mut fast, act) };
                // SAFETY: as above.
                unsafe { run_avx2_fma(&g, &x, &k, &b, &mut portable, act) };
                let differ = fast
                    .iter()
                    .zip(&portable)
                    .filter(|(a, b)| a.to_bits() != b.to_bits())
                    .count();
                assert_eq!(differ, 0, "{h}x{w}x{c} k{kh} s{s} same {same} {act:?}");
            }
        }
    }
}
