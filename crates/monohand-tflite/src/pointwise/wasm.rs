//! The WebAssembly `simd128` f32 kernel: tiles of 2 rows x 16 channels in 8 registers of 4
//! lanes, multiplied then added in the portable kernel's order (no fused multiply-adds).

use super::{Tile, TileFn, MR128, NR};
use crate::isa::{wasm_load_lanes, wasm_store_lanes};
use core::arch::wasm32::*;

/// The tiles of 1 to [`MR128`] rows for `V` vectors of 4 channels.
macro_rules! heights {
    ($v:literal) => {
        [micro::<1, $v>, micro::<2, $v>]
    };
}

/// By vectors (1-4), then height.
static TILES: [[TileFn; MR128]; NR / 4] = [heights!(1), heights!(2), heights!(3), heights!(4)];

/// The monomorphised tile for `m` rows and `v` vectors of 4 channels.
pub(super) fn tile(m: usize, v: usize) -> TileFn {
    TILES[v.clamp(1, NR / 4) - 1][m.clamp(1, MR128) - 1]
}

/// Four floats from `p` (WebAssembly loads need no alignment).
///
/// # Safety
/// `p` is valid for reading 4 floats.
#[inline(always)]
unsafe fn load(p: *const f32) -> v128 {
    // SAFETY: the caller's contract; `v128_load` has no alignment requirement.
    unsafe { v128_load(p as *const v128) }
}

/// `M` rows x `V` vectors of 4 channels accumulated in `M·V` registers, one weight
/// vector loaded at a time; the epilogue runs on the registers. Where the tile is
/// narrower than `4·V` channels, the last vector's residual is read and its result
/// written lane by lane. In a module built with `simd128` alone the sums are those of
/// the portable kernel (a product, then a sum, in the same order), so its results are
/// the same bits; with `relaxed-simd` each product and sum is one
/// [`wasm_madd`](crate::isa::wasm_madd), fused where the engine's CPU has FMA, as the
/// native AVX2 and AVX-512 kernels are.
///
/// # Safety
/// `t` satisfies `Tile`'s contract with `t.m == M` and `4·(V-1) < t.width <= 4·V`.
#[inline(never)]
unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
    // SAFETY: the reads and writes stay in the tile (`Tile`'s contract, m == M,
    // 4·(V-1) < width <= 4·V <= NR): `a` at rows i < M, columns < k <= lda; `b` at k
    // rows of the panel, 4·V <= NR values each; `bias` and `alpha` at 4·V <= NR values
    // (padded to whole panels); `res` and `out` at rows i < M, whole vectors below
    // `width` and the last vector's lanes below `width` one by one.
    unsafe {
        let mut acc = [[f32x4_splat(0.0); V]; M];
        let mut a = t.a;
        let mut b = t.b;
        for _ in 0..t.k {
            let mut x = [f32x4_splat(0.0); M];
            for (i, x) in x.iter_mut().enumerate() {
                *x = f32x4_splat(*a.add(i * t.lda));
            }
            for v in 0..V {
                let bv = load(b.add(4 * v));
                for (acc, &x) in acc.iter_mut().zip(&x) {
                    acc[v] = crate::isa::wasm_madd(x, bv, acc[v]);
                }
            }
            a = a.add(1);
            b = b.add(NR);
        }
        let lanes = t.width - 4 * (V - 1);
        let (lo, hi) = (f32x4_splat(t.act.0), f32x4_splat(t.act.1));
        let (rlo, rhi) = (f32x4_splat(t.residual_act.0), f32x4_splat(t.residual_act.1));
        let zero = f32x4_splat(0.0);
        for (i, acc) in acc.iter().enumerate() {
            for (v, &acc) in acc.iter().enumerate() {
                let full = v + 1 < V || lanes == 4;
                let at = i * t.ldo + 4 * v;
                let mut y = f32x4_add(acc, load(t.bias.add(4 * v)));
                y = f32x4_min(f32x4_max(y, lo), hi);
                if !t.res.is_null() {
                    let r = wasm_load_lanes(t.res.add(at), if full { 4 } else { lanes });
                    y = f32x4_min(f32x4_max(f32x4_add(y, r), rlo), rhi);
                }
                if !t.alpha.is_null() {
                    let al = load(t.alpha.add(4 * v));
                    y = f32x4_add(f32x4_max(y, zero), f32x4_mul(al, f32x4_min(y, zero)));
                }
                wasm_store_lanes(t.out.add(at), y, if full { 4 } else { lanes });
            }
        }
    }
}
