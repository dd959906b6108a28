//! The AVX-512 kernel: [`avx2`]'s register blocking with 16-lane vectors, 64 channels per
//! block, then the remaining 1-63 channels in one block whose last vector is under a lane
//! mask (instead of one channel at a time). Same order of the same fused multiply-adds per lane, so
//! the results are bit-identical to the portable loop's.

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

/// The taps of one pixel's window summed onto the biases, then stored: the body of
/// [`block`]'s `one`, a step of it written as a macro (as [`crate::int8`]'s AMX kernel
/// writes its depth steps) so that the code generated is that of one function. With
/// `K > 0` and the window wholly inside the image, the `K x K` taps unrolled.
macro_rules! window_taps {
    (
        $win:ident,
        $g:ident,
        $src:ident,
        $k:ident,
        $c:ident,
        $ch:ident,
        $row:ident,
        $bias:ident,
        $load:ident,
        $store:ident
    ) => {{
        let mut acc = $bias;
        if K > 0 && $win.ky == (0, K) && $win.kx == (0, K) {
            // SAFETY: the window's K x K taps are all inside the image (its valid rows and
            // columns are (0, K)), the top-left one included.
            let i0 = unsafe { $src.add($win.input($g, 0, 0) + $ch) };
            for ky in 0..K {
                for kx in 0..K {
                    // SAFETY: as above, tap (ky, kx) is inside the image; and of the
                    // K x K weights (kh == kw == K).
                    let (i, w) = unsafe {
                        (
                            i0.add(ky * $row + kx * $c),
                            $k.add((ky * K + kx) * $c + $ch),
                        )
                    };
                    for (r, a) in acc.iter_mut().enumerate() {
                        *a = _mm512_fmadd_ps($load(i, r), $load(w, r), *a);
                    }
                }
            }
        } else {
            for ky in $win.ky.0..$win.ky.1 {
                for kx in $win.kx.0..$win.kx.1 {
                    // SAFETY: (ky, kx) is a valid tap of the window, so its input pixel is
                    // inside the image (`Window::input`), and ky < kh, kx < kw.
                    let (i, w) = unsafe {
                        (
                            $src.add($win.input($g, ky, kx) + $ch),
                            $k.add((ky * $g.kw + kx) * $c + $ch),
                        )
                    };
                    for (r, a) in acc.iter_mut().enumerate() {
                        *a = _mm512_fmadd_ps($load(i, r), $load(w, r), *a);
                    }
                }
            }
        }
        $store($win.pixel, &acc);
    }};
}

/// The output rows of [`block`] with a `K x K` kernel (`K > 0`), `P` neighbouring pixels of
/// a row at a time where all their windows are inside the image, the others one by one
/// (`one`): a step of [`block`] written as a macro, as [`window_taps`].
macro_rules! pixel_rows {
    (
        $g:ident,
        $src:ident,
        $k:ident,
        $c:ident,
        $ch:ident,
        $row:ident,
        $bias:ident,
        $load:ident,
        $store:ident,
        $one:ident
    ) => {
        for oy in $g.rows.0..$g.rows.1 {
            let y0 = (oy * $g.sy) as isize - $g.pt as isize;
            let ky = valid(y0, $g.h, $g.kh);
            let mut ox = 0;
            while ox < $g.ow {
                let x0 = (ox * $g.sx) as isize - $g.pl as isize;
                let kx = valid(x0, $g.w, $g.kw);
                let pixel = (oy - $g.rows.0) * $g.ow + ox;
                // The windows of pixels ox .. ox + P all inside the image: the first's and
                // the last's are (the ones between lie between them).
                let last = x0 + ((P - 1) * $g.sx) as isize;
                if ky == (0, K) && kx == (0, K) && ox + P <= $g.ow && valid(last, $g.w, K) == (0, K)
                {
                    let mut acc = [$bias; P];
                    // SAFETY: the P windows' K x K taps are all inside the image (checked
                    // above: rows (0, K) of each, columns (0, K) of the first and the last),
                    // the first one's top-left tap included.
                    let i0 = unsafe { $src.add((y0 as usize * $g.w + x0 as usize) * $c + $ch) };
                    for ky in 0..K {
                        for kx in 0..K {
                            // SAFETY: of the K x K weights (kh == kw == K).
                            let w = unsafe { $k.add((ky * K + kx) * $c + $ch) };
                            let mut wv = [_mm512_setzero_ps(); N];
                            for (r, v) in wv.iter_mut().enumerate() {
                                *v = $load(w, r);
                            }
                            for (p, acc) in acc.iter_mut().enumerate() {
                                // SAFETY: tap (ky, kx) of pixel ox + p's window, inside the
                                // image as above.
                                let i = unsafe { i0.add(ky * $row + (kx + p * $g.sx) * $c) };
                                for (r, a) in acc.iter_mut().enumerate() {
                                    *a = _mm512_fmadd_ps($load(i, r), wv[r], *a);
                                }
                            }
                        }
                    }
                    for (p, acc) in acc.iter().enumerate() {
                        // Pixels ox .. ox + P <= ow of output row oy, one of `dst`'s rows.
                        $store(pixel + p, acc);
                    }
                    ox += P;
                } else {
                    $one(Window {
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
    };
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
    let one = |win: Window| window_taps!(win, g, src, k, c, ch, row, bias, load, store);
    if K == 0 || P < 2 {
        each_window(g, one);
        return;
    }
    pixel_rows!(g, src, k, c, ch, row, bias, load, store, one);
}
