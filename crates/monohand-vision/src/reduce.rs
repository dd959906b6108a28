//! Box-filtered reductions of an image, made for one crop at a time.
//!
//! A crop that shrinks the image (a hand filling a 4K frame warped into the landmark
//! network's 224 pixels, a whole frame letterboxed into the detector's 192) must average
//! each output pixel's footprint, or the network sees aliasing. Instead of many bilinear
//! samples per output pixel (the warp before issue 34: up to 8 x 8, so a cost that grew
//! with the frame), the part of the image under the crop is first reduced by `2^k` along
//! each side, every reduced pixel the mean of a `2^k x 2^k` block of image pixels (the level
//! `k` of a mip pyramid, made in one pass straight from the image and rounded once), and
//! the crop is then sampled bilinearly from the reduction with a footprint of 1 to 2 of its
//! pixels. Each image pixel under the crop is read once.
//!
//! The reduction lives in a buffer each thread keeps and reuses (the pipeline's two worker
//! threads, rayon's), so a steady stream of frames allocates nothing here.
//!
//! The image as both the warp and the reductions read it ([`Src`]) and the footprint where
//! the reductions start ([`PLAIN_BILINEAR_UP_TO`], re-exported by the warp) are defined
//! here, below the warp, which samples from the reductions.

use std::cell::RefCell;

use image::RgbImage;

/// The largest footprint (image pixels per output pixel, along a side) sampled plainly
/// bilinearly from the image, as MediaPipe does; above it the image is box-filtered first.
pub const PLAIN_BILINEAR_UP_TO: f64 = 2.0;

/// An RGB image borrowed as bytes: `w x h` pixels, rows of `w * 3` bytes, no padding.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Src<'a> {
    pub(crate) raw: &'a [u8],
    pub(crate) w: usize,
    pub(crate) h: usize,
}

