//! The tile logic: one evaluation cut into blocks of rows and micro-tiles ([`Job`]), and
//! the micro-tile each kernel computes ([`Tile`], [`TileFn`]).

use tract_core::internal::*;

use super::{Kernel, NR, ROWS_TO_SPLIT, ROW_BLOCK_BYTES};

/// One micro-tile: `m` rows of the input against one weight panel, epilogue included.
///
/// Pointers are valid for: `a`: `m` rows of `lda` floats, of which the first `k <= lda` are
/// read; `b`: `k` rows of [`NR`] floats (one panel), followed, when `width > NR`, by the next
/// panel's `k` rows; `bias`, `alpha`: `NR · width.div_ceil(NR)` floats; `out`, `res`: `m`
/// rows of stride `ldo`, `width` floats each. `alpha`, `res` may be null (absent).
pub(super) struct Tile {
    pub(super) a: *const f32,
    pub(super) lda: usize,
    pub(super) k: usize,
    pub(super) b: *const f32,
    pub(super) out: *mut f32,
    pub(super) res: *const f32,
    pub(super) ldo: usize,
    pub(super) m: usize,
    pub(super) width: usize,
    pub(super) bias: *const f32,
    pub(super) alpha: *const f32,
    pub(super) act: (f32, f32),
    pub(super) residual_act: (f32, f32),
}

/// A micro-kernel for one tile (see [`Kernel::tile`]).
///
/// # Safety
/// Call it only with a [`Tile`] that satisfies `Tile`'s contract and the `m` and `width` it
/// was chosen for, on a CPU with the features of the kernel that gave it.
pub(super) type TileFn = unsafe fn(&Tile);

/// One evaluation, its slices checked against each other by [`Job::run`].
pub(super) struct Job<'a> {
    pub(super) x: &'a [f32],
    pub(super) rows: usize,
    pub(super) cin: usize,
    pub(super) cout: usize,
    pub(super) packed: &'a [f32],
    pub(super) bias: &'a [f32],
    pub(super) alpha: Option<&'a [f32]>,
    pub(super) residual: Option<&'a [f32]>,
    pub(super) act: (f32, f32),
    pub(super) residual_act: (f32, f32),
}

impl Job<'_> {
    /// Checks the slices against each other and against an output of `out_len` values.
    fn check(&self, out_len: usize) -> TractResult<()> {
        let panels = self.cout.div_ceil(NR);
        ensure!(
            self.x.len() == self.rows * self.cin
                && out_len == self.rows * self.cout
                && self.packed.len() == panels * self.cin * NR
                && self.bias.len() == panels * NR
                && self.alpha.is_none_or(|a| a.len() == panels * NR)
                && self.residual.is_none_or(|r| r.len() == out_len),
            "pointwise convolution: inconsistent buffer sizes"
        );
        Ok(())
    }

    /// The whole output, shared between the cores with `split` (see
    /// [`PointwiseConv::compute`]).
    pub(super) fn run(&self, out: &mut [f32], kernel: Kernel, split: bool) -> TractResult<()> {
        self.check(out.len())?;
        let (mr, step) = (kernel.rows(), kernel.panels());
        let panels = self.cout.div_ceil(NR);
        let work = self.x.len() * self.cout;
        let base = crate::split::Out(out.as_mut_ptr());
        let team = crate::split::team();
        if self.rows >= ROWS_TO_SPLIT {
            team.pieces(self.rows, mr, work, split, &|rows| {
                // SAFETY: `out` holds the output (checked) and is borrowed mutably here; the
                // pieces' rows do not overlap and are within `0..self.rows`. The CPU has the
                // kernel's features: a `Kernel` is only made by run-time detection.
                unsafe { self.run_part(base.ptr(), kernel, rows, 0..panels) };
                Ok(())
            })
        } else {
            team.pieces(panels, step, work, split, &|p| {
                // SAFETY: as above; the pieces' panels do not overlap and are within
                // `0..panels`.
                unsafe { self.run_part(base.ptr(), kernel, 0..self.rows, p) };
                Ok(())
            })
        }
    }

    /// Rows `rows` and weight panels `panels` (channels `NR·panels`) of the output at `out`.
    ///
    /// # Safety
    /// [`check`](Self::check) passed for an output of `self.rows·cout` values at `out` (valid
    /// for writes), `rows` and `panels` are within the output (`rows.end <= self.rows`,
    /// `panels.end <= cout.div_ceil(NR)`), nothing else reads or writes that part of it
    /// meanwhile. (The CPU has the features of `kernel`: a [`Kernel`] is only made by
    /// run-time detection.)
    unsafe fn run_part(
        &self,
        out: *mut f32,
        kernel: Kernel,
        rows: std::ops::Range<usize>,
        panels: std::ops::Range<usize>,
    ) {
        let (mr, step) = (kernel.rows(), kernel.panels());
        let block = (ROW_BLOCK_BYTES / (4 * self.cin)).max(mr) / mr * mr;
        let mut r0 = rows.start;
        while r0 < rows.end {
            let r1 = (r0 + block).min(rows.end);
            for p in panels.clone().step_by(step) {
                let c0 = p * NR;
                let width = (step.min(panels.end - p) * NR).min(self.cout - c0);
                let mut r = r0;
                while r < r1 {
                    // Rather than a last tile of at most half the height (which streams the
                    // whole panel for little work), two tiles of about equal height.
                    let left = r1 - r;
                    let m = if left > mr && left <= mr + mr / 2 {
                        left.div_ceil(2)
                    } else {
                        mr.min(left)
                    };
                    // The pointers below stay inside their buffers: r + m <= rows.end <=
                    // self.rows, p < panels.end <= cout.div_ceil(NR) and c0 + width <= cout,
                    // and `check` matched the lengths to rows, cin and cout.
                    let t = Tile {
                        // SAFETY: row r < self.rows of `x` (rows·cin values).
                        a: unsafe { self.x.as_ptr().add(r * self.cin) },
                        lda: self.cin,
                        k: self.cin,
                        // SAFETY: panel p of `packed` (panels·cin·NR values).
                        b: unsafe { self.packed.as_ptr().add(p * self.cin * NR) },
                        // SAFETY: row r, channel c0 < cout of the output (rows·cout values).
                        out: unsafe { out.add(r * self.cout + c0) },
                        // SAFETY: the same place in the residual (the output's length).
                        res: self.residual.map_or(std::ptr::null(), |v| unsafe {
                            v.as_ptr().add(r * self.cout + c0)
                        }),
                        ldo: self.cout,
                        m,
                        width,
                        // SAFETY: c0 < cout <= panels·NR biases.
                        bias: unsafe { self.bias.as_ptr().add(c0) },
                        alpha: self
                            .alpha
                            // SAFETY: c0 < cout <= panels·NR slopes.
                            .map_or(std::ptr::null(), |v| unsafe { v.as_ptr().add(c0) }),
                        act: self.act,
                        residual_act: self.residual_act,
                    };
                    // SAFETY: the tile satisfies `Tile`'s contract: its pointers are valid for
                    // `m` rows from r and `width` channels from c0 (two panels when width >
                    // NR: `step` is 2 only for AVX-512), bias and slopes padded to whole panels,
                    // and this function's caller gives it those rows and channels alone;
                    // 1 <= m <= mr and 1 <= width <= NR·step, as `Kernel::tile` asks; the CPU
                    // has the kernel's features (this function's contract).
                    unsafe { kernel.tile(m, width)(&t) };
                    r += m;
                }
            }
            r0 = r1;
        }
    }
}
