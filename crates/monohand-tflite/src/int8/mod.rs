//! An int8 pointwise (1x1, stride 1) convolution with f32 input and output, the first step of
//! issue 46 (int8 inference). It is a drop-in for [`PointwiseConv`](crate::PointwiseConv)
//! between f32 layers, with the same fused epilogue:
//!
//! * **weights**: symmetric int8 per output channel, quantized once at load
//!   (`scale_o = max|w_o| / 127`, `q = round(w / scale_o)` in `[-127, 127]`), packed in
//!   panels of 16 output channels, four input channels at a time (`[Cin/4][NR][4]` bytes
//!   per panel, zero padded): the layout of both `vpmaddubsw` and `vpdpbusd` (VNNI);
//! * **activations**: per tensor, asymmetric, **7-bit unsigned** (`q = clamp(round(x / s) + z,
//!   0, 127)`, [`ActivationQuant`]), quantized on the fly, one block of input rows at a time,
//!   into a buffer of the thread's own (allocated once, reused). 7 bits rather than 8 because AVX2's `vpmaddubsw`
//!   (u8 x i8, adjacent pairs summed into a *saturating* i16) can then never saturate:
//!   `2 · 127 · 127 = 32258 <= 32767`. So the AVX2 kernel's integer sums are exact and equal,
//!   bit for bit, to the portable kernel's; with 8-bit activations (`2 · 255 · 127 = 64770`)
//!   they would saturate on some inputs, and a kernel that differs from the reference on
//!   some inputs is hard to test and to trust. (The other exact route on AVX2 widens both
//!   operands to i16 and uses `vpmaddwd` alone: 8-bit activations, but twice the weight
//!   bytes and register traffic for the same multiply-port throughput. Whether the 8th bit
//!   matters for accuracy is for the calibration step to show; VNNI's `vpdpbusd`
//!   accumulates in i32 and would take 8-bit activations exactly, but the codes stay 7-bit
//!   so that every kernel gives the same bits.) Asymmetric because most
//!   1x1 inputs in these networks follow a RELU6 or a PRELU, i.e. are mostly one-sided: a
//!   symmetric code would waste most of its levels;
//! * **accumulation** in i32 of the raw `x_q · w_q` products (exact: at most
//!   `Cin · 127 · 127`, far below 2³¹ for `Cin <= 100 000`); the zero point is taken out
//!   in the epilogue with a per-channel `z · Σ_k w_q` precomputed at load;
//! * **epilogue** in f32: `y = (acc - z·Σw_q) · (s_x · s_w,o) + b_o`, then the
//!   convolution's activation, the optional residual `ADD` with its activation, the optional
//!   PRELU — as [`PointwiseConv`](crate::PointwiseConv)'s, without fused multiply-adds so
//!   that the portable and SIMD kernels round alike.
//!
//! Kernels, chosen at run time (the CPU's features and `MONOHAND_KERNEL` come from
//! [`crate::isa`], as for the f32 kernels), fastest first:
//!
//! * **AMX** (`amx`: AVX-512 VNNI and AMX-INT8, where Linux grants this process the tile
//!   state): `tdpbusd` multiplies 16 coded rows x 64 codes by 16 groups of a panel's
//!   weights (the VNNI panels are AMX's weight layout) into 16 x 16 i32 sums; tiles of 16
//!   rows x 2 panels, the depth 64 codes at a time and the last 4-60 in tiles shaped for
//!   them, then the AVX-512 VNNI kernel's epilogue on the stored sums; shorter tiles go to
//!   the AVX-512 VNNI kernel. Written with `asm!`: Rust 1.95 has no stable AMX intrinsics;
//! * **AVX-512 VNNI** (`avx512vnni`: AVX-512F + BW + VL + VNNI): `vpdpbusd` on `zmm`, one
//!   panel of 16 channels per register, the four u8 x i8 products of a group added straight
//!   into the i32 lanes (no i16 step); tiles of 8 rows x 2 panels (16 accumulators, two
//!   weight vectors, the broadcast), masked stores for a narrower last panel, and a
//!   16-lane quantizer with masked tails;
//! * **AVX-VNNI** (`avxvnni`: AVX2 + the VEX-coded 256-bit `vpdpbusd` of Alder Lake and
//!   later, Zen 5): the AVX2 kernel with `vpdpbusd` in place of `vpmaddubsw` + `vpmaddwd`,
//!   which frees the ones and the product registers: tiles of 6 rows x 16 channels in 12
//!   `ymm` accumulators; the AVX2 quantizer;
//! * **AVX2** (`avx2`): `vpmaddubsw` + `vpmaddwd` against ones + `vpaddd`, tiles of 4 rows x
//!   16 channels in 8 `ymm` accumulators;
//! * **portable**, the reference.
//!
//! **Coded inputs**: where the input is the result of a depthwise convolution that nothing
//! else reads, [`quantize_pointwise`] has that convolution write the codes itself
//! ([`NhwcDepthwiseCodes`](crate::NhwcDepthwiseCodes): a few f32 rows at a time into a
//! buffer in L1, coded there with the same quantizer) and the 1x1 convolution read them
//! ([`PointwiseConvInt8::with_coded_input`]): the same codes, so the same bits, without the
//! f32 tensor's write and read (a quarter of the bytes cross the caches).
//!
//! Every kernel gives the portable one's bits: the sums are exact in all of them, and the
//! epilogues round alike. (The VNNI kernels start their accumulators at `-z·Σw_q`, which
//! leaves the same i32 as subtracting it at the end.) `MONOHAND_KERNEL` caps the level
//! (`portable`, `avx2`, `avxvnni`, `avx512` — the AVX-VNNI kernel where the CPU has it —
//! `avx512vnni`, `amx`); a module built for WebAssembly with `relaxed-simd` runs that kernel. A large product is shared between
//! the cores as [`PointwiseConv`](crate::PointwiseConv)'s is, with the same bits.

