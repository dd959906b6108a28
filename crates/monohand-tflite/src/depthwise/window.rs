//! The pieces the register-blocked kernels share: the check of the slices against the
//! geometry, each output pixel's window of valid taps, and the last channels one at a time.

use super::{Bounds, Geometry};

/// Whether the slices hold what the geometry reads and writes (the register-blocked
/// kernels' contract).
pub(super) fn sized(g: &Geometry, src: &[f32], k: &[f32], b: &[f32], dst: &[f32]) -> bool {
    src.len() >= g.h * g.w * g.c
        && k.len() >= g.kh * g.kw * g.c
        && b.len() >= g.c
        && g.rows.0 <= g.rows.1
        && g.rows.1 <= g.oh
        && dst.len() >= (g.rows.1 - g.rows.0) * g.ow * g.c
}

/// Valid kernel rows (or columns) `[k0, k1)` of an output pixel whose window starts at
/// input coordinate `start` on an axis of `size` pixels.
#[inline(always)]
pub(super) fn valid(start: isize, size: usize, k: usize) -> (usize, usize) {
    let k0 = (-start).max(0) as usize;
    let k1 = ((size as isize - start).max(0) as usize).min(k);
    (k0, k1)
}

/// The window of one output pixel, for the register-blocked kernels.
#[derive(Clone, Copy)]
pub(super) struct Window {
    /// Index of the output pixel (`oy · ow + ox`).
    pub(super) pixel: usize,
    /// Input coordinates of the window's top left tap (may be negative: padding).
    pub(super) y0: isize,
    pub(super) x0: isize,
    /// Kernel rows `[ky0, ky1)` and columns `[kx0, kx1)` inside the image.
    pub(super) ky: (usize, usize),
    pub(super) kx: (usize, usize),
}

impl Window {
    /// Offset in the input of channel 0 of tap `(ky, kx)`, which must be a valid tap
    /// (`ky >= ky0` and `kx >= kx0` keep the coordinates >= 0).
    #[inline(always)]
    pub(super) fn input(&self, g: &Geometry, ky: usize, kx: usize) -> usize {
        ((self.y0 + ky as isize) as usize * g.w + (self.x0 + kx as isize) as usize) * g.c
    }
}

/// Calls `f` with each output pixel's window, row by row.
#[inline(always)]
pub(super) fn each_window(g: &Geometry, mut f: impl FnMut(Window)) {
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
#[inline(always)]
pub(super) unsafe fn channel_tail<const FMA: bool>(
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
