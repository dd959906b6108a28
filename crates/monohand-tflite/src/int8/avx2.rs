//! The AVX2 int8 kernel: `vpmaddubsw` + `vpmaddwd` against ones + `vpaddd`, tiles of 4 rows x
//! 16 channels in 8 `ymm` accumulators; its quantizer and epilogue serve the AVX-VNNI kernel too.

use super::{ActivationQuant, Tile, TileFn, ACTIVATION_QMAX, KG, MR, NR};
use std::arch::x86_64::*;

/// The monomorphised tile for `m` rows and `v` vectors of 8 channels.
pub(super) fn tile(m: usize, v: usize) -> TileFn {
    const _: () = assert!(MR == 4 && NR == 16 && KG == 4);
    match (m, v) {
        (1, 1) => micro::<1, 1>,
        (2, 1) => micro::<2, 1>,
        (3, 1) => micro::<3, 1>,
        (4, 1) => micro::<4, 1>,
        (1, _) => micro::<1, 2>,
        (2, _) => micro::<2, 2>,
        (3, _) => micro::<3, 2>,
        _ => micro::<4, 2>,
    }
}

/// Codes `x` into `q` as [`ActivationQuant::quantize`] does, 8 values at a time
/// (`vroundps` to nearest even, the same clamp, an exact conversion).
///
/// # Safety
/// The CPU has AVX2; `x.len() == q.len()`.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn quantize(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
    let n = x.len().min(q.len());
    let z = quant.zero_point as f32;
    let inv = _mm256_set1_ps(quant.inv_scale);
    let lo = _mm256_set1_ps(-z);
    let hi = _mm256_set1_ps(ACTIVATION_QMAX as f32 - z);
    let zp = _mm256_set1_epi32(quant.zero_point as i32);
    let mut k = 0;
    while k + 8 <= n {
        // SAFETY: k + 8 <= n values of `x` and of `q`; the CPU has AVX2 (the contract).
        unsafe {
            let v = _mm256_mul_ps(_mm256_loadu_ps(x.as_ptr().add(k)), inv);
            let v = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v);
            // `maxps` returns its second operand for NaN: NaN becomes `lo`, as in
            // `quantize`.
            let v = _mm256_min_ps(_mm256_max_ps(v, lo), hi);
            let v = _mm256_add_epi32(_mm256_cvtps_epi32(v), zp);
            let w = _mm_packs_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
            let b = _mm_packus_epi16(w, w);
            _mm_storel_epi64(q.as_mut_ptr().add(k) as *mut __m128i, b);
        }
        k += 8;
    }
    for (q, &x) in q[k..n].iter_mut().zip(&x[k..n]) {
        *q = quant.quantize(x);
    }
}

/// `M` rows x `V` vectors of 8 channels accumulated in `M·V` i32 registers: per group
/// of 4 input channels one broadcast of the row's 4 bytes, `vpmaddubsw` against the
/// panel (never saturating: activations are at most 127, weights within ±127) and
/// `vpmaddwd` against ones to sum the pairs; the epilogue runs on the registers (no FMA,
/// as the portable one) and stores with a mask where the panel is narrower than `8·V`.
///
/// # Safety
/// The CPU has AVX2; `t` satisfies `Tile`'s contract with `t.m == M` and
/// `8·(V-1) < t.width <= 8·V`.
#[target_feature(enable = "avx2")]
unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
    // SAFETY: the CPU has AVX2 (the contract). The reads and writes stay in the tile
    // (`Tile`'s contract, m == M, 8·(V-1) < width <= 8·V <= NR): `a` at rows i < M,
    // 4 bytes of group g < groups (4·groups <= lda); `b` at `groups` groups of 4·NR
    // bytes, 32·V <= 4·NR of each; `zcorr`, `scale`, `bias`, `alpha` at 8·V <= NR
    // values; `res` and `out` at rows i < M, 8·V channels of which the last vector's
    // lanes at and past `width` are masked off.
    unsafe {
        let ones = _mm256_set1_epi16(1);
        let mut acc = [start::<V>(t); M];
        let mut a = t.a;
        let mut b = t.b;
        for _ in 0..t.groups {
            let mut bv = [_mm256_setzero_si256(); V];
            for (v, bv) in bv.iter_mut().enumerate() {
                *bv = _mm256_loadu_si256(b.add(32 * v) as *const __m256i);
            }
            for (i, acc) in acc.iter_mut().enumerate() {
                let x = _mm256_set1_epi32((a.add(i * t.lda) as *const i32).read_unaligned());
                for (acc, &bv) in acc.iter_mut().zip(&bv) {
                    let p = _mm256_madd_epi16(_mm256_maddubs_epi16(x, bv), ones);
                    *acc = _mm256_add_epi32(*acc, p);
                }
            }
            a = a.add(KG);
            b = b.add(KG * NR);
        }
        store::<M, V>(t, &acc);
    }
}

/// Each accumulator's start: `-zcorr` of its 8 channels, so that the sums end at the
/// portable kernel's `sum - zcorr` (the same i32 values, wrapping alike).
///
/// # Safety
/// The CPU has AVX2; `t.zcorr` holds `8·V` values.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn start<const V: usize>(t: &Tile) -> [__m256i; V] {
    let mut start = [_mm256_setzero_si256(); V];
    for (v, s) in start.iter_mut().enumerate() {
        // SAFETY: 8·v + 8 <= 8·V values of `zcorr` (the contract).
        let z = unsafe { _mm256_loadu_si256(t.zcorr.add(8 * v) as *const __m256i) };
        *s = _mm256_sub_epi32(_mm256_setzero_si256(), z);
    }
    start
}

/// The epilogue of an `M` x `8·V` tile whose sums less `zcorr` are `acc`, shared by the
/// AVX2 and AVX-VNNI kernels: scale, bias, activation, residual, PRELU on the registers
/// (no FMA, as the portable one), stored with a mask where the panel is narrower than
/// `8·V`.
///
/// # Safety
/// The CPU has AVX2; `t` satisfies `Tile`'s contract with `t.m == M` and
/// `8·(V-1) < t.width <= 8·V`.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn store<const M: usize, const V: usize>(t: &Tile, acc: &[[__m256i; V]; M]) {
    // SAFETY: the CPU has AVX2 (the contract); `scale`, `bias`, `alpha` are read at
    // 8·V <= NR values, `res` and `out` at rows i < M, 8·V channels of which the last
    // vector's lanes at and past `width` are masked off (`Tile`'s contract).
    unsafe {
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
                let mut y = _mm256_add_ps(
                    _mm256_mul_ps(_mm256_cvtepi32_ps(acc), _mm256_loadu_ps(t.scale.add(8 * v))),
                    _mm256_loadu_ps(t.bias.add(8 * v)),
                );
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
                    y = _mm256_add_ps(
                        _mm256_max_ps(y, zero),
                        _mm256_mul_ps(al, _mm256_min_ps(y, zero)),
                    );
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
