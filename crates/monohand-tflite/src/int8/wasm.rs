//! The WebAssembly relaxed-SIMD kernel, the VNNI kernels' scheme on 128-bit vectors:
//! `i32x4.relaxed_dot_i8x16_i7x16_add_s` sums each i32 lane's 4 products of a weight byte
//! and an activation code. Its result is implementation-defined only where a byte of its
//! second operand has its top bit set, and engines may saturate the pairs' i16 sums
//! (`pmaddubsw`); neither happens here: the codes are at most 127 (7 bits) and a pair's
//! sum is at most 2·128·127 = 32512. So the sums are exact, and the epilogue (without
//! fused multiply-adds, as the portable one) gives the portable kernel's bits.

use super::{ActivationQuant, Tile, TileFn, ACTIVATION_QMAX, KG, MR_RELAXED, NR};
use crate::isa::{wasm_load_lanes, wasm_store_lanes};
use core::arch::wasm32::*;

/// The tiles of 1 to [`MR_RELAXED`] rows for `V` vectors of 4 channels.
macro_rules! heights {
    ($v:literal) => {
        [micro::<1, $v>, micro::<2, $v>]
    };
}

/// By vectors (1-4), then height.
static TILES: [[TileFn; MR_RELAXED]; NR / 4] = [heights!(1), heights!(2), heights!(3), heights!(4)];

/// The monomorphised tile for `m` rows and `v` vectors of 4 channels.
pub(super) fn tile(m: usize, v: usize) -> TileFn {
    const _: () = assert!(NR == 16 && KG == 4);
    TILES[v.clamp(1, NR / 4) - 1][m.clamp(1, MR_RELAXED) - 1]
}

/// Four values from `p` (WebAssembly loads need no alignment).
///
/// # Safety
/// `p` is valid for reading 16 bytes.
#[inline(always)]
unsafe fn load<T>(p: *const T) -> v128 {
    // SAFETY: the caller's contract; `v128_load` has no alignment requirement.
    unsafe { v128_load(p as *const v128) }
}

/// Codes `x` into `q` as [`ActivationQuant::quantize`] does, 16 values at a time
/// (`f32x4.nearest` rounds to even; NaN becomes the lower bound, as in `quantize`, and
/// `pmax`/`pmin` clamp as `max_ps`/`min_ps` do; the conversion and narrowing are exact
/// for codes within `[0, 127]`), the last 0-15 one by one.
pub(super) fn quantize(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
    let n = x.len().min(q.len());
    let z = quant.zero_point as f32;
    let inv = f32x4_splat(quant.inv_scale);
    let lo = f32x4_splat(-z);
    let hi = f32x4_splat(ACTIVATION_QMAX as f32 - z);
    let zp = i32x4_splat(quant.zero_point as i32);
    let code = |v: v128| {
        let v = f32x4_nearest(f32x4_mul(v, inv));
        // NaN becomes `lo` explicitly: written as `pmax(lo, v)` alone (which is `lo`
        // for NaN by the specification) LLVM's optimiser made NaN 0 here.
        let v = v128_bitselect(v, lo, f32x4_eq(v, v));
        // pmax(lo, v) is `v > lo ? v : lo`, pmin(hi, v) `v < hi ? v : hi`: `max_ps`
        // and `min_ps`.
        let v = f32x4_pmin(hi, f32x4_pmax(lo, v));
        i32x4_add(i32x4_trunc_sat_f32x4(v), zp)
    };
    let mut k = 0;
    while k + 16 <= n {
        // SAFETY: k + 16 <= n values of `x` and of `q`.
        unsafe {
            let p = x.as_ptr().add(k);
            let a = i16x8_narrow_i32x4(code(load(p)), code(load(p.add(4))));
            let b = i16x8_narrow_i32x4(code(load(p.add(8))), code(load(p.add(12))));
            v128_store(q.as_mut_ptr().add(k) as *mut v128, u8x16_narrow_i16x8(a, b));
        }
        k += 16;
    }
    for (q, &x) in q[k..n].iter_mut().zip(&x[k..n]) {
        *q = quant.quantize(x);
    }
}