use std::cell::RefCell;

use tract_core::internal::*;

use crate::pointwise_common::{eval_1x1, Activation, NR};

/// The largest activation code (7-bit unsigned activations; see the module documentation).
pub const ACTIVATION_QMAX: u8 = 127;
/// The largest weight magnitude (weights in `[-127, 127]`).
pub const WEIGHT_QMAX: i8 = 127;
/// Input channels per group: one 32-bit broadcast of four activation bytes.
const KG: usize = 4;
/// Rows from which a product shared between the cores is cut by rows (fewer: by
/// channels), as in `PointwiseConv`.
const ROWS_TO_SPLIT: usize = 256;
/// Rows (pixels) per micro-tile of the portable and AVX2 kernels (AVX2: `2·MR`
/// accumulators, two weight vectors, the broadcast, the ones and a product in the 16 `ymm`
/// registers).
const MR: usize = 4;
/// Rows per micro-tile of the AVX-VNNI kernel: `vpdpbusd` needs neither the ones nor a
/// product register, so `2·6` accumulators, two weight vectors and the broadcast fill 15 of
/// the 16 `ymm` registers.
#[cfg(target_arch = "x86_64")]
const MR_AVX_VNNI: usize = 6;
/// Rows per micro-tile of the AVX-512 VNNI kernel, whose tiles are two panels wide:
/// `2·MR_512` accumulators, two weight vectors and the broadcast of the 32 `zmm` registers.
#[cfg(target_arch = "x86_64")]
const MR_512: usize = 8;
/// Rows per micro-tile of the WebAssembly relaxed-SIMD kernel: `4·MR_RELAXED` accumulators
/// of 4 lanes for a whole panel, the weight vector, the broadcasts and what the engine's
/// lowering of the dot product needs (on x86-64 without VNNI: a product and the ones) within
/// the 16 vector registers of an x86-64 engine (as the f32 `simd128` kernel's 2 rows).
#[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
const MR_RELAXED: usize = 2;
/// Quantized input bytes of one block of rows, kept in L2 while every panel passes over it.
const ROW_BLOCK_BYTES: usize = 64 * 1024;
/// The most input channels (so that the i32 sums cannot overflow: `Cin · 127 · 127 < 2³¹`).
const MAX_CIN: usize = 100_000;

