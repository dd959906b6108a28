//! The tile logic: one evaluation's rows coded a block at a time and cut into micro-tiles
//! ([`Job`]), each computed by the kernel's [`TileFn`](super::tile::TileFn).

use super::tile::Tile;
use super::{quantize_rows, Int8Kernel, PointwiseConvInt8, KG, NR, ROW_BLOCK_BYTES};

/// One evaluation, its slices checked by [`PointwiseConvInt8::compute_with`].
pub(super) struct Job<'a> {
    pub(super) op: &'a PointwiseConvInt8,
    pub(super) x: &'a [f32],
    pub(super) residual: Option<&'a [f32]>,
    pub(super) out: crate::split::Out,
    pub(super) kernel: Int8Kernel,
}

impl Job<'_> {
    /// Rows `rows` and panels `panels` of the output: the rows coded one block at a time
    /// into `scratch`, then the tiles.
    ///
    /// # Safety
    /// The slices passed `compute_with`'s checks, the output (at `self.out`) is valid for
    /// writes, `rows` and `panels` are within it, and nothing else reads or writes that part
    /// of it meanwhile.
    pub(super) unsafe fn run_rows(
        &self,
        rows: std::ops::Range<usize>,
        panels: std::ops::Range<usize>,
        scratch: &mut Vec<u8>,
    ) {
        let (cin, kp, mr) = (self.op.cin, self.op.kp, self.kernel.rows());
        let block = (ROW_BLOCK_BYTES / kp).max(mr) / mr * mr;
        let need = block.min(rows.len()) * kp;
        if scratch.len() < need {
            scratch.resize(need, 0);
        }
        let mut r0 = rows.start;
        while r0 < rows.end {
            let r1 = (r0 + block).min(rows.end);
            let q = &mut scratch[..(r1 - r0) * kp];
            quantize_rows(
                &self.x[r0 * cin..r1 * cin],
                cin,
                kp,
                self.op.input,
                q,
                self.kernel,
            );
            // SAFETY: `q` codes rows r0..r1, within `rows` (this function's contract).
            unsafe { self.tiles(q, r0..r1, panels.clone()) };
            r0 = r1;
        }
    }

    /// The tiles of rows `rows` (coded in `q`, whose first row is row `rows.start`) and
    /// panels `panels`.
    ///
    /// # Safety
    /// As [`run_rows`](Self::run_rows), and `q` holds `rows.len()` rows of `kp` codes.
    pub(super) unsafe fn tiles(
        &self,
        q: &[u8],
        rows: std::ops::Range<usize>,
        panels: std::ops::Range<usize>,
    ) {
        let op = self.op;
        let e = &*op.epilogue;
        let act = op.activation.bounds();
        let residual_act = op.residual.unwrap_or_default().bounds();
        let (mr, step) = (self.kernel.rows(), self.kernel.panels());
        // AMX's tile shapes for this layer's depth, released when the tiles are done.
        #[cfg(target_arch = "x86_64")]
        let _tiles = self.kernel.prepare(op.kp / KG);
        for p in panels.clone().step_by(step) {
            let c0 = p * NR;
            let width = (step.min(panels.end - p) * NR).min(op.cout - c0);
            let mut r = rows.start;
            while r < rows.end {
                // Rather than a last tile of at most half the height, two of about equal
                // height (as `PointwiseConv`).
                let left = rows.end - r;
                let m = if left > mr && left <= mr + mr / 2 {
                    left.div_ceil(2)
                } else {
                    mr.min(left)
                };
                // The pointers below stay inside their buffers: rows.start <= r, r + m <=
                // rows.end <= the output's rows (`q` holds rows.start..rows.end of kp
                // bytes), p < panels.end <= the panels and c0 + width <= cout, and the
                // lengths were checked.
                let t = Tile {
                    // SAFETY: row r - rows.start < rows.len() of `q`.
                    a: unsafe { q.as_ptr().add((r - rows.start) * op.kp) },
                    lda: op.kp,
                    groups: op.kp / KG,
                    // SAFETY: panel p of `packed` (panels·kp·NR bytes).
                    b: unsafe { op.packed.as_ptr().add(p * op.kp * NR) },
                    // SAFETY: row r, channel c0 < cout of the output (rows·cout values).
                    out: unsafe { self.out.ptr().add(r * op.cout + c0) },
                    // SAFETY: the same place in the residual (the output's length).
                    res: self.residual.map_or(std::ptr::null(), |v| unsafe {
                        v.as_ptr().add(r * op.cout + c0)
                    }),
                    ldo: op.cout,
                    m,
                    width,
                    // SAFETY: c0 < cout <= panels·NR values in each (padded).
                    zcorr: unsafe { e.zcorr.as_ptr().add(c0) },
                    // SAFETY: as above.
                    scale: unsafe { e.scale.as_ptr().add(c0) },
                    // SAFETY: as above.
                    bias: unsafe { e.bias.as_ptr().add(c0) },
                    alpha: e
                        .alpha
                        .as_ref()
                        // SAFETY: as above.
                        .map_or(std::ptr::null(), |v| unsafe { v.as_ptr().add(c0) }),
                    act,
                    residual_act,
                };
                // SAFETY: `t` satisfies `Tile`'s contract (the pointers above, valid for `m`
                // rows from r and `width` channels from c0 — two panels only where width >
                // NR, i.e. `step` is 2 and panel p + 1 < panels.end exists — with the
                // epilogue's values padded to whole panels, a part of the output nothing
                // else touches: this function's contract), 1 <= m <= mr and
                // 1 <= width <= NR·step as `Int8Kernel::tile` asks, and the CPU has the
                // kernel's features (an `Int8Kernel` is only made by run-time detection).
                unsafe { self.kernel.tile(m, width)(&t) };
                r += m;
            }
        }
    }
}
