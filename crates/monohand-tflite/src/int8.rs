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

use crate::pointwise::{Activation, NR};

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

/// `a` if it is greater than `b`, else `b` (x86's `maxps` rule: `b` where either is NaN or
/// both are zeros), so that the portable and SIMD kernels give the same bits.
#[inline(always)]
fn max_ps(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `a` if it is less than `b`, else `b` (x86's `minps` rule).
#[inline(always)]
fn min_ps(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// How an f32 activation tensor is coded in 7 bits: `x ≈ scale · (q - zero_point)` with
/// `q` in `[0, 127]` ([`ACTIVATION_QMAX`]).
#[derive(Debug, Clone, Copy)]
pub struct ActivationQuant {
    scale: f32,
    /// `1 / scale`, the factor the quantizer multiplies by.
    inv_scale: f32,
    zero_point: u8,
}

impl PartialEq for ActivationQuant {
    fn eq(&self, other: &Self) -> bool {
        self.scale.to_bits() == other.scale.to_bits() && self.zero_point == other.zero_point
    }
}

impl Eq for ActivationQuant {}

impl ActivationQuant {
    /// A code of step `scale` (finite, > 0) with `zero_point` (at most 127) coding 0.0.
    pub fn new(scale: f32, zero_point: u8) -> TractResult<Self> {
        ensure!(
            scale.is_finite() && scale > 0.0 && (1.0 / scale).is_finite(),
            "activation scale {scale} is not a finite positive number"
        );
        ensure!(
            zero_point <= ACTIVATION_QMAX,
            "activation zero point {zero_point} above {ACTIVATION_QMAX}"
        );
        Ok(ActivationQuant {
            scale,
            inv_scale: 1.0 / scale,
            zero_point,
        })
    }

    /// The code spanning observed values from `min` to `max` (widened to include 0.0, which
    /// is then coded exactly, as zero padding and RELU outputs need): the step is
    /// `(max - min) / 127` and the zero point the code nearest to 0.0. Non-finite or empty
    /// ranges give the step 1.
    pub fn from_min_max(min: f32, max: f32) -> Self {
        let (lo, hi) = (min.min(0.0), max.max(0.0));
        let mut scale = (hi - lo) / ACTIVATION_QMAX as f32;
        if !(scale.is_finite() && scale > 0.0 && (1.0 / scale).is_finite()) {
            scale = 1.0;
        }
        let zero = (-lo / scale)
            .round_ties_even()
            .clamp(0.0, ACTIVATION_QMAX as f32) as u8;
        ActivationQuant {
            scale,
            inv_scale: 1.0 / scale,
            zero_point: zero,
        }
    }

    /// The step between codes.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The code of 0.0.
    pub fn zero_point(&self) -> u8 {
        self.zero_point
    }

    /// The code of `x`: `round(x / scale) + zero_point` (ties to even, the division a
    /// multiplication by `1 / scale`), clamped to `[0, 127]`; NaN gives 0.
    #[inline(always)]
    pub fn quantize(&self, x: f32) -> u8 {
        let z = self.zero_point as f32;
        let t = (x * self.inv_scale).round_ties_even();
        let t = min_ps(max_ps(t, -z), ACTIVATION_QMAX as f32 - z);
        (t as i32 + self.zero_point as i32) as u8
    }

    /// The value code `q` stands for.
    pub fn dequantize(&self, q: u8) -> f32 {
        self.scale * (q as f32 - self.zero_point as f32)
    }
}

/// The smallest and largest finite values seen in a tensor over some runs: what
/// [`ActivationQuant::from_min_max`] is computed from (the calibration of a later step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinMax {
    /// The smallest finite value seen (`+inf` before any).
    pub min: f32,
    /// The largest finite value seen (`-inf` before any).
    pub max: f32,
}

impl Default for MinMax {
    fn default() -> Self {
        MinMax {
            min: f32::INFINITY,
            max: f32::NEG_INFINITY,
        }
    }
}

impl MinMax {
    /// Widens the range to the finite values of `values`.
    pub fn observe(&mut self, values: &[f32]) {
        for &v in values.iter().filter(|v| v.is_finite()) {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
        }
    }

    /// The code for the range seen so far (see [`ActivationQuant::from_min_max`]).
    pub fn quant(&self) -> ActivationQuant {
        ActivationQuant::from_min_max(self.min, self.max)
    }
}

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

/// Symmetric int8 codes of one output channel's weights and their scale `max|w| / 127`
/// (1 for an all-zero channel).
pub fn quantize_weights(w: &[f32]) -> (Vec<i8>, f32) {
    let max = w
        .iter()
        .filter(|v| v.is_finite())
        .fold(0f32, |m, v| m.max(v.abs()));
    let scale = if max > 0.0 && (max / WEIGHT_QMAX as f32) > 0.0 {
        max / WEIGHT_QMAX as f32
    } else {
        1.0
    };
    let q = w
        .iter()
        .map(|&v| {
            (v / scale)
                .round_ties_even()
                .clamp(-(WEIGHT_QMAX as f32), WEIGHT_QMAX as f32) as i8
        })
        .collect();
    (q, scale)
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

/// Codes `x` into `q` (of the same length) with `quant` and the quantizer of the best int8
/// kernel: the codes a [`PointwiseConvInt8`] with this input code makes of these values.
pub(crate) fn quantize_values(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
    let n = x.len().min(q.len());
    quantize_run(&x[..n], &mut q[..n], quant, Int8Kernel::best());
}

/// Calls `f` with this thread's buffer for quantized rows (a new one if it is in use).
fn with_scratch<R>(f: impl FnOnce(&mut Vec<u8>) -> R) -> R {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        // Re-entered on this thread (not expected): a buffer of its own.
        Err(_) => f(&mut Vec::new()),
    })
}

/// One evaluation, its slices checked by [`PointwiseConvInt8::compute_with`].
struct Job<'a> {
    op: &'a PointwiseConvInt8,
    x: &'a [f32],
    residual: Option<&'a [f32]>,
    out: crate::split::Out,
    kernel: Int8Kernel,
}

