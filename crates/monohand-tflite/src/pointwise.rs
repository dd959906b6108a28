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

/// Output channels per packed weight panel (two AVX2 vectors of 8 floats).
pub const NR: usize = 16;
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

/// An activation clamped into the result of a [`PointwiseConv`] (TFLite's fused activations).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Activation {
    /// Identity.
    #[default]
    None,
    /// `max(x, 0)`.
    Relu,
    /// `min(max(x, 0), 6)`.
    Relu6,
}

impl Activation {
    /// The clamp bounds `(low, high)` the activation amounts to.
    pub(crate) fn bounds(self) -> (f32, f32) {
        match self {
            Activation::None => (f32::NEG_INFINITY, f32::INFINITY),
            Activation::Relu => (0.0, f32::INFINITY),
            Activation::Relu6 => (0.0, 6.0),
        }
    }
}

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

/// The `eval` of a 1x1 convolution over channels-last tensors (this operator's and
/// [`crate::PointwiseConvInt8`]'s; input `X` f32, or u8 codes for a coded
/// [`crate::PointwiseConvInt8`]; output f32): checks the inputs (`cin` channels, a residual of the
/// output's shape when `has_residual`), makes the output (`cout` channels) and has
/// `compute(input, residual, output)` write every one of its values.
pub(crate) fn eval_1x1<X: Datum>(
    inputs: &TVec<TValue>,
    cin: usize,
    cout: usize,
    has_residual: bool,
    what: &str,
    compute: impl FnOnce(&[X], Option<&[f32]>, &mut [f32]) -> TractResult<()>,
) -> TractResult<TVec<TValue>> {
    ensure!(
        inputs.len() == 1 + has_residual as usize,
        "{what} got {} inputs",
        inputs.len()
    );
    let x = &inputs[0];
    let mut shape: TVec<usize> = x.shape().into();
    ensure!(
        shape.last() == Some(&cin),
        "{what} over {cin} channels, input {shape:?}"
    );
    if let Some(last) = shape.last_mut() {
        *last = cout;
    }
    if let Some(r) = inputs.get(1) {
        ensure!(
            r.shape() == &*shape,
            "residual {:?} for an output {shape:?}",
            r.shape()
        );
    }
    // SAFETY: the tensor's values are left unwritten, and nothing reads one before it is
    // written: `compute` (each operator's) stores every output value from its epilogue (the
    // tiles cover all rows and channels, and only store into the output), and an error
    // drops the tensor without reading it (f32 has no drop).
    let mut output = unsafe { Tensor::uninitialized::<f32>(&shape)? };
    {
        let xr = x.try_as_plain_ram()?;
        let rr = inputs.get(1).map(|r| r.try_as_plain_ram()).transpose()?;
        let mut o = output.try_as_plain_ram_mut()?;
        compute(
            xr.as_slice::<X>()?,
            rr.as_ref().map(|r| r.as_slice::<f32>()).transpose()?,
            o.as_slice_mut::<f32>()?,
        )?;
    }
    Ok(tvec!(output.into_tvalue()))
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

/// The kernel type, in a module of its own so that nothing else can make one.
mod kernel {
    #[cfg(target_arch = "x86_64")]
    use crate::isa::Cpu;
    use crate::isa::Level;

    /// The instruction set of a micro-kernel.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(crate) enum Isa {
        /// Plain Rust, any CPU.
        Portable,
        /// `std::arch` AVX2 + FMA intrinsics.
        #[cfg(target_arch = "x86_64")]
        Avx2Fma,
        /// `std::arch` AVX-512F + VL intrinsics.
        #[cfg(target_arch = "x86_64")]
        Avx512,
        /// `core::arch::wasm32` 128-bit SIMD, in a module built with `simd128` (a
        /// WebAssembly engine either runs such a module or refuses to load it, so there is
        /// nothing to detect at run time).
        #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
        Simd128,
    }

    /// A micro-kernel that this CPU runs. Its field is private: a `Kernel` is made only by
    /// run-time detection ([`Kernel::supported`], [`Kernel::best`]), or is the portable one,
    /// so holding one shows that the CPU has the features of its [`Isa`] — what the
    /// `unsafe` calls of the intrinsics behind it rely on.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(crate) struct Kernel(Isa);

    impl Kernel {
        /// The portable kernel (any CPU).
        pub(crate) const PORTABLE: Kernel = Kernel(Isa::Portable);

        /// Its instruction set (which the CPU has).
        pub(crate) fn isa(self) -> Isa {
            self.0
        }

        /// The name of its level in `MONOHAND_KERNEL` (which the measurements print).
        #[cfg(test)]
        pub(crate) fn name(self) -> &'static str {
            match self.0 {
                Isa::Portable => "portable",
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2Fma => "avx2",
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => "avx512",
                #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
                Isa::Simd128 => "simd128",
            }
        }

        /// Its instruction-set level (what `MONOHAND_KERNEL` caps).
        pub(crate) fn level(self) -> Level {
            match self.0 {
                Isa::Portable => Level::Portable,
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2Fma => Level::Avx2,
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => Level::Avx512,
                #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
                Isa::Simd128 => Level::Avx2,
            }
        }

        /// Every kernel this CPU runs, slowest first (detected at run time, [`Cpu`]).
        pub(crate) fn supported() -> Vec<Kernel> {
            #[allow(unused_mut)]
            let mut v = vec![Kernel::PORTABLE];
            #[cfg(target_arch = "x86_64")]
            {
                let cpu = Cpu::get();
                if cpu.avx2_fma() {
                    v.push(Kernel(Isa::Avx2Fma));
                }
                if cpu.avx512f_vl() {
                    v.push(Kernel(Isa::Avx512));
                }
            }
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            v.push(Kernel(Isa::Simd128));
            v
        }

        /// The fastest kernel this CPU runs at or below the level `MONOHAND_KERNEL` names
        /// (decided once per process; see [`crate::isa`]).
        pub(crate) fn best() -> Kernel {
            static BEST: std::sync::OnceLock<Kernel> = std::sync::OnceLock::new();
            *BEST.get_or_init(|| {
                crate::isa::choose(
                    &Kernel::supported(),
                    Kernel::level,
                    crate::isa::cap(),
                    Kernel::PORTABLE,
                )
            })
        }
    }
}

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
            Isa::Simd128 => simd128::tile(m, width.div_ceil(4)),
        }
    }
}

