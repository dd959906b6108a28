//! The micro-tile each int8 kernel computes ([`Tile`], [`TileFn`]): below the kernels and
//! the evaluation that cuts its rows into tiles (`job.rs`).

/// One micro-tile: `m` quantized rows against one weight panel (two side by side where
/// `width > NR`), epilogue included.
///
/// Pointers are valid for: `a`: `m` rows of `lda` bytes, of which the first `4·groups <=
/// lda` are read; `b`: `groups` groups of `4·NR` bytes (one panel), followed, when
/// `width > NR`, by the next panel's `groups` groups; `zcorr`, `scale`, `bias`, `alpha`:
/// `NR · width.div_ceil(NR)` values; `out`, `res`: `m` rows of stride `ldo`, `width` floats
/// each. `alpha`, `res` may be null (absent).
pub(super) struct Tile {
    pub(super) a: *const u8,
    pub(super) lda: usize,
    pub(super) groups: usize,
    pub(super) b: *const i8,
    pub(super) out: *mut f32,
    pub(super) res: *const f32,
    pub(super) ldo: usize,
    pub(super) m: usize,
    pub(super) width: usize,
    pub(super) zcorr: *const i32,
    pub(super) scale: *const f32,
    pub(super) bias: *const f32,
    pub(super) alpha: *const f32,
    pub(super) act: (f32, f32),
    pub(super) residual_act: (f32, f32),
}

/// A micro-kernel for one tile (see [`Int8Kernel::tile`](super::Int8Kernel::tile)).
///
/// # Safety
/// Call it only with a [`Tile`] that satisfies `Tile`'s contract and the `m` and `width` it
/// was chosen for, on a CPU with the features of the kernel that gave it.
pub(super) type TileFn = unsafe fn(&Tile);