impl Job<'_> {
    /// Rows `rows` and panels `panels` of the output: the rows coded one block at a time
    /// into `scratch`, then the tiles.
    ///
    /// # Safety
    /// The slices passed `compute_with`'s checks, the output (at `self.out`) is valid for
    /// writes, `rows` and `panels` are within it, and nothing else reads or writes that part
    /// of it meanwhile.
    unsafe fn run_rows(
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
    unsafe fn tiles(&self, q: &[u8], rows: std::ops::Range<usize>, panels: std::ops::Range<usize>) {
        let op = self.op;
        let e = &*op.epilogue;
        let act = op.activation.bounds();
        let residual_act = op.residual.unwrap_or_default().bounds();
        let (mr, step) = (self.kernel.rows(), self.kernel.panels());
        // AMX's tile shapes for this layer's depth, released when the tiles are done.
        #[cfg(target_arch = "x86_64")]
        let _tiles = (self.kernel.isa() == Isa::Amx).then(|| {
            // SAFETY: an `Int8Kernel` of `Isa::Amx` is only made where AMX is usable.
            unsafe { amx::Tiles::load(op.kp / KG) }
        });
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

/// Codes `x` (rows of `cin` f32) into `q` (rows of `kp` bytes, the `kp - cin` last ones 0).
fn quantize_rows(
    x: &[f32],
    cin: usize,
    kp: usize,
    quant: ActivationQuant,
    q: &mut [u8],
    kernel: Int8Kernel,
) {
    if cin == kp {
        // No padding: the rows are one run of values in both.
        let n = x.len().min(q.len());
        quantize_run(&x[..n], &mut q[..n], quant, kernel);
        return;
    }
    for (x, q) in x.chunks_exact(cin).zip(q.chunks_exact_mut(kp)) {
        let (q, pad) = q.split_at_mut(cin);
        quantize_run(x, q, quant, kernel);
        pad.fill(0);
    }
}

/// Codes `x` into `q` (of the same length) with `kernel`'s quantizer.
pub(crate) fn quantize_run(x: &[f32], q: &mut [u8], quant: ActivationQuant, kernel: Int8Kernel) {
    match kernel.isa() {
        Isa::Portable => {
            for (q, &x) in q.iter_mut().zip(x) {
                *q = quant.quantize(x);
            }
        }
        // SAFETY: the CPU has AVX2 (an `Int8Kernel` of these ISAs is only made by run-time
        // detection, and AVX-VNNI's is made only where AVX2 is detected too); `x` and `q`
        // have the same length.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 | Isa::AvxVnni => unsafe { avx2::quantize(x, q, quant) },
        // SAFETY: the CPU has AVX-512F, BW and VL (as above); `x` and `q` have the same
        // length.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512Vnni | Isa::Amx => unsafe { avx512vnni::quantize(x, q, quant) },
        #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
        Isa::RelaxedSimd => relaxed::quantize(x, q, quant),
    }
}

pub(crate) use kernel::{Int8Kernel, Isa};

/// The kernel type, in a module of its own so that nothing else can make one.
mod kernel {
    #[cfg(target_arch = "x86_64")]
    use crate::isa::Cpu;
    use crate::isa::Level;

    /// The instruction set of an int8 micro-kernel.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(crate) enum Isa {
        /// Plain Rust, any CPU: the reference.
        Portable,
        /// `std::arch` AVX2 intrinsics (`vpmaddubsw`, `vpmaddwd`).
        #[cfg(target_arch = "x86_64")]
        Avx2,
        /// AVX2 with AVX-VNNI's VEX-coded 256-bit `vpdpbusd`.
        #[cfg(target_arch = "x86_64")]
        AvxVnni,
        /// AVX-512F + BW + VL with AVX-512 VNNI's 512-bit `vpdpbusd`.
        #[cfg(target_arch = "x86_64")]
        Avx512Vnni,
        /// AMX's `tdpbusd` on tiles of 16 rows, with the AVX-512 VNNI kernel's epilogue
        /// and for the rows left over.
        #[cfg(target_arch = "x86_64")]
        Amx,
        /// WebAssembly's relaxed SIMD, `i32x4.relaxed_dot_i8x16_i7x16_add_s`, in a module
        /// built with `relaxed-simd` (an engine either runs such a module or refuses to
        /// load it: nothing to detect at run time).
        #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
        RelaxedSimd,
    }

    /// An int8 micro-kernel that this CPU runs. Its field is private: one is made only by
    /// run-time detection ([`Int8Kernel::supported`], [`Int8Kernel::best`], from
    /// [`Cpu`](crate::isa::Cpu)) or is the portable one, so holding one shows that the CPU
    /// has the features of its [`Isa`].
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(crate) struct Int8Kernel(Isa);

    impl Int8Kernel {
        /// The portable kernel (any CPU).
        pub(crate) const PORTABLE: Int8Kernel = Int8Kernel(Isa::Portable);

        /// Its instruction set (which the CPU has).
        pub(crate) fn isa(self) -> Isa {
            self.0
        }

        /// Its name (that of its level in `MONOHAND_KERNEL`).
        pub(crate) fn name(self) -> &'static str {
            match self.0 {
                Isa::Portable => "portable",
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => "avx2",
                #[cfg(target_arch = "x86_64")]
                Isa::AvxVnni => "avxvnni",
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512Vnni => "avx512vnni",
                #[cfg(target_arch = "x86_64")]
                Isa::Amx => "amx",
                #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
                Isa::RelaxedSimd => "relaxed-simd",
            }
        }

        /// Its instruction-set level (what `MONOHAND_KERNEL` caps).
        pub(crate) fn level(self) -> Level {
            match self.0 {
                Isa::Portable => Level::Portable,
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => Level::Avx2,
                #[cfg(target_arch = "x86_64")]
                Isa::AvxVnni => Level::AvxVnni,
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512Vnni => Level::Avx512Vnni,
                #[cfg(target_arch = "x86_64")]
                Isa::Amx => Level::Amx,
                #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
                Isa::RelaxedSimd => Level::Avx2,
            }
        }

        /// Every int8 kernel this CPU runs, slowest first (detected at run time).
        pub(crate) fn supported() -> Vec<Int8Kernel> {
            #[allow(unused_mut)]
            let mut v = vec![Int8Kernel::PORTABLE];
            #[cfg(target_arch = "x86_64")]
            {
                let cpu = Cpu::get();
                if cpu.avx2() {
                    v.push(Int8Kernel(Isa::Avx2));
                }
                if cpu.avx_vnni() {
                    v.push(Int8Kernel(Isa::AvxVnni));
                }
                if cpu.avx512_vnni() {
                    v.push(Int8Kernel(Isa::Avx512Vnni));
                }
                if cpu.amx_int8() {
                    v.push(Int8Kernel(Isa::Amx));
                }
            }
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            v.push(Int8Kernel(Isa::RelaxedSimd));
            v
        }

        /// The fastest kernel this CPU runs at or below the level `MONOHAND_KERNEL` names
        /// (decided once per process; see [`crate::isa`]).
        pub(crate) fn best() -> Int8Kernel {
            static BEST: std::sync::OnceLock<Int8Kernel> = std::sync::OnceLock::new();
            *BEST.get_or_init(|| {
                crate::isa::choose(
                    &Int8Kernel::supported(),
                    Int8Kernel::level,
                    crate::isa::cap(),
                    Int8Kernel::PORTABLE,
                )
            })
        }
    }
}

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
            Isa::Avx512Vnni => avx512vnni::tile(m, width),
            #[cfg(target_arch = "x86_64")]
            Isa::Amx => amx::tile(m, width),
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            Isa::RelaxedSimd => relaxed::tile(m, width.div_ceil(4)),
        }
    }
}

/// One micro-tile: `m` quantized rows against one weight panel (two side by side where
/// `width > NR`), epilogue included.
///
/// Pointers are valid for: `a`: `m` rows of `lda` bytes, of which the first `4·groups <=
/// lda` are read; `b`: `groups` groups of `4·NR` bytes (one panel), followed, when
/// `width > NR`, by the next panel's `groups` groups; `zcorr`, `scale`, `bias`, `alpha`:
/// `NR · width.div_ceil(NR)` values; `out`, `res`: `m` rows of stride `ldo`, `width` floats
/// each. `alpha`, `res` may be null (absent).
struct Tile {
    a: *const u8,
    lda: usize,
    groups: usize,
    b: *const i8,
    out: *mut f32,
    res: *const f32,
    ldo: usize,
    m: usize,
    width: usize,
    zcorr: *const i32,
    scale: *const f32,
    bias: *const f32,
    alpha: *const f32,
    act: (f32, f32),
    residual_act: (f32, f32),
}

