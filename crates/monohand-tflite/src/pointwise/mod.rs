//! A pointwise (1x1, stride 1) convolution operator for tract, channels last.
//!
//! On an NHWC tensor a 1x1 stride-1 convolution is the plain matrix product
//! `[H·W, Cin] x [Cin, Cout]`. tract 0.23 runs it through its generic matrix multiply, which
//! packs the input on every call and applies the bias and activation as separate passes; in
//! the hand-landmark network that is most of the time. This operator
//!
//! * packs the weights once, at load, into panels of [`NR`] output channels (`[Cin][NR]`
//!   per panel, zero padded), so the inner loop reads one contiguous row of a panel per input
//!   channel;
//! * reads the input rows where they are (no packing per call);
//! * applies a fused epilogue while the results are still in registers: bias, the conv's
//!   activation (none, RELU, RELU6), optionally a residual `ADD` of a second input of the same
//!   shape with its own activation, and optionally a per-channel PRELU — the patterns that
//!   follow the 1x1 convolutions in MediaPipe's palm and hand-landmark networks;
//! * runs a hand-written micro-kernel chosen at run time: AVX-512F + VL (8 rows x 32
//!   channels, two panels side by side, in 16-lane registers, an 8-lane one for a last 8 or
//!   fewer channels, masked loads and stores for the channel tail) when the CPU has it, else AVX2 + FMA (6 rows x 16 channels in 12 registers), else a
//!   portable one; in a WebAssembly module built with `simd128`, a 128-bit kernel (2 rows x
//!   16 channels in 8 registers). The portable one is a correct but slow fallback; the
//!   importer uses this operator only where [`PointwiseConv::fast_kernel_available`].
//!
//! The environment variable `MONOHAND_KERNEL` (`portable`, `avx2` or `avx512`, read once per
//! process, [`crate::isa`]) forces a slower kernel than the CPU allows, to compare them in one
//! run: the fastest one at or below that level (so a kernel the CPU lacks gives the best one
//! it has below it; the int8 levels `avxvnni` and `avx512vnni` give the AVX2 + FMA and the
//! AVX-512 kernels). It also steers [`crate::NhwcDepthwise`].
//! `portable` makes [`PointwiseConv::fast_kernel_available`] false, so the importer then
//! keeps tract's own 1x1 convolutions.

use tract_core::internal::*;

use crate::pointwise_common::eval_1x1;
use crate::pointwise_common::{Activation, NR};

/// Rows (pixels) per micro-tile of the portable and AVX2 kernels.
const MR: usize = 6;
/// Rows per micro-tile of the AVX-512 kernel (its tiles are two panels wide: `2·MR512`
/// accumulators plus two weight vectors of the 32 registers).
#[cfg(target_arch = "x86_64")]
const MR512: usize = 8;
/// Rows per micro-tile of the WebAssembly `simd128` kernel: `4·MR128` accumulators of 4
/// lanes for a whole panel, the rows' broadcasts and one weight vector stay within the 16
/// vector registers of an x86-64 engine. (3 rows, 16 registers in all, made a tracked frame
/// slower in Node, 30 against 36 fps: V8 spilled; 4 rows were no faster than 3.
/// docs/performance.md, "monohand in the browser".)
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
const MR128: usize = 2;
/// Input bytes of one block of rows that should stay in L2 while every weight panel passes
/// over it.
const ROW_BLOCK_BYTES: usize = 128 * 1024;

/// Rows from which a product shared between the cores is cut by rows (fewer: by channels).
const ROWS_TO_SPLIT: usize = 256;

/// 1x1 stride-1 convolution on f32 tensors whose last axis holds the `Cin` channels (NHWC),
/// producing `Cout` channels, with the fused epilogue
///
/// `y = act(x·W + b)`, then if a residual input `r` is wired `y = act_r(y + r)`, then if PRELU
/// slopes `α` are set `y = max(y, 0) + α · min(y, 0)`.
///
/// Input 0 is the activation tensor; input 1, present only when built
/// [`with_residual`](Self::with_residual), has the output's shape.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PointwiseConv {
    cin: usize,
    cout: usize,
    /// `[Cout.div_ceil(NR), Cin, NR]`, zero padded.
    packed: Arc<Tensor>,
    /// `[Cout.div_ceil(NR) · NR]`, zero padded.
    bias: Arc<Tensor>,
    activation: Activation,
    residual: Option<Activation>,
    /// Slopes padded like the bias.
    prelu: Option<Arc<Tensor>>,
    /// Share large outputs between the cores ([`crate::split`]).
    split: bool,
}

