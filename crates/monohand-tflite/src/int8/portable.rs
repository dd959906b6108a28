//! The portable int8 kernel, the reference the others give the bits of.

use super::quant::{max_ps, min_ps};
use super::{Tile, KG, MR, NR};

/// The epilogue on the sum `acc` of channel `j` of the tile's row `i`.
///
/// # Safety
/// `t` satisfies `Tile`'s contract, `i < t.m` and `j < t.width`.
#[inline(always)]
unsafe fn epilogue_scalar(t: &Tile, acc: i32, i: usize, j: usize) -> f32 {
    // SAFETY: i < m and j < width within `Tile`'s contract (this function's contract).
    unsafe {
        let v = (acc.wrapping_sub(*t.zcorr.add(j))) as f32 * *t.scale.add(j) + *t.bias.add(j);
        let mut y = min_ps(max_ps(v, t.act.0), t.act.1);
        if !t.res.is_null() {
            y = min_ps(
                max_ps(y + *t.res.add(i * t.ldo + j), t.residual_act.0),
                t.residual_act.1,
            );
        }
        if !t.alpha.is_null() {
            y = max_ps(y, 0.0) + *t.alpha.add(j) * min_ps(y, 0.0);
        }
        y
    }
}

/// Portable tile, the reference: exact i32 sums of the products.
///
/// # Safety
/// `t` satisfies `Tile`'s contract (no CPU feature is needed; `t.m <= MR`,
/// `t.width <= NR`).
pub(super) unsafe fn tile_portable(t: &Tile) {
    let mut acc = [[0i32; NR]; MR];
    for g in 0..t.groups {
        // SAFETY: group g < groups of 4·NR bytes in the panel (`Tile`'s contract); an array
        // of i8 has i8's alignment.
        let b: &[i8; KG * NR] = unsafe { &*(t.b.add(g * KG * NR) as *const [i8; KG * NR]) };
        for (i, acc) in acc.iter_mut().enumerate().take(t.m) {
            // SAFETY: i < m rows (`take`), 4·g + 4 <= 4·groups <= lda bytes of the row.
            let a: &[u8; KG] = unsafe { &*(t.a.add(i * t.lda + KG * g) as *const [u8; KG]) };
            for (acc, w) in acc.iter_mut().zip(b.chunks_exact(KG)) {
                for (&a, &w) in a.iter().zip(w) {
                    *acc += a as i32 * w as i32;
                }
            }
        }
    }
    for (i, acc) in acc.iter().enumerate().take(t.m) {
        for (j, &acc) in acc.iter().enumerate().take(t.width) {
            // SAFETY: `t` satisfies `Tile`'s contract (ours), i < m and j < width (`take`).
            let y = unsafe { epilogue_scalar(t, acc, i, j) };
            // SAFETY: i < m rows and j < width channels of the output (`take`).
            unsafe { *t.out.add(i * t.ldo + j) = y };
        }
    }
}