/// A micro-kernel for one tile (see [`Int8Kernel::tile`]).
///
/// # Safety
/// Call it only with a [`Tile`] that satisfies `Tile`'s contract and the `m` and `width` it
/// was chosen for, on a CPU with the features of the kernel that gave it.
type TileFn = unsafe fn(&Tile);

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
unsafe fn tile_portable(t: &Tile) {
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

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{ActivationQuant, Tile, TileFn, ACTIVATION_QMAX, KG, MR, NR};
    use std::arch::x86_64::*;

    /// The monomorphised tile for `m` rows and `v` vectors of 8 channels.
    pub(super) fn tile(m: usize, v: usize) -> TileFn {
        const _: () = assert!(MR == 4 && NR == 16 && KG == 4);
        match (m, v) {
            (1, 1) => micro::<1, 1>,
            (2, 1) => micro::<2, 1>,
            (3, 1) => micro::<3, 1>,
            (4, 1) => micro::<4, 1>,
            (1, _) => micro::<1, 2>,
            (2, _) => micro::<2, 2>,
            (3, _) => micro::<3, 2>,
            _ => micro::<4, 2>,
        }
    }

    /// Codes `x` into `q` as [`ActivationQuant::quantize`] does, 8 values at a time
    /// (`vroundps` to nearest even, the same clamp, an exact conversion).
    ///
    /// # Safety
    /// The CPU has AVX2; `x.len() == q.len()`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn quantize(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
        let n = x.len().min(q.len());
        let z = quant.zero_point as f32;
        let inv = _mm256_set1_ps(quant.inv_scale);
        let lo = _mm256_set1_ps(-z);
        let hi = _mm256_set1_ps(ACTIVATION_QMAX as f32 - z);
        let zp = _mm256_set1_epi32(quant.zero_point as i32);
        let mut k = 0;
        while k + 8 <= n {
            // SAFETY: k + 8 <= n values of `x` and of `q`; the CPU has AVX2 (the contract).
            unsafe {
                let v = _mm256_mul_ps(_mm256_loadu_ps(x.as_ptr().add(k)), inv);
                let v = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v);
                // `maxps` returns its second operand for NaN: NaN becomes `lo`, as in
                // `quantize`.
                let v = _mm256_min_ps(_mm256_max_ps(v, lo), hi);
                let v = _mm256_add_epi32(_mm256_cvtps_epi32(v), zp);
                let w = _mm_packs_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
                let b = _mm_packus_epi16(w, w);
                _mm_storel_epi64(q.as_mut_ptr().add(k) as *mut __m128i, b);
            }
            k += 8;
        }
        for (q, &x) in q[k..n].iter_mut().zip(&x[k..n]) {
            *q = quant.quantize(x);
        }
    }

    /// `M` rows x `V` vectors of 8 channels accumulated in `M·V` i32 registers: per group
    /// of 4 input channels one broadcast of the row's 4 bytes, `vpmaddubsw` against the
    /// panel (never saturating: activations are at most 127, weights within ±127) and
    /// `vpmaddwd` against ones to sum the pairs; the epilogue runs on the registers (no FMA,
    /// as the portable one) and stores with a mask where the panel is narrower than `8·V`.
    ///
    /// # Safety
    /// The CPU has AVX2; `t` satisfies `Tile`'s contract with `t.m == M` and
    /// `8·(V-1) < t.width <= 8·V`.
    #[target_feature(enable = "avx2")]
    unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
        // SAFETY: the CPU has AVX2 (the contract). The reads and writes stay in the tile
        // (`Tile`'s contract, m == M, 8·(V-1) < width <= 8·V <= NR): `a` at rows i < M,
        // 4 bytes of group g < groups (4·groups <= lda); `b` at `groups` groups of 4·NR
        // bytes, 32·V <= 4·NR of each; `zcorr`, `scale`, `bias`, `alpha` at 8·V <= NR
        // values; `res` and `out` at rows i < M, 8·V channels of which the last vector's
        // lanes at and past `width` are masked off.
        unsafe {
            let ones = _mm256_set1_epi16(1);
            let mut acc = [start::<V>(t); M];
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
                        let p = _mm256_madd_epi16(_mm256_maddubs_epi16(x, bv), ones);
                        *acc = _mm256_add_epi32(*acc, p);
                    }
                }
                a = a.add(KG);
                b = b.add(KG * NR);
            }
            store::<M, V>(t, &acc);
        }
    }

    /// Each accumulator's start: `-zcorr` of its 8 channels, so that the sums end at the
    /// portable kernel's `sum - zcorr` (the same i32 values, wrapping alike).
    ///
    /// # Safety
    /// The CPU has AVX2; `t.zcorr` holds `8·V` values.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn start<const V: usize>(t: &Tile) -> [__m256i; V] {
        let mut start = [_mm256_setzero_si256(); V];
        for (v, s) in start.iter_mut().enumerate() {
            // SAFETY: 8·v + 8 <= 8·V values of `zcorr` (the contract).
            let z = unsafe { _mm256_loadu_si256(t.zcorr.add(8 * v) as *const __m256i) };
            *s = _mm256_sub_epi32(_mm256_setzero_si256(), z);
        }
        start
    }

    /// The epilogue of an `M` x `8·V` tile whose sums less `zcorr` are `acc`, shared by the
    /// AVX2 and AVX-VNNI kernels: scale, bias, activation, residual, PRELU on the registers
    /// (no FMA, as the portable one), stored with a mask where the panel is narrower than
    /// `8·V`.
    ///
    /// # Safety
    /// The CPU has AVX2; `t` satisfies `Tile`'s contract with `t.m == M` and
    /// `8·(V-1) < t.width <= 8·V`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn store<const M: usize, const V: usize>(t: &Tile, acc: &[[__m256i; V]; M]) {
        // SAFETY: the CPU has AVX2 (the contract); `scale`, `bias`, `alpha` are read at
        // 8·V <= NR values, `res` and `out` at rows i < M, 8·V channels of which the last
        // vector's lanes at and past `width` are masked off (`Tile`'s contract).
        unsafe {
            let lanes = (t.width - 8 * (V - 1)) as i32;
            let mask = _mm256_cmpgt_epi32(
                _mm256_set1_epi32(lanes),
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
            );
            let (lo, hi) = (_mm256_set1_ps(t.act.0), _mm256_set1_ps(t.act.1));
            let (rlo, rhi) = (
                _mm256_set1_ps(t.residual_act.0),
                _mm256_set1_ps(t.residual_act.1),
            );
            let zero = _mm256_setzero_ps();
            for (i, acc) in acc.iter().enumerate() {
                for (v, &acc) in acc.iter().enumerate() {
                    let full = v + 1 < V || lanes == 8;
                    let at = i * t.ldo + 8 * v;
                    let mut y = _mm256_add_ps(
                        _mm256_mul_ps(_mm256_cvtepi32_ps(acc), _mm256_loadu_ps(t.scale.add(8 * v))),
                        _mm256_loadu_ps(t.bias.add(8 * v)),
                    );
                    y = _mm256_min_ps(_mm256_max_ps(y, lo), hi);
                    if !t.res.is_null() {
                        let r = if full {
                            _mm256_loadu_ps(t.res.add(at))
                        } else {
                            _mm256_maskload_ps(t.res.add(at), mask)
                        };
                        y = _mm256_min_ps(_mm256_max_ps(_mm256_add_ps(y, r), rlo), rhi);
                    }
                    if !t.alpha.is_null() {
                        let al = _mm256_loadu_ps(t.alpha.add(8 * v));
                        y = _mm256_add_ps(
                            _mm256_max_ps(y, zero),
                            _mm256_mul_ps(al, _mm256_min_ps(y, zero)),
                        );
                    }
                    if full {
                        _mm256_storeu_ps(t.out.add(at), y);
                    } else {
                        _mm256_maskstore_ps(t.out.add(at), mask, y);
                    }
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avxvnni {
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
}

#[cfg(target_arch = "x86_64")]
mod avx512vnni {
    use super::{ActivationQuant, Tile, TileFn, ACTIVATION_QMAX, KG, MR_512, NR};
    use std::arch::x86_64::*;

    /// The tiles of 1 to 8 rows for `P` panels.
    macro_rules! heights {
        ($p:literal) => {
            [
                micro::<1, $p>,
                micro::<2, $p>,
                micro::<3, $p>,
                micro::<4, $p>,
                micro::<5, $p>,
                micro::<6, $p>,
                micro::<7, $p>,
                micro::<8, $p>,
            ]
        };
    }

    /// By panels (1-16, 17-32 channels), then height.
    static TILES: [[TileFn; MR_512]; 2] = [heights!(1), heights!(2)];

    /// The monomorphised tile for `m` rows and `width` channels (`1 <= width <= 32`).
    pub(super) fn tile(m: usize, width: usize) -> TileFn {
        const _: () = assert!(NR == 16 && KG == 4);
        TILES[(width.clamp(1, 2 * NR) - 1) / NR][m.clamp(1, MR_512) - 1]
    }

    /// The mask of the first `n` (<= 16) lanes.
    #[inline(always)]
    fn lanes(n: usize) -> u16 {
        if n >= 16 {
            0xffff
        } else {
            (1u16 << n) - 1
        }
    }

    /// Codes `x` into `q` as [`ActivationQuant::quantize`] does, 16 values at a time, the
    /// last ones under a mask (`vrndscaleps` to nearest even, the same clamp as the AVX2
    /// quantizer, an exact conversion, `vpmovdb`: the codes are within `[0, 127]`).
    ///
    /// # Safety
    /// The CPU has AVX-512F, BW and VL; `x.len() == q.len()`.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    pub(super) unsafe fn quantize(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
        let n = x.len().min(q.len());
        let z = quant.zero_point as f32;
        let inv = _mm512_set1_ps(quant.inv_scale);
        let lo = _mm512_set1_ps(-z);
        let hi = _mm512_set1_ps(ACTIVATION_QMAX as f32 - z);
        let zp = _mm512_set1_epi32(quant.zero_point as i32);
        let mut k = 0;
        while k < n {
            let mask = lanes(n - k);
            // SAFETY: the CPU has AVX-512F, BW and VL (the contract); the lanes at and past
            // n - k are masked off, so the load reads and the store writes values
            // k..min(k + 16, n) of `x` and of `q` alone (masked-off lanes do not fault).
            unsafe {
                let v = _mm512_mul_ps(_mm512_maskz_loadu_ps(mask, x.as_ptr().add(k)), inv);
                let v =
                    _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v);
                // `vmaxps` returns its second operand for NaN: NaN becomes `lo`, as in
                // `quantize`.
                let v = _mm512_min_ps(_mm512_max_ps(v, lo), hi);
                let v = _mm512_add_epi32(_mm512_cvtps_epi32(v), zp);
                let b = _mm512_cvtepi32_epi8(v);
                _mm_mask_storeu_epi8(q.as_mut_ptr().add(k) as *mut i8, mask, b);
            }
            k += 16;
        }
    }

    /// `M` rows x `P` panels of 16 channels accumulated in `M·P` `zmm` registers of i32,
    /// which start at `-zcorr` (so that they end at the portable kernel's `sum - zcorr`: the
    /// same i32 sums, wrapping alike): per group of 4 input channels one load of each
    /// panel's 64 bytes, one broadcast of each row's 4 bytes and one `vpdpbusd` (the 4
    /// products u8 x i8 added to each i32 lane, exactly) per row and panel. The epilogue
    /// runs on the registers without FMA (as the portable one) and the last panel loads the
    /// residual and stores under a mask where the tile is narrower than it.
    ///
    /// # Safety
    /// The CPU has AVX-512F, BW, VL and VNNI; `t` satisfies `Tile`'s contract with
    /// `t.m == M`, `P` in 1..=2 and `16·(P-1) < t.width <= 16·P`.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512vnni")]
    unsafe fn micro<const M: usize, const P: usize>(t: &Tile) {
        // SAFETY: the CPU has AVX-512F, BW, VL and VNNI (the contract). The reads and writes
        // stay in the tile (`Tile`'s contract, m == M, 16·(P-1) < width <= 16·P): `a` at
        // rows i < M, 4 bytes of group g < groups (4·groups <= lda); `b` at `groups` groups
        // of 4·NR bytes of the first panel, and of the second where P == 2 (then
        // width > NR: two panels); `zcorr`, `scale`, `bias`, `alpha` at 16·P values, within
        // NR·width.div_ceil(NR); `res` and `out` at rows i < M, 16·P channels of which the
        // last panel's lanes at and past `width` are masked off.
        unsafe {
            let mut start = [_mm512_setzero_si512(); P];
            for (p, s) in start.iter_mut().enumerate() {
                let z = _mm512_loadu_si512(t.zcorr.add(16 * p) as *const __m512i);
                *s = _mm512_sub_epi32(_mm512_setzero_si512(), z);
            }
            let mut acc = [start; M];
            let mut a = t.a;
            let mut b = t.b;
            // The second panel's groups start a whole panel further.
            let panel = t.groups * KG * NR;
            for _ in 0..t.groups {
                let mut bv = [_mm512_setzero_si512(); P];
                for (p, bv) in bv.iter_mut().enumerate() {
                    *bv = _mm512_loadu_si512(b.add(p * panel) as *const __m512i);
                }
                for (i, acc) in acc.iter_mut().enumerate() {
                    let x = _mm512_set1_epi32((a.add(i * t.lda) as *const i32).read_unaligned());
                    for (acc, &bv) in acc.iter_mut().zip(&bv) {
                        *acc = _mm512_dpbusd_epi32(*acc, x, bv);
                    }
                }
                a = a.add(KG);
                b = b.add(KG * NR);
            }
            let e = Epilogue::<P>::new(t);
            for (i, acc) in acc.iter().enumerate() {
                // `acc` is already the sum less `zcorr`; row i < M of the tile.
                e.store_row(t, i, acc);
            }
        }
    }

    /// The epilogue's per-tile constants for `P` panels: the channels' scales, biases and
    /// PRELU slopes, the clamps, the last panel's mask; loaded once per tile (the output's
    /// stores would otherwise have them loaded again for every row).
    pub(super) struct Epilogue<const P: usize> {
        scale: [__m512; P],
        bias: [__m512; P],
        alpha: [__m512; P],
        lo: __m512,
        hi: __m512,
        rlo: __m512,
        rhi: __m512,
        last: u16,
    }

    impl<const P: usize> Epilogue<P> {
        /// # Safety
        /// The caller has AVX-512F, BW and VL (it is inlined into such a function); `t`
        /// satisfies `Tile`'s contract with `P` in 1..=2 and `16·(P-1) < t.width <= 16·P`.
        #[inline(always)]
        pub(super) unsafe fn new(t: &Tile) -> Self {
            // SAFETY: the caller's features and `Tile`'s contract: `scale`, `bias` and
            // `alpha` (where not null) hold 16·P values, within NR·width.div_ceil(NR).
            unsafe {
                let mut e = Epilogue {
                    scale: [_mm512_setzero_ps(); P],
                    bias: [_mm512_setzero_ps(); P],
                    alpha: [_mm512_setzero_ps(); P],
                    lo: _mm512_set1_ps(t.act.0),
                    hi: _mm512_set1_ps(t.act.1),
                    rlo: _mm512_set1_ps(t.residual_act.0),
                    rhi: _mm512_set1_ps(t.residual_act.1),
                    last: lanes(t.width - 16 * (P - 1)),
                };
                for p in 0..P {
                    e.scale[p] = _mm512_loadu_ps(t.scale.add(16 * p));
                    e.bias[p] = _mm512_loadu_ps(t.bias.add(16 * p));
                    if !t.alpha.is_null() {
                        e.alpha[p] = _mm512_loadu_ps(t.alpha.add(16 * p));
                    }
                }
                e
            }
        }

        /// The epilogue of row `i` of the tile from its i32 sums less `zcorr` (`acc`),
        /// stored to the output: without FMA, as the portable one; the last panel loads the
        /// residual and stores under a mask where the tile is narrower than it.
        ///
        /// # Safety
        /// As [`new`](Self::new), with the same `t`, and `i < t.m`.
        #[inline(always)]
        pub(super) unsafe fn store_row(&self, t: &Tile, i: usize, acc: &[__m512i; P]) {
            // SAFETY: the caller's features and `Tile`'s contract: `res` and `out` at row
            // i < m, 16·P channels of which the last panel's lanes at and past `width` are
            // masked off.
            unsafe {
                let zero = _mm512_setzero_ps();
                for (p, &acc) in acc.iter().enumerate() {
                    let mask = if p + 1 == P { self.last } else { 0xffff };
                    let at = i * t.ldo + 16 * p;
                    let mut y = _mm512_add_ps(
                        _mm512_mul_ps(_mm512_cvtepi32_ps(acc), self.scale[p]),
                        self.bias[p],
                    );
                    y = _mm512_min_ps(_mm512_max_ps(y, self.lo), self.hi);
                    if !t.res.is_null() {
                        let r = _mm512_maskz_loadu_ps(mask, t.res.add(at));
                        y = _mm512_min_ps(_mm512_max_ps(_mm512_add_ps(y, r), self.rlo), self.rhi);
                    }
                    if !t.alpha.is_null() {
                        y = _mm512_add_ps(
                            _mm512_max_ps(y, zero),
                            _mm512_mul_ps(self.alpha[p], _mm512_min_ps(y, zero)),
                        );
                    }
                    _mm512_mask_storeu_ps(t.out.add(at), mask, y);
                }
            }
        }
    }
}

/// The AMX kernel: `tdpbusd` multiplies a tile of 16 rows x 64 codes by one of 16 groups
/// of 4 weight bytes x 16 channels into 16 x 16 i32 sums, exactly: the VNNI panels' layout
/// (`[groups][16][4]`, rows of 64 bytes) is AMX's for the weights, and the coded rows (a
/// stride of `kp` bytes) are its for the activations. A micro-tile of 16 rows and one or
/// two panels sums the layer's depth 64 codes at a time (the last 4-60 in tiles
/// configured for them), stores the sums, and runs the AVX-512 VNNI kernel's epilogue on
/// them less `zcorr`: the same i32 values, the same bits. Shorter tiles (fewer than 16
/// rows) go to the AVX-512 VNNI kernel. The instructions are written with `asm!` (Rust
/// 1.95 has no stable AMX intrinsics); the tile shapes are loaded once per call of
/// `Job::tiles` ([`Tiles`]) and released after it.
#[cfg(target_arch = "x86_64")]
mod amx {
    use super::{avx512vnni, Tile, TileFn, KG, MR_512, NR};
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
            let mut i = 0;
            while i < t.m {
                let m = MR_512.min(t.m - i);
                let part = Tile {
                    // SAFETY: row i < m of the tile's codes.
                    a: unsafe { t.a.add(i * t.lda) },
                    // SAFETY: row i < m of its output.
                    out: unsafe { t.out.add(i * t.ldo) },
                    res: if t.res.is_null() {
                        t.res
                    } else {
                        // SAFETY: row i < m of its residual, which it has.
                        unsafe { t.res.add(i * t.ldo) }
                    },
                    m,
                    ..*t
                };
                // SAFETY: `part` is rows i..i + m of `t`, within its contract, m <= 8 as
                // the AVX-512 VNNI kernel's tiles need, the CPU has its features.
                unsafe { avx512vnni::tile(m, t.width)(&part) };
                i += m;
            }
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
            let mut zcorr = [_mm512_setzero_si512(); P];
            for (p, z) in zcorr.iter_mut().enumerate() {
                *z = _mm512_loadu_si512(t.zcorr.add(16 * p) as *const __m512i);
            }
            let e = avx512vnni::Epilogue::<P>::new(t);
            for i in 0..ROWS {
                let mut acc = [_mm512_setzero_si512(); P];
                for (p, acc) in acc.iter_mut().enumerate() {
                    let v = _mm512_load_si512(
                        sums.0.as_ptr().add(i * 2 * NR + 16 * p) as *const __m512i
                    );
                    // The same i32 as the VNNI kernel's: it starts at -zcorr and adds the
                    // same products (wrapping alike).
                    *acc = _mm512_sub_epi32(v, zcorr[p]);
                }
                e.store_row(t, i, &acc);
            }
        }
    }

    /// The sums of a tile, 16 rows of two panels.
    #[repr(C, align(64))]
    struct Sums([i32; ROWS * 2 * NR]);
}

