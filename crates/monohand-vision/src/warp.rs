//! One affine warp from an RGB image straight into a network's f32 NHWC input buffer.
//!
//! Every output pixel centre is mapped through `crop → image` and the image is sampled
//! bilinearly, then normalised as `value · scale + offset`. There is no intermediate resized or rotated copy.
//! When one output pixel covers more than 2 image pixels (a 4000-pixel photo squeezed into
//! 192 pixels, a hand filling a 4K frame) the part of the image under the crop is first
//! reduced by box filtering (`2^k x 2^k` block means, `reduce.rs`) and sampled
//! bilinearly from there, so the network does not see aliasing and the cost does not grow
//! with the frame; for ordinary crops the warp is plain bilinear from the image, as
//! MediaPipe's. (Before issue 34 the footprint was supersampled on an `n x n` grid, n ≤ 8:
//! [`warp_into_supersampled`].)
//!
//! A rotated crop (every hand crop) is sampled eight output pixels at a time with AVX2 where
//! the CPU has it (chosen at run time): gathers of the four neighbours and the same f32
//! operations in the same order as the one-pixel loop, so the outputs are the same bits. A
//! close-up hand (a crop 2-3x the network's input, so 4 or 9 sub-samples per pixel) spent
//! more time here than in the landmark network before (docs/performance.md).

use image::RgbImage;

use crate::geometry::Affine2;
use crate::reduce::Src;
// Where the box filter starts: defined by the reductions (reduce.rs), which the warp
// samples from and which must not import the warp back.
pub use crate::reduce::PLAIN_BILINEAR_UP_TO;

/// How network inputs are normalised from 8-bit pixel values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    /// Multiplier on the 0..255 value.
    pub scale: f32,
    /// Added after scaling.
    pub offset: f32,
}

impl Normalization {
    /// `[0, 1]`: palm detector and hand-landmark model.
    pub const UNIT: Normalization = Normalization {
        scale: 1.0 / 255.0,
        offset: 0.0,
    };
    /// `[-1, 1]`: BlazeFace.
    pub const SIGNED: Normalization = Normalization {
        scale: 2.0 / 255.0,
        offset: -1.0,
    };
}

/// What a crop reads outside the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Border {
    /// Black.
    #[default]
    Zero,
    /// The nearest edge pixel.
    Replicate,
}

/// Bilinear sample of channel values at continuous image coordinates `(x, y)`, black outside.
#[inline(always)]
fn sample(raw: &[u8], w: i32, h: i32, x: f32, y: f32) -> [f32; 3] {
    let fx = x - 0.5;
    let fy = y - 0.5;
    // floor without a libm call (baseline x86-64 has no SSE4.1 rounding instruction)
    let x0 = fx as i32 - (fx < 0.0 && fx != (fx as i32) as f32) as i32;
    let y0 = fy as i32 - (fy < 0.0 && fy != (fy as i32) as f32) as i32;
    let ax = fx - x0 as f32;
    let ay = fy - y0 as f32;
    let stride = w as usize * 3;
    if x0 >= 0 && y0 >= 0 && x0 + 1 < w && y0 + 1 < h {
        // Interior: all four neighbours exist.
        let o = y0 as usize * stride + x0 as usize * 3;
        let (top, bottom) = (&raw[o..o + 6], &raw[o + stride..o + stride + 6]);
        let mut out = [0.0; 3];
        for c in 0..3 {
            let t = top[c] as f32 + (top[c + 3] as f32 - top[c] as f32) * ax;
            let b = bottom[c] as f32 + (bottom[c + 3] as f32 - bottom[c] as f32) * ax;
            out[c] = t + (b - t) * ay;
        }
        return out;
    }
    if x0 < -1 || y0 < -1 || x0 >= w || y0 >= h {
        return [0.0; 3];
    }
    let px = |xi: i32, yi: i32| -> [f32; 3] {
        if xi < 0 || yi < 0 || xi >= w || yi >= h {
            [0.0; 3]
        } else {
            let o = yi as usize * stride + xi as usize * 3;
            [raw[o] as f32, raw[o + 1] as f32, raw[o + 2] as f32]
        }
    };
    let (p00, p10, p01, p11) = (
        px(x0, y0),
        px(x0 + 1, y0),
        px(x0, y0 + 1),
        px(x0 + 1, y0 + 1),
    );
    let mut out = [0.0; 3];
    for c in 0..3 {
        let top = p00[c] + (p10[c] - p00[c]) * ax;
        let bottom = p01[c] + (p11[c] - p01[c]) * ax;
        out[c] = top + (bottom - top) * ay;
    }
    out
}

/// Fills `out` (`out_h x out_w x 3`, row-major NHWC without the batch axis) with the crop of
/// `img` defined by `crop_to_image`.
///
/// `out.len()` must be at least `out_w * out_h * 3` (debug-asserted; a shorter buffer is
/// filled as far as it goes).
pub fn warp_into(
    img: &RgbImage,
    crop_to_image: &Affine2,
    out_w: usize,
    out_h: usize,
    norm: Normalization,
    out: &mut [f32],
) {
    warp_into_with_border(img, crop_to_image, out_w, out_h, norm, Border::Zero, out);
}