/// `values` (length `n`) zero padded to a whole number of panels.
fn padded(values: &[f32], n: usize) -> Arc<Tensor> {
    let mut v = vec![0f32; n.div_ceil(NR) * NR];
    v[..n].copy_from_slice(&values[..n]);
    tensor1(&v).into_arc_tensor()
}

impl PointwiseConv {
    /// Packs `weights` (`[Cout, Cin]`, or TFLite's OHWI `[Cout, 1, 1, Cin]`) and `bias`
    /// (`[Cout]`), with the convolution's own `activation`.
    pub fn new(weights: &Tensor, bias: &Tensor, activation: Activation) -> TractResult<Self> {
        let s = weights.shape();
        ensure!(
            (s.len() == 2 || (s.len() == 4 && s[1] == 1 && s[2] == 1)) && s[0] > 0,
            "pointwise weights must be [Cout, Cin] or [Cout, 1, 1, Cin], got {s:?}"
        );
        let (cout, cin) = (s[0], s[s.len() - 1]);
        ensure!(cin > 0, "pointwise convolution without input channels");
        let w = weights.cast_to::<f32>()?;
        let w = w.try_as_plain_ram()?;
        let w = w.as_slice::<f32>()?;
        let b = bias.cast_to::<f32>()?;
        let b = b.try_as_plain_ram()?;
        let b = b.as_slice::<f32>()?;
        ensure!(b.len() == cout, "{} biases for {cout} channels", b.len());
        let panels = cout.div_ceil(NR);
        let mut packed = vec![0f32; panels * cin * NR];
        for (o, row) in w.chunks_exact(cin).enumerate() {
            let (p, j) = (o / NR, o % NR);
            for (i, &v) in row.iter().enumerate() {
                packed[(p * cin + i) * NR + j] = v;
            }
        }
        Ok(PointwiseConv {
            cin,
            cout,
            packed: Tensor::from_shape(&[panels, cin, NR], &packed)?.into_arc_tensor(),
            bias: padded(b, cout),
            activation,
            residual: None,
            prelu: None,
            split: true,
        })
    }

