//! 8-bit 4:2:0 YUV frames (ffmpeg's `yuv420p` and `yuvj420p`) to packed RGB.
//!
//! Phone and camera video is 4:2:0 YUV: 1.5 bytes a pixel, where packed RGB is 3. Asking
//! ffmpeg for RGB made it convert each frame (its `swscale`) and push twice the bytes
//! through the pipe; at 3840x2160 that was a quarter of the run's CPU (issue 34,
//! docs/performance.md). [`VideoReader`](super::VideoReader) now reads such streams as
//! they are decoded and converts them here, on its reading thread.
//!
//! The conversion is the one ffmpeg 5.1 applies to these streams (checked against its
//! `rgb24` output in the tests below): the stream's matrix (BT.709 where the stream says
//! so, else BT.601, as ffmpeg does for an untagged stream), its range (limited, or full for
//! `yuvj420p` and streams tagged `pc`), and each chroma sample used for its 2 x 2 pixels.
//! Unlike ffmpeg's fast path, which truncates (its RGB is on average 1 level darker than the
//! exact conversion, and up to 3 levels off), this one rounds: every value is within 0.53
//! of the exact conversion (0.15 on average). Streams of any other kind (RGB, 4:2:2, 4:4:4, more than 8 bits, BT.2020) are still
//! converted by ffmpeg.
//!
//! The arithmetic is 16-bit fixed point with 6 fractional bits (13 for the chroma weights),
//! the same in the portable loop, the AVX2 one (16 pixels at a time) and the AVX-512 one
//! (32 pixels, with VBMI's byte permutes for the interleave), so all give the same bits;
//! the fastest the CPU has is chosen at run time. `cargo bench -p monohand-media --bench
//! yuv` (AMD EPYC 2-core VM, other work running): a 3840x2160 frame in 4.3 ms with AVX2,
//! 2.8 ms with AVX-512; 1920x1080 in 0.90 and 0.53 ms.

use super::VideoInfo;

/// A stream's YUV to RGB matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum YuvMatrix {
    /// ITU-R BT.601 (standard-definition video, and ffmpeg's choice for untagged streams).
    Bt601,
    /// ITU-R BT.709 (high-definition video: phones, cameras).
    Bt709,
}

/// How an 8-bit 4:2:0 stream's samples map to RGB.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Yuv420 {
    /// The matrix.
    pub matrix: YuvMatrix,
    /// Full range (0-255 luma, as JPEG) rather than limited (16-235 luma, 16-240 chroma).
    pub full_range: bool,
}

impl Yuv420 {
    /// The layout of a probed stream when it is 8-bit 4:2:0 with a matrix this module
    /// converts and an even width and height; `None` for anything else (ffmpeg then
    /// converts to RGB itself). Odd sizes stay with ffmpeg because it converts them
    /// differently (interpolating the chroma), and H.264 and H.265 have even sizes anyway.
    pub fn of_stream(info: &VideoInfo) -> Option<Yuv420> {
        if info.width % 2 == 1 || info.height % 2 == 1 {
            return None;
        }
        let full_tag = info.color_range.as_deref() == Some("pc");
        let full_range = match info.pix_fmt.as_deref()? {
            "yuv420p" => full_tag,
            "yuvj420p" => true,
            _ => return None,
        };
        let matrix = match info.color_space.as_deref() {
            None | Some("unknown" | "bt470bg" | "smpte170m") => YuvMatrix::Bt601,
            Some("bt709") => YuvMatrix::Bt709,
            Some(_) => return None,
        };
        Some(Yuv420 { matrix, full_range })
    }