mod coding;
mod job;
mod portable;
mod quant;
mod tile;

use coding::quantize_rows;
pub(crate) use coding::{quantize_run, quantize_values};
use job::Job;
use portable::tile_portable;
pub use quant::{quantize_weights, ActivationQuant, MinMax};
use tile::{Tile, TileFn};

/// The per-channel constants of the epilogue, padded to whole panels.
#[derive(Debug, Clone)]
struct Epilogue {
    /// `zero_point · Σ_k w_q[o][k]`.
    zcorr: Vec<i32>,
    /// `s_x · s_w[o]`.
    scale: Vec<f32>,
    bias: Vec<f32>,
    alpha: Option<Vec<f32>>,
}

impl PartialEq for Epilogue {
    fn eq(&self, other: &Self) -> bool {
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        self.zcorr == other.zcorr
            && bits(&self.scale) == bits(&other.scale)
            && bits(&self.bias) == bits(&other.bias)
            && self.alpha.as_deref().map(bits) == other.alpha.as_deref().map(bits)
    }
}

/// 1x1 stride-1 convolution of f32 NHWC tensors in int8 arithmetic (see the module
/// documentation): the input is coded in 7 bits with a fixed [`ActivationQuant`], the
/// weights in int8 per output channel; the result is f32, with the fused epilogue of
/// [`PointwiseConv`](crate::PointwiseConv):
///
/// `y = act(x·W + b)`, then if a residual input `r` is wired `y = act_r(y + r)`, then if PRELU
/// slopes `α` are set `y = max(y, 0) + α · min(y, 0)`.
///
/// Input 0 is the activation tensor; input 1, present only when built
/// [`with_residual`](Self::with_residual), has the output's shape.
#[derive(Debug, Clone, PartialEq)]
pub struct PointwiseConvInt8 {
    cin: usize,
    /// `cin` rounded up to a multiple of the group of 4.
    kp: usize,
    cout: usize,
    input: ActivationQuant,
    /// `[Cout.div_ceil(NR), kp / 4, NR, 4]`, zero padded.
    packed: Arc<Vec<i8>>,
    /// `max|w_o| / 127` per output channel (unpadded).
    weight_scales: Arc<Vec<f32>>,
    epilogue: Arc<Epilogue>,
    activation: Activation,
    residual: Option<Activation>,
    /// Input 0 is already coded: a `u8` tensor of `input`'s codes, rows of `cin == kp`
    /// bytes ([`with_coded_input`](Self::with_coded_input)).
    coded_input: bool,
    /// Share large outputs between the cores ([`crate::split`]).
    split: bool,
}

impl Eq for PointwiseConvInt8 {}

/// `values` (length `n`) zero padded to a whole number of panels.
fn padded<T: Copy + Default>(values: &[T], n: usize) -> Vec<T> {
    let mut v = vec![T::default(); n.div_ceil(NR) * NR];
    v[..n].copy_from_slice(&values[..n]);
    v
}

/// The f32 values of a tensor.
fn floats(t: &Tensor) -> TractResult<Vec<f32>> {
    let t = t.cast_to::<f32>()?;
    let t = t.try_as_plain_ram()?;
    Ok(t.as_slice::<f32>()?.to_vec())
}

