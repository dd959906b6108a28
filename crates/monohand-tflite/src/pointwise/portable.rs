//! The portable f32 kernel.

use super::{Tile, MR, NR};

/// The epilogue on one value of channel `j` of the tile's row `i`.
///
/// # Safety
/// `t` satisfies `Tile`'s contract, `i < t.m` and `j < t.width` (it reads the bias and the
/// slope of channel `j` and the residual of row `i`, channel `j`).
#[inline(always)]
unsafe fn epilogue_scalar(t: &Tile, acc: f32, i: usize, j: usize) -> f32 {
    // SAFETY: i < m and j < width within `Tile`'s contract (this function's contract).
    unsafe {
        let mut y = (acc + *t.bias.add(j)).max(t.act.0).min(t.act.1);
        if !t.res.is_null() {
            y = (y + *t.res.add(i * t.ldo + j))
                .max(t.residual_act.0)
                .min(t.residual_act.1);
        }
        if !t.alpha.is_null() {
            y = y.max(0.0) + *t.alpha.add(j) * y.min(0.0);
        }
        y
    }
}

/// Portable tile: the compiler vectorises the 16-wide inner loop with whatever the target
/// has by default (SSE2 on x86-64).
///
/// # Safety
/// `t` satisfies `Tile`'s contract (no CPU feature is needed). (Only its first [`MR`]
/// rows and [`NR`] channels are computed: `t.m <= MR` and `t.width <= NR` for the whole
/// tile.)
pub(super) unsafe fn tile_portable(t: &Tile) {
    let mut acc = [[0f32; NR]; MR];
    for kk in 0..t.k {
        // SAFETY: kk < k rows of NR values in the panel (`Tile`'s contract); an array of f32
        // has f32's alignment.
        let b: &[f32; NR] = unsafe { &*(t.b.add(kk * NR) as *const [f32; NR]) };
        for (i, acc) in acc.iter_mut().enumerate().take(t.m) {
            // SAFETY: i < m rows (`take`), kk < k <= lda.
            let a = unsafe { *t.a.add(i * t.lda + kk) };
            for (acc, &b) in acc.iter_mut().zip(b) {
                *acc += a * b;
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
