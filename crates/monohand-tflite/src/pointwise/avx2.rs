//! The AVX2 + FMA f32 kernel: tiles of 6 rows x 16 channels in 12 registers.

use super::{Tile, TileFn, MR, NR};
use std::arch::x86_64::*;

/// The monomorphised tile for `m` rows and `v` vectors.
pub(super) fn tile(m: usize, v: usize) -> TileFn {
    const _: () = assert!(MR == 6 && NR == 16);
    match (m, v) {
        (1, 1) => micro::<1, 1>,
        (2, 1) => micro::<2, 1>,
        (3, 1) => micro::<3, 1>,
        (4, 1) => micro::<4, 1>,
        (5, 1) => micro::<5, 1>,
        (6, 1) => micro::<6, 1>,
        (1, _) => micro::<1, 2>,
        (2, _) => micro::<2, 2>,
        (3, _) => micro::<3, 2>,
        (4, _) => micro::<4, 2>,
        (5, _) => micro::<5, 2>,
        _ => micro::<6, 2>,
    }
}

/// `M` rows x `V` vectors of 8 channels accumulated in `M·V` registers; the epilogue runs
/// on the registers and stores with a mask where the panel is narrower than `8·V`.
///
/// # Safety
/// The CPU has AVX2 and FMA; `t` satisfies `Tile`'s contract with `t.m == M` and
/// `8·(V-1) < t.width <= 8·V`.
#[target_feature(enable = "avx2,fma")]
unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
    // SAFETY: the CPU has AVX2 and FMA (the contract). The reads and writes stay in the
    // tile (`Tile`'s contract, m == M, 8·(V-1) < width <= 8·V <= NR): `a` at rows
    // i < M, columns < k <= lda; `b` at k rows of the panel, 8·V <= NR values each;
    // `bias` and `alpha` at 8·V <= NR values; `res` and `out` at rows i < M, 8·V
    // channels of which the last vector's lanes at and past `width` are masked off.
    unsafe {
        let mut acc = [[_mm256_setzero_ps(); V]; M];
        let mut a = t.a;
        let mut b = t.b;
        for _ in 0..t.k {
            let mut bv = [_mm256_setzero_ps(); V];
            for (v, bv) in bv.iter_mut().enumerate() {
                *bv = _mm256_loadu_ps(b.add(8 * v));
            }
            for (i, acc) in acc.iter_mut().enumerate() {
                let x = _mm256_broadcast_ss(&*a.add(i * t.lda));
                for (acc, &bv) in acc.iter_mut().zip(&bv) {
                    *acc = _mm256_fmadd_ps(x, bv, *acc);
                }
            }
            a = a.add(1);
            b = b.add(NR);
        }
        let lanes = (t.width - 8 * (V - 1)) as i32;
        let mask = _mm256_cmpgt_epi32(
            _mm256_set1_epi32(lanes),
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
        );
        let (lo, hi) = (_mm256_set1_ps(t.act.0), _mm256_set1_ps(t.act.1));
        let (rlo, rhi) = (
            _mm256_set1_ps(t.residual_act.0),
            _mm256_set1_ps(t.residual_act.1),
        );
        let zero = _mm256_setzero_ps();
        for (i, acc) in acc.iter().enumerate() {
            for (v, &acc) in acc.iter().enumerate() {
                let full = v + 1 < V || lanes == 8;
                let at = i * t.ldo + 8 * v;
                let mut y = _mm256_add_ps(acc, _mm256_loadu_ps(t.bias.add(8 * v)));
                y = _mm256_min_ps(_mm256_max_ps(y, lo), hi);
                if !t.res.is_null() {
                    let r = if full {
                        _mm256_loadu_ps(t.res.add(at))
                    } else {
                        _mm256_maskload_ps(t.res.add(at), mask)
                    };
                    y = _mm256_min_ps(_mm256_max_ps(_mm256_add_ps(y, r), rlo), rhi);
                }
                if !t.alpha.is_null() {
                    let al = _mm256_loadu_ps(t.alpha.add(8 * v));
                    y = _mm256_fmadd_ps(al, _mm256_min_ps(y, zero), _mm256_max_ps(y, zero));
                }
                if full {
                    _mm256_storeu_ps(t.out.add(at), y);
                } else {
                    _mm256_maskstore_ps(t.out.add(at), mask, y);
                }
            }
        }
    }
}