impl PointwiseConvInt8 {
    /// Quantizes and packs `weights` (`[Cout, Cin]`, or TFLite's OHWI `[Cout, 1, 1, Cin]`),
    /// with `bias` (`[Cout]`), the convolution's own `activation`, and the code `input` of
    /// its input tensor.
    pub fn new(
        weights: &Tensor,
        bias: &Tensor,
        activation: Activation,
        input: ActivationQuant,
    ) -> TractResult<Self> {
        let s = weights.shape();
        ensure!(
            (s.len() == 2 || (s.len() == 4 && s[1] == 1 && s[2] == 1)) && s[0] > 0,
            "pointwise weights must be [Cout, Cin] or [Cout, 1, 1, Cin], got {s:?}"
        );
        let (cout, cin) = (s[0], s[s.len() - 1]);
        ensure!(
            cin > 0 && cin <= MAX_CIN,
            "pointwise convolution over {cin} input channels (1 to {MAX_CIN})"
        );
        let w = floats(weights)?;
        let b = floats(bias)?;
        ensure!(b.len() == cout, "{} biases for {cout} channels", b.len());
        let kp = cin.div_ceil(KG) * KG;
        let panels = cout.div_ceil(NR);
        let mut packed = vec![0i8; panels * kp * NR];
        let mut scales = Vec::with_capacity(cout);
        let mut zcorr = Vec::with_capacity(cout);
        for (o, row) in w.chunks_exact(cin).enumerate() {
            let (q, scale) = quantize_weights(row);
            let (p, j) = (o / NR, o % NR);
            for (k, &v) in q.iter().enumerate() {
                packed[((p * kp / KG + k / KG) * NR + j) * KG + k % KG] = v;
            }
            let sum: i32 = q.iter().map(|&v| v as i32).sum();
            zcorr.push(input.zero_point as i32 * sum);
            scales.push(scale);
        }
        let combined: Vec<f32> = scales.iter().map(|s| input.scale * s).collect();
        Ok(PointwiseConvInt8 {
            cin,
            kp,
            cout,
            input,
            packed: Arc::new(packed),
            weight_scales: Arc::new(scales),
            epilogue: Arc::new(Epilogue {
                zcorr: padded(&zcorr, cout),
                scale: padded(&combined, cout),
                bias: padded(&b, cout),
                alpha: None,
            }),
            activation,
            residual: None,
            coded_input: false,
            split: true,
        })
    }

    /// Whether large products are shared between the cores when the network runs alone
    /// (default: true, as [`PointwiseConv`](crate::PointwiseConv)). The results are the
    /// same bits.
    pub fn with_split(mut self, split: bool) -> Self {
        self.split = split;
        self
    }

    /// Adds a second input of the output's shape after the activation, then applies
    /// `activation` to the sum (a following residual `ADD` with its fused activation).
    pub fn with_residual(mut self, activation: Activation) -> Self {
        self.residual = Some(activation);
        self
    }

    /// Ends the epilogue with a PRELU of per-channel slopes `alpha` (`[Cout]`).
    pub fn with_prelu(mut self, alpha: &Tensor) -> TractResult<Self> {
        let a = floats(alpha)?;
        ensure!(
            a.len() == self.cout,
            "{} PRELU slopes for {} channels",
            a.len(),
            self.cout
        );
        let mut e = (*self.epilogue).clone();
        e.alpha = Some(padded(&a, self.cout));
        self.epilogue = Arc::new(e);
        Ok(self)
    }

    /// The coding of its f32 input if it could read the codes instead
    /// ([`with_coded_input`](Self::with_coded_input)): its input is not coded yet and `cin`
    /// is a whole number of groups of 4 (for [`crate::code_depthwise_results`]).
    pub(crate) fn codable_input(&self) -> Option<ActivationQuant> {
        (!self.coded_input && self.cin == self.kp).then_some(self.input)
    }

    /// Takes input 0 already coded: a `u8` tensor of [`input_quant`](Self::input_quant)'s
    /// codes (as [`NhwcDepthwiseCodes`](crate::NhwcDepthwiseCodes) writes them), instead of
    /// f32 values to code. The result is the same bits as coding the f32 values here. Only
    /// where the input channels are a multiple of 4 (the rows of codes are then the
    /// kernels' rows, without padding): an error otherwise.
    pub fn with_coded_input(mut self) -> TractResult<Self> {
        ensure!(
            self.cin == self.kp,
            "a coded input needs a multiple of {KG} channels, not {}",
            self.cin
        );
        self.coded_input = true;
        Ok(self)
    }

    /// Whether input 0 is already coded (see [`with_coded_input`](Self::with_coded_input)).
    pub fn has_coded_input(&self) -> bool {
        self.coded_input
    }