/// [`warp_into`] with a choice of what is read outside the image.
///
/// A crop whose output pixel covers at most [`PLAIN_BILINEAR_UP_TO`] image pixels is plain
/// bilinear from the image. A smaller one is bilinear from a box-filtered reduction of the
/// image (`reduce.rs`): the `2^k x 2^k` averages of the pixels (`2^k` the largest power
/// of two not above the footprint), made only over the part of the image the crop covers,
/// so its cost does not grow with the footprint (docs/performance.md, issue 34).
pub fn warp_into_with_border(
    img: &RgbImage,
    crop_to_image: &Affine2,
    out_w: usize,
    out_h: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
) {
    debug_assert!(out.len() >= out_w * out_h * 3);
    let src = Src::of(img);
    let size = (out_w, out_h);
    match crate::reduce::level_for(crop_to_image.scale()) {
        None => warp_plain(src, &crop_to_image.0, size, 1, norm, border, out),
        Some(k) => crate::reduce::with_region(src, &crop_to_image.0, size, k, |level, m| {
            warp_plain(level, m, size, 1, norm, border, out)
        }),
    }
}

/// The warp as it was before the reductions (issue 34): each output pixel's footprint
/// supersampled on an `n x n` grid (`n` the footprint rounded, 2 to 8) when it covers more
/// than [`PLAIN_BILINEAR_UP_TO`] image pixels. Kept to measure the reductions against
/// (`examples/antialias.rs`); the pipeline does not use it.
pub fn warp_into_supersampled(
    img: &RgbImage,
    crop_to_image: &Affine2,
    out_w: usize,
    out_h: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
) {
    debug_assert!(out.len() >= out_w * out_h * 3);
    let n = crop_to_image.scale();
    let n = if n > PLAIN_BILINEAR_UP_TO {
        (n.round() as usize).clamp(2, 8)
    } else {
        1
    };
    let size = (out_w, out_h);
    warp_plain(Src::of(img), &crop_to_image.0, size, n, norm, border, out)
}

/// The axis-aligned or the general warp of `img` by `m` with `n x n` sub-samples per output
/// pixel, with the best row loop of this CPU.
#[allow(clippy::too_many_arguments)]
fn warp_plain(
    img: Src,
    m: &[[f64; 3]; 2],
    size: (usize, usize),
    n: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
) {
    if m[0][1] == 0.0 && m[1][0] == 0.0 {
        return warp_axis_aligned(img, m, size, n, norm, border, out, Simd::best());
    }
    warp_rotated(img, m, size, n, norm, border, out, Simd::best());
}

