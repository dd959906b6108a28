//! The AVX-512 VNNI int8 kernel: `vpdpbusd` on `zmm`, tiles of 8 rows x 2 panels, its
//! quantizer and the epilogue the AMX kernel shares.

use super::{ActivationQuant, Tile, TileFn, ACTIVATION_QMAX, KG, MR_512, NR};
use crate::isa::lanes;
use std::arch::x86_64::*;

/// The tiles of 1 to 8 rows for `P` panels.
macro_rules! heights {
    ($p:literal) => {
        [
            micro::<1, $p>,
            micro::<2, $p>,
            micro::<3, $p>,
            micro::<4, $p>,
            micro::<5, $p>,
            micro::<6, $p>,
            micro::<7, $p>,
            micro::<8, $p>,
        ]
    };
}

/// By panels (1-16, 17-32 channels), then height.
static TILES: [[TileFn; MR_512]; 2] = [heights!(1), heights!(2)];

/// The monomorphised tile for `m` rows and `width` channels (`1 <= width <= 32`).
pub(super) fn tile(m: usize, width: usize) -> TileFn {
    const _: () = assert!(NR == 16 && KG == 4);
    TILES[(width.clamp(1, 2 * NR) - 1) / NR][m.clamp(1, MR_512) - 1]
}

/// Codes `x` into `q` as [`ActivationQuant::quantize`] does, 16 values at a time, the
/// last ones under a mask (`vrndscaleps` to nearest even, the same clamp as the AVX2
/// quantizer, an exact conversion, `vpmovdb`: the codes are within `[0, 127]`).
///
/// # Safety
/// The CPU has AVX-512F, BW and VL; `x.len() == q.len()`.
#[target_feature(enable = "avx512f,avx512bw,avx512vl")]
pub(super) unsafe fn quantize(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
    let n = x.len().min(q.len());
    let z = quant.zero_point as f32;
    let inv = _mm512_set1_ps(quant.inv_scale);
    let lo = _mm512_set1_ps(-z);
    let hi = _mm512_set1_ps(ACTIVATION_QMAX as f32 - z);
    let zp = _mm512_set1_epi32(quant.zero_point as i32);
    let mut k = 0;
    while k < n {
        let mask = lanes(n - k);
        // SAFETY: the CPU has AVX-512F, BW and VL (the contract); the lanes at and past
        // n - k are masked off, so the load reads and the store writes values
        // k..min(k + 16, n) of `x` and of `q` alone (masked-off lanes do not fault).
        unsafe {
            let v = _mm512_mul_ps(_mm512_maskz_loadu_ps(mask, x.as_ptr().add(k)), inv);
            let v = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v);
            // `vmaxps` returns its second operand for NaN: NaN becomes `lo`, as in
            // `quantize`.
            let v = _mm512_min_ps(_mm512_max_ps(v, lo), hi);
            let v = _mm512_add_epi32(_mm512_cvtps_epi32(v), zp);
            let b = _mm512_cvtepi32_epi8(v);
            _mm_mask_storeu_epi8(q.as_mut_ptr().add(k) as *mut i8, mask, b);
        }
        k += 16;
    }
}

/// `M` rows x `P` panels of 16 channels accumulated in `M·P` `zmm` registers of i32,
/// which start at `-zcorr` (so that they end at the portable kernel's `sum - zcorr`: the
/// same i32 sums, wrapping alike): per group of 4 input channels one load of each
/// panel's 64 bytes, one broadcast of each row's 4 bytes and one `vpdpbusd` (the 4
/// products u8 x i8 added to each i32 lane, exactly) per row and panel. The epilogue
/// runs on the registers without FMA (as the portable one) and the last panel loads the
/// residual and stores under a mask where the tile is narrower than it.
///
/// # Safety
/// The CPU has AVX-512F, BW, VL and VNNI; `t` satisfies `Tile`'s contract with
/// `t.m == M`, `P` in 1..=2 and `16·(P-1) < t.width <= 16·P`.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512vnni")]
unsafe fn micro<const M: usize, const P: usize>(t: &Tile) {
    // SAFETY: the CPU has AVX-512F, BW, VL and VNNI (the contract). The reads and writes
    // stay in the tile (`Tile`'s contract, m == M, 16·(P-1) < width <= 16·P): `a` at
    // rows i < M, 4 bytes of group g < groups (4·groups <= lda); `b` at `groups` groups
    // of 4·NR bytes of the first panel, and of the second where P == 2 (then
    // width > NR: two panels); `zcorr`, `scale`, `bias`, `alpha` at 16·P values, within
    // NR·width.div_ceil(NR); `res` and `out` at rows i < M, 16·P channels of which the
    // last panel's lanes at and past `width` are masked off.
    unsafe {
        let mut start = [_mm512_setzero_si512(); P];
        for (p, s) in start.iter_mut().enumerate() {
            let z = _mm512_loadu_si512(t.zcorr.add(16 * p) as *const __m512i);
            *s = _mm512_sub_epi32(_mm512_setzero_si512(), z);
        }
        let mut acc = [start; M];
        let mut a = t.a;
        let mut b = t.b;
        // The second panel's groups start a whole panel further.
        let panel = t.groups * KG * NR;
        for _ in 0..t.groups {
            let mut bv = [_mm512_setzero_si512(); P];
            for (p, bv) in bv.iter_mut().enumerate() {
                *bv = _mm512_loadu_si512(b.add(p * panel) as *const __m512i);
            }
            for (i, acc) in acc.iter_mut().enumerate() {
                let x = _mm512_set1_epi32((a.add(i * t.lda) as *const i32).read_unaligned());
                for (acc, &bv) in acc.iter_mut().zip(&bv) {
                    *acc = _mm512_dpbusd_epi32(*acc, x, bv);
                }
            }
            a = a.add(KG);
            b = b.add(KG * NR);
        }
        let e = Epilogue::<P>::new(t);
        for (i, acc) in acc.iter().enumerate() {
            // `acc` is already the sum less `zcorr`; row i < M of the tile.
            e.store_row(t, i, acc);
        }
    }
}

