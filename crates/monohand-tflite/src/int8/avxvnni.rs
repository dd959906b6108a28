//! The AVX-VNNI int8 kernel: the AVX2 kernel with the VEX-coded 256-bit `vpdpbusd`, tiles of
//! 6 rows x 16 channels; the AVX2 kernel's quantizer and epilogue.

use super::{Tile, TileFn, KG, MR_AVX_VNNI, NR};
use std::arch::x86_64::*;

/// The tiles of 1 to 6 rows for `V` vectors of 8 channels.
macro_rules! heights {
    ($v:literal) => {
        [
            micro::<1, $v>,
            micro::<2, $v>,
            micro::<3, $v>,
            micro::<4, $v>,
            micro::<5, $v>,
            micro::<6, $v>,
        ]
    };
}

/// By vectors (1-8, 9-16 channels), then height.
static TILES: [[TileFn; MR_AVX_VNNI]; 2] = [heights!(1), heights!(2)];

/// The monomorphised tile for `m` rows and `width` channels (`1 <= width <= 16`).
pub(super) fn tile(m: usize, width: usize) -> TileFn {
    const _: () = assert!(NR == 16 && KG == 4);
    TILES[(width.clamp(1, NR) - 1) / 8][m.clamp(1, MR_AVX_VNNI) - 1]
}

/// `M` rows x `V` vectors of 8 channels accumulated in `M·V` i32 registers, which start
/// at `-zcorr` (so that they end at the portable kernel's `sum - zcorr`: the same i32
/// sums, wrapping alike): per group of 4 input channels one broadcast of the row's 4
/// bytes and one `vpdpbusd` (the 4 products u8 x i8 added to each i32 lane, exactly, no
/// intermediate i16) per vector; the epilogue as the AVX2 kernel's (no FMA).
///
/// # Safety
/// The CPU has AVX2 and AVX-VNNI; `t` satisfies `Tile`'s contract with `t.m == M` and
/// `8·(V-1) < t.width <= 8·V`.
#[target_feature(enable = "avx2,avxvnni")]
unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
    // SAFETY: the CPU has AVX2 and AVX-VNNI (the contract). The reads and writes stay in
    // the tile (`Tile`'s contract, m == M, 8·(V-1) < width <= 8·V <= NR): `a` at rows
    // i < M, 4 bytes of group g < groups (4·groups <= lda); `b` at `groups` groups of
    // 4·NR bytes, 32·V <= 4·NR of each; `zcorr`, `scale`, `bias`, `alpha` at 8·V <= NR
    // values; `res` and `out` at rows i < M, 8·V channels of which the last vector's
    // lanes at and past `width` are masked off.
    unsafe {
        let mut acc = [super::avx2::start::<V>(t); M];
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
                    *acc = _mm256_dpbusd_avx_epi32(*acc, x, bv);
                }
            }
            a = a.add(KG);
            b = b.add(KG * NR);
        }
        super::avx2::store::<M, V>(t, &acc);
    }
}