/// The general warp (`n x n` sub-samples per output pixel), with the row loop `simd`.
#[allow(clippy::too_many_arguments)]
fn warp_rotated(
    img: Src,
    m: &[[f64; 3]; 2],
    (out_w, out_h): (usize, usize),
    n: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
    simd: Simd,
) {
    let (w, h) = (img.w as i32, img.h as i32);
    let raw = img.raw;
    let (scale, offset) = (norm.scale / (n * n) as f32, norm.offset);
    // Sub-sample offsets inside an output pixel, and the image-space step per output column.
    let offsets: Vec<(f64, f64)> = (0..n * n)
        .map(|k| {
            (
                ((k % n) as f64 + 0.5) / n as f64,
                ((k / n) as f64 + 0.5) / n as f64,
            )
        })
        .collect();
    let (dx_col, dy_col) = (m[0][0] as f32, m[1][0] as f32);
    let mut starts: Vec<(f32, f32)> = Vec::with_capacity(offsets.len());
    for (row, line) in out.chunks_exact_mut(out_w * 3).take(out_h).enumerate() {
        // Image position of each sub-sample at column 0, then stepped along the row in f32
        // (exact enough: < 1e-3 px drift over 224 columns).
        starts.clear();
        starts.extend(offsets.iter().map(|&(ou, ov)| {
            let v = row as f64 + ov;
            (
                (m[0][0] * ou + m[0][1] * v + m[0][2]) as f32,
                (m[1][0] * ou + m[1][1] * v + m[1][2]) as f32,
            )
        }));
        let r = Row {
            raw,
            w,
            h,
            starts: &starts,
            step: (dx_col, dy_col),
            border,
            scale,
            offset,
        };
        let done = match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` is `Simd::best()` (`warp_into_with_border`), which is AVX2 only on
            // a CPU that has it (the tests pass it only where `Simd::best` is AVX2); `r.raw`
            // is the image's `w x h x 3` bytes.
            Simd::Avx2 => unsafe { avx2::row(&r, line) },
            Simd::None => 0,
        };
        r.scalar(line, done);
    }
}

/// Which row loop runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Simd {
    /// One output pixel at a time.
    None,
    /// Eight output pixels at a time with AVX2 (the same arithmetic, so the same bits).
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Simd {
    fn best() -> Simd {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Simd::Avx2;
        }
        Simd::None
    }
}

/// One output row of the general (rotated) warp.
struct Row<'a> {
    raw: &'a [u8],
    w: i32,
    h: i32,
    /// Image position of each sub-sample of column 0.
    starts: &'a [(f32, f32)],
    /// Image step per output column.
    step: (f32, f32),
    border: Border,
    scale: f32,
    offset: f32,
}

impl Row<'_> {
    /// The sub-sample `(x0, y0)` of output column `cf`, clamped for a replicated border.
    #[inline(always)]
    fn position(&self, (x0, y0): (f32, f32), cf: f32) -> (f32, f32) {
        let (mut x, mut y) = (x0 + self.step.0 * cf, y0 + self.step.1 * cf);
        if self.border == Border::Replicate {
            // Bilinear sampling clamped to the outer pixel centres = edge replication.
            x = x.clamp(0.5, self.w as f32 - 0.5);
            y = y.clamp(0.5, self.h as f32 - 0.5);
        }
        (x, y)
    }

    /// The sum of output column `col`'s sub-samples.
    #[inline(always)]
    fn sum(&self, col: usize) -> [f32; 3] {
        let mut acc = [0.0f32; 3];
        let cf = col as f32;
        for &start in self.starts {
            let (x, y) = self.position(start, cf);
            let s = sample(self.raw, self.w, self.h, x, y);
            acc[0] += s[0];
            acc[1] += s[1];
            acc[2] += s[2];
        }
        acc
    }

    /// Output columns from `from` on, one at a time.
    fn scalar(&self, line: &mut [f32], from: usize) {
        for (col, px) in line.chunks_exact_mut(3).enumerate().skip(from) {
            let acc = self.sum(col);
            px[0] = acc[0] * self.scale + self.offset;
            px[1] = acc[1] * self.scale + self.offset;
            px[2] = acc[2] * self.scale + self.offset;
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::Row;
    use std::arch::x86_64::*;

    /// Channel `ch` (0, 1 or 2) of eight RGB pixels read as little-endian 4-byte words.
    ///
    /// # Safety
    /// The CPU must support AVX2 (a safe `#[target_feature]` function: calling it needs
    /// `unsafe` outside code compiled with AVX2). It reads no memory.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn channel(v: __m256i, ch: usize) -> __m256 {
        let shifted = match ch {
            0 => v,
            1 => _mm256_srli_epi32::<8>(v),
            _ => _mm256_srli_epi32::<16>(v),
        };
        _mm256_cvtepi32_ps(_mm256_and_si256(shifted, _mm256_set1_epi32(0xff)))
    }

    /// Writes eight pixels' sums (one vector per channel) as `sum · scale + offset`,
    /// interleaved RGB, into `px` (24 floats).
    ///
    /// # Safety
    /// The CPU must support AVX2 (a safe `#[target_feature]` function: calling it needs
    /// `unsafe` outside code compiled with AVX2). `px` is indexed with bounds checks.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(acc: &[__m256; 3], px: &mut [f32], (scale, offset): (f32, f32)) {
        let mut out = [[0f32; 8]; 3];
        for (o, a) in out.iter_mut().zip(acc) {
            // SAFETY: `o` holds 8 floats.
            unsafe { _mm256_storeu_ps(o.as_mut_ptr(), *a) };
        }
        for (l, p) in px.chunks_exact_mut(3).enumerate() {
            for c in 0..3 {
                p[c] = out[c][l] * scale + offset;
            }
        }
    }

    /// Output columns in groups of eight, each lane doing exactly [`Row::sum`]'s arithmetic
    /// (`sample`'s interior case; a group with a sub-sample outside the interior takes the
    /// scalar `sample` for that sub-sample). Returns how many columns it wrote.
    ///
    /// # Safety
    /// The CPU must support AVX2, and where `r.w` and `r.h` are both positive, `r.raw` must
    /// hold at least `r.w · r.h · 3` bytes (an RGB image of `r.w x r.h` pixels; with a size
    /// of 0 or less every sample takes the scalar path). The gathers read `raw` at byte
    /// offsets computed in i32 lanes and checked against `raw.len()`; with such a buffer
    /// (and `raw.len() <= i32::MAX`, checked here) the offsets of the pixels inside the
    /// image do not wrap. `line` may have any length (the groups are within it).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn row(r: &Row, line: &mut [f32]) -> usize {
        // Offsets are i32 lanes: images of 2 GB and more stay with the scalar loop.
        if r.raw.len() > i32::MAX as usize || r.raw.len() < 4 {
            return 0;
        }
        let cols = line.len() / 3;
        let groups = cols / 8;
        let stride = r.w * 3;
        // A gather reads 4 bytes from a pixel's 3: the last one it may start at.
        let last = r.raw.len() as i32 - 4;
        let lane = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
        let one = _mm256_set1_epi32(1);
        let (wv, hv) = (_mm256_set1_epi32(r.w), _mm256_set1_epi32(r.h));
        let half = _mm256_set1_ps(0.5);
        let (lo_x, hi_x) = (_mm256_set1_ps(0.5), _mm256_set1_ps(r.w as f32 - 0.5));
        let (lo_y, hi_y) = (_mm256_set1_ps(0.5), _mm256_set1_ps(r.h as f32 - 0.5));
        let (sx, sy) = (_mm256_set1_ps(r.step.0), _mm256_set1_ps(r.step.1));
        let base = r.raw.as_ptr() as *const i32;
        for g in 0..groups {
            let cf = _mm256_add_ps(_mm256_set1_ps((g * 8) as f32), lane);
            let mut acc = [_mm256_setzero_ps(); 3];
            for &(x0, y0) in r.starts {
                let mut x = _mm256_add_ps(_mm256_set1_ps(x0), _mm256_mul_ps(sx, cf));
                let mut y = _mm256_add_ps(_mm256_set1_ps(y0), _mm256_mul_ps(sy, cf));
                if r.border == super::Border::Replicate {
                    // f32::clamp for numbers: max with the low bound, then min with the high.
                    x = _mm256_min_ps(_mm256_max_ps(x, lo_x), hi_x);
                    y = _mm256_min_ps(_mm256_max_ps(y, lo_y), hi_y);
                }
                let fx = _mm256_sub_ps(x, half);
                let fy = _mm256_sub_ps(y, half);
                let flx = _mm256_floor_ps(fx);
                let fly = _mm256_floor_ps(fy);
                let ix = _mm256_cvttps_epi32(flx);
                let iy = _mm256_cvttps_epi32(fly);
                let ax = _mm256_sub_ps(fx, flx);
                let ay = _mm256_sub_ps(fy, fly);
                let o = _mm256_add_epi32(
                    _mm256_mullo_epi32(iy, _mm256_set1_epi32(stride)),
                    _mm256_mullo_epi32(ix, _mm256_set1_epi32(3)),
                );
                // Interior as `sample` has it, and the bottom-right gather inside the buffer.
                let inside = _mm256_and_si256(
                    _mm256_and_si256(
                        _mm256_cmpgt_epi32(ix, _mm256_set1_epi32(-1)),
                        _mm256_cmpgt_epi32(iy, _mm256_set1_epi32(-1)),
                    ),
                    _mm256_and_si256(
                        _mm256_and_si256(
                            _mm256_cmpgt_epi32(wv, _mm256_add_epi32(ix, one)),
                            _mm256_cmpgt_epi32(hv, _mm256_add_epi32(iy, one)),
                        ),
                        _mm256_cmpgt_epi32(
                            _mm256_set1_epi32(last + 1),
                            _mm256_add_epi32(o, _mm256_set1_epi32(stride + 3)),
                        ),
                    ),
                );
                // NaN positions convert to i32::MIN, which fails the interior test above.
                if _mm256_movemask_ps(_mm256_castsi256_ps(inside)) != 0xff {
                    let mut xs = [0f32; 8];
                    let mut ys = [0f32; 8];
                    _mm256_storeu_ps(xs.as_mut_ptr(), x);
                    _mm256_storeu_ps(ys.as_mut_ptr(), y);
                    let mut s = [[0f32; 8]; 3];
                    for l in 0..8 {
                        let v = super::sample(r.raw, r.w, r.h, xs[l], ys[l]);
                        for c in 0..3 {
                            s[c][l] = v[c];
                        }
                    }
                    for c in 0..3 {
                        acc[c] = _mm256_add_ps(acc[c], _mm256_loadu_ps(s[c].as_ptr()));
                    }
                    continue;
                }
                // SAFETY: every lane is interior: its four pixels' bytes, read 4 at a time from
                // each pixel's first byte, lie inside `raw` (checked against `last` above).
                let tl = _mm256_i32gather_epi32::<1>(base, o);
                let tr =
                    _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(o, _mm256_set1_epi32(3)));
                let ob = _mm256_add_epi32(o, _mm256_set1_epi32(stride));
                let bl = _mm256_i32gather_epi32::<1>(base, ob);
                let br =
                    _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(ob, _mm256_set1_epi32(3)));
                for (c, acc) in acc.iter_mut().enumerate() {
                    let ch = |v| channel(v, c);
                    let (a, b, cc, d) = (ch(tl), ch(tr), ch(bl), ch(br));
                    let t = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), ax));
                    let bo = _mm256_add_ps(cc, _mm256_mul_ps(_mm256_sub_ps(d, cc), ax));
                    let s = _mm256_add_ps(t, _mm256_mul_ps(_mm256_sub_ps(bo, t), ay));
                    *acc = _mm256_add_ps(*acc, s);
                }
            }
            store(&acc, &mut line[g * 24..(g + 1) * 24], (r.scale, r.offset));
        }
        groups * 8
    }

    /// The column taps of an axis-aligned warp by sub-sample, eight columns to a vector:
    /// byte offsets of the two source pixels and their weights.
    pub(super) struct ColumnTaps {
        n: usize,
        groups: usize,
        /// `[s][g]`: sub-sample `s` of the columns of group `g` (8 lanes each).
        i0: Vec<[i32; 8]>,
        i1: Vec<[i32; 8]>,
        w0: Vec<[f32; 8]>,
        w1: Vec<[f32; 8]>,
    }

    impl ColumnTaps {
        pub(super) fn new(xs: &[super::Tap], n: usize, out_w: usize) -> ColumnTaps {
            let groups = out_w / 8;
            let mut t = ColumnTaps {
                n,
                groups,
                i0: vec![[0; 8]; n * groups],
                i1: vec![[0; 8]; n * groups],
                w0: vec![[0.0; 8]; n * groups],
                w1: vec![[0.0; 8]; n * groups],
            };
            for g in 0..groups {
                for l in 0..8 {
                    for s in 0..n {
                        let tap = xs[(g * 8 + l) * n + s];
                        let k = s * groups + g;
                        // Indices are inside the image (`axis_taps`), so these fit in i32
                        // for any image under `image_io::MAX_IMAGE_PIXELS`.
                        t.i0[k][l] = (tap.i0 * 3) as i32;
                        t.i1[k][l] = (tap.i1 * 3) as i32;
                        t.w0[k][l] = tap.w0;
                        t.w1[k][l] = tap.w1;
                    }
                }
            }
            t
        }
    }

    /// One output row of the axis-aligned warp, eight columns at a time, doing exactly the
    /// one-column loop's arithmetic per lane. Returns how many columns it wrote (0 where a
    /// 4-byte read of the row's last pixel would pass the end of the image).
    ///
    /// # Safety
    /// The CPU must support AVX2, and every column index of `cols` (the `i0` and `i1` of
    /// the taps it was built from) must be below `w`: the gathers read `raw` at those
    /// columns without bounds checks. (The rows are checked here: the row taps must be
    /// above the last whole row of `w` pixels in `raw`, else nothing is written.)
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn aligned_row(
        raw: &[u8],
        w: usize,
        row_taps: &[super::Tap],
        cols: &ColumnTaps,
        (scale, offset): (f32, f32),
        line: &mut [f32],
    ) -> usize {
        // A gather reads 4 bytes from a pixel's 3: every row used must not hold the last
        // pixel of the image (the last row is read 3 bytes short of its end).
        // Offsets are i32 lanes: images of 2 GB and more stay with the scalar loop.
        let Some(last_row) = (raw.len() / (w * 3).max(1)).checked_sub(1) else {
            return 0;
        };
        if raw.len() > i32::MAX as usize || row_taps.iter().any(|t| t.i0.max(t.i1) >= last_row) {
            return 0;
        }
        let base = raw.as_ptr() as *const i32;
        for g in 0..cols.groups {
            let mut acc = [_mm256_setzero_ps(); 3];
            for ty in row_taps {
                let (r0, r1) = (
                    _mm256_set1_epi32((ty.i0 * w * 3) as i32),
                    _mm256_set1_epi32((ty.i1 * w * 3) as i32),
                );
                let (yw0, yw1) = (_mm256_set1_ps(ty.w0), _mm256_set1_ps(ty.w1));
                for s in 0..cols.n {
                    let k = s * cols.groups + g;
                    let i0 = _mm256_loadu_si256(cols.i0[k].as_ptr() as *const __m256i);
                    let i1 = _mm256_loadu_si256(cols.i1[k].as_ptr() as *const __m256i);
                    let xw0 = _mm256_loadu_ps(cols.w0[k].as_ptr());
                    let xw1 = _mm256_loadu_ps(cols.w1[k].as_ptr());
                    // SAFETY: rows below the last and columns inside the image: every 4-byte
                    // read starts at a pixel and ends inside `raw`.
                    let a = _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(r0, i0));
                    let b = _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(r0, i1));
                    let c = _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(r1, i0));
                    let d = _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(r1, i1));
                    for (ch, acc) in acc.iter_mut().enumerate() {
                        let get = |v| channel(v, ch);
                        let top =
                            _mm256_add_ps(_mm256_mul_ps(xw0, get(a)), _mm256_mul_ps(xw1, get(b)));
                        let bottom =
                            _mm256_add_ps(_mm256_mul_ps(xw0, get(c)), _mm256_mul_ps(xw1, get(d)));
                        let sum =
                            _mm256_add_ps(_mm256_mul_ps(yw0, top), _mm256_mul_ps(yw1, bottom));
                        *acc = _mm256_add_ps(*acc, sum);
                    }
                }
            }
            store(&acc, &mut line[g * 24..(g + 1) * 24], (scale, offset));
        }
        cols.groups * 8
    }
}