    /// Input channels.
    pub fn input_channels(&self) -> usize {
        self.cin
    }

    /// Output channels.
    pub fn output_channels(&self) -> usize {
        self.cout
    }

    /// The code of the input tensor.
    pub fn input_quant(&self) -> ActivationQuant {
        self.input
    }

    /// The weights' scale per output channel (`max|w_o| / 127`).
    pub fn weight_scales(&self) -> &[f32] {
        &self.weight_scales
    }

    /// Whether a residual input is added (see [`with_residual`](Self::with_residual)).
    pub fn has_residual(&self) -> bool {
        self.residual.is_some()
    }

    /// Whether the epilogue ends with a PRELU (see [`with_prelu`](Self::with_prelu)).
    pub fn has_prelu(&self) -> bool {
        self.epilogue.alpha.is_some()
    }

    /// The name of the int8 kernel this process runs (`portable`, `avx2`, `avxvnni` or
    /// `avx512vnni`).
    pub fn kernel_name() -> &'static str {
        Int8Kernel::best().name()
    }

    /// The product of `x` (rows of `Cin` f32) into `out` (rows of `Cout` f32), with
    /// `residual` (the output's shape) where the operator has one, on the calling thread
    /// with the best kernel. The quantized rows go to a buffer of the thread's own
    /// (at most about 64 KiB, or the whole coded input of a layer of fewer than 256 rows),
    /// allocated on its first call and reused after that.
    pub fn compute(&self, x: &[f32], residual: Option<&[f32]>, out: &mut [f32]) -> TractResult<()> {
        self.compute_with(Input::Values(x), residual, out, Int8Kernel::best(), false)
    }

    /// [`compute`](Self::compute) from rows of codes already made with
    /// [`input_quant`](Self::input_quant) (`Cin` bytes each; `Cin` a multiple of 4).
    pub fn compute_coded(
        &self,
        codes: &[u8],
        residual: Option<&[f32]>,
        out: &mut [f32],
    ) -> TractResult<()> {
        ensure!(
            self.cin == self.kp,
            "coded rows need a multiple of {KG} channels"
        );
        self.compute_with(
            Input::Codes(codes),
            residual,
            out,
            Int8Kernel::best(),
            false,
        )
    }

    /// [`compute`](Self::compute) with a given kernel; with `split`, a large product is
    /// shared between the cores ([`crate::split`]) as [`PointwiseConv`](crate::PointwiseConv)
    /// shares it: by rows where there are many (each piece coding its own rows), else by
    /// channels (the input coded once, then shared). Every value is computed as in one
    /// piece: the same bits.
    pub(crate) fn compute_with<'x>(
        &self,
        x: impl Into<Input<'x>>,
        residual: Option<&[f32]>,
        out: &mut [f32],
        kernel: Int8Kernel,
        split: bool,
    ) -> TractResult<()> {
        let x = x.into();
        let rows = x.len() / self.cin;
        let panels = self.cout.div_ceil(NR);
        let e = &*self.epilogue;
        ensure!(
            x.len() == rows * self.cin
                && (matches!(x, Input::Values(_)) || self.cin == self.kp)
                && out.len() == rows * self.cout
                && self.packed.len() == panels * self.kp * NR
                && e.zcorr.len() == panels * NR
                && e.scale.len() == panels * NR
                && e.bias.len() == panels * NR
                && e.alpha.as_ref().is_none_or(|a| a.len() == panels * NR)
                && residual.is_none_or(|r| r.len() == out.len())
                && residual.is_some() == self.residual.is_some(),
            "int8 pointwise convolution: inconsistent buffer sizes"
        );
        // The f32 rows that `run_rows` codes (none when they come coded).
        let values = match x {
            Input::Values(v) => v,
            Input::Codes(_) => &[],
        };
        let job = Job {
            op: self,
            x: values,
            residual,
            out: crate::split::Out(out.as_mut_ptr()),
            kernel,
        };
        let team = crate::split::team();
        let work = rows * self.cin * self.cout;
        if let Input::Codes(q) = x {
            // Rows of `kp` codes (`cin == kp`, checked), ready for the tiles: by rows or by
            // channels as below, without coding.
            return if rows >= ROWS_TO_SPLIT {
                // Blocks of rows as `run_rows` codes them, so that every panel passes over
                // a block while it is in cache.
                let mr = kernel.rows();
                let block = (ROW_BLOCK_BYTES / self.kp).max(mr) / mr * mr;
                team.pieces(rows, mr, work, split, &|r| {
                    for r0 in r.clone().step_by(block) {
                        let r1 = (r0 + block).min(r.end);
                        let q = &q[r0 * self.kp..r1 * self.kp];
                        // SAFETY: the lengths were checked and `out` is borrowed mutably
                        // here; the pieces' rows do not overlap and are within `0..rows`,
                        // r0..r1 is within the piece's, and `q` holds those rows' codes.
                        unsafe { job.tiles(q, r0..r1, 0..panels) };
                    }
                    Ok(())
                })
            } else {
                team.pieces(panels, kernel.panels(), work, split, &|p| {
                    // SAFETY: as above; `q` codes all the rows, and the pieces' panels do not
                    // overlap and are within `0..panels`.
                    unsafe { job.tiles(q, 0..rows, p) };
                    Ok(())
                })
            };
        }
        if rows >= ROWS_TO_SPLIT {
            team.pieces(rows, kernel.rows(), work, split, &|r| {
                with_scratch(|s| {
                    // SAFETY: the lengths were checked and `out` is borrowed mutably here;
                    // the pieces' rows do not overlap and are within `0..rows`.
                    unsafe { job.run_rows(r, 0..panels, s) }
                });
                Ok(())
            })
        } else {
            with_scratch(|s| {
                let n = rows * self.kp;
                if s.len() < n {
                    s.resize(n, 0);
                }
                let q = &mut s[..n];
                quantize_rows(values, self.cin, self.kp, self.input, q, kernel);
                let q = &*q;
                team.pieces(panels, kernel.panels(), work, split, &|p| {
                    // SAFETY: as above; `q` codes all the rows, and the pieces' panels do not
                    // overlap and are within `0..panels`.
                    unsafe { job.tiles(q, 0..rows, p) };
                    Ok(())
                })
            })
        }
    }
}

