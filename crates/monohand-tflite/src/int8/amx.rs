//! The AMX kernel: `tdpbusd` multiplies a tile of 16 rows x 64 codes by one of 16 groups
//! of 4 weight bytes x 16 channels into 16 x 16 i32 sums, exactly: the VNNI panels' layout
//! (`[groups][16][4]`, rows of 64 bytes) is AMX's for the weights, and the coded rows (a
//! stride of `kp` bytes) are its for the activations. A micro-tile of 16 rows and one or
//! two panels sums the layer's depth 64 codes at a time (the last 4-60 in tiles
//! configured for them), stores the sums, and runs the AVX-512 VNNI kernel's epilogue on
//! them less `zcorr`: the same i32 values, the same bits. Shorter tiles (fewer than 16
//! rows) go to the AVX-512 VNNI kernel. The instructions are written with `asm!` (Rust
//! 1.95 has no stable AMX intrinsics); the tile shapes are loaded once per call of
//! `Job::tiles` ([`Tiles`]) and released after it.

use super::{avx512, Tile, TileFn, KG, MR_512, NR};
use std::arch::asm;
use std::arch::x86_64::*;

/// Rows of a tile.
pub(super) const ROWS: usize = 16;
/// Groups of 4 codes in a full tile's depth (64 bytes).
const GROUPS: usize = 16;

/// The tile shapes of a layer of `groups` groups of 4 input codes, loaded into this
/// thread's tile configuration (`ldtilecfg`); dropping it releases the tiles
/// (`tilerelease`). tmm0, tmm1: the sums of two panels (16 x 16 i32); tmm2: 16 rows x 64
/// codes; tmm3, tmm4: 16 groups of two panels' weights; tmm5-7: the same for the last
/// `groups % 16` groups, where there are any.
pub(super) struct Tiles(());

#[repr(C, align(64))]
struct Config([u8; 64]);

impl Tiles {
    /// # Safety
    /// The CPU has AMX-TILE and AMX-INT8 and this process may use them
    /// (`Cpu::amx_int8`).
    pub(super) unsafe fn load(groups: usize) -> Tiles {
        let rest = groups % GROUPS;
        let mut c = Config([0; 64]);
        // Palette 1; per tile t, its bytes per row at 16 + 2t (u16) and rows at 48 + t.
        c.0[0] = 1;
        let mut shape = |t: usize, rows: usize, bytes: usize| {
            c.0[16 + 2 * t..18 + 2 * t].copy_from_slice(&(bytes as u16).to_le_bytes());
            c.0[48 + t] = rows as u8;
        };
        for t in 0..5 {
            shape(t, ROWS, 64);
        }
        if rest > 0 {
            shape(5, ROWS, KG * rest);
            shape(6, rest, 64);
            shape(7, rest, 64);
        }
        // SAFETY: the CPU has AMX-TILE and the process may use it (the contract); `c`
        // is a valid palette-1 configuration (rows <= 16, bytes per row <= 64, the
        // unused tiles all zero), 64 bytes readable.
        unsafe { asm!("ldtilecfg [{0}]", in(reg) c.0.as_ptr(), options(nostack, readonly)) };
        Tiles(())
    }
}

impl Drop for Tiles {
    fn drop(&mut self) {
        // SAFETY: tiles were configured (`load`), so AMX-TILE is usable.
        unsafe { asm!("tilerelease", options(nostack, nomem)) };
    }
}

/// The tile function for `m` rows and `width` channels.
pub(super) fn tile(m: usize, width: usize) -> TileFn {
    let _ = m;
    if width > NR {
        tile16::<2>
    } else {
        tile16::<1>
    }
}

/// The rows of a tile of fewer than 16, with the AVX-512 VNNI kernel in tiles of at most 8
/// rows: a step of [`tile16`] written as a macro, as its depth steps are, so that the code
/// generated is that of one function.
macro_rules! short_tile {
    ($t:ident) => {
        let mut i = 0;
        while i < $t.m {
            let m = MR_512.min($t.m - i);
            let part = Tile {
                // SAFETY: row i < m of the tile's codes.
                a: unsafe { $t.a.add(i * $t.lda) },
                // SAFETY: row i < m of its output.
                out: unsafe { $t.out.add(i * $t.ldo) },
                res: if $t.res.is_null() {
                    $t.res
                } else {
                    // SAFETY: row i < m of its residual, which it has.
                    unsafe { $t.res.add(i * $t.ldo) }
                },
                m,
                ..*$t
            };
            // SAFETY: `part` is rows i..i + m of `t`, within its contract, m <= 8 as
            // the AVX-512 VNNI kernel's tiles need, the CPU has its features.
            unsafe { avx512::tile(m, $t.width)(&part) };
            i += m;
        }
    };
}

