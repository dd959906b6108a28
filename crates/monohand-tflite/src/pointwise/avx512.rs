//! The AVX-512F + VL f32 kernel: tiles of 8 rows x 32 channels (two panels), masked loads and
//! stores for the channel tail.

use super::{Tile, TileFn, MR512, NR};
use crate::isa::lanes;
use std::arch::x86_64::*;

/// The tiles of 1 to 8 rows for `V` 16-lane and `H` 8-lane vectors.
macro_rules! heights {
    ($v:literal, $h:literal) => {
        [
            micro::<1, $v, $h>,
            micro::<2, $v, $h>,
            micro::<3, $v, $h>,
            micro::<4, $v, $h>,
            micro::<5, $v, $h>,
            micro::<6, $v, $h>,
            micro::<7, $v, $h>,
            micro::<8, $v, $h>,
        ]
    };
}

/// By width class (1-8, 9-16, 17-24, 25-32 channels), then height.
static TILES: [[TileFn; MR512]; 4] = [
    heights!(0, 1),
    heights!(1, 0),
    heights!(1, 1),
    heights!(2, 0),
];

/// The monomorphised tile for `m` rows and `width` channels (`1 <= width <= 32`): whole
/// 16-lane vectors, and an 8-lane one where at most 8 channels are left (on cores that
/// split 512-bit operations in two, such as Zen 4, it costs half).
pub(super) fn tile(m: usize, width: usize) -> TileFn {
    TILES[(width.clamp(1, 2 * NR) - 1) / 8][m.clamp(1, MR512) - 1]
}

/// `M` rows x (`V` vectors of 16 channels, then `H` of 8) accumulated in registers; the
/// epilogue runs on the registers, and the last vector loads and stores under a mask
/// where the tile is narrower than the vectors.
///
/// # Safety
/// The CPU has AVX-512F and AVX-512VL; `t` satisfies `Tile`'s contract with `t.m == M`,
/// `H <= 1`, `V + H >= 1` and `16·V + 8·H - (8 if H else 16) < t.width <= 16·V + 8·H`.
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn micro<const M: usize, const V: usize, const H: usize>(t: &Tile) {
    // SAFETY: the CPU has AVX-512F and VL (the contract). The reads and writes stay in
    // the tile (`Tile`'s contract, m == M): `a` at rows i < M, columns < k <= lda; `b` at
    // k rows of the first panel, and of the second where 16·V + 8·H > NR (then
    // width > NR: two panels); `bias` and `alpha` at 16·V + 8·H values, within
    // NR·width.div_ceil(NR); `res` and `out` at rows i < M, 16·V + 8·H channels of
    // which the last vector's lanes at and past `width` are masked off.
    unsafe {
        let mut acc = [[_mm512_setzero_ps(); V]; M];
        let mut half = [[_mm256_setzero_ps(); H]; M];
        let mut a = t.a;
        let mut b = t.b;
        // The second panel's rows start a whole panel further.
        let panel = t.k * NR;
        for _ in 0..t.k {
            let mut bv = [_mm512_setzero_ps(); V];
            for (v, bv) in bv.iter_mut().enumerate() {
                *bv = _mm512_loadu_ps(b.add(v * panel));
            }
            let mut bh = [_mm256_setzero_ps(); H];
            for bh in bh.iter_mut() {
                *bh = _mm256_loadu_ps(b.add(V * panel));
            }
            for (i, (acc, half)) in acc.iter_mut().zip(half.iter_mut()).enumerate() {
                let s = *a.add(i * t.lda);
                let x = _mm512_set1_ps(s);
                for (acc, &bv) in acc.iter_mut().zip(&bv) {
                    *acc = _mm512_fmadd_ps(x, bv, *acc);
                }
                let x = _mm256_set1_ps(s);
                for (half, &bh) in half.iter_mut().zip(&bh) {
                    *half = _mm256_fmadd_ps(x, bh, *half);
                }
            }
            a = a.add(1);
            b = b.add(NR);
        }
        // Lanes of the last vector: the 16-lane one if there is no 8-lane one.
        let last = if H == 0 {
            lanes(t.width - 16 * (V - 1))
        } else {
            lanes(t.width - 16 * V)
        };
        let (lo, hi) = (_mm512_set1_ps(t.act.0), _mm512_set1_ps(t.act.1));
        let (rlo, rhi) = (
            _mm512_set1_ps(t.residual_act.0),
            _mm512_set1_ps(t.residual_act.1),
        );
        let zero = _mm512_setzero_ps();
        for (i, (acc, half)) in acc.iter().zip(&half).enumerate() {
            for (v, &acc) in acc.iter().enumerate() {
                let mask = if H == 0 && v + 1 == V { last } else { 0xffff };
                let at = i * t.ldo + 16 * v;
                let mut y = _mm512_add_ps(acc, _mm512_loadu_ps(t.bias.add(16 * v)));
                y = _mm512_min_ps(_mm512_max_ps(y, lo), hi);
                if !t.res.is_null() {
                    let r = _mm512_maskz_loadu_ps(mask, t.res.add(at));
                    y = _mm512_min_ps(_mm512_max_ps(_mm512_add_ps(y, r), rlo), rhi);
                }
                if !t.alpha.is_null() {
                    let al = _mm512_loadu_ps(t.alpha.add(16 * v));
                    y = _mm512_fmadd_ps(al, _mm512_min_ps(y, zero), _mm512_max_ps(y, zero));
                }
                _mm512_mask_storeu_ps(t.out.add(at), mask, y);
            }
            for &acc in half {
                let mask = last as u8;
                let at = i * t.ldo + 16 * V;
                let y = _mm256_add_ps(acc, _mm256_loadu_ps(t.bias.add(16 * V)));
                let y = _mm256_min_ps(
                    _mm256_max_ps(y, _mm512_castps512_ps256(lo)),
                    _mm512_castps512_ps256(hi),
                );
                let mut y = y;
                if !t.res.is_null() {
                    let r = _mm256_maskz_loadu_ps(mask, t.res.add(at));
                    y = _mm256_min_ps(
                        _mm256_max_ps(_mm256_add_ps(y, r), _mm512_castps512_ps256(rlo)),
                        _mm512_castps512_ps256(rhi),
                    );
                }
                if !t.alpha.is_null() {
                    let al = _mm256_loadu_ps(t.alpha.add(16 * V));
                    let z = _mm256_setzero_ps();
                    y = _mm256_fmadd_ps(al, _mm256_min_ps(y, z), _mm256_max_ps(y, z));
                }
                _mm256_mask_storeu_ps(t.out.add(at), mask, y);
            }
        }
    }
}