/// The input of one evaluation: f32 values to code, or rows of codes made already.
#[derive(Clone, Copy)]
pub(crate) enum Input<'a> {
    /// Rows of `cin` f32 values.
    Values(&'a [f32]),
    /// Rows of `cin == kp` codes.
    Codes(&'a [u8]),
}

impl<'a> From<&'a [f32]> for Input<'a> {
    fn from(v: &'a [f32]) -> Self {
        Input::Values(v)
    }
}

impl<'a> From<&'a Vec<f32>> for Input<'a> {
    fn from(v: &'a Vec<f32>) -> Self {
        Input::Values(v)
    }
}

impl<'a> From<&'a [u8]> for Input<'a> {
    fn from(q: &'a [u8]) -> Self {
        Input::Codes(q)
    }
}

impl Input<'_> {
    /// The number of values (or codes).
    fn len(&self) -> usize {
        match self {
            Input::Values(v) => v.len(),
            Input::Codes(q) => q.len(),
        }
    }
}

/// Calls `f` with this thread's buffer for quantized rows (a new one if it is in use).
fn with_scratch<R>(f: impl FnOnce(&mut Vec<u8>) -> R) -> R {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        // Re-entered on this thread (not expected): a buffer of its own.
        Err(_) => f(&mut Vec::new()),
    })
}

pub(crate) use kernel::{Int8Kernel, Isa};

mod kernel;

impl Int8Kernel {
    /// Rows per micro-tile.
    fn rows(self) -> usize {
        match self.isa() {
            #[cfg(target_arch = "x86_64")]
            Isa::AvxVnni => MR_AVX_VNNI,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512Vnni => MR_512,
            #[cfg(target_arch = "x86_64")]
            Isa::Amx => amx::ROWS,
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            Isa::RelaxedSimd => MR_RELAXED,
            _ => MR,
        }
    }

