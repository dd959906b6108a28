//! One affine warp from an RGB image straight into a network's f32 NHWC input buffer.
//!
//! Every output pixel centre is mapped through `crop → image` and the image is sampled
//! bilinearly, then normalised as `value · scale + offset`. There is no intermediate resized or rotated copy.
//! When one output pixel covers more than 2 image pixels (a 4000-pixel photo squeezed into
//! 192 pixels) the footprint is supersampled on an `n x n` grid (n ≤ 8) so the detector does
//! not see aliasing; for ordinary crops n = 1 and the warp is plain bilinear, as MediaPipe's.

use image::RgbImage;

use crate::geometry::Affine2;

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
    let n = crop_to_image.scale();
    let n = if n > 2.0 {
        (n.round() as usize).clamp(2, 8)
    } else {
        1
    };
    let scale = norm.scale / (n * n) as f32;
    let m = crop_to_image.0;
    if m[0][1] == 0.0 && m[1][0] == 0.0 {
        return warp_axis_aligned(img, &m, (out_w, out_h), n, norm, border, out);
    }
    let (w, h) = (img.width() as i32, img.height() as i32);
    let raw = img.as_raw().as_slice();
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
    for (row, line) in out.chunks_exact_mut(out_w * 3).take(out_h).enumerate() {
        // Image position of each sub-sample at column 0, then stepped along the row in f32
        // (exact enough: < 1e-3 px drift over 224 columns).
        let starts: Vec<(f32, f32)> = offsets
            .iter()
            .map(|&(ou, ov)| {
                let v = row as f64 + ov;
                (
                    (m[0][0] * ou + m[0][1] * v + m[0][2]) as f32,
                    (m[1][0] * ou + m[1][1] * v + m[1][2]) as f32,
                )
            })
            .collect();
        for (col, px) in line.chunks_exact_mut(3).enumerate() {
            let mut acc = [0.0f32; 3];
            let cf = col as f32;
            for &(x0, y0) in &starts {
                let (mut x, mut y) = (x0 + dx_col * cf, y0 + dy_col * cf);
                if border == Border::Replicate {
                    // Bilinear sampling clamped to the outer pixel centres = edge replication.
                    x = x.clamp(0.5, w as f32 - 0.5);
                    y = y.clamp(0.5, h as f32 - 0.5);
                }
                let s = sample(raw, w, h, x, y);
                acc[0] += s[0];
                acc[1] += s[1];
                acc[2] += s[2];
            }
            px[0] = acc[0] * scale + norm.offset;
            px[1] = acc[1] * scale + norm.offset;
            px[2] = acc[2] * scale + norm.offset;
        }
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
fn warp_axis_aligned(
    img: &RgbImage,
    m: &[[f64; 3]; 2],
    (out_w, out_h): (usize, usize),
    n: usize,
    norm: Normalization,
    border: Border,
    out: &mut [f32],
) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let raw = img.as_raw().as_slice();
    let xs = axis_taps(out_w, n, m[0][0], m[0][2], w, border);
    let ys = axis_taps(out_h, n, m[1][1], m[1][2], h, border);
    let scale = norm.scale / (n * n) as f32;
    let px = |y: usize, x: usize| {
        let o = (y * w + x) * 3;
        [raw[o] as f32, raw[o + 1] as f32, raw[o + 2] as f32]
    };
    for (row, line) in out.chunks_exact_mut(out_w * 3).take(out_h).enumerate() {
        let row_taps = &ys[row * n..(row + 1) * n];
        for (col, dst) in line.chunks_exact_mut(3).enumerate() {
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
    fn outside_is_black_then_normalised() {
        let img = gradient();
        let far = Affine2([[1.0, 0.0, 1000.0], [0.0, 1.0, 1000.0]]);
        let mut out = vec![5.0; 4 * 4 * 3];
        warp_into(&img, &far, 4, 4, Normalization::SIGNED, &mut out);
        assert!(out.iter().all(|&v| v == -1.0));
    }
}
