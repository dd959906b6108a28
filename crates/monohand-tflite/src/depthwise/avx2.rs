//! The AVX2 + FMA kernel: register-blocked like XNNPACK's depthwise kernels. For each block
//! of 32 (then 8) channels, and each output pixel, the accumulators stay in registers over
//! all of the pixel's kernel taps and are stored once, with the activation applied; the
//! block's weights (at most 25 taps x 32 channels, 3.2 kB) stay in L1 while the block
//! sweeps the image. The portable loop nest instead reads and writes the output row once
//! per tap. The taps are summed in the same order (bias, then row by row, column by column)
//! with the same fused multiply-adds, so the results are bit-identical to it.

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

/// The portable loop nest compiled for AVX2 + FMA (the kernel before the register-blocked
/// one; kept to compare, and for slices shorter than the geometry, which never happen).
///
/// # Safety
/// The CPU must support AVX2 and FMA. Nothing else: the loop nest indexes the slices with
/// bounds checks (a slice shorter than the geometry panics, it is not read past its end).
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn run_avx2_fma(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    act: Bounds,
) {
    super::kernel::<true>(g, src, k, b, dst, act);
}