    /// Weight panels per micro-tile.
    fn panels(self) -> usize {
        match self.isa() {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512Vnni | Isa::Amx => 2,
            _ => 1,
        }
    }

    /// Sets up what the kernel needs on this thread for a layer of `groups` groups of 4
    /// input codes, until the value is dropped: AMX's tile shapes (`amx::Tiles`); nothing
    /// for the other kernels.
    #[cfg(target_arch = "x86_64")]
    fn prepare(self, groups: usize) -> Option<amx::Tiles> {
        (self.isa() == Isa::Amx).then(|| {
            // SAFETY: an `Int8Kernel` of `Isa::Amx` is only made where AMX is usable.
            unsafe { amx::Tiles::load(groups) }
        })
    }

    /// The tile function for `m` rows and `width` channels (`1 <= m <= self.rows()`,
    /// `1 <= width <= NR · self.panels()`).
    fn tile(self, m: usize, width: usize) -> TileFn {
        #[cfg(not(any(
            target_arch = "x86_64",
            all(target_arch = "wasm32", target_feature = "relaxed-simd")
        )))]
        let _ = (m, width);
        match self.isa() {
            Isa::Portable => tile_portable,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => avx2::tile(m, width.div_ceil(8)),
            #[cfg(target_arch = "x86_64")]
            Isa::AvxVnni => avxvnni::tile(m, width),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512Vnni => avx512::tile(m, width),
            #[cfg(target_arch = "x86_64")]
            Isa::Amx => amx::tile(m, width),
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            Isa::RelaxedSimd => wasm::tile(m, width.div_ceil(4)),
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod amx;
#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
mod avxvnni;
#[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
mod wasm;

thread_local! {
    /// Each thread's buffer for the quantized rows of [`PointwiseConvInt8`]'s evaluations
    /// (allocated once per thread, reused).
    static SCRATCH: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
}

impl Op for PointwiseConvInt8 {
    fn name(&self) -> StaticName {
        "MonohandPointwiseConvInt8".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        Ok(vec![format!(
            "{}->{} act {:?} residual {:?} prelu {} input scale {} zero {}{}",
            self.cin,
            self.cout,
            self.activation,
            self.residual,
            self.has_prelu(),
            self.input.scale,
            self.input.zero_point,
            if self.coded_input { " (coded)" } else { "" }
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for PointwiseConvInt8 {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let what = "int8 pointwise convolution";
        let has_residual = self.residual.is_some();
        if self.coded_input {
            eval_1x1::<u8>(
                &inputs,
                self.cin,
                self.cout,
                has_residual,
                what,
                |x, r, o| self.compute_with(x, r, o, Int8Kernel::best(), self.split),
            )
        } else {
            eval_1x1::<f32>(
                &inputs,
                self.cin,
                self.cout,
                has_residual,
                what,
                |x, r, o| self.compute_with(x, r, o, Int8Kernel::best(), self.split),
            )
        }
    }
}

impl TypedOp for PointwiseConvInt8 {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let want = if self.coded_input {
            u8::datum_type()
        } else {
            f32::datum_type()
        };
        ensure!(
            inputs[0].datum_type == want,
            "int8 pointwise convolution over {want:?}, input is {:?}",
            inputs[0].datum_type
        );
        let mut shape = inputs[0].shape.to_tvec();
        let last = shape
            .last_mut()
            .context("pointwise convolution on a scalar")?;
        ensure!(
            last.to_usize().ok() == Some(self.cin),
            "pointwise convolution over {} channels, input has {last}",
            self.cin
        );
        *last = self.cout.to_dim();
        if let Some(r) = inputs.get(1) {
            ensure!(
                r.shape.to_tvec() == shape,
                "residual {:?} for an output {shape:?}",
                r.shape
            );
        }
        Ok(tvec!(f32::fact(shape)))
    }
}
#[cfg(test)]
mod speed;
#[cfg(test)]
mod tests;