/// One micro-tile: `m` rows of the input against one weight panel, epilogue included.
///
/// Pointers are valid for: `a`: `m` rows of `lda` floats, of which the first `k <= lda` are
/// read; `b`: `k` rows of [`NR`] floats (one panel), followed, when `width > NR`, by the next
/// panel's `k` rows; `bias`, `alpha`: `NR · width.div_ceil(NR)` floats; `out`, `res`: `m`
/// rows of stride `ldo`, `width` floats each. `alpha`, `res` may be null (absent).
struct Tile {
    a: *const f32,
    lda: usize,
    k: usize,
    b: *const f32,
    out: *mut f32,
    res: *const f32,
    ldo: usize,
    m: usize,
    width: usize,
    bias: *const f32,
    alpha: *const f32,
    act: (f32, f32),
    residual_act: (f32, f32),
}

/// A micro-kernel for one tile (see [`Kernel::tile`]).
///
/// # Safety
/// Call it only with a [`Tile`] that satisfies `Tile`'s contract and the `m` and `width` it
/// was chosen for, on a CPU with the features of the kernel that gave it.
type TileFn = unsafe fn(&Tile);

/// One evaluation, its slices checked against each other by [`Job::run`].
struct Job<'a> {
    x: &'a [f32],
    rows: usize,
    cin: usize,
    cout: usize,
    packed: &'a [f32],
    bias: &'a [f32],
    alpha: Option<&'a [f32]>,
    residual: Option<&'a [f32]>,
    act: (f32, f32),
    residual_act: (f32, f32),
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
    fn run(&self, out: &mut [f32], kernel: Kernel, split: bool) -> TractResult<()> {
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
unsafe fn tile_portable(t: &Tile) {
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

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Tile, TileFn, MR, NR};
    use std::arch::x86_64::*;

    /// The monomorphised tile for `m` rows and `v` vectors.
    pub(super) fn tile(m: usize, v: usize) -> TileFn {
        const _: () = assert!(MR == 6 && NR == 16);
        match (m, v) {
            (1, 1) => micro::<1, 1>,
            (2, 1) => micro::<2, 1>,
            (3, 1) => micro::<3, 1>,
            (4, 1) => micro::<4, 1>,
            (5, 1) => micro::<5, 1>,
            (6, 1) => micro::<6, 1>,
            (1, _) => micro::<1, 2>,
            (2, _) => micro::<2, 2>,
            (3, _) => micro::<3, 2>,
            (4, _) => micro::<4, 2>,
            (5, _) => micro::<5, 2>,
            _ => micro::<6, 2>,
        }
    }

    /// `M` rows x `V` vectors of 8 channels accumulated in `M·V` registers; the epilogue runs
    /// on the registers and stores with a mask where the panel is narrower than `8·V`.
    ///
    /// # Safety
    /// The CPU has AVX2 and FMA; `t` satisfies `Tile`'s contract with `t.m == M` and
    /// `8·(V-1) < t.width <= 8·V`.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn micro<const M: usize, const V: usize>(t: &Tile) {
        // SAFETY: the CPU has AVX2 and FMA (the contract). The reads and writes stay in the
        // tile (`Tile`'s contract, m == M, 8·(V-1) < width <= 8·V <= NR): `a` at rows
        // i < M, columns < k <= lda; `b` at k rows of the panel, 8·V <= NR values each;
        // `bias` and `alpha` at 8·V <= NR values; `res` and `out` at rows i < M, 8·V
        // channels of which the last vector's lanes at and past `width` are masked off.
        unsafe {
            let mut acc = [[_mm256_setzero_ps(); V]; M];
            let mut a = t.a;
            let mut b = t.b;
            for _ in 0..t.k {
                let mut bv = [_mm256_setzero_ps(); V];
                for (v, bv) in bv.iter_mut().enumerate() {
                    *bv = _mm256_loadu_ps(b.add(8 * v));
                }
                for (i, acc) in acc.iter_mut().enumerate() {
                    let x = _mm256_broadcast_ss(&*a.add(i * t.lda));
                    for (acc, &bv) in acc.iter_mut().zip(&bv) {
                        *acc = _mm256_fmadd_ps(x, bv, *acc);
                    }
                }
                a = a.add(1);
                b = b.add(NR);
            }
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
                    let mut y = _mm256_add_ps(acc, _mm256_loadu_ps(t.bias.add(8 * v)));
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
                        y = _mm256_fmadd_ps(al, _mm256_min_ps(y, zero), _mm256_max_ps(y, zero));
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
mod avx512 {
    use super::{Tile, TileFn, MR512, NR};
    use std::arch::x86_64::*;

    /// The tiles of 1 to 8 rows for `V` 16-lane and `H` 8-lane vectors.
    macro_rules! heights {
        ($v:literal, $h:literal) => {
            [
                micro::<1, $v, $h>,
                micro::<2, $v, $h>,
                micro::<3, $v, $h>,
                micro::<4, $v, $h>,
                micro::<5, $v, $h>,
                micro::<6, $v, $h>,
                micro::<7, $v, $h>,
                micro::<8, $v, $h>,
            ]
        };
    }

    /// By width class (1-8, 9-16, 17-24, 25-32 channels), then height.
    static TILES: [[TileFn; MR512]; 4] = [
        heights!(0, 1),
        heights!(1, 0),
        heights!(1, 1),
        heights!(2, 0),
    ];

    /// The monomorphised tile for `m` rows and `width` channels (`1 <= width <= 32`): whole
    /// 16-lane vectors, and an 8-lane one where at most 8 channels are left (on cores that
    /// split 512-bit operations in two, such as Zen 4, it costs half).
    pub(super) fn tile(m: usize, width: usize) -> TileFn {
        TILES[(width.clamp(1, 2 * NR) - 1) / 8][m.clamp(1, MR512) - 1]
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

    /// `M` rows x (`V` vectors of 16 channels, then `H` of 8) accumulated in registers; the
    /// epilogue runs on the registers, and the last vector loads and stores under a mask
    /// where the tile is narrower than the vectors.
    ///
    /// # Safety
    /// The CPU has AVX-512F and AVX-512VL; `t` satisfies `Tile`'s contract with `t.m == M`,
    /// `H <= 1`, `V + H >= 1` and `16·V + 8·H - (8 if H else 16) < t.width <= 16·V + 8·H`.
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn micro<const M: usize, const V: usize, const H: usize>(t: &Tile) {
        // SAFETY: the CPU has AVX-512F and VL (the contract). The reads and writes stay in
        // the tile (`Tile`'s contract, m == M): `a` at rows i < M, columns < k <= lda; `b` at
        // k rows of the first panel, and of the second where 16·V + 8·H > NR (then
        // width > NR: two panels); `bias` and `alpha` at 16·V + 8·H values, within
        // NR·width.div_ceil(NR); `res` and `out` at rows i < M, 16·V + 8·H channels of
        // which the last vector's lanes at and past `width` are masked off.
        unsafe {
            let mut acc = [[_mm512_setzero_ps(); V]; M];
            let mut half = [[_mm256_setzero_ps(); H]; M];
            let mut a = t.a;
            let mut b = t.b;
            // The second panel's rows start a whole panel further.
            let panel = t.k * NR;
            for _ in 0..t.k {
                let mut bv = [_mm512_setzero_ps(); V];
                for (v, bv) in bv.iter_mut().enumerate() {
                    *bv = _mm512_loadu_ps(b.add(v * panel));
                }
                let mut bh = [_mm256_setzero_ps(); H];
                for bh in bh.iter_mut() {
                    *bh = _mm256_loadu_ps(b.add(V * panel));
                }
                for (i, (acc, half)) in acc.iter_mut().zip(half.iter_mut()).enumerate() {
                    let s = *a.add(i * t.lda);
                    let x = _mm512_set1_ps(s);
                    for (acc, &bv) in acc.iter_mut().zip(&bv) {
                        *acc = _mm512_fmadd_ps(x, bv, *acc);
                    }
                    let x = _mm256_set1_ps(s);
                    for (half, &bh) in half.iter_mut().zip(&bh) {
                        *half = _mm256_fmadd_ps(x, bh, *half);
                    }
                }
                a = a.add(1);
                b = b.add(NR);
            }
            // Lanes of the last vector: the 16-lane one if there is no 8-lane one.
            let last = if H == 0 {
                lanes(t.width - 16 * (V - 1))
            } else {
                lanes(t.width - 16 * V)
            };
            let (lo, hi) = (_mm512_set1_ps(t.act.0), _mm512_set1_ps(t.act.1));
            let (rlo, rhi) = (
                _mm512_set1_ps(t.residual_act.0),
                _mm512_set1_ps(t.residual_act.1),
            );
            let zero = _mm512_setzero_ps();
            for (i, (acc, half)) in acc.iter().zip(&half).enumerate() {
                for (v, &acc) in acc.iter().enumerate() {
                    let mask = if H == 0 && v + 1 == V { last } else { 0xffff };
                    let at = i * t.ldo + 16 * v;
                    let mut y = _mm512_add_ps(acc, _mm512_loadu_ps(t.bias.add(16 * v)));
                    y = _mm512_min_ps(_mm512_max_ps(y, lo), hi);
                    if !t.res.is_null() {
                        let r = _mm512_maskz_loadu_ps(mask, t.res.add(at));
                        y = _mm512_min_ps(_mm512_max_ps(_mm512_add_ps(y, r), rlo), rhi);
                    }
                    if !t.alpha.is_null() {
                        let al = _mm512_loadu_ps(t.alpha.add(16 * v));
                        y = _mm512_fmadd_ps(al, _mm512_min_ps(y, zero), _mm512_max_ps(y, zero));
                    }
                    _mm512_mask_storeu_ps(t.out.add(at), mask, y);
                }
                for &acc in half {
                    let mask = last as u8;
                    let at = i * t.ldo + 16 * V;
                    let y = _mm256_add_ps(acc, _mm256_loadu_ps(t.bias.add(16 * V)));
                    let y = _mm256_min_ps(
                        _mm256_max_ps(y, _mm512_castps512_ps256(lo)),
                        _mm512_castps512_ps256(hi),
                    );
                    let mut y = y;
                    if !t.res.is_null() {
                        let r = _mm256_maskz_loadu_ps(mask, t.res.add(at));
                        y = _mm256_min_ps(
                            _mm256_max_ps(_mm256_add_ps(y, r), _mm512_castps512_ps256(rlo)),
                            _mm512_castps512_ps256(rhi),
                        );
                    }
                    if !t.alpha.is_null() {
                        let al = _mm256_loadu_ps(t.alpha.add(16 * V));
                        let z = _mm256_setzero_ps();
                        y = _mm256_fmadd_ps(al, _mm256_min_ps(y, z), _mm256_max_ps(y, z));
                    }
                    _mm256_mask_storeu_ps(t.out.add(at), mask, y);
                }
            }
        }
    }
}

#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod simd128 {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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

    fn clamp(y: f64, a: Activation) -> f64 {
        let (lo, hi) = a.bounds();
        y.max(lo as f64).min(hi as f64)
    }

    /// The epilogue written out naively, in f64.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        x: &[f32],
        w: &[f32],
        b: &[f32],
        (rows, cin, cout): (usize, usize, usize),
        act: Activation,
        res: Option<(&[f32], Activation)>,
        alpha: Option<&[f32]>,
    ) -> Vec<f32> {
        let mut out = vec![0f32; rows * cout];
        for r in 0..rows {
            for o in 0..cout {
                let mut acc = b[o] as f64;
                for i in 0..cin {
                    acc += x[r * cin + i] as f64 * w[o * cin + i] as f64;
                }
                let mut y = clamp(acc, act);
                if let Some((res, ract)) = res {
                    y = clamp(y + res[r * cout + o] as f64, ract);
                }
                if let Some(al) = alpha {
                    y = y.max(0.0) + al[o] as f64 * y.min(0.0);
                }
                out[r * cout + o] = y as f32;
            }
        }
        out
    }

    const ACTS: [Activation; 3] = [Activation::None, Activation::Relu, Activation::Relu6];

    #[test]
    fn every_kernel_and_epilogue_matches_a_naive_reference() {
        let mut g = Lcg(7);
        // (rows, cin, cout): channel counts off the panel and vector widths, row counts off
        // the tile height, and one input larger than a row block.
        let shapes = [
            (1, 1, 1),
            (5, 3, 7),
            (6, 8, 16),
            (7, 17, 23),
            (13, 16, 24),
            (11, 33, 2),
            (25, 19, 36),
            (9, 40, 108),
            (12, 64, 9),
            (700, 64, 40),
        ];
        for kernel in Kernel::available() {
            for &(rows, cin, cout) in &shapes {
                let x = g.vec(rows * cin, 4.0);
                let w = g.vec(cout * cin, 1.0);
                let b = g.vec(cout, 2.0);
                let r = g.vec(rows * cout, 4.0);
                let alpha = g.vec(cout, 0.5);
                let wt = Tensor::from_shape(&[cout, 1, 1, cin], &w).expect("w");
                let bt = tensor1(&b);
                for act in ACTS {
                    let residuals = [None, Some(Activation::None), Some(Activation::Relu6)];
                    for ract in residuals {
                        for prelu in [false, true] {
                            let mut op = PointwiseConv::new(&wt, &bt, act).expect("op");
                            if let Some(ract) = ract {
                                op = op.with_residual(ract);
                            }
                            if prelu {
                                op = op.with_prelu(&tensor1(&alpha)).expect("prelu");
                            }
                            let mut got = vec![f32::NAN; rows * cout];
                            op.compute(&x, ract.map(|_| &r[..]), &mut got, kernel, false)
                                .expect("compute");
                            let want = reference(
                                &x,
                                &w,
                                &b,
                                (rows, cin, cout),
                                act,
                                ract.map(|a| (&r[..], a)),
                                prelu.then_some(&alpha[..]),
                            );
                            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                                assert!(
                                    (g - w).abs() <= 1e-4 * (1.0 + w.abs()),
                                    "{kernel:?} {rows}x{cin}->{cout} act {act:?} res {ract:?} \
                                     prelu {prelu} at {k}: {g} vs {w}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// The `simd128` kernel sums as the portable one (a product, then a sum, in the same
    /// order): the same bits. (Run by `scripts/web-test.sh` under Node's WASI.) With
    /// `relaxed-simd` its sums may be fused, as the AVX2 and AVX-512 kernels' are, and it is
    /// held to the naive reference as they are (`every_kernel_and_epilogue_...`).
    #[cfg(all(
        target_arch = "wasm32",
        target_feature = "simd128",
        not(target_feature = "relaxed-simd")
    ))]
    #[test]
    fn the_simd128_kernel_gives_the_portable_kernels_bits() {
        let mut g = Lcg(11);
        let simd = Kernel::best();
        assert_eq!(simd.isa(), Isa::Simd128);
        for (rows, cin, cout) in [(7, 17, 23), (13, 16, 24), (25, 19, 36), (300, 64, 40)] {
            let x = g.vec(rows * cin, 4.0);
            let w = g.vec(cout * cin, 1.0);
            let r = g.vec(rows * cout, 4.0);
            let wt = Tensor::from_shape(&[cout, 1, 1, cin], &w).expect("w");
            let op = PointwiseConv::new(&wt, &tensor1(&g.vec(cout, 2.0)), Activation::Relu6)
                .expect("op")
                .with_residual(Activation::None)
                .with_prelu(&tensor1(&g.vec(cout, 0.5)))
                .expect("prelu");
            let mut want = vec![f32::NAN; rows * cout];
            let mut got = vec![f32::NAN; rows * cout];
            op.compute(&x, Some(&r), &mut want, Kernel::PORTABLE, false)
                .expect("portable");
            op.compute(&x, Some(&r), &mut got, simd, false)
                .expect("simd128");
            let differ = crate::split::testing::differing_bits(&got, &want);
            assert_eq!(differ, 0, "{rows}x{cin}->{cout}");
        }
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
            let wt = Tensor::from_shape(&[cout, cin], &g.vec(cout * cin, 0.5)).expect("w");
            let (bias, alpha) = (tensor1(&g.vec(cout, 1.0)), tensor1(&g.vec(cout, 1.0)));
            let make = |split| {
                let op = PointwiseConv::new(&wt, &bias, Activation::Relu6)
                    .expect("op")
                    .with_split(split);
                match residual {
                    true => op
                        .with_residual(Activation::None)
                        .with_prelu(&alpha)
                        .expect("prelu"),
                    false => op,
                }
            };
            let mut inputs =
                vec![Tensor::from_shape(&[1, rows, 1, cin], &g.vec(rows * cin, 2.0)).expect("x")];
            if residual {
                inputs.push(
                    Tensor::from_shape(&[1, rows, 1, cout], &g.vec(rows * cout, 2.0)).expect("r"),
                );
            }
            crate::split::testing::same_bits_split(&make(true), &make(false), &inputs);
        }
    }

    #[test]
    fn evaluates_as_a_tract_operator_with_a_residual() {
        let mut g = Lcg(11);
        let (h, w, cin, cout) = (3, 5, 10, 12);
        let x = g.vec(h * w * cin, 1.0);
        let k = g.vec(cout * cin, 1.0);
        let b = g.vec(cout, 1.0);
        let r = g.vec(h * w * cout, 1.0);
        let op = PointwiseConv::new(
            &Tensor::from_shape(&[cout, cin], &k).expect("k"),
            &tensor1(&b),
            Activation::Relu,
        )
        .expect("op")
        .with_residual(Activation::None);
        let out = op
            .eval_out_of_plan(tvec!(
                Tensor::from_shape(&[1, h, w, cin], &x)
                    .expect("x")
                    .into_tvalue(),
                Tensor::from_shape(&[1, h, w, cout], &r)
                    .expect("r")
                    .into_tvalue()
            ))
            .expect("eval")
            .expect("evaluates out of plan");
        assert_eq!(out[0].shape(), &[1, h, w, cout]);
        let got = out[0].try_as_plain_ram().expect("ram");
        let got = got.as_slice::<f32>().expect("f32");
        let want = reference(
            &x,
            &k,
            &b,
            (h * w, cin, cout),
            Activation::Relu,
            Some((&r, Activation::None)),
            None,
        );
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-5, "{g} vs {w}");
        }
    }
}

#[cfg(test)]
mod speed {
    use super::*;

    /// GFLOP/s of the dispatched kernel (`MONOHAND_KERNEL=portable|avx2|avx512` forces one)
    /// on the hand-landmark (full) and some palm shapes:
    /// `cargo test --release -p monohand-tflite pointwise::speed -- --ignored --nocapture`.
    #[test]
    #[ignore = "a measurement, not a test"]
    fn landmark_shapes() {
        let shapes = [
            (12544, 24, 16),
            (12544, 16, 64),
            (3136, 64, 24),
            (3136, 24, 144),
            (3136, 144, 24),
            (784, 144, 40),
            (784, 40, 240),
            (784, 240, 40),
            (196, 240, 80),
            (196, 80, 480),
            (196, 480, 80),
            (196, 112, 672),
            (196, 672, 112),
            (49, 192, 1152),
            (49, 1152, 192),
            (576, 128, 128),
            (144, 256, 256),
            (9216, 32, 32),
        ];
        let kernel = Kernel::best();
        for (rows, cin, cout) in shapes {
            let x = vec![0.5f32; rows * cin];
            let w = Tensor::zero::<f32>(&[cout, cin]).expect("w");
            let b = Tensor::zero::<f32>(&[cout]).expect("b");
            let op = PointwiseConv::new(&w, &b, Activation::Relu6).expect("op");
            let mut out = vec![0f32; rows * cout];
            let n = (1e9 / (rows * cin * cout) as f64).max(3.0) as usize;
            let mut best = f64::MAX;
            for _ in 0..7 {
                let t = std::time::Instant::now();
                for _ in 0..n {
                    op.compute(&x, None, &mut out, kernel, false).expect("run");
                }
                best = best.min(t.elapsed().as_secs_f64() / n as f64);
            }
            let gflops = 2.0 * (rows * cin * cout) as f64 / best / 1e9;
            println!(
                "{rows:>6} x {cin:>5} -> {cout:>5}: {:8.3} ms {gflops:6.1} GFLOP/s",
                best * 1e3
            );
        }
    }
}