/// The epilogue's per-tile constants for `P` panels: the channels' scales, biases and
/// PRELU slopes, the clamps, the last panel's mask; loaded once per tile (the output's
/// stores would otherwise have them loaded again for every row).
pub(super) struct Epilogue<const P: usize> {
    scale: [__m512; P],
    bias: [__m512; P],
    alpha: [__m512; P],
    lo: __m512,
    hi: __m512,
    rlo: __m512,
    rhi: __m512,
    last: u16,
}

impl<const P: usize> Epilogue<P> {
    /// # Safety
    /// The caller has AVX-512F, BW and VL (it is inlined into such a function); `t`
    /// satisfies `Tile`'s contract with `P` in 1..=2 and `16·(P-1) < t.width <= 16·P`.
    #[inline(always)]
    pub(super) unsafe fn new(t: &Tile) -> Self {
        // SAFETY: the caller's features and `Tile`'s contract: `scale`, `bias` and
        // `alpha` (where not null) hold 16·P values, within NR·width.div_ceil(NR).
        unsafe {
            let mut e = Epilogue {
                scale: [_mm512_setzero_ps(); P],
                bias: [_mm512_setzero_ps(); P],
                alpha: [_mm512_setzero_ps(); P],
                lo: _mm512_set1_ps(t.act.0),
                hi: _mm512_set1_ps(t.act.1),
                rlo: _mm512_set1_ps(t.residual_act.0),
                rhi: _mm512_set1_ps(t.residual_act.1),
                last: lanes(t.width - 16 * (P - 1)),
            };
            for p in 0..P {
                e.scale[p] = _mm512_loadu_ps(t.scale.add(16 * p));
                e.bias[p] = _mm512_loadu_ps(t.bias.add(16 * p));
                if !t.alpha.is_null() {
                    e.alpha[p] = _mm512_loadu_ps(t.alpha.add(16 * p));
                }
            }
            e
        }
    }

    /// The epilogue of row `i` of the tile from its i32 sums less `zcorr` (`acc`),
    /// stored to the output: without FMA, as the portable one; the last panel loads the
    /// residual and stores under a mask where the tile is narrower than it.
    ///
    /// # Safety
    /// As [`new`](Self::new), with the same `t`, and `i < t.m`.
    #[inline(always)]
    pub(super) unsafe fn store_row(&self, t: &Tile, i: usize, acc: &[__m512i; P]) {
        // SAFETY: the caller's features and `Tile`'s contract: `res` and `out` at row
        // i < m, 16·P channels of which the last panel's lanes at and past `width` are
        // masked off.
        unsafe {
            let zero = _mm512_setzero_ps();
            for (p, &acc) in acc.iter().enumerate() {
                let mask = if p + 1 == P { self.last } else { 0xffff };
                let at = i * t.ldo + 16 * p;
                let mut y = _mm512_add_ps(
                    _mm512_mul_ps(_mm512_cvtepi32_ps(acc), self.scale[p]),
                    self.bias[p],
                );
                y = _mm512_min_ps(_mm512_max_ps(y, self.lo), self.hi);
                if !t.res.is_null() {
                    let r = _mm512_maskz_loadu_ps(mask, t.res.add(at));
                    y = _mm512_min_ps(_mm512_max_ps(_mm512_add_ps(y, r), self.rlo), self.rhi);
                }
                if !t.alpha.is_null() {
                    y = _mm512_add_ps(
                        _mm512_max_ps(y, zero),
                        _mm512_mul_ps(self.alpha[p], _mm512_min_ps(y, zero)),
                    );
                }
                _mm512_mask_storeu_ps(t.out.add(at), mask, y);
            }
        }
    }
}