    /// The ffmpeg pixel format that delivers the stream's samples unchanged.
    pub fn pix_fmt(&self) -> &'static str {
        if self.full_range {
            "yuvj420p"
        } else {
            "yuv420p"
        }
    }

    /// The fixed-point constants of this conversion.
    fn coefficients(&self) -> Coefficients {
        let (kr, kb) = match self.matrix {
            YuvMatrix::Bt601 => (0.299, 0.114),
            YuvMatrix::Bt709 => (0.2126, 0.0722),
        };
        let kg = 1.0 - kr - kb;
        let (y_scale, y_offset, c_scale) = if self.full_range {
            (1.0, 0.0, 1.0)
        } else {
            (255.0 / 219.0, 16.0, 255.0 / 224.0)
        };
        let one = f64::from(1 << FRACTION_BITS);
        // Chroma products are `mulhrs(c · 256, w) = round(c · w / 128)`, so `w` carries 7
        // more bits than the result (at most 2.41 · 64 · 128 = 19,700).
        let q = |x: f64| (x * c_scale * one * 128.0).round() as i16;
        Coefficients {
            // Luma is read as `y · 257` (its byte in both halves of a u16), so that an
            // unsigned high multiply gives `y · y_scale · 64`.
            ky: (y_scale * one * 65536.0 / 257.0).round() as u16,
            bias: (one / 2.0 - y_scale * one * y_offset).round() as i16,
            crv: q(2.0 * (1.0 - kr)),
            cgu: q(2.0 * (1.0 - kb) * kb / kg),
            cgv: q(2.0 * (1.0 - kr) * kr / kg),
            cbu: q(2.0 * (1.0 - kb)),
        }
    }
}

/// Fractional bits of the fixed-point arithmetic.
const FRACTION_BITS: u32 = 6;

/// The conversion's constants: `ky` for luma, `bias` (the luma offset and the rounding
/// half), both for results scaled by `2^FRACTION_BITS`, and the chroma weights, scaled by
/// `2^(FRACTION_BITS + 7)` for [`mulhrs`].
#[derive(Clone, Copy, Debug)]
struct Coefficients {
    ky: u16,
    bias: i16,
    crv: i16,
    cgu: i16,
    cgv: i16,
    cbu: i16,
}

/// The number of bytes of one `width x height` 4:2:0 frame: the luma plane, then the two
/// chroma planes of `ceil(width / 2) x ceil(height / 2)`.
pub fn yuv420_frame_len(width: usize, height: usize) -> usize {
    let (cw, ch) = (width.div_ceil(2), height.div_ceil(2));
    width * height + 2 * cw * ch
}

/// Converts one `width x height` 4:2:0 frame (`src`, planar as ffmpeg writes it, of
/// [`yuv420_frame_len`] bytes) into packed RGB (`dst`, `width · height · 3` bytes).
///
/// Returns `false`, writing nothing, if a buffer has the wrong length.
pub fn yuv420_to_rgb(
    src: &[u8],
    (width, height): (usize, usize),
    layout: Yuv420,
    dst: &mut [u8],
) -> bool {
    convert(src, (width, height), layout, dst, Simd::best())
}

/// [`yuv420_to_rgb`] with the row loop `simd`.
fn convert(
    src: &[u8],
    (width, height): (usize, usize),
    layout: Yuv420,
    dst: &mut [u8],
    simd: Simd,
) -> bool {
    if src.len() != yuv420_frame_len(width, height) || dst.len() != width * height * 3 {
        return false;
    }
    let c = layout.coefficients();
    let (cw, ch) = (width.div_ceil(2), height.div_ceil(2));
    let (luma, chroma) = src.split_at(width * height);
    let (u_plane, v_plane) = chroma.split_at(cw * ch);
    // Two rows of pixels (one at the bottom of an odd height) share a row of chroma.
    let pairs = luma
        .chunks(2 * width.max(1))
        .zip(dst.chunks_mut(2 * width.max(1) * 3));
    for ((ys, out), (u_row, v_row)) in pairs.zip(
        u_plane
            .chunks_exact(cw.max(1))
            .zip(v_plane.chunks_exact(cw.max(1))),
    ) {
        let done = match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Simd::available` lists AVX2 only on a CPU that has it.
            Simd::Avx2 => unsafe { avx2::rows(ys, width, u_row, v_row, out, &c) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Simd::available` lists AVX-512 only on a CPU with F, BW and VBMI.
            Simd::Avx512 => unsafe { avx512::rows(ys, width, u_row, v_row, out, &c) },
            Simd::None => 0,
        };
        for (y_row, out_row) in ys.chunks_exact(width).zip(out.chunks_exact_mut(3 * width)) {
            scalar_row(y_row, u_row, v_row, out_row, &c, done);
        }
    }
    true
}

