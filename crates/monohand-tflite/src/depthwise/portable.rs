//! The portable loop nest (also compiled for AVX2 + FMA, `avx2::run_avx2_fma`).

use super::{Bounds, Geometry};

/// The loop nest: output row, kernel tap, output column, channels (innermost, contiguous).
/// For one tap the valid output columns are computed once, so the two inner loops run over
/// contiguous chunks without per-pixel bounds tests.
#[inline(always)]
pub(super) fn kernel<const FMA: bool>(
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
    let rows = g.rows.0..g.rows.1.min(g.oh);
    for (oy, orow) in rows.zip(dst.chunks_exact_mut(row_out)) {
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