    /// Whether large products are shared between the cores when the network runs alone
    /// (default: true; see `ImportOptions::split_rows`). The results are the same bits.
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
        let a = alpha.cast_to::<f32>()?;
        let a = a.try_as_plain_ram()?;
        let a = a.as_slice::<f32>()?;
        ensure!(
            a.len() == self.cout,
            "{} PRELU slopes for {} channels",
            a.len(),
            self.cout
        );
        self.prelu = Some(padded(a, self.cout));
        Ok(self)
    }

    /// Input channels.
    pub fn input_channels(&self) -> usize {
        self.cin
    }

    /// Output channels.
    pub fn output_channels(&self) -> usize {
        self.cout
    }

    /// Whether this CPU runs a vectorised kernel (x86-64 with AVX2 and FMA, or AVX-512F and
    /// AVX-512VL; WebAssembly built with `simd128`), and `MONOHAND_KERNEL` does not force the
    /// portable one. The portable
    /// fallback is correct but slow (≈ 4 GFLOP/s against ≈ 65-95 for AVX2 + FMA on the
    /// hand-landmark shapes, and slower than tract's own kernels), so the importer only uses
    /// this operator when this is true.
    pub fn fast_kernel_available() -> bool {
        Kernel::best() != Kernel::PORTABLE
    }

    /// Whether a residual input is added (see [`with_residual`](Self::with_residual)).
    pub fn has_residual(&self) -> bool {
        self.residual.is_some()
    }

    /// Whether the epilogue ends with a PRELU (see [`with_prelu`](Self::with_prelu)).
    pub fn has_prelu(&self) -> bool {
        self.prelu.is_some()
    }

    /// The same convolution and epilogue in int8 arithmetic, its input coded with `input`
    /// (weights, bias and slopes recovered exactly from the packed panels).
    pub fn to_int8(
        &self,
        input: crate::int8::ActivationQuant,
    ) -> TractResult<crate::int8::PointwiseConvInt8> {
        let packed = self.packed.try_as_plain_ram()?;
        let packed = packed.as_slice::<f32>()?;
        let mut w = vec![0f32; self.cout * self.cin];
        for (o, row) in w.chunks_exact_mut(self.cin).enumerate() {
            let (p, j) = (o / NR, o % NR);
            for (i, v) in row.iter_mut().enumerate() {
                *v = packed[(p * self.cin + i) * NR + j];
            }
        }
        let first = |t: &Tensor| -> TractResult<Tensor> {
            let t = t.try_as_plain_ram()?;
            Ok(tensor1(&t.as_slice::<f32>()?[..self.cout]))
        };
        let w = Tensor::from_shape(&[self.cout, self.cin], &w)?;
        let mut op =
            crate::int8::PointwiseConvInt8::new(&w, &first(&self.bias)?, self.activation, input)?
                .with_split(self.split);
        if let Some(act) = self.residual {
            op = op.with_residual(act);
        }
        if let Some(alpha) = &self.prelu {
            op = op.with_prelu(&first(alpha)?)?;
        }
        Ok(op)
    }

    /// Calls `f` with the evaluation of `x` (rows of `Cin`) with `residual`.
    fn with_job<R>(
        &self,
        x: &[f32],
        residual: Option<&[f32]>,
        f: impl FnOnce(&Job<'_>) -> TractResult<R>,
    ) -> TractResult<R> {
        let packed = self.packed.try_as_plain_ram()?;
        let bias = self.bias.try_as_plain_ram()?;
        let prelu = self
            .prelu
            .as_ref()
            .map(|a| a.try_as_plain_ram())
            .transpose()?;
        f(&Job {
            x,
            rows: x.len() / self.cin,
            cin: self.cin,
            cout: self.cout,
            packed: packed.as_slice::<f32>()?,
            bias: bias.as_slice::<f32>()?,
            alpha: prelu.as_ref().map(|a| a.as_slice::<f32>()).transpose()?,
            residual,
            act: self.activation.bounds(),
            residual_act: self.residual.unwrap_or_default().bounds(),
        })
    }

    /// The product of `x` (rows of `Cin`) into `out` (rows of `Cout`), with `residual` (the
    /// output's shape) where the operator has one. With `split`, a large product is shared
    /// between the cores ([`crate::split`]): by rows where there are many, else by channels
    /// (the deep 14x14 and 7x7 layers, where each piece would otherwise stream all the
    /// weights for a few rows). Pieces are whole tiles of the kernel, so every value is
    /// computed as in one piece.
    pub(crate) fn compute(
        &self,
        x: &[f32],
        residual: Option<&[f32]>,
        out: &mut [f32],
        kernel: Kernel,
        split: bool,
    ) -> TractResult<()> {
        self.with_job(x, residual, |job| job.run(out, kernel, split))
    }
}

impl Op for PointwiseConv {
    fn name(&self) -> StaticName {
        "MonohandPointwiseConv".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        Ok(vec![format!(
            "{}->{} act {:?} residual {:?} prelu {}",
            self.cin,
            self.cout,
            self.activation,
            self.residual,
            self.prelu.is_some()
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for PointwiseConv {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        eval_1x1(
            &inputs,
            self.cin,
            self.cout,
            self.residual.is_some(),
            "pointwise convolution",
            |x, r, o| self.compute(x, r, o, Kernel::best(), self.split),
        )
    }
}

impl TypedOp for PointwiseConv {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
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

pub(crate) use kernel::{Isa, Kernel};

mod kernel;

impl Kernel {
    /// Every kernel this CPU runs.
    #[cfg(test)]
    fn available() -> Vec<Kernel> {
        Kernel::supported()
    }

    /// Rows per micro-tile.
    fn rows(self) -> usize {
        match self.isa() {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => MR512,
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Isa::Simd128 => MR128,
            _ => MR,
        }
    }

    /// Weight panels per micro-tile.
    fn panels(self) -> usize {
        match self.isa() {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => 2,
            _ => 1,
        }
    }

    /// The tile function for `m` rows and `width` channels (`1 <= m <= self.rows()`,
    /// `1 <= width <= NR · self.panels()`).
    fn tile(self, m: usize, width: usize) -> TileFn {
        // Only the SIMD kernels have a function per tile shape.
        #[cfg(not(any(
            target_arch = "x86_64",
            all(target_arch = "wasm32", target_feature = "simd128")
        )))]
        let _ = (m, width);
        match self.isa() {
            Isa::Portable => tile_portable,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2Fma => avx2::tile(m, width.div_ceil(8)),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => avx512::tile(m, width),
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Isa::Simd128 => wasm::tile(m, width.div_ceil(4)),
        }
    }
}

mod portable;
mod tile;

use portable::tile_portable;
use tile::{Job, Tile, TileFn};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(test)]
mod speed;
#[cfg(test)]
mod tests;
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod wasm;