/// `_mm256_mulhrs_epi16` for one lane: `a · b / 2^15`, rounded.
#[inline]
fn mulhrs(a: i16, b: i16) -> i16 {
    ((i32::from(a) * i32::from(b) + (1 << 14)) >> 15) as i16
}

/// One pixel: exactly the arithmetic of the AVX2 lanes (rounded high products, saturating
/// sums, an arithmetic shift, a clamp to 0-255).
#[inline]
fn pixel(y: u8, u: u8, v: u8, c: &Coefficients) -> [u8; 3] {
    let yy = ((u32::from(y) * 257 * u32::from(c.ky)) >> 16) as i16;
    // (c - 128) · 256, the chroma sample in the top byte.
    let (u, v) = ((i16::from(u) - 128) << 8, (i16::from(v) - 128) << 8);
    let t = yy.saturating_add(c.bias);
    let out = |x: i16| (x >> FRACTION_BITS).clamp(0, 255) as u8;
    [
        out(t.saturating_add(mulhrs(v, c.crv))),
        out(t.saturating_sub(mulhrs(u, c.cgu) + mulhrs(v, c.cgv))),
        out(t.saturating_add(mulhrs(u, c.cbu))),
    ]
}

/// Pixels `from..` of one row.
fn scalar_row(
    y_row: &[u8],
    u_row: &[u8],
    v_row: &[u8],
    out: &mut [u8],
    c: &Coefficients,
    from: usize,
) {
    for (x, (&y, px)) in y_row
        .iter()
        .zip(out.chunks_exact_mut(3))
        .enumerate()
        .skip(from)
    {
        let (u, v) = (u_row[x / 2], v_row[x / 2]);
        px.copy_from_slice(&pixel(y, u, v, c));
    }
}