/// One bilinear tap along an axis: two source indices and their weights (an index outside
/// the image gets weight 0 and a harmless in-range index).
#[derive(Clone, Copy, Debug)]
struct Tap {
    i0: usize,
    w0: f32,
    i1: usize,
    w1: f32,
}

/// Taps of every sub-sample of every output position along one axis: output `o`, sub-sample
/// `s` samples source coordinate `scale · (o + (s + ½)/n) + offset`.
fn axis_taps(
    len_out: usize,
    n: usize,
    scale: f64,
    offset: f64,
    len_in: usize,
    border: Border,
) -> Vec<Tap> {
    let mut taps = Vec::with_capacity(len_out * n);
    for o in 0..len_out {
        for s in 0..n {
            let mut f = scale * (o as f64 + (s as f64 + 0.5) / n as f64) + offset - 0.5;
            if border == Border::Replicate {
                f = f.clamp(0.0, len_in as f64 - 1.0);
            }
            let f0 = f.floor();
            let frac = (f - f0) as f32;
            let inside = |i: f64| i >= 0.0 && i < len_in as f64;
            let (i0, i1) = (f0, f0 + 1.0);
            taps.push(Tap {
                i0: if inside(i0) { i0 as usize } else { 0 },
                w0: if inside(i0) { 1.0 - frac } else { 0.0 },
                i1: if inside(i1) { i1 as usize } else { 0 },
                w1: if inside(i1) { frac } else { 0.0 },
            });
        }
    }
    taps
}