/// `M` rows x `V` vectors of 4 channels accumulated in `M·V` i32 registers, which start
/// at `-zcorr` (so that they end at the portable kernel's `sum - zcorr`, wrapping
/// alike): per group of 4 input channels one splat of each row's 4 code bytes and one
/// relaxed dot product per vector against the panel's 16 bytes (4 channels x 4 inputs);
/// the epilogue on the registers without fused multiply-adds, the last vector's residual
/// read and result written lane by lane where the tile is narrower than `4·V`.
///
/// # Safety
/// `t` satisfies `Tile`'s contract with `t.m == M` and `4·(V-1) < t.width <= 4·V`.
#[inline(never)]
unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
    // SAFETY: the reads and writes stay in the tile (`Tile`'s contract, m == M,
    // 4·(V-1) < width <= 4·V <= NR): `a` at rows i < M, 4 bytes of group g < groups
    // (4·groups <= lda); `b` at `groups` groups of 4·NR bytes, 16·V <= 4·NR of each;
    // `zcorr`, `scale`, `bias`, `alpha` at 4·V <= NR values (padded to whole panels);
    // `res` and `out` at rows i < M, whole vectors below `width` and the last vector's
    // lanes below `width` one by one.
    unsafe {
        let mut start = [i32x4_splat(0); V];
        for (v, s) in start.iter_mut().enumerate() {
            *s = i32x4_sub(i32x4_splat(0), load(t.zcorr.add(4 * v)));
        }
        let mut acc = [start; M];
        let mut a = t.a;
        let mut b = t.b;
        for _ in 0..t.groups {
            let mut x = [i32x4_splat(0); M];
            for (i, x) in x.iter_mut().enumerate() {
                *x = u32x4_splat((a.add(i * t.lda) as *const u32).read_unaligned());
            }
            for v in 0..V {
                let w = load(b.add(16 * v));
                for (acc, &x) in acc.iter_mut().zip(&x) {
                    acc[v] = i32x4_relaxed_dot_i8x16_i7x16_add(w, x, acc[v]);
                }
            }
            a = a.add(KG);
            b = b.add(KG * NR);
        }
        let lanes = t.width - 4 * (V - 1);
        let (lo, hi) = (f32x4_splat(t.act.0), f32x4_splat(t.act.1));
        let (rlo, rhi) = (f32x4_splat(t.residual_act.0), f32x4_splat(t.residual_act.1));
        let zero = f32x4_splat(0.0);
        // `max_ps(y, b)` and `min_ps(y, b)` of the portable epilogue.
        let max = |y: v128, b: v128| f32x4_pmax(b, y);
        let min = |y: v128, b: v128| f32x4_pmin(b, y);
        for (i, acc) in acc.iter().enumerate() {
            for (v, &acc) in acc.iter().enumerate() {
                let full = v + 1 < V || lanes == 4;
                let at = i * t.ldo + 4 * v;
                let mut y = f32x4_add(
                    f32x4_mul(f32x4_convert_i32x4(acc), load(t.scale.add(4 * v))),
                    load(t.bias.add(4 * v)),
                );
                y = min(max(y, lo), hi);
                if !t.res.is_null() {
                    let r = wasm_load_lanes(t.res.add(at), if full { 4 } else { lanes });
                    y = min(max(f32x4_add(y, r), rlo), rhi);
                }
                if !t.alpha.is_null() {
                    let al = load(t.alpha.add(4 * v));
                    y = f32x4_add(max(y, zero), f32x4_mul(al, min(y, zero)));
                }
                wasm_store_lanes(t.out.add(at), y, if full { 4 } else { lanes });
            }
        }
    }
}