impl<'a> Src<'a> {
    pub(crate) fn of(img: &'a RgbImage) -> Src<'a> {
        Src {
            raw: img.as_raw(),
            w: img.width() as usize,
            h: img.height() as usize,
        }
    }
}

/// The deepest reduction (blocks of 256 x 256 pixels, whose column sums still fit in u16).
const MAX_LEVEL: u32 = 8;

/// The reduction level for a crop whose output pixel covers `footprint` image pixels along
/// a side: `None` (sample the image itself) up to [`PLAIN_BILINEAR_UP_TO`],
/// else the largest `k` with `2^k <= footprint` (at most [`MAX_LEVEL`]).
pub(crate) fn level_for(footprint: f64) -> Option<u32> {
    if footprint > PLAIN_BILINEAR_UP_TO {
        Some((footprint.log2().floor() as u32).clamp(1, MAX_LEVEL))
    } else {
        // Also NaN: the plain warp reads nothing for a non-finite map.
        None
    }
}

/// What one thread keeps between crops.
#[derive(Default)]
struct Scratch {
    /// The reduced pixels, RGB.
    pixels: Vec<u8>,
    /// Column sums of one band of `2^k` image rows.
    sums: Vec<u16>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Reduces by `2^k` the part of `img` that the crop of `size` output pixels mapped by `m`
/// (output → image) reads, and calls `f` with the reduction and the map from output pixels
/// to it.
///
/// The region is aligned to the `2^k` grid of the whole image (so a reduced pixel is the
/// same block whichever crop asked for it) and reaches two reduced pixels past the crop
/// (bilinear reads one), clipped to the image: what lies outside the image stays outside the
/// reduction, so the warp's border rule applies unchanged. A crop entirely outside the image
/// gets the image's nearest edge block as its region.
pub(crate) fn with_region<R>(
    img: Src,
    m: &[[f64; 3]; 2],
    (out_w, out_h): (usize, usize),
    k: u32,
    f: impl FnOnce(Src, &[[f64; 3]; 2]) -> R,
) -> R {
    let block = 1usize << k;
    let b = block as f64;
    // Bounding box of the crop in the image.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (u, v) in [(0.0, 0.0), (out_w as f64, 0.0), (0.0, out_h as f64)]
        .into_iter()
        .chain([(out_w as f64, out_h as f64)])
    {
        for a in 0..2 {
            let p = m[a][0] * u + m[a][1] * v + m[a][2];
            lo[a] = lo[a].min(p);
            hi[a] = hi[a].max(p);
        }
    }
    // Aligned to the block grid, two blocks of margin, clipped to the image (casts of
    // non-finite values saturate; the clamps then keep the region inside the image).
    let span = |a: usize, len: usize| -> (usize, usize) {
        let last_block = (len.saturating_sub(1) / block) * block;
        let start =
            ((((lo[a] / b).floor() - 2.0).max(0.0) as usize).saturating_mul(block)).min(last_block);
        let end = (((hi[a] / b).ceil() + 2.0).max(0.0) as usize)
            .saturating_mul(block)
            .clamp(start + 1, len.max(start + 1));
        (start, end.min(len))
    };
    let (x0, x1) = span(0, img.w);
    let (y0, y1) = span(1, img.h);
    let reduced_map = [
        [m[0][0] / b, m[0][1] / b, (m[0][2] - x0 as f64) / b],
        [m[1][0] / b, m[1][1] / b, (m[1][2] - y0 as f64) / b],
    ];
    SCRATCH.with(|cell| {
        // A warp does not call itself, so the buffer is never borrowed twice; should it
        // be, a fresh buffer does the job.
        let mut fresh = None;
        let mut guard = cell.try_borrow_mut().ok();
        let scratch = match guard.as_deref_mut() {
            Some(s) => s,
            None => fresh.insert(Scratch::default()),
        };
        let (w, h) = reduce(img, (x0, y0, x1, y1), k, scratch);
        let level = Src {
            raw: &scratch.pixels,
            w,
            h,
        };
        f(level, &reduced_map)
    })
}

/// The `2^k x 2^k` block means of the image region `[x0, x1) x [y0, y1)` (`x0`, `y0` on the
/// block grid, the region inside the image) into `scratch.pixels`, rounded to the nearest
/// integer; blocks cut by the region's right or bottom edge average the pixels they hold.
/// Returns the reduction's width and height. An empty region (an empty image) gives an
/// empty reduction.
fn reduce(
    img: Src,
    (x0, y0, x1, y1): (usize, usize, usize, usize),
    k: u32,
    scratch: &mut Scratch,
) -> (usize, usize) {
    let block = 1usize << k;
    let (x1, y1) = (x1.min(img.w), y1.min(img.h));
    if x0 >= x1 || y0 >= y1 {
        scratch.pixels.clear();
        return (0, 0);
    }
    let (rw, rh) = ((x1 - x0).div_ceil(block), (y1 - y0).div_ceil(block));
    let stride = img.w * 3;
    let row_bytes = (x1 - x0) * 3;
    scratch.pixels.clear();
    scratch.pixels.resize(rw * rh * 3, 0);
    scratch.sums.clear();
    scratch.sums.resize(row_bytes, 0);
    let add = AddRow::best();
    let full = (block * block) as u32;
    for (j, out_row) in scratch.pixels.chunks_exact_mut(rw * 3).enumerate() {
        let ys = y0 + j * block;
        let ye = (ys + block).min(y1);
        scratch.sums.fill(0);
        for y in ys..ye {
            let start = y * stride + x0 * 3;
            add.run(&mut scratch.sums, &img.raw[start..start + row_bytes]);
        }
        let rows = (ye - ys) as u32;
        for (i, px) in out_row.chunks_exact_mut(3).enumerate() {
            let cols = &scratch.sums[i * block * 3..((i + 1) * block * 3).min(row_bytes)];
            let mut acc = [0u32; 3];
            for p in cols.chunks_exact(3) {
                acc[0] += p[0] as u32;
                acc[1] += p[1] as u32;
                acc[2] += p[2] as u32;
            }
            let count = rows * (cols.len() / 3) as u32;
            for c in 0..3 {
                // A whole block is a shift; a cut one a division (at most one row and one
                // column of blocks).
                px[c] = if count == full {
                    ((acc[c] + full / 2) >> (2 * k)) as u8
                } else {
                    ((acc[c] + count / 2) / count) as u8
                };
            }
        }
    }
    (rw, rh)
}

/// The column sums' inner loop, `acc[i] += row[i]`, compiled for the best vector unit of
/// this CPU (chosen at run time; integer sums, so every choice gives the same numbers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum AddRow {
    /// Baseline (SSE2 on x86-64).
    Portable,
    /// 32 bytes at a time.
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl AddRow {
    fn best() -> AddRow {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return AddRow::Avx2;
        }
        AddRow::Portable
    }