/// [`warp_into`] for maps without rotation (letterboxing): the bilinear indices and weights
/// of every column and row are computed once, so each sample is four loads and no branches.
/// With `simd`, eight output columns at a time (the same operations in the same order: the
/// same bits).
#[allow(clippy::too_many_arguments)]
fn warp_axis_aligned(
    img: Src,
    m: &[[f64; 3]; 2],
    (out_w, out_h): (usize, usize),
    n: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
    simd: Simd,
) {
    let (w, h) = (img.w, img.h);
    let raw = img.raw;
    let xs = axis_taps(out_w, n, m[0][0], m[0][2], w, border);
    let ys = axis_taps(out_h, n, m[1][1], m[1][2], h, border);
    let scale = norm.scale / (n * n) as f32;
    let px = |y: usize, x: usize| {
        let o = (y * w + x) * 3;
        [raw[o] as f32, raw[o + 1] as f32, raw[o + 2] as f32]
    };
    // The vector loop's column taps, built only when it runs.
    #[cfg(target_arch = "x86_64")]
    let columns = (simd == Simd::Avx2).then(|| avx2::ColumnTaps::new(&xs, n, out_w));
    for (row, line) in out.chunks_exact_mut(out_w * 3).take(out_h).enumerate() {
        let row_taps = &ys[row * n..(row + 1) * n];
        let done = match simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => match &columns {
                // SAFETY: `simd` is `Simd::best()`, AVX2 only on a CPU that has it (the tests
                // pass it only where `Simd::best` is AVX2); `c` was built from `xs`, the taps
                // of an axis of `w` pixels, whose indices are below `w` (`axis_taps`).
                Some(c) => unsafe {
                    avx2::aligned_row(raw, w, row_taps, c, (scale, norm.offset), line)
                },
                None => 0,
            },
            Simd::None => 0,
        };
        for (col, dst) in line.chunks_exact_mut(3).enumerate().skip(done) {
            let col_taps = &xs[col * n..(col + 1) * n];
            let mut acc = [0.0f32; 3];
            for ty in row_taps {
                for tx in col_taps {
                    let (a, b) = (px(ty.i0, tx.i0), px(ty.i0, tx.i1));
                    let (c, d) = (px(ty.i1, tx.i0), px(ty.i1, tx.i1));
                    for ch in 0..3 {
                        let top = tx.w0 * a[ch] + tx.w1 * b[ch];
                        let bottom = tx.w0 * c[ch] + tx.w1 * d[ch];
                        acc[ch] += ty.w0 * top + ty.w1 * bottom;
                    }
                }
            }
            for ch in 0..3 {
                dst[ch] = acc[ch] * scale + norm.offset;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::RotatedRect;

    fn gradient() -> RgbImage {
        RgbImage::from_fn(64, 48, |x, y| image::Rgb([(x * 4) as u8, (y * 5) as u8, 7]))
    }

    #[test]
    fn replicate_border_repeats_the_edge_pixels() {
        let img = gradient();
        let norm = Normalization {
            scale: 1.0,
            offset: 0.0,
        };
        // A crop shifted 10 px left of the image, axis-aligned and slightly rotated.
        for m in [
            Affine2([[1.0, 0.0, -10.0], [0.0, 1.0, 0.0]]),
            Affine2([[1.0, 1e-9, -10.0], [-1e-9, 1.0, 0.0]]),
        ] {
            let mut zero = vec![0.0; 20 * 20 * 3];
            let mut rep = vec![0.0; 20 * 20 * 3];
            warp_into_with_border(&img, &m, 20, 20, norm, Border::Zero, &mut zero);
            warp_into_with_border(&img, &m, 20, 20, norm, Border::Replicate, &mut rep);
            let at = |b: &[f32], x: usize, y: usize, c: usize| b[(y * 20 + x) * 3 + c];
            // Column 3 is 7 px left of the image: black, or column 0's pixel (x = 0, so
            // channel 0 is 0 either way; channel 1 = 5y and channel 2 = 7 tell).
            assert_eq!(at(&zero, 3, 4, 2), 0.0);
            assert!((at(&rep, 3, 4, 2) - 7.0).abs() < 1e-4);
            assert!((at(&rep, 3, 4, 1) - 20.0).abs() < 1e-4);
            // Inside the image both agree.
            assert!((at(&zero, 15, 4, 1) - at(&rep, 15, 4, 1)).abs() < 1e-4);
        }
    }

    #[test]
    fn identity_crop_reproduces_pixels() {
        let img = gradient();
        let mut out = vec![0.0; 64 * 48 * 3];
        warp_into(
            &img,
            &Affine2::IDENTITY,
            64,
            48,
            Normalization {
                scale: 1.0,
                offset: 0.0,
            },
            &mut out,
        );
        let at = |x: usize, y: usize, c: usize| out[(y * 64 + x) * 3 + c];
        assert_eq!(at(10, 20, 0), 40.0);
        assert_eq!(at(10, 20, 1), 100.0);
        assert_eq!(at(63, 47, 2), 7.0);
    }

    #[test]
    fn rotation_by_half_turn_flips_the_crop() {
        let img = gradient();
        let r = RotatedRect {
            center: [32.0, 24.0],
            width: 20.0,
            height: 20.0,
            rotation: std::f64::consts::PI,
        };
        let mut out = vec![0.0; 20 * 20 * 3];
        warp_into(
            &img,
            &r.crop_to_image(20, 20),
            20,
            20,
            Normalization {
                scale: 1.0,
                offset: 0.0,
            },
            &mut out,
        );
        // Crop pixel (0,0) centre is image pixel (41, 33) after a half turn.
        assert!((out[0] - 41.0 * 4.0).abs() < 1e-3, "{}", out[0]);
        assert!((out[1] - 33.0 * 5.0).abs() < 1e-3, "{}", out[1]);
    }

    #[test]
    fn axis_aligned_fast_path_matches_the_general_warp() {
        let img = RgbImage::from_fn(97, 61, |x, y| {
            image::Rgb([(x * 2 + y) as u8, (y * 4) as u8, (x ^ y) as u8])
        });
        let norm = Normalization {
            scale: 1.0,
            offset: 0.0,
        };
        for (size, m) in [
            (24, crate::geometry::letterbox_to_image(97, 61, 24)),
            (64, crate::geometry::letterbox_to_image(97, 61, 64)),
        ] {
            let mut fast = vec![0.0; size * size * 3];
            warp_into(&img, &m, size, size, norm, &mut fast);
            // A tiny rotation forces the general path.
            let tilted = Affine2([[m.0[0][0], 1e-12, m.0[0][2]], [1e-12, m.0[1][1], m.0[1][2]]]);
            let mut slow = vec![0.0; size * size * 3];
            warp_into(&img, &tilted, size, size, norm, &mut slow);
            for (a, b) in fast.iter().zip(&slow) {
                assert!((a - b).abs() < 1e-2, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn the_simd_rows_give_the_same_bits_as_the_scalar_rows() {
        let img = RgbImage::from_fn(211, 157, |x, y| {
            image::Rgb([(x * 7 + y * 3) as u8, (x * y) as u8, (x ^ (y * 5)) as u8])
        });
        let simd = Simd::best();
        if simd == Simd::None {
            eprintln!("no SIMD row loop on this CPU: nothing to compare");
            return;
        }
        let mut checked = 0;
        // Rotations, scales giving 1 to 4 sub-samples, crops inside, across the border and
        // past the bottom-right pixel, outside; both borders; sizes with a scalar tail.
        for (k, angle) in [0.3f64, -1.1, 2.7, 0.05].into_iter().enumerate() {
            for (scale, centre) in [
                (0.7, (100.0, 80.0)),
                (2.6, (105.0, 78.0)),
                (3.4, (200.0, 150.0)),
                (1.0, (-30.0, 40.0)),
                (1.5, (400.0, 400.0)),
            ] {
                let (c, s) = (angle.cos() * scale, angle.sin() * scale);
                let size = [224usize, 37][k % 2];
                let half = size as f64 / 2.0;
                let m = [
                    [c, -s, centre.0 - c * half + s * half],
                    [s, c, centre.1 - s * half - c * half],
                ];
                let n = if scale > 2.0 {
                    (scale.round() as usize).clamp(2, 8)
                } else {
                    1
                };
                for border in [Border::Zero, Border::Replicate] {
                    let mut a = vec![0.0f32; size * size * 3];
                    let mut b = vec![1.0f32; size * size * 3];
                    let norm = Normalization::UNIT;
                    warp_rotated(
                        Src::of(&img),
                        &m,
                        (size, size),
                        n,
                        norm,
                        border,
                        &mut a,
                        Simd::None,
                    );
                    warp_rotated(
                        Src::of(&img),
                        &m,
                        (size, size),
                        n,
                        norm,
                        border,
                        &mut b,
                        simd,
                    );
                    let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                    assert!(
                        bits(&a) == bits(&b),
                        "angle {angle} scale {scale} {border:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 40);
    }

    #[test]
    fn the_simd_letterbox_rows_give_the_same_bits_as_the_scalar_rows() {
        let simd = Simd::best();
        if simd == Simd::None {
            eprintln!("no SIMD row loop on this CPU: nothing to compare");
            return;
        }
        let mut checked = 0;
        // Letterboxes of wide and tall images (1 to 4 sub-samples), a crop past the image's
        // edge, both borders, output widths with a scalar tail.
        for (iw, ih) in [(640u32, 480u32), (97, 61), (61, 97), (1200, 1799), (9, 9)] {
            let img = RgbImage::from_fn(iw, ih, |x, y| {
                image::Rgb([(x * 7 + y * 3) as u8, (x * y) as u8, (x ^ (y * 5)) as u8])
            });
            for size in [192usize, 37, 8] {
                let letterbox = crate::geometry::letterbox_to_image(iw, ih, size).0;
                let shifted = [[letterbox[0][0], 0.0, -20.0], [0.0, letterbox[1][1], 15.0]];
                for m in [letterbox, shifted] {
                    let n = Affine2(m).scale();
                    let n = if n > 2.0 {
                        (n.round() as usize).clamp(2, 8)
                    } else {
                        1
                    };
                    for border in [Border::Zero, Border::Replicate] {
                        let norm = Normalization::UNIT;
                        let mut a = vec![0.0f32; size * size * 3];
                        let mut b = vec![1.0f32; size * size * 3];
                        let sz = (size, size);
                        warp_axis_aligned(
                            Src::of(&img),
                            &m,
                            sz,
                            n,
                            norm,
                            border,
                            &mut a,
                            Simd::None,
                        );
                        warp_axis_aligned(Src::of(&img), &m, sz, n, norm, border, &mut b, simd);
                        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                        assert!(bits(&a) == bits(&b), "{iw}x{ih} -> {size} {m:?} {border:?}");
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 60);
    }

    /// Each output pixel the mean of `img`'s pixels over its footprint (replicated border),
    /// from `n x n` point samples of the pixels (piecewise constant): the exact area
    /// average as `n` grows.
    fn area_average(img: &RgbImage, m: &Affine2, size: usize, n: usize) -> Vec<f32> {
        let (w, h) = (img.width() as i64, img.height() as i64);
        let mut out = vec![0f32; size * size * 3];
        for (k, px) in out.chunks_exact_mut(3).enumerate() {
            let (col, row) = ((k % size) as f64, (k / size) as f64);
            let mut acc = [0f64; 3];
            for s in 0..n * n {
                let u = col + ((s % n) as f64 + 0.5) / n as f64;
                let v = row + ((s / n) as f64 + 0.5) / n as f64;
                let [x, y] = m.apply([u, v]);
                let p = img.get_pixel(
                    (x.floor() as i64).clamp(0, w - 1) as u32,
                    (y.floor() as i64).clamp(0, h - 1) as u32,
                );
                for c in 0..3 {
                    acc[c] += p[c] as f64;
                }
            }
            for c in 0..3 {
                px[c] = (acc[c] / (n * n) as f64) as f32;
            }
        }
        out
    }

    #[test]
    fn shrinking_a_pixel_checkerboard_gives_its_mean_without_moire() {
        // A checkerboard of single pixels: its area average over any footprint of several
        // pixels is mid-grey. One bilinear sample per output pixel reads moiré; the
        // reduction reads grey.
        let img = RgbImage::from_fn(900, 700, |x, y| {
            let v = if (x + y) % 2 == 0 { 250 } else { 10 };
            image::Rgb([v, v, v])
        });
        let size = 40;
        let norm = Normalization {
            scale: 1.0,
            offset: 0.0,
        };
        for footprint in [3.0, 5.5, 12.0, 16.0] {
            let roi = RotatedRect {
                center: [450.0, 350.0],
                width: footprint * size as f64,
                height: footprint * size as f64,
                rotation: 0.4,
            };
            let m = roi.crop_to_image(size, size);
            let reference = area_average(&img, &m, size, 32);
            let mut new = vec![0f32; size * size * 3];
            warp_into_with_border(&img, &m, size, size, norm, Border::Replicate, &mut new);
            let mut plain = vec![0f32; size * size * 3];
            let one = Src::of(&img);
            warp_plain(
                one,
                &m.0,
                (size, size),
                1,
                norm,
                Border::Replicate,
                &mut plain,
            );
            let worst = |v: &[f32]| {
                v.iter()
                    .zip(&reference)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0f32, f32::max)
            };
            assert!(worst(&new) < 8.0, "footprint {footprint}: {}", worst(&new));
            assert!(
                worst(&plain) > 60.0,
                "footprint {footprint}: {}",
                worst(&plain)
            );
        }
    }

    #[test]
    fn crops_up_to_the_plain_footprint_are_sampled_as_before() {
        let img = RgbImage::from_fn(211, 157, |x, y| {
            image::Rgb([(x * 7 + y * 3) as u8, (x * y) as u8, (x ^ (y * 5)) as u8])
        });
        for (footprint, rotation) in [(0.5, 0.3), (1.0, 0.0), (1.9, 2.0), (2.0, 0.0), (2.0, 1.0)] {
            let roi = RotatedRect {
                center: [100.0, 80.0],
                width: footprint * 48.0,
                height: footprint * 48.0,
                rotation,
            };
            let m = roi.crop_to_image(48, 48);
            let mut a = vec![0f32; 48 * 48 * 3];
            let mut b = vec![1f32; 48 * 48 * 3];
            let norm = Normalization::UNIT;
            warp_into_with_border(&img, &m, 48, 48, norm, Border::Replicate, &mut a);
            warp_into_supersampled(&img, &m, 48, 48, norm, Border::Replicate, &mut b);
            let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert!(bits(&a) == bits(&b), "footprint {footprint}");
        }
    }

    #[test]
    fn a_flat_image_stays_flat_through_the_reduction() {
        let img = RgbImage::from_pixel(333, 251, image::Rgb([200, 17, 90]));
        for (footprint, rotation) in [(2.5, 0.0), (4.0, 0.7), (7.3, -2.0), (30.0, 0.0)] {
            let roi = RotatedRect {
                center: [166.0, 125.0],
                width: footprint * 8.0,
                height: footprint * 8.0,
                rotation,
            };
            let mut out = vec![0f32; 8 * 8 * 3];
            let norm = Normalization {
                scale: 1.0,
                offset: 0.0,
            };
            let m = roi.crop_to_image(8, 8);
            warp_into_with_border(&img, &m, 8, 8, norm, Border::Replicate, &mut out);
            for px in out.chunks_exact(3) {
                assert!(
                    (px[0] - 200.0).abs() < 1e-3 && (px[1] - 17.0).abs() < 1e-3,
                    "{px:?}"
                );
                assert!((px[2] - 90.0).abs() < 1e-3, "footprint {footprint}: {px:?}");
            }
        }
    }

    #[test]
    fn outside_is_black_then_normalised() {
        let img = gradient();
        let far = Affine2([[1.0, 0.0, 1000.0], [0.0, 1.0, 1000.0]]);
        let mut out = vec![5.0; 4 * 4 * 3];
        warp_into(&img, &far, 4, 4, Normalization::SIGNED, &mut out);
        assert!(out.iter().all(|&v| v == -1.0));
    }
}
