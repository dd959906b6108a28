//! The WebAssembly `simd128` kernel: [`avx2`]'s register blocking with 4-lane vectors, 16
//! channels per block, then blocks of 4, then the last 1-3 channels one at a time. Each
//! tap is one [`wasm_madd`](crate::isa::wasm_madd) in the portable loop's order (bias, then
//! row by row, column by column). In a module built with `simd128` alone that is a product
//! then a sum, as the portable loop does on this target (`kernel::<false>`): the results
//! are the same bits. With `relaxed-simd` the engine fuses it where its CPU has FMA (the
//! bits of `kernel::<true>`, but for the last 1-3 channels, which are the portable loop's)
//! or not (those of `kernel::<false>`).

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