/// The WebAssembly relaxed-SIMD kernel, the VNNI kernels' scheme on 128-bit vectors:
/// `i32x4.relaxed_dot_i8x16_i7x16_add_s` sums each i32 lane's 4 products of a weight byte
/// and an activation code. Its result is implementation-defined only where a byte of its
/// second operand has its top bit set, and engines may saturate the pairs' i16 sums
/// (`pmaddubsw`); neither happens here: the codes are at most 127 (7 bits) and a pair's
/// sum is at most 2·128·127 = 32512. So the sums are exact, and the epilogue (without
/// fused multiply-adds, as the portable one) gives the portable kernel's bits.
#[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
mod relaxed {
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
    static TILES: [[TileFn; MR_RELAXED]; NR / 4] =
        [heights!(1), heights!(2), heights!(3), heights!(4)];

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
}

/// The range of the input of every [`PointwiseConv`](crate::PointwiseConv) and
/// [`NhwcConv`](crate::NhwcConv) node of `model` (by node name) over runs on `inputs` (each
/// the model's inputs): what [`quantize_pointwise`] codes them from. The model runs
/// optimised (tract's unoptimised operators are many times slower); the optimiser keeps
/// these nodes and their names, which are those of the imported graph (an error if one of
/// them went missing).
pub fn int8_input_ranges(
    model: &TypedModel,
    inputs: &[TVec<Tensor>],
) -> TractResult<std::collections::HashMap<String, MinMax>> {
    let coded = |n: &TypedNode| {
        n.op_as::<crate::PointwiseConv>().is_some() || n.op_as::<crate::NhwcConv>().is_some()
    };
    let names = |m: &TypedModel| -> std::collections::BTreeSet<String> {
        m.nodes()
            .iter()
            .filter(|n| coded(n))
            .map(|n| n.name.clone())
            .collect()
    };
    let optimised = model.clone().into_optimized()?;
    ensure!(
        names(&optimised) == names(model),
        "the optimiser renamed or removed 1x1 convolutions or stems"
    );
    let plan = optimised.into_runnable()?;
    let mut state = plan.spawn()?;
    let mut ranges: std::collections::HashMap<String, MinMax> = Default::default();
    for input in inputs {
        let input: TVec<TValue> = input.iter().map(|t| t.clone().into_tvalue()).collect();
        state.run_plan_with_eval(input, |ctx, st, node, inputs| {
            if coded(node) {
                if let Some(x) = inputs.first() {
                    let x = x.try_as_plain_ram()?;
                    ranges
                        .entry(node.name.clone())
                        .or_default()
                        .observe(x.as_slice::<f32>()?);
                }
            }
            tract_core::plan::eval(ctx, st, node, inputs)
        })?;
    }
    Ok(ranges)
}