/// The AVX-512 VNNI kernel's epilogue on the 16 rows of sums that AMX stored, less `zcorr`:
/// a step of [`tile16`] written as a macro, as [`short_tile`].
macro_rules! sums_epilogue {
    ($t:ident, $sums:ident) => {
        let mut zcorr = [_mm512_setzero_si512(); P];
        for (p, z) in zcorr.iter_mut().enumerate() {
            *z = _mm512_loadu_si512($t.zcorr.add(16 * p) as *const __m512i);
        }
        let e = avx512::Epilogue::<P>::new($t);
        for i in 0..ROWS {
            let mut acc = [_mm512_setzero_si512(); P];
            for (p, acc) in acc.iter_mut().enumerate() {
                let v =
                    _mm512_load_si512($sums.0.as_ptr().add(i * 2 * NR + 16 * p) as *const __m512i);
                // The same i32 as the VNNI kernel's: it starts at -zcorr and adds the
                // same products (wrapping alike).
                *acc = _mm512_sub_epi32(v, zcorr[p]);
            }
            e.store_row($t, i, &acc);
        }
    };
}

/// A micro-tile of `t.m` rows and `P` panels: 16 rows with AMX, fewer with the AVX-512
/// VNNI kernel (in tiles of at most 8 rows).
///
/// # Safety
/// The CPU has AVX-512F, BW, VL and VNNI and AMX; this thread's tiles hold the shapes
/// `Tiles::load(t.groups)` sets; `t` satisfies `Tile`'s contract with `t.m <= 16` and
/// `16·(P-1) < t.width <= 16·P`.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512vnni")]
unsafe fn tile16<const P: usize>(t: &Tile) {
    if t.m < ROWS {
        short_tile!(t);
        return;
    }
    let (full, rest) = (t.groups / GROUPS, t.groups % GROUPS);
    // The weights of the second panel start a whole panel further (`groups` groups
    // of 4·NR bytes).
    let panel = t.groups * KG * NR;
    let mut sums = Sums([0; ROWS * 2 * NR]);
    // SAFETY: the tiles have the shapes of `Tiles::load(t.groups)` (the contract).
    // Reads: 16 rows of `a` at a stride of `lda`, 64 bytes at 64·j for j < full (within
    // 4·groups <= lda), 4·rest bytes after them; the panels' weights, 16 (or `rest`)
    // rows of 64 bytes from group 16·j, of panel 2 only where P == 2 (then width > NR:
    // it exists). Writes: `sums`, 16 rows of 128 bytes.
    unsafe {
        asm!("tilezero tmm0", "tilezero tmm1", options(nostack, nomem));
        // One step of the depth: codes tile `$ta` and weight tiles `$tb0` (and `$tb1`
        // for the second panel) loaded from `$a` and `$b`, multiplied into tmm0 (tmm1).
        macro_rules! step {
            ($ta:literal, $tb0:literal, $tb1:literal, $a:expr, $b:expr) => {
                asm!(
                    concat!("tileloadd tmm", $ta, ", [{a} + {lda}*1]"),
                    concat!("tileloadd tmm", $tb0, ", [{b} + {ldb}*1]"),
                    concat!("tdpbusd tmm0, tmm", $ta, ", tmm", $tb0),
                    a = in(reg) $a,
                    b = in(reg) $b,
                    lda = in(reg) t.lda,
                    ldb = in(reg) KG * NR,
                    options(nostack, readonly)
                );
                if P == 2 {
                    asm!(
                        concat!("tileloadd tmm", $tb1, ", [{b} + {ldb}*1]"),
                        concat!("tdpbusd tmm1, tmm", $ta, ", tmm", $tb1),
                        b = in(reg) $b.add(panel),
                        ldb = in(reg) KG * NR,
                        options(nostack, readonly)
                    );
                }
            };
        }
        for j in 0..full {
            step!(
                "2",
                "3",
                "4",
                t.a.add(64 * j),
                t.b.add(j * GROUPS * KG * NR)
            );
        }
        if rest > 0 {
            step!(
                "5",
                "6",
                "7",
                t.a.add(64 * full),
                t.b.add(full * GROUPS * KG * NR)
            );
        }
        let out = sums.0.as_mut_ptr();
        asm!(
            "tilestored [{o} + {ld}*1], tmm0",
            o = in(reg) out,
            ld = in(reg) 2 * NR * 4,
            options(nostack)
        );
        if P == 2 {
            asm!(
                "tilestored [{o} + {ld}*1], tmm1",
                o = in(reg) out.add(NR),
                ld = in(reg) 2 * NR * 4,
                options(nostack)
            );
        }
        sums_epilogue!(t, sums);
    }
}

/// The sums of a tile, 16 rows of two panels.
#[repr(C, align(64))]
struct Sums([i32; ROWS * 2 * NR]);