/// Which row loop runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Simd {
    /// One pixel at a time.
    None,
    /// Sixteen pixels at a time with AVX2 (the same arithmetic, so the same bits).
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// Thirty-two pixels at a time with AVX-512 (BW, and VBMI for the byte interleave).
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Simd {
    /// Every loop this CPU can run, the fastest last.
    fn available() -> Vec<Simd> {
        // Only x86-64 has loops to add.
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut all = vec![Simd::None];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                all.push(Simd::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
                && std::arch::is_x86_feature_detected!("avx512vbmi")
            {
                all.push(Simd::Avx512);
            }
        }
        all
    }

    /// The fastest loop this CPU runs (looked up once).
    fn best() -> Simd {
        static BEST: std::sync::OnceLock<Simd> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| Simd::available().pop().unwrap_or(Simd::None))
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Coefficients, FRACTION_BITS};
    use std::arch::x86_64::*;

    /// The byte shuffles that interleave 16 R, 16 G and 16 B bytes into 48 bytes of RGB:
    /// `[k][c]` picks channel `c`'s bytes of output block `k` (-128: none).
    const INTERLEAVE: [[[i8; 16]; 3]; 3] = {
        let mut m = [[[-128i8; 16]; 3]; 3];
        let mut i = 0;
        while i < 48 {
            m[i / 16][i % 3][i % 16] = (i / 3) as i8;
            i += 1;
        }
        m
    };

    /// Converts the pixels of one or two rows (`ys`, rows of `width` bytes, into `out`,
    /// rows of `3 · width` bytes) that share the chroma rows `u_row` and `v_row`, in
    /// groups of 16 columns, and returns how many columns it wrote (a multiple of 16; the
    /// caller does the rest). The chroma of a group is weighed once for both rows.
    ///
    /// # Safety
    /// The CPU must support AVX2 (a safe `#[target_feature]` function: calling it needs
    /// `unsafe` outside code compiled with AVX2). Every load and store is of a slice
    /// checked here to hold the bytes it reads or writes.
    #[target_feature(enable = "avx2")]
    pub(super) fn rows(
        ys: &[u8],
        width: usize,
        u_row: &[u8],
        v_row: &[u8],
        out: &mut [u8],
        c: &Coefficients,
    ) -> usize {
        let ky = _mm256_set1_epi16(c.ky as i16);
        let bias = _mm256_set1_epi16(c.bias);
        let sign = _mm256_set1_epi16(i16::MIN);
        let (crv, cgu, cgv, cbu) = (
            _mm256_set1_epi16(c.crv),
            _mm256_set1_epi16(c.cgu),
            _mm256_set1_epi16(c.cgv),
            _mm256_set1_epi16(c.cbu),
        );
        let masks = INTERLEAVE.map(|block| {
            // SAFETY: each mask is 16 bytes, read unaligned.
            block.map(|m| unsafe { _mm_loadu_si128(m.as_ptr().cast()) })
        });
        let n_rows = ys.len().checked_div(width).unwrap_or(0);
        if n_rows == 0 || n_rows > 2 || out.len() < 3 * width * n_rows {
            return 0;
        }
        let groups = width / 16;
        for g in 0..groups {
            let x = 16 * g;
            let (Some(us), Some(vs)) = (u_row.get(x / 2..x / 2 + 8), v_row.get(x / 2..x / 2 + 8))
            else {
                return x;
            };
            // SAFETY: `us` and `vs` hold 8 bytes each, read by `_mm_loadl_epi64`.
            let (u, v) = unsafe {
                // Each chroma byte twice (its two pixels), as `(c - 128) · 256`: the byte
                // in the top half of the lane with its top bit flipped.
                let widen = |p: *const u8| {
                    let b = _mm_loadl_epi64(p.cast());
                    let doubled = _mm_unpacklo_epi8(b, b);
                    let high = _mm256_slli_epi16::<8>(_mm256_cvtepu8_epi16(doubled));
                    _mm256_xor_si256(high, sign)
                };
                (widen(us.as_ptr()), widen(vs.as_ptr()))
            };
            let rv = _mm256_mulhrs_epi16(v, crv);
            let guv = _mm256_add_epi16(_mm256_mulhrs_epi16(u, cgu), _mm256_mulhrs_epi16(v, cgv));
            let bu = _mm256_mulhrs_epi16(u, cbu);
            for r in 0..n_rows {
                let at = r * width + x;
                let (Some(y_px), Some(dst)) =
                    (ys.get(at..at + 16), out.get_mut(3 * at..3 * at + 48))
                else {
                    return x;
                };
                // SAFETY: `y_px` holds 16 bytes and `dst` 48: each load and store below
                // stays within them.
                unsafe {
                    let y = _mm256_cvtepu8_epi16(_mm_loadu_si128(y_px.as_ptr().cast()));
                    let y257 = _mm256_or_si256(_mm256_slli_epi16::<8>(y), y);
                    let t = _mm256_adds_epi16(_mm256_mulhi_epu16(y257, ky), bias);
                    let bytes = |x: __m256i| {
                        let s = _mm256_srai_epi16::<{ FRACTION_BITS as i32 }>(x);
                        _mm_packus_epi16(
                            _mm256_castsi256_si128(s),
                            _mm256_extracti128_si256::<1>(s),
                        )
                    };
                    let rgb = [
                        bytes(_mm256_adds_epi16(t, rv)),
                        bytes(_mm256_subs_epi16(t, guv)),
                        bytes(_mm256_adds_epi16(t, bu)),
                    ];
                    for (k, block) in masks.iter().enumerate() {
                        let v = _mm_or_si128(
                            _mm_or_si128(
                                _mm_shuffle_epi8(rgb[0], block[0]),
                                _mm_shuffle_epi8(rgb[1], block[1]),
                            ),
                            _mm_shuffle_epi8(rgb[2], block[2]),
                        );
                        _mm_storeu_si128(dst.as_mut_ptr().add(16 * k).cast(), v);
                    }
                }
            }
        }
        16 * groups
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{Coefficients, FRACTION_BITS};
    use std::arch::x86_64::*;

    /// `_mm512_permutex2var_epi8` indices that interleave 32 R bytes (table bytes 0-31),
    /// 32 G bytes (32-63) and 32 B bytes (64-95) into 96 bytes of RGB, in a block of 64
    /// and one of 32 (its upper half unused).
    const INTERLEAVE: [[u8; 64]; 2] = {
        let mut m = [[0u8; 64]; 2];
        let mut i = 0;
        while i < 96 {
            m[i / 64][i % 64] = (32 * (i % 3) + i / 3) as u8;
            i += 1;
        }
        m
    };

    /// [`super::avx2::rows`] 32 columns at a time: the same arithmetic, lane for lane.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VBMI (a safe `#[target_feature]` function:
    /// calling it needs `unsafe` outside code compiled with them). Every load and store is
    /// of a slice checked here to hold the bytes it reads or writes.
    #[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
    pub(super) fn rows(
        ys: &[u8],
        width: usize,
        u_row: &[u8],
        v_row: &[u8],
        out: &mut [u8],
        c: &Coefficients,
    ) -> usize {
        let n_rows = ys.len().checked_div(width).unwrap_or(0);
        if n_rows == 0 || n_rows > 2 || out.len() < 3 * width * n_rows {
            return 0;
        }
        let ky = _mm512_set1_epi16(c.ky as i16);
        let bias = _mm512_set1_epi16(c.bias);
        let sign = _mm512_set1_epi16(i16::MIN);
        let zero = _mm512_setzero_si512();
        let (crv, cgu, cgv, cbu) = (
            _mm512_set1_epi16(c.crv),
            _mm512_set1_epi16(c.cgu),
            _mm512_set1_epi16(c.cgv),
            _mm512_set1_epi16(c.cbu),
        );
        // Lane i of 32 takes chroma lane i / 2 of 16.
        let pairs: [i16; 32] = std::array::from_fn(|i| (i / 2) as i16);
        // SAFETY: the tables hold 64 bytes each, read unaligned.
        let (pairs, lo, hi) = unsafe {
            (
                _mm512_loadu_si512(pairs.as_ptr().cast()),
                _mm512_loadu_si512(INTERLEAVE[0].as_ptr().cast()),
                _mm512_loadu_si512(INTERLEAVE[1].as_ptr().cast()),
            )
        };
        let groups = width / 32;
        for g in 0..groups {
            let x = 32 * g;
            let (Some(us), Some(vs)) = (u_row.get(x / 2..x / 2 + 16), v_row.get(x / 2..x / 2 + 16))
            else {
                return x;
            };
            // Each chroma byte twice, as `(c - 128) · 256` (see the AVX2 loop).
            let widen = |b: &[u8]| {
                // SAFETY: `b` holds 16 bytes.
                let b = unsafe { _mm_loadu_si128(b.as_ptr().cast()) };
                let lanes = _mm512_castsi256_si512(_mm256_cvtepu8_epi16(b));
                let doubled = _mm512_permutexvar_epi16(pairs, lanes);
                _mm512_xor_si512(_mm512_slli_epi16::<8>(doubled), sign)
            };
            let (u, v) = (widen(us), widen(vs));
            let rv = _mm512_mulhrs_epi16(v, crv);
            let guv = _mm512_add_epi16(_mm512_mulhrs_epi16(u, cgu), _mm512_mulhrs_epi16(v, cgv));
            let bu = _mm512_mulhrs_epi16(u, cbu);
            for r in 0..n_rows {
                let at = r * width + x;
                let (Some(y_px), Some(dst)) =
                    (ys.get(at..at + 32), out.get_mut(3 * at..3 * at + 96))
                else {
                    return x;
                };
                // SAFETY: `y_px` holds 32 bytes, read unaligned.
                let y = unsafe { _mm256_loadu_si256(y_px.as_ptr().cast()) };
                let y = _mm512_cvtepu8_epi16(y);
                let y257 = _mm512_or_si512(_mm512_slli_epi16::<8>(y), y);
                let t = _mm512_adds_epi16(_mm512_mulhi_epu16(y257, ky), bias);
                // The AVX2 loop's shift and unsigned saturating pack: negative lanes to 0
                // first, then down to bytes with saturation at 255.
                let bytes = |x: __m512i| {
                    let s = _mm512_srai_epi16::<{ FRACTION_BITS }>(x);
                    _mm512_cvtusepi16_epi8(_mm512_max_epi16(s, zero))
                };
                let r8 = bytes(_mm512_adds_epi16(t, rv));
                let g8 = bytes(_mm512_subs_epi16(t, guv));
                let b8 = bytes(_mm512_adds_epi16(t, bu));
                let rg = _mm512_inserti64x4::<1>(_mm512_castsi256_si512(r8), g8);
                let b = _mm512_castsi256_si512(b8);
                let first = _mm512_permutex2var_epi8(rg, lo, b);
                let second = _mm512_permutex2var_epi8(rg, hi, b);
                // SAFETY: `dst` holds 96 bytes: 64 at its start, 32 after them.
                unsafe {
                    _mm512_storeu_si512(dst.as_mut_ptr().cast(), first);
                    _mm256_storeu_si256(
                        dst.as_mut_ptr().add(64).cast(),
                        _mm512_castsi512_si256(second),
                    );
                }
            }
        }
        32 * groups
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact conversion in floating point, chroma repeated over its 2 x 2 pixels.
    fn exact(y: u8, u: u8, v: u8, layout: Yuv420) -> [f64; 3] {
        let (kr, kb) = match layout.matrix {
            YuvMatrix::Bt601 => (0.299, 0.114),
            YuvMatrix::Bt709 => (0.2126, 0.0722),
        };
        let (ys, cs) = if layout.full_range {
            (f64::from(y), 1.0)
        } else {
            ((f64::from(y) - 16.0) * 255.0 / 219.0, 255.0 / 224.0)
        };
        let (u, v) = ((f64::from(u) - 128.0) * cs, (f64::from(v) - 128.0) * cs);
        let r = ys + 2.0 * (1.0 - kr) * v;
        let b = ys + 2.0 * (1.0 - kb) * u;
        let g = (ys - kr * r - kb * b) / (1.0 - kr - kb);
        [r, g, b].map(|x| x.clamp(0.0, 255.0))
    }

    fn layouts() -> [Yuv420; 4] {
        [YuvMatrix::Bt601, YuvMatrix::Bt709]
            .into_iter()
            .flat_map(|matrix| [false, true].map(|full_range| Yuv420 { matrix, full_range }))
            .collect::<Vec<_>>()
            .try_into()
            .expect("four layouts")
    }

    /// A frame of pseudo-random samples (a fixed LCG, so every run sees the same bytes).
    fn noise_frame(w: usize, h: usize, seed: u32) -> Vec<u8> {
        let mut s = seed;
        (0..yuv420_frame_len(w, h))
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn every_sample_near_the_exact_conversion() {
        for layout in layouts() {
            let c = layout.coefficients();
            let (mut worst, mut sum, mut n) = (0.0f64, 0.0, 0.0);
            for y in 0..=255u8 {
                for u in (0..=255u8).step_by(3) {
                    for v in (0..=255u8).step_by(5) {
                        let got = pixel(y, u, v, &c);
                        for (g, e) in got.iter().zip(exact(y, u, v, layout)) {
                            let d = (f64::from(*g) - e).abs();
                            worst = worst.max(d);
                            sum += d;
                            n += 1.0;
                        }
                    }
                }
            }
            eprintln!("{layout:?}: worst {worst:.3}, mean {:.3}", sum / n);
            // Measured: worst 0.52, mean 0.15-0.17 (rounding to whole levels alone gives
            // 0.5 and 0.25 on uniform values).
            assert!(worst < 0.55, "{layout:?}: {worst}");
            assert!(sum / n < 0.2, "{layout:?}: mean {}", sum / n);
        }
    }

    #[test]
    fn simd_rows_give_the_portable_bits_at_every_size() {
        // Odd sizes (a last chroma column and row of one pixel), sizes below one AVX2 group
        // and not a multiple of it.
        for (w, h) in [
            (1, 1),
            (7, 3),
            (16, 2),
            (33, 5),
            (64, 9),
            (101, 20),
            (130, 7),
        ] {
            for layout in layouts() {
                let src = noise_frame(w, h, (w * 31 + h) as u32);
                let fast: Vec<(Simd, Vec<u8>)> = Simd::available()
                    .into_iter()
                    .map(|simd| {
                        let mut out = vec![0u8; w * h * 3];
                        assert!(convert(&src, (w, h), layout, &mut out, simd));
                        (simd, out)
                    })
                    .collect();
                let c = layout.coefficients();
                let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
                let mut slow = vec![0u8; w * h * 3];
                for y in 0..h {
                    let u_row = &src[w * h + (y / 2) * cw..][..cw];
                    let v_row = &src[w * h + cw * ch + (y / 2) * cw..][..cw];
                    let y_row = &src[y * w..(y + 1) * w];
                    scalar_row(
                        y_row,
                        u_row,
                        v_row,
                        &mut slow[y * w * 3..(y + 1) * w * 3],
                        &c,
                        0,
                    );
                }
                for (simd, out) in &fast {
                    assert!(*out == slow, "{simd:?} {w}x{h} {layout:?}");
                }
            }
        }
    }

    #[test]
    fn buffers_of_the_wrong_size_are_refused() {
        let layout = layouts()[0];
        let mut dst = vec![7u8; 4 * 2 * 3];
        assert!(!yuv420_to_rgb(&[0; 11], (4, 2), layout, &mut dst));
        assert!(!yuv420_to_rgb(&[0; 12], (4, 2), layout, &mut dst[1..]));
        assert!(dst.iter().all(|&b| b == 7));
        assert!(yuv420_to_rgb(&[0; 12], (4, 2), layout, &mut dst));
        assert!(yuv420_to_rgb(&[], (0, 0), layout, &mut []));
    }

    #[test]
    fn streams_pick_their_layout_as_ffmpeg_does() {
        let info = |pix: &str, space: Option<&str>, range: Option<&str>| VideoInfo {
            width: 2,
            height: 2,
            fps: None,
            frame_count: None,
            codec: None,
            rotation_deg: 0,
            pix_fmt: Some(pix.into()),
            color_space: space.map(String::from),
            color_range: range.map(String::from),
        };
        let l = |matrix, full_range| Some(Yuv420 { matrix, full_range });
        use YuvMatrix::*;
        assert_eq!(
            Yuv420::of_stream(&info("yuv420p", None, None)),
            l(Bt601, false)
        );
        assert_eq!(
            Yuv420::of_stream(&info("yuv420p", Some("bt709"), Some("tv"))),
            l(Bt709, false)
        );
        assert_eq!(
            Yuv420::of_stream(&info("yuv420p", Some("smpte170m"), Some("pc"))),
            l(Bt601, true)
        );
        assert_eq!(
            Yuv420::of_stream(&info("yuvj420p", Some("bt709"), None)),
            l(Bt709, true)
        );
        assert_eq!(
            Yuv420::of_stream(&info("yuv420p", Some("bt2020nc"), None)),
            None
        );
        assert_eq!(Yuv420::of_stream(&info("yuv422p", None, None)), None);
        assert_eq!(Yuv420::of_stream(&info("yuv420p10le", None, None)), None);
        assert_eq!(Yuv420::of_stream(&info("rgb24", None, None)), None);
        let odd = VideoInfo {
            width: 3,
            ..info("yuv420p", None, None)
        };
        assert_eq!(Yuv420::of_stream(&odd), None);
        assert_eq!(l(Bt709, true).map(|l| l.pix_fmt()), Some("yuvj420p"));
    }
}