/// Replaces every [`PointwiseConv`](crate::PointwiseConv) node of `model` that `ranges` has
/// a range for, and that `keep_f32` does not name, by the same convolution in int8
/// ([`PointwiseConvInt8`], its input coded from the range), and every
/// [`NhwcConv`](crate::NhwcConv) (the stem) that `ranges` has a range for by
/// [`NhwcConvInt8`](crate::NhwcConvInt8), folding in a [`ChannelPrelu`](crate::ChannelPrelu)
/// that alone reads its result; returns how many layers were replaced. Then, where a 1x1
/// convolution's input is the result of a [`NhwcDepthwise`](crate::NhwcDepthwise) that
/// nothing else reads, has the depthwise convolution write the codes
/// ([`code_depthwise_results`]): the same results, bit for bit.
pub fn quantize_pointwise(
    model: &mut TypedModel,
    ranges: &std::collections::HashMap<String, MinMax>,
    keep_f32: impl Fn(&str, &crate::PointwiseConv) -> bool,
) -> TractResult<usize> {
    let outputs = model.output_outlets()?.to_vec();
    let mut replaced = 0;
    for id in 0..model.nodes().len() {
        let node = model.node(id);
        let Some(range) = ranges.get(&node.name) else {
            continue;
        };
        if let Some(stem) = node.op_as::<crate::NhwcConv>() {
            let mut int8 = stem.to_int8(range.quant())?;
            let out = OutletId::new(id, 0);
            let single = &node.outputs[0].successors;
            if let ([next], false) = (&single[..], outputs.contains(&out)) {
                let next_id = next.node;
                if let Some(prelu) = model.node(next_id).op_as::<crate::ChannelPrelu>() {
                    int8 = int8.with_prelu(&prelu.alpha)?;
                    // The PRELU node passes its input on; the optimiser removes it.
                    model.node_mut(next_id).op = Box::new(tract_core::ops::identity::Identity);
                }
            }
            model.node_mut(id).op = Box::new(int8);
            replaced += 1;
            continue;
        }
        let Some(op) = node.op_as::<crate::PointwiseConv>() else {
            continue;
        };
        if keep_f32(&node.name, op) {
            continue;
        }
        let int8 = op.to_int8(range.quant())?;
        model.node_mut(id).op = Box::new(int8);
        replaced += 1;
    }
    code_depthwise_results(model)?;
    Ok(replaced)
}