    fn run(self, acc: &mut [u16], row: &[u8]) {
        match self {
            AddRow::Portable => add_row(acc, row),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `AddRow::Avx2` is chosen only where the CPU has AVX2 (`best`; the tests
            // use it only where `best` returns it); the function reads and writes only
            // through the slices.
            AddRow::Avx2 => unsafe { add_row_avx2(acc, row) },
        }
    }
}

/// `acc[i] += row[i]` over the shorter of the two (no overflow: at most 256 rows of 255).
#[inline(always)]
fn add_row(acc: &mut [u16], row: &[u8]) {
    for (a, &v) in acc.iter_mut().zip(row) {
        *a = a.wrapping_add(v as u16);
    }
}

/// [`add_row`] compiled with AVX2.
///
/// # Safety
/// The CPU must support AVX2 (a safe `#[target_feature]` function: calling it needs
/// `unsafe` outside code compiled with AVX2).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn add_row_avx2(acc: &mut [u16], row: &[u8]) {
    add_row(acc, row)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn textured(w: u32, h: u32) -> image::RgbImage {
        image::RgbImage::from_fn(w, h, |x, y| {
            image::Rgb([
                ((x * 7 + y * 3) % 256) as u8,
                ((x * x / 5 + y * 11) % 256) as u8,
                ((x ^ y) % 256) as u8,
            ])
        })
    }

    #[test]
    fn levels_start_above_the_plain_bilinear_footprint() {
        assert_eq!(level_for(1.0), None);
        assert_eq!(level_for(2.0), None);
        assert_eq!(level_for(f64::NAN), None);
        assert_eq!(level_for(2.01), Some(1));
        assert_eq!(level_for(3.99), Some(1));
        assert_eq!(level_for(4.0), Some(2));
        assert_eq!(level_for(20.0), Some(4));
        assert_eq!(level_for(1e9), Some(MAX_LEVEL));
        assert_eq!(level_for(f64::INFINITY), Some(MAX_LEVEL));
    }

    #[test]
    fn a_reduced_pixel_is_the_rounded_mean_of_its_block() {
        let img = textured(53, 37);
        let src = Src::of(&img);
        for k in [1, 2, 3] {
            let block = 1usize << k;
            let mut scratch = Scratch::default();
            let (x0, y0) = (block, 2 * block);
            let (w, h) = reduce(src, (x0, y0, 53, 37), k, &mut scratch);
            assert_eq!(
                (w, h),
                ((53 - x0).div_ceil(block), (37 - y0).div_ceil(block))
            );
            for j in 0..h {
                for i in 0..w {
                    for c in 0..3 {
                        let (mut sum, mut count) = (0u32, 0u32);
                        for y in y0 + j * block..(y0 + (j + 1) * block).min(37) {
                            for x in x0 + i * block..(x0 + (i + 1) * block).min(53) {
                                sum += img.get_pixel(x as u32, y as u32)[c] as u32;
                                count += 1;
                            }
                        }
                        let want = (sum as f64 / count as f64).round() as u8;
                        let got = scratch.pixels[(j * w + i) * 3 + c];
                        // Ties round up in both (x.5 → x+1).
                        assert_eq!(got, want, "k {k} block ({i}, {j}) channel {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_vector_column_sums_equal_the_portable_ones() {
        let row: Vec<u8> = (0..1001u32).map(|i| (i * 37 % 256) as u8).collect();
        let mut a = vec![7u16; row.len()];
        let mut b = a.clone();
        AddRow::Portable.run(&mut a, &row);
        AddRow::best().run(&mut b, &row);
        assert_eq!(a, b);
        assert_eq!(a[5], 7 + 185, "7 plus row[5] = 5 * 37");
        assert_eq!(a[1000], 7 + u16::from(row[1000]));
    }

    #[test]
    fn the_region_covers_the_crop_and_stays_inside_the_image() {
        let img = textured(300, 200);
        let src = Src::of(&img);
        // A crop of 48 output pixels at footprint 3 (level 1) in the middle, one past the
        // left edge, one entirely outside, and a non-finite map: no panic, and the reduced
        // map sends the crop into the region.
        for m in [
            [[3.0, 0.0, 80.0], [0.0, 3.0, 40.0]],
            [[2.5, 1.5, -60.0], [-1.5, 2.5, 100.0]],
            [[3.0, 0.0, 5000.0], [0.0, 3.0, -900.0]],
            [[f64::INFINITY, 0.0, 0.0], [0.0, 3.0, f64::NAN]],
        ] {
            with_region(src, &m, (48, 48), 1, |level, r| {
                assert!(level.w >= 1 && level.h >= 1 && level.w <= 150 && level.h <= 100);
                assert_eq!(level.raw.len(), level.w * level.h * 3);
                if m[0][2] == 80.0 {
                    // The whole crop (image x 80..224, y 40..184) is inside the region.
                    for (u, v) in [(0.0, 0.0), (48.0, 48.0)] {
                        let x = r[0][0] * u + r[0][1] * v + r[0][2];
                        let y = r[1][0] * u + r[1][1] * v + r[1][2];
                        assert!(x >= 1.0 && y >= 1.0, "{x} {y}");
                        assert!(x <= level.w as f64 - 1.0 && y <= level.h as f64 - 1.0);
                    }
                }
            });
        }
    }
}