/// Where a [`PointwiseConvInt8`] of `model` reads the result of a
/// [`NhwcDepthwise`](crate::NhwcDepthwise) that nothing else reads (nor is a model output),
/// over a multiple of 4 channels, replaces the depthwise convolution by a
/// [`NhwcDepthwiseCodes`](crate::NhwcDepthwiseCodes) that writes the 1x1 convolution's
/// input codes, and has the 1x1 convolution read them
/// ([`with_coded_input`](PointwiseConvInt8::with_coded_input)); returns how many pairs.
/// The results are the same bits: the codes are those the 1x1 convolution made of the f32
/// values, which are no longer written to memory and read back.
pub fn code_depthwise_results(model: &mut TypedModel) -> TractResult<usize> {
    let outputs = model.output_outlets()?.to_vec();
    let mut fused = 0;
    for id in 0..model.nodes().len() {
        let node = model.node(id);
        let Some(op) = node.op_as::<PointwiseConvInt8>() else {
            continue;
        };
        if op.coded_input || op.cin != op.kp {
            continue;
        }
        let Some(&from) = node.inputs.first() else {
            continue;
        };
        let producer = model.node(from.node);
        let Some(dw) = producer.op_as::<crate::NhwcDepthwise>() else {
            continue;
        };
        if from.slot != 0 || producer.outputs[0].successors.len() != 1 || outputs.contains(&from) {
            continue;
        }
        let codes = crate::NhwcDepthwiseCodes::new(dw.clone(), op.input);
        let int8 = op.clone().with_coded_input()?;
        let fact = u8::fact(producer.outputs[0].fact.shape.clone());
        let producer = model.node_mut(from.node);
        producer.op = Box::new(codes);
        producer.outputs[0].fact = fact;
        model.node_mut(id).op = Box::new(int8);
        fused += 1;
    }
    Ok(fused)
}

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
            crate::pointwise::eval_1x1::<u8>(
                &inputs,
                self.cin,
                self.cout,
                has_residual,
                what,
                |x, r, o| self.compute_with(x, r, o, Int8Kernel::best(), self.split),
            )
        } else {
            crate::pointwise::eval_1x1::<f32>(
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
mod tests {
    use super::*;
    use crate::split::testing::differing_bits;

    /// A small deterministic generator of values in [-1, 1).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        }

        fn vec(&mut self, n: usize, scale: f32) -> Vec<f32> {
            (0..n).map(|_| self.next() * scale).collect()
        }
    }

    const ACTS: [Activation; 3] = [Activation::None, Activation::Relu, Activation::Relu6];

    /// The operator for `(rows, cin, cout)` with one of every epilogue.
    struct Case {
        rows: usize,
        cin: usize,
        cout: usize,
        x: Vec<f32>,
        w: Vec<f32>,
        b: Vec<f32>,
        r: Vec<f32>,
        alpha: Vec<f32>,
    }

    impl Case {
        fn random(g: &mut Lcg, (rows, cin, cout): (usize, usize, usize)) -> Case {
            Case {
                rows,
                cin,
                cout,
                // Mostly one-sided, as after a RELU6 or a PRELU.
                x: g.vec(rows * cin, 3.0).iter().map(|v| v + 2.0).collect(),
                w: g.vec(cout * cin, 1.0),
                b: g.vec(cout, 2.0),
                r: g.vec(rows * cout, 4.0),
                alpha: g.vec(cout, 2.0),
            }
        }

        fn op(
            &self,
            quant: ActivationQuant,
            act: Activation,
            res: Option<Activation>,
            prelu: bool,
        ) -> PointwiseConvInt8 {
            let wt = Tensor::from_shape(&[self.cout, 1, 1, self.cin], &self.w).expect("w");
            let mut op = PointwiseConvInt8::new(&wt, &tensor1(&self.b), act, quant).expect("op");
            if let Some(ract) = res {
                op = op.with_residual(ract);
            }
            if prelu {
                op = op.with_prelu(&tensor1(&self.alpha)).expect("prelu");
            }
            op
        }

        fn run(&self, op: &PointwiseConvInt8, kernel: Int8Kernel) -> Vec<f32> {
            let mut out = vec![f32::NAN; self.rows * self.cout];
            let res = op.has_residual().then_some(&self.r[..]);
            op.compute_with(&self.x, res, &mut out, kernel, false)
                .expect("compute");
            out
        }
    }

    /// (rows, cin, cout): input channels off the group of 4 and the vector of 8, output
    /// channels off the 8- and 16-channel vectors, the panels and the pairs of panels, row
    /// counts off the tile heights (4, 6, 8), and inputs larger than one block of rows.
    // Rows of 16 and more take AMX's tiles where the CPU has them: depths of a whole
    // number of 64 codes, and not, and two panels with a narrow last one.
    const SHAPES: [(usize, usize, usize); 18] = [
        (32, 64, 16),
        (48, 1152, 40),
        (20, 200, 33),
        (1, 1, 1),
        (5, 3, 7),
        (4, 4, 16),
        (6, 8, 16),
        (7, 17, 23),
        (13, 16, 24),
        (11, 33, 2),
        (25, 19, 36),
        (9, 40, 108),
        (12, 64, 9),
        (17, 12, 32),
        (19, 20, 48),
        (23, 8, 33),
        (3000, 24, 40),
        (700, 150, 17),
    ];

    #[test]
    fn the_simd_kernels_give_the_portable_kernels_bits() {
        let kernels = Int8Kernel::supported();
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let wanted = [
                (has!("avx2"), Isa::Avx2),
                (has!("avx2") && has!("avxvnni"), Isa::AvxVnni),
                (
                    has!("avx512f") && has!("avx512bw") && has!("avx512vl") && has!("avx512vnni"),
                    Isa::Avx512Vnni,
                ),
            ];
            for (detected, isa) in wanted {
                assert_eq!(kernels.iter().any(|k| k.isa() == isa), detected, "{isa:?}");
            }
            // The default is the last (fastest) one, unless `MONOHAND_KERNEL` caps it.
            if std::env::var_os("MONOHAND_KERNEL").is_none() {
                assert_eq!(Some(&Int8Kernel::best()), kernels.last());
            }
        }
        let mut g = Lcg(3);
        for shape in SHAPES {
            let c = Case::random(&mut g, shape);
            // A range narrower than the inputs', so that some are clamped.
            let quant = ActivationQuant::from_min_max(-0.5, 4.0);
            for act in ACTS {
                for res in [None, Some(Activation::None), Some(Activation::Relu6)] {
                    for prelu in [false, true] {
                        let op = c.op(quant, act, res, prelu);
                        let want = c.run(&op, Int8Kernel::PORTABLE);
                        assert!(want.iter().all(|v| v.is_finite()));
                        for &k in &kernels {
                            let got = c.run(&op, k);
                            assert_eq!(
                                differing_bits(&got, &want),
                                0,
                                "{k:?} {shape:?} act {act:?} res {res:?} prelu {prelu}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// Every pair summed by `vpmaddubsw` at its extremes: codes 127 (and 0) against weights
    /// of ±127, as many input channels as the deepest layer's and more: the sums are exact
    /// (checked against i64 arithmetic) and the same in every kernel.
    #[test]
    fn extreme_codes_do_not_saturate() {
        for (rows, cin, cout) in [
            (5, 1152, 19),
            (6, 4, 16),
            (9, 2001, 8),
            (16, 1152, 19),
            (33, 2001, 8),
        ] {
            // Weights all ±1 (codes ±127), signs by a pattern; each channel's largest is 1.
            let w: Vec<f32> = (0..cout * cin)
                .map(|i| if (i * 7 + i / 3) % 5 < 3 { 1.0 } else { -1.0 })
                .collect();
            let wt = Tensor::from_shape(&[cout, cin], &w).expect("w");
            // Codes from 0 to 127: a zero point of 0 and a step of 1.
            let quant = ActivationQuant::new(1.0, 0).expect("quant");
            for x_code in [127.0f32, 0.0, 1e9] {
                let mut x = vec![x_code; rows * cin];
                // And a row of alternating extremes.
                for (k, v) in x[..cin].iter_mut().enumerate() {
                    *v = if k % 2 == 0 { 127.0 } else { 0.0 };
                }
                let op = PointwiseConvInt8::new(
                    &wt,
                    &tensor1(&vec![0f32; cout]),
                    Activation::None,
                    quant,
                )
                .expect("op");
                let mut want = vec![f32::NAN; rows * cout];
                op.compute_with(&x, None, &mut want, Int8Kernel::PORTABLE, false)
                    .expect("portable");
                for r in 0..rows {
                    for o in 0..cout {
                        let exact: i64 = (0..cin)
                            .map(|k| {
                                let q = x[r * cin + k].clamp(0.0, 127.0) as i64;
                                q * (w[o * cin + k] as i64 * 127)
                            })
                            .sum();
                        // Scale 1 · 1/127 per unit of weight code: the sum in units of x·w.
                        let want_v = exact as f32 * (1.0 / 127.0);
                        let got = want[r * cout + o];
                        assert!(
                            (got - want_v).abs() <= 1e-6 * (1.0 + want_v.abs()),
                            "{rows}x{cin}->{cout} row {r} ch {o}: {got} vs {want_v}"
                        );
                    }
                }
                for k in Int8Kernel::supported() {
                    let mut got = vec![f32::NAN; rows * cout];
                    op.compute_with(&x, None, &mut got, k, false)
                        .expect("kernel");
                    assert_eq!(differing_bits(&got, &want), 0, "{k:?} {rows}x{cin}->{cout}");
                }
            }
        }
    }

    #[test]
    fn every_quantizer_codes_edge_values_alike() {
        let quant = ActivationQuant::from_min_max(-1.0, 3.0);
        let s = quant.scale();
        let z = quant.zero_point() as f32;
        // Ties on both sides, the range's ends and beyond, zeros, infinities and NaN.
        let mut x = vec![
            0.0,
            -0.0,
            0.5 * s,
            1.5 * s,
            2.5 * s,
            -0.5 * s,
            -1.5 * s,
            -z * s,
            (127.0 - z) * s,
            (127.0 - z + 0.5) * s,
            (-z - 0.5) * s,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
        ];
        x.extend(Lcg(9).vec(61, 5.0));
        let cin = x.len();
        let kp = cin.div_ceil(KG) * KG;
        let mut want = vec![0xAAu8; kp];
        quantize_rows(&x, cin, kp, quant, &mut want, Int8Kernel::PORTABLE);
        assert!(want.iter().all(|&q| q <= ACTIVATION_QMAX));
        assert_eq!(want[0], quant.zero_point());
        assert_eq!(want[1], quant.zero_point());
        assert_eq!(want[11], ACTIVATION_QMAX);
        assert_eq!(want[12], 0);
        assert_eq!(want[15], 0, "NaN");
        assert!(want[cin..].iter().all(|&q| q == 0), "padding");
        for k in Int8Kernel::supported() {
            let mut got = vec![0x55u8; kp];
            quantize_rows(&x, cin, kp, quant, &mut got, k);
            assert_eq!(got, want, "{k:?}");
        }
        // Three rows of 76 channels (a multiple of 4: coded as one run of 228 values, the
        // vector quantizers' tails at the end only).
        let x3: Vec<f32> = [&x[..76], &x[1..77], &x[2..78]].concat();
        let mut want = vec![0xAAu8; x3.len()];
        quantize_rows(&x3, 76, 76, quant, &mut want, Int8Kernel::PORTABLE);
        for (r, row) in want.chunks_exact(76).enumerate() {
            for (q, &v) in row.iter().zip(&x[r..r + 76]) {
                assert_eq!(*q, quant.quantize(v));
            }
        }
        for k in Int8Kernel::supported() {
            let mut got = vec![0x55u8; x3.len()];
            quantize_rows(&x3, 76, 76, quant, &mut got, k);
            assert_eq!(got, want, "{k:?}, whole rows");
        }
    }

    #[test]
    fn activation_codes_span_the_observed_range_and_code_zero_exactly() {
        let mut g = Lcg(21);
        for (lo, hi) in [
            (0.0, 6.0),
            (-1.3, 4.7),
            (-8.0, -2.0),
            (0.25, 0.5),
            (0.0, 0.0),
        ] {
            let values: Vec<f32> = g
                .vec(1000, 1.0)
                .iter()
                .map(|v| lo + (hi - lo) * (v + 1.0) / 2.0)
                .chain([lo, hi])
                .collect();
            let mut seen = MinMax::default();
            seen.observe(&values);
            seen.observe(&[f32::NAN, f32::INFINITY]);
            assert_eq!((seen.min, seen.max), (lo, hi));
            let q = seen.quant();
            assert_eq!(q.dequantize(q.quantize(0.0)), 0.0);
            for &v in &values {
                let back = q.dequantize(q.quantize(v));
                assert!(
                    (back - v).abs() <= 0.5 * q.scale() * (1.0 + 1e-5),
                    "[{lo}, {hi}]: {v} -> {back} (step {})",
                    q.scale()
                );
            }
        }
    }

    /// The portable int8 result against the exact (f64) value of the f32 operator:
    /// with `x̂ = s_x (q_x - z)` and `ŵ = s_w q_w`, `x·w - x̂·ŵ = x (w - ŵ) + ŵ (x - x̂)`, and
    /// `|w - ŵ| <= s_w / 2`, `|x - x̂| <= s_x / 2` for inputs inside the coded range, so each
    /// output before its epilogue is off by at most `Σ_k (|x_k| s_w + |ŵ_k| s_x) / 2` (plus
    /// the f32 rounding of the epilogue). The clamps and the residual add do not widen it;
    /// the PRELU multiplies it by at most `max(1, |α|)`.
    #[test]
    fn the_int8_result_is_within_the_quantization_error_of_the_f32_one() {
        let mut g = Lcg(17);
        let mut worst = 0f64;
        for shape in SHAPES {
            let c = Case::random(&mut g, shape);
            let mut seen = MinMax::default();
            seen.observe(&c.x);
            let quant = seen.quant();
            let (s_x, z) = (quant.scale() as f64, quant.zero_point() as f64);
            let wq: Vec<(Vec<i8>, f32)> = c.w.chunks_exact(c.cin).map(quantize_weights).collect();
            for act in ACTS {
                for res in [None, Some(Activation::Relu6)] {
                    for prelu in [false, true] {
                        let op = c.op(quant, act, res, prelu);
                        let got = c.run(&op, Int8Kernel::PORTABLE);
                        for r in 0..c.rows {
                            for o in 0..c.cout {
                                let w = &c.w[o * c.cin..(o + 1) * c.cin];
                                let x = &c.x[r * c.cin..(r + 1) * c.cin];
                                let (wq, s_w) = (&wq[o].0, wq[o].1 as f64);
                                let (mut exact, mut bound, mut mag) = (c.b[o] as f64, 0.0, 0.0);
                                for k in 0..c.cin {
                                    let (xv, wv) = (x[k] as f64, w[k] as f64);
                                    exact += xv * wv;
                                    let w_hat = s_w * wq[k] as f64;
                                    bound += 0.5 * (xv.abs() * s_w + w_hat.abs() * s_x);
                                    mag += xv.abs() * wv.abs();
                                    // The coded input is the nearest code (no clamp here).
                                    let x_hat = s_x * (quant.quantize(x[k]) as f64 - z);
                                    assert!((x_hat - xv).abs() <= 0.5 * s_x * (1.0 + 1e-5));
                                }
                                let clamp = |y: f64, a: Activation| {
                                    let (lo, hi) = a.bounds();
                                    y.max(lo as f64).min(hi as f64)
                                };
                                let mut y = clamp(exact, act);
                                if let Some(ract) = res {
                                    y = clamp(y + c.r[r * c.cout + o] as f64, ract);
                                }
                                let mut gain = 1.0;
                                if prelu {
                                    let a = c.alpha[o] as f64;
                                    y = y.max(0.0) + a * y.min(0.0);
                                    gain = a.abs().max(1.0);
                                }
                                let slack = 1e-5 * (1.0 + mag + c.b[o].abs() as f64);
                                let err = (got[r * c.cout + o] as f64 - y).abs();
                                assert!(
                                    err <= gain * bound + slack,
                                    "{shape:?} act {act:?} res {res:?} prelu {prelu} \
                                     ({r}, {o}): {} vs {y}, bound {}",
                                    got[r * c.cout + o],
                                    gain * bound + slack
                                );
                                worst = worst.max(err / (gain * bound + slack));
                            }
                        }
                    }
                }
            }
        }
        // The bound is a worst case; the errors of random data stay well inside it.
        assert!(worst < 0.8, "worst error {worst} of the bound");
    }

    #[test]
    fn evaluates_as_a_tract_operator_with_a_residual() {
        let mut g = Lcg(11);
        let (h, w, cin, cout) = (3, 5, 10, 12);
        let c = Case::random(&mut g, (h * w, cin, cout));
        let quant = ActivationQuant::from_min_max(-1.0, 5.0);
        let op = c.op(quant, Activation::Relu, Some(Activation::None), true);
        let out = op
            .eval_out_of_plan(tvec!(
                Tensor::from_shape(&[1, h, w, cin], &c.x)
                    .expect("x")
                    .into_tvalue(),
                Tensor::from_shape(&[1, h, w, cout], &c.r)
                    .expect("r")
                    .into_tvalue()
            ))
            .expect("eval")
            .expect("evaluates out of plan");
        assert_eq!(out[0].shape(), &[1, h, w, cout]);
        let got = out[0].try_as_plain_ram().expect("ram");
        let got = got.as_slice::<f32>().expect("f32");
        let want = c.run(&op, Int8Kernel::PORTABLE);
        assert_eq!(differing_bits(got, &want), 0);
    }

    #[test]
    fn a_float_operator_converts_and_a_model_is_calibrated_and_quantized() {
        let mut g = Lcg(29);
        let c = Case::random(&mut g, (6 * 7, 20, 24));
        let quant = ActivationQuant::from_min_max(0.0, 5.0);
        let wt = Tensor::from_shape(&[c.cout, c.cin], &c.w).expect("w");
        let f32op = crate::PointwiseConv::new(&wt, &tensor1(&c.b), Activation::Relu6)
            .expect("op")
            .with_residual(Activation::None)
            .with_prelu(&tensor1(&c.alpha))
            .expect("prelu");
        let want = c.op(quant, Activation::Relu6, Some(Activation::None), true);
        assert!(f32op.to_int8(quant).expect("to_int8") == want);

        // source -> 1x1 (RELU6) -> 1x1 (no activation): both calibrated and replaced.
        let mut model = TypedModel::default();
        let x = model
            .add_source("x", f32::fact([1, 6, 7, c.cin]))
            .expect("source");
        let first = crate::PointwiseConv::new(&wt, &tensor1(&c.b), Activation::Relu6)
            .expect("op")
            .with_split(false);
        let y = model.wire_node("first", first, &[x]).expect("first")[0];
        let w2 = Tensor::from_shape(&[5, c.cout], &g.vec(5 * c.cout, 1.0)).expect("w2");
        let second = crate::PointwiseConv::new(&w2, &tensor1(&[0.5f32; 5]), Activation::None)
            .expect("op")
            .with_split(false);
        let z = model.wire_node("second", second, &[y]).expect("second")[0];
        model.select_output_outlets(&[z]).expect("outputs");
        let input = Tensor::from_shape(&[1, 6, 7, c.cin], &c.x).expect("x");
        let ranges = int8_input_ranges(&model, &[tvec!(input.clone())]).expect("ranges");
        assert_eq!(ranges.len(), 2);
        let (lo, hi) =
            c.x.iter()
                .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        assert_eq!((ranges["first"].min, ranges["first"].max), (lo, hi));
        // The second reads RELU6 outputs.
        assert!(ranges["second"].min >= 0.0 && ranges["second"].max <= 6.0);
        let run = |m: &TypedModel| -> Vec<f32> {
            let out = m
                .clone()
                .into_runnable()
                .expect("plan")
                .run(tvec!(input.clone().into_tvalue()))
                .expect("run");
            let o = out[0].try_as_plain_ram().expect("ram");
            o.as_slice::<f32>().expect("f32").to_vec()
        };
        let reference = run(&model);
        let mut kept = model.clone();
        let n = quantize_pointwise(&mut kept, &ranges, |name, _| name == "first").expect("q");
        assert_eq!(n, 1);
        assert!(kept.node(1).op_as::<crate::PointwiseConv>().is_some());
        assert!(kept.node(2).op_as::<PointwiseConvInt8>().is_some());
        let mut all = model.clone();
        assert_eq!(
            quantize_pointwise(&mut all, &ranges, |_, _| false).expect("q"),
            2
        );
        let (half, full) = (run(&kept), run(&all));
        let scale = reference.iter().fold(0f32, |m, v| m.max(v.abs()));
        for ((r, h), f) in reference.iter().zip(&half).zip(&full) {
            // 7-bit activations over ranges of about 5 and 6 units, 20 and 24 terms.
            assert!((r - h).abs() <= 0.05 * scale, "{r} vs {h}");
            assert!((r - f).abs() <= 0.05 * scale, "{r} vs {f}");
        }
        assert!(half != reference && full != half);
    }

    #[test]
    fn shared_between_threads_by_rows_or_channels_gives_the_same_bits() {
        let mut g = Lcg(5);
        // (rows, cin, cout): by rows (56x56x24 to 144, with a residual and PRELU), by
        // channels (7x7x192 to 1152, 14x14x112 to 672).
        for (rows, cin, cout, residual) in [
            (3136, 24, 144, true),
            (49, 192, 1152, false),
            (196, 112, 672, true),
        ] {
            let c = Case::random(&mut g, (rows, cin, cout));
            let quant = ActivationQuant::from_min_max(-1.0, 5.0);
            let res = residual.then_some(Activation::None);
            let make = |split| {
                c.op(quant, Activation::Relu6, res, residual)
                    .with_split(split)
            };
            let mut inputs = vec![Tensor::from_shape(&[1, rows, 1, cin], &c.x).expect("x")];
            if residual {
                inputs.push(Tensor::from_shape(&[1, rows, 1, cout], &c.r).expect("r"));
            }
            crate::split::testing::same_bits_split(&make(true), &make(false), &inputs);
        }
    }

    #[test]
    fn coded_rows_give_the_bits_of_coding_the_values() {
        let mut g = Lcg(41);
        // Input channels a multiple of 4 (the coded rows' condition), with rows below and
        // above the split threshold and over one block of rows.
        let shapes = SHAPES
            .iter()
            .copied()
            .filter(|s| s.1 % KG == 0)
            .chain([(3136, 24, 144), (49, 192, 40)]);
        for shape in shapes {
            let c = Case::random(&mut g, shape);
            let quant = ActivationQuant::from_min_max(-0.5, 4.0);
            let codes: Vec<u8> = c.x.iter().map(|&v| quant.quantize(v)).collect();
            for (res, prelu) in [(None, false), (Some(Activation::Relu6), true)] {
                let op = c.op(quant, Activation::Relu6, res, prelu);
                let coded = op.clone().with_coded_input().expect("coded");
                assert!(coded.has_coded_input() && !op.has_coded_input());
                let r = res.map(|_| &c.r[..]);
                for k in Int8Kernel::supported() {
                    let want = c.run(&op, k);
                    let mut got = vec![f32::NAN; want.len()];
                    coded
                        .compute_with(&codes[..], r, &mut got, k, false)
                        .expect("coded");
                    assert_eq!(differing_bits(&got, &want), 0, "{k:?} {shape:?}");
                }
            }
        }
        // As a tract operator, in one piece and shared between threads (by rows, by
        // channels).
        for (rows, cin, cout) in [(3136, 24, 144), (49, 192, 1152)] {
            let c = Case::random(&mut g, (rows, cin, cout));
            let quant = ActivationQuant::from_min_max(-1.0, 5.0);
            let codes: Vec<u8> = c.x.iter().map(|&v| quant.quantize(v)).collect();
            let op = |split| {
                c.op(quant, Activation::Relu6, None, false)
                    .with_split(split)
            };
            let coded = |split| op(split).with_coded_input().expect("coded");
            let x = Tensor::from_shape(&[1, rows, 1, cin], &c.x).expect("x");
            let q = Tensor::from_shape(&[1, rows, 1, cin], &codes).expect("codes");
            let want = crate::split::testing::bits(&op(false), &[x]);
            let got = crate::split::testing::bits(&coded(false), std::slice::from_ref(&q));
            assert_eq!(got, want);
            crate::split::testing::same_bits_split(&coded(true), &coded(false), &[q]);
        }
        // Not without whole groups of 4 channels.
        let c = Case::random(&mut g, (4, 6, 8));
        let op = c.op(
            ActivationQuant::from_min_max(0.0, 1.0),
            Activation::None,
            None,
            false,
        );
        assert!(op.with_coded_input().is_err());
    }

    /// `source -> depthwise (RELU6) -> 1x1`, and a second depthwise whose result is read by
    /// two 1x1 convolutions (so not coded), in f32.
    fn depthwise_model(g: &mut Lcg, c: usize) -> TypedModel {
        let (h, k) = (9, 3);
        let dw = |g: &mut Lcg| crate::NhwcDepthwise {
            kernel: Tensor::from_shape(&[k, k, c], &g.vec(k * k * c, 1.0))
                .expect("k")
                .into_arc_tensor(),
            bias: tensor1(&g.vec(c, 1.0)).into_arc_tensor(),
            strides: (1, 1),
            same: true,
            activation: Activation::Relu6,
            register_blocked: true,
            split: false,
        };
        let pw = |g: &mut Lcg, cout: usize| {
            let w = Tensor::from_shape(&[cout, c], &g.vec(cout * c, 1.0)).expect("w");
            crate::PointwiseConv::new(&w, &tensor1(&g.vec(cout, 1.0)), Activation::None)
                .expect("op")
                .with_split(false)
        };
        let mut model = TypedModel::default();
        let x = model.add_source("x", f32::fact([1, h, h, c])).expect("x");
        let d1 = model.wire_node("dw1", dw(g), &[x]).expect("dw1")[0];
        let p1 = model.wire_node("pw1", pw(g, c), &[d1]).expect("pw1")[0];
        let d2 = model.wire_node("dw2", dw(g), &[p1]).expect("dw2")[0];
        let a = model.wire_node("pw2", pw(g, 8), &[d2]).expect("pw2")[0];
        let b = model.wire_node("pw3", pw(g, 8), &[d2]).expect("pw3")[0];
        model.select_output_outlets(&[a, b]).expect("outputs");
        model
    }

    #[test]
    fn depthwise_results_read_only_by_an_int8_1x1_are_coded_with_the_same_bits() {
        let mut g = Lcg(43);
        let c = 24;
        let model = depthwise_model(&mut g, c);
        let input = Tensor::from_shape(&[1, 9, 9, c], &g.vec(81 * c, 3.0)).expect("x");
        let ranges = int8_input_ranges(&model, &[tvec!(input.clone())]).expect("ranges");
        assert_eq!(ranges.len(), 3);
        // Each 1x1 layer in int8 coding its own input (no coded results).
        let mut plain = model.clone();
        for id in 0..plain.nodes().len() {
            let node = plain.node(id);
            if let Some(op) = node.op_as::<crate::PointwiseConv>() {
                let int8 = op.to_int8(ranges[&node.name].quant()).expect("int8");
                plain.node_mut(id).op = Box::new(int8);
            }
        }
        let mut coded = model.clone();
        assert_eq!(
            quantize_pointwise(&mut coded, &ranges, |_, _| false).expect("q"),
            3
        );
        let op_name = |m: &TypedModel, name: &str| {
            let id = m.node_by_name(name).expect("node").id;
            m.node(id).op().name().to_string()
        };
        assert_eq!(op_name(&coded, "dw1"), "MonohandNhwcDepthwiseCodes");
        assert_eq!(op_name(&coded, "dw2"), "MonohandNhwcDepthwise");
        for (name, is_coded) in [("pw1", true), ("pw2", false), ("pw3", false)] {
            let id = coded.node_by_name(name).expect("node").id;
            let op = coded.node(id).op_as::<PointwiseConvInt8>().expect("int8");
            assert_eq!(op.has_coded_input(), is_coded, "{name}");
        }
        assert_eq!(code_depthwise_results(&mut coded).expect("again"), 0);
        let run = |m: TypedModel| -> Vec<Vec<u32>> {
            let out = m
                .into_optimized()
                .expect("optimised")
                .into_runnable()
                .expect("plan")
                .run(tvec!(input.clone().into_tvalue()))
                .expect("run");
            out.iter()
                .map(|o| {
                    let o = o.try_as_plain_ram().expect("ram");
                    let v = o.as_slice::<f32>().expect("f32");
                    v.iter().map(|v| v.to_bits()).collect()
                })
                .collect()
        };
        assert_eq!(run(coded), run(plain));
    }

    #[test]
    fn rejects_inconsistent_buffers_and_codes() {
        assert!(ActivationQuant::new(0.0, 0).is_err());
        assert!(ActivationQuant::new(f32::NAN, 0).is_err());
        assert!(ActivationQuant::new(1.0, 128).is_err());
        let op = PointwiseConvInt8::new(
            &Tensor::from_shape(&[2, 3], &[1f32; 6]).expect("w"),
            &tensor1(&[0f32; 2]),
            Activation::None,
            ActivationQuant::from_min_max(0.0, 1.0),
        )
        .expect("op");
        let mut out = vec![0f32; 4];
        assert!(op.compute(&[0.5; 6], None, &mut out).is_ok());
        assert!(op.compute(&[0.5; 5], None, &mut out).is_err());
        assert!(op.compute(&[0.5; 6], Some(&[0.0; 4]), &mut out).is_err());
        assert!(PointwiseConvInt8::new(
            &Tensor::from_shape(&[2, 3], &[1f32; 6]).expect("w"),
            &tensor1(&[0f32; 3]),
            Activation::None,
            ActivationQuant::from_min_max(0.0, 1.0),
        )
        .is_err());
    }
}

#[cfg(test)]
mod speed {
    use super::*;
    use crate::pointwise::{Kernel, PointwiseConv};

    /// Times `f` (best of 5 rounds of enough calls for about 2·10⁸ multiply-adds, a few
    /// milliseconds), in seconds per call.
    fn time(work: usize, mut f: impl FnMut()) -> f64 {
        let n = (2e8 / work as f64).max(3.0) as usize;
        let mut best = f64::MAX;
        for _ in 0..5 {
            let t = std::time::Instant::now();
            for _ in 0..n {
                f();
            }
            best = best.min(t.elapsed().as_secs_f64() / n as f64);
        }
        best
    }

    /// The f32 and the int8 1x1 convolution on hand_landmark_full's 1x1 shapes, one
    /// thread, hot caches: the dispatched f32 kernel (`MONOHAND_KERNEL` caps it) against
    /// every int8 kernel this CPU runs but the portable one, interleaved (per shape, `ROUNDS`
    /// rounds over all kernels, the best time of each kept):
    /// `cargo test --release -p monohand-tflite int8::speed -- --ignored --nocapture`.
    /// The int8 times include quantizing the f32 input; all write f32 outputs.
    #[test]
    #[ignore = "a measurement, not a test"]
    fn landmark_shapes() {
        const ROUNDS: usize = 4;
        // (rows, cin, cout, how many such layers in hand_landmark_full), from
        // `PER_NODE=1 cargo run --release -p monohand-tflite --example profile_ops`.
        let shapes = SHAPES_LANDMARK_FULL;
        let k32 = Kernel::best();
        let k8: Vec<Int8Kernel> = Int8Kernel::supported()
            .into_iter()
            .filter(|&k| k != Int8Kernel::PORTABLE)
            .collect();
        let mut names = vec![format!("f32 {}", k32.name())];
        names.extend(k8.iter().map(|k| format!("int8 {}", k.name())));
        println!("ms per call (GMAC/s), speedup against f32 in []");
        println!(
            "{:>24} | {}",
            "rows x cin -> cout (n)",
            names
                .iter()
                .map(|n| format!("{n:>24}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let mut totals = vec![0.0; names.len()];
        for &(rows, cin, cout, count) in shapes {
            let mut g = 1u64;
            let mut next = || {
                g = g
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((g >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
            };
            let x: Vec<f32> = (0..rows * cin).map(|_| 3.0 * next() + 3.0).collect();
            let w: Vec<f32> = (0..cout * cin).map(|_| next()).collect();
            let w = Tensor::from_shape(&[cout, cin], &w).expect("w");
            let b = Tensor::zero::<f32>(&[cout]).expect("b");
            let f32op = PointwiseConv::new(&w, &b, Activation::Relu6).expect("op");
            let q = ActivationQuant::from_min_max(0.0, 6.0);
            let i8op = PointwiseConvInt8::new(&w, &b, Activation::Relu6, q).expect("op");
            let mut out = vec![0f32; rows * cout];
            let work = rows * cin * cout;
            let mut best = vec![f64::MAX; names.len()];
            for _ in 0..ROUNDS {
                best[0] = best[0].min(time(work, || {
                    f32op.compute(&x, None, &mut out, k32, false).expect("f32");
                }));
                for (b, &k) in best[1..].iter_mut().zip(&k8) {
                    *b = b.min(time(work, || {
                        i8op.compute_with(&x, None, &mut out, k, false)
                            .expect("int8");
                    }));
                }
            }
            for (t, b) in totals.iter_mut().zip(&best) {
                *t += b * count as f64;
            }
            let cells: Vec<String> = best
                .iter()
                .map(|&t| {
                    format!(
                        "{:7.3} ({:5.1}) [{:4.2}]",
                        t * 1e3,
                        work as f64 / t / 1e9,
                        best[0] / t
                    )
                })
                .collect();
            println!(
                "{:>24} | {}",
                format!("{rows} x {cin} -> {cout} ({count})"),
                cells.join(" | ")
            );
        }
        let cells: Vec<String> = totals
            .iter()
            .map(|&t| format!("{:>15.3} [{:4.2}]", t * 1e3, totals[0] / t))
            .collect();
        println!("{:>24} | {}", "all 30 layers", cells.join(" | "));
    }

    /// hand_landmark_full's 30 1x1 convolutions: (rows, cin, cout, count).
    const SHAPES_LANDMARK_FULL: &[(usize, usize, usize, usize)] = &[
        (12544, 24, 16, 1),
        (12544, 16, 64, 1),
        (3136, 64, 24, 1),
        (3136, 24, 144, 2),
        (3136, 144, 24, 1),
        (784, 144, 40, 1),
        (784, 40, 240, 2),
        (784, 240, 40, 1),
        (196, 240, 80, 1),
        (196, 80, 480, 3),
        (196, 480, 80, 2),
        (196, 480, 112, 1),
        (196, 112, 672, 3),
        (196, 672, 112, 2),
        (49, 672, 192, 1),
        (49, 192, 1152, 4),
        (49, 1152, 192, 3),
    ];
}
