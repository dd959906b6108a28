//! monohand's own importer from a `.tflite` flatbuffer to a tract [`TypedModel`].
//!
//! `tract-tflite` 0.23 cannot run MediaPipe's hand and face models as published: it has no
//! `PRELU`, no float16 `DEQUANTIZE` (MediaPipe stores every weight as fp16 behind a
//! `DEQUANTIZE`), and its `MEAN` on float tensors goes through an integer rescale. Its op
//! registry is private, so this crate walks the flatbuffer itself — through the schema
//! `tract_tflite` re-exports — and wires tract-core operators for exactly the operators the
//! MediaPipe palm, hand-landmark and face-detection models use:
//!
//! `DEQUANTIZE` (fp16 constants are widened to f32 at load, so no cast runs at inference),
//! `CONV_2D`, `DEPTHWISE_CONV_2D`, `PRELU`, `ADD`, `MAX_POOL_2D`, `PAD`, `RESIZE_BILINEAR`,
//! `RESHAPE`, `CONCATENATION`, `MEAN`, `FULLY_CONNECTED`, `LOGISTIC`, `RELU`, `RELU6`,
//! plus the fused activations `RELU` and `RELU6`.
//!
//! Anything else is refused with [`ImportError::UnsupportedOperator`] rather than guessed.
//!
//! Four operators are this crate's own tract operators, because tract's generic versions
//! were the largest costs of the networks: [`NhwcDepthwise`] (depthwise convolution with the
//! channels innermost), [`ChannelPrelu`] (PRELU in one pass), [`PointwiseConv`] (the 1x1
//! stride-1 convolutions, i.e. a `[H·W, Cin] x [Cin, Cout]` product, with weights packed at
//! load, an AVX-512 or AVX2 + FMA micro-kernel chosen at run time and a fused epilogue: bias,
//! activation, and the residual `ADD` and/or `PRELU` that follow it when nothing else reads
//! the convolution's result), and [`NhwcConv`] (the other convolutions over few input
//! channels, i.e. the stems: im2col rows gathered a few output rows at a time, padding
//! included, and multiplied with [`PointwiseConv`]'s kernels). A fifth,
//! [`NhwcResizeBilinear`], does the palm detectors' `RESIZE_BILINEAR` in one pass with
//! tract's arithmetic, and [`NhwcMaxPool`] their `MAX_POOL_2D` and channel `PAD`. [`ImportOptions`] switches back to tract's built-in operators.
//!
//! In int8 ([`Precision::Int8`], [`quantize_pointwise`]), [`PointwiseConvInt8`] replaces
//! [`PointwiseConv`], [`NhwcConvInt8`] replaces the stem's [`NhwcConv`] (with a PRELU after
//! it folded in), and a depthwise convolution read only by an int8 1x1 convolution becomes
//! [`NhwcDepthwiseCodes`], which writes the int8 layer's input codes instead of f32.
//!
//! When one network runs alone, [`NhwcDepthwise`], [`PointwiseConv`] and [`NhwcConv`] share
//! a large output between the cores, with the same results bit for bit (see [`Running`] and
//! [`allow_split_here`]; `MONOHAND_OP_THREADS` sets how many threads, `1` none).

#![deny(missing_docs)]

mod conv;
mod depthwise;
mod int8;
mod isa;
mod ops;
mod pointwise;
mod pointwise_common;
mod pool;
mod prelu;
mod quantize;
mod resize;
mod split;
mod tensors;

pub use conv::{NhwcConv, NhwcConvInt8};
pub use depthwise::{NhwcDepthwise, NhwcDepthwiseCodes};
pub use int8::{
    quantize_weights, ActivationQuant, MinMax, PointwiseConvInt8, ACTIVATION_QMAX, WEIGHT_QMAX,
};
pub use pointwise::PointwiseConv;
pub use pointwise_common::Activation;
pub use pool::NhwcMaxPool;
pub use prelu::ChannelPrelu;
pub use quantize::{code_depthwise_results, int8_input_ranges, quantize_pointwise};
pub use resize::NhwcResizeBilinear;
pub use split::{allow_split_here, shared_operators, start_team, team_size, Running};

use std::collections::HashMap;

use tract_core::internal::*;
use tract_tflite::tflite;

pub use ops::SUPPORTED_OPERATORS;

/// The sizes `(N, H, W, C)` of a channels-last tensor, or an error naming `what` for any
/// other rank (the palm detectors' resize and pool take batches of images).
pub(crate) fn nhwc(shape: &[usize], what: &str) -> TractResult<(usize, usize, usize, usize)> {
    match *shape {
        [n, h, w, c] => Ok((n, h, w, c)),
        _ => bail!("{what}: a rank-4 input is needed, got {shape:?}"),
    }
}

/// The arithmetic a network's convolutions run in.
///
/// [`Precision::Int8`] runs the quantizable layers (the 1x1 convolutions,
/// [`PointwiseConvInt8`], and the stems, [`NhwcConvInt8`]) in int8 with activation codes
/// from a calibration
/// ([`int8_input_ranges`], [`quantize_pointwise`]); everything else stays f32.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Precision {
    /// f32 throughout (MediaPipe's own arithmetic; the default).
    #[default]
    F32,
    /// int8 where a calibration codes the layer's input, f32 elsewhere.
    Int8,
}

impl Precision {
    /// Its name in options and records: `f32` or `int8`.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::Int8 => "int8",
        }
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Precision {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "f32" => Ok(Precision::F32),
            "int8" => Ok(Precision::Int8),
            other => Err(format!("precision {other:?} is neither f32 nor int8")),
        }
    }
}

/// Why a `.tflite` file could not be turned into a tract model.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The bytes are not a TFLite flatbuffer.
    #[error("not a valid TFLite flatbuffer: {0}")]
    InvalidFlatbuffer(String),
    /// The model uses an operator this importer does not translate.
    #[error("TFLite operator {0} is not supported by monohand's importer (supported: {SUPPORTED:?})", SUPPORTED = SUPPORTED_OPERATORS)]
    UnsupportedOperator(String),
    /// The model is structurally unexpected (missing subgraph, dynamic shape, ...).
    #[error("unexpected TFLite model structure: {0}")]
    Malformed(String),
    /// tract refused to build or type the graph.
    #[error("tract graph construction failed: {0}")]
    Tract(String),
}

impl From<TractError> for ImportError {
    fn from(e: TractError) -> Self {
        ImportError::Tract(format!("{e:#}"))
    }
}

/// Operators of a `.tflite` model with how often each occurs, in first-seen order.
///
/// Useful to check what a model needs before importing it.
pub fn list_operators(bytes: &[u8]) -> Result<Vec<(String, usize)>, ImportError> {
    let model = parse(bytes)?;
    let graph = main_subgraph(&model)?;
    let mut counts: Vec<(String, usize)> = Vec::new();
    for op in graph.operators().into_iter().flatten() {
        let name = ops::operator_name(&model, &op)?;
        match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += 1,
            None => counts.push((name, 1)),
        }
    }
    Ok(counts)
}

/// Choices of the importer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Translate depthwise convolutions to [`NhwcDepthwise`] (channels-innermost, vectorised)
    /// instead of tract's generic grouped `Conv`. Default: true. (On WebAssembly it needs the
    /// `simd128` kernel: the portable loop alone was 1.4-1.6x slower than tract's `Conv` in
    /// Chromium; with it the two are level, docs/performance.md, "monohand in the browser".)
    pub fast_depthwise: bool,
    /// Translate PRELU with constant per-channel slopes to one [`ChannelPrelu`] pass instead
    /// of four tract element-wise ops. Default: true.
    pub fused_prelu: bool,
    /// Translate 1x1 stride-1 `CONV_2D` to [`PointwiseConv`] (weights packed at load, bias
    /// and activation applied in registers) instead of tract's generic `Conv`, on CPUs where
    /// [`PointwiseConv::fast_kernel_available`] (x86-64 with AVX2 + FMA, WebAssembly with
    /// `simd128`; elsewhere tract's `Conv` is kept either way). Default: true.
    pub fast_pointwise: bool,
    /// With `fast_pointwise`: fold a residual `ADD` (with its activation) and/or a `PRELU`
    /// that is the only consumer of a [`PointwiseConv`]'s result into its epilogue.
    /// Default: true.
    pub fused_pointwise_epilogue: bool,
    /// With `fast_depthwise`: apply a depthwise convolution's fused `RELU`/`RELU6` inside
    /// [`NhwcDepthwise`], on each output row while it is in cache, instead of as tract's
    /// `Max` and `Min` nodes over the whole tensor. Default: true.
    pub fused_depthwise_activation: bool,
    /// With `fast_depthwise`: on CPUs with AVX2 + FMA (or AVX-512), sum each output pixel's
    /// taps in registers over blocks of channels ([`NhwcDepthwise::register_blocked`])
    /// instead of the portable loop that passes over the output row once per tap. The
    /// results are the same bits. Default: true.
    pub register_blocked_depthwise: bool,
    /// Translate the other `CONV_2D`s (kernels larger than 1x1 or strides above 1) with at
    /// most 512 weights per output channel and a NONE/RELU/RELU6 activation — the networks'
    /// first layer — to [`NhwcConv`] (padding, product, bias and activation in one operator)
    /// instead of tract's `Pad`, im2col product and activation nodes, where
    /// [`PointwiseConv::fast_kernel_available`]. Default: true.
    pub fast_conv: bool,
    /// Let [`NhwcDepthwise`], [`PointwiseConv`] and [`NhwcConv`] share a large output
    /// between the cores when the network runs alone: its pieces are computed side by side
    /// by the calling thread and a small process-wide team of helpers (the same results,
    /// bit for bit; see [`Running`], [`allow_split_here`] and `MONOHAND_OP_THREADS` in
    /// docs/pipeline.md). Default: true.
    pub split_rows: bool,
    /// Translate `RESIZE_BILINEAR` to [`NhwcResizeBilinear`] (one pass, a row buffer)
    /// instead of tract's `Resize` (an axis at a time, a new buffer each). The same bits.
    /// Default: true.
    pub fast_resize: bool,
    /// Translate `MAX_POOL_2D` to [`NhwcMaxPool`] (each window folded in registers, stored
    /// once), with a `PAD` of zero channels that alone reads it folded in, instead of tract's
    /// `MaxPool` and `Pad`. The same bits. Default: true.
    pub fast_pool: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            fast_depthwise: true,
            fused_prelu: true,
            fast_pointwise: true,
            fused_pointwise_epilogue: true,
            fused_depthwise_activation: true,
            register_blocked_depthwise: true,
            fast_conv: true,
            split_rows: true,
            fast_resize: true,
            fast_pool: true,
        }
    }
}

/// Translates a `.tflite` flatbuffer into an (unoptimised) tract [`TypedModel`] with the
/// default [`ImportOptions`].
///
/// Inputs and outputs keep the order and shapes of the TFLite subgraph; weights are f32.
pub fn import(bytes: &[u8]) -> Result<TypedModel, ImportError> {
    import_with(bytes, ImportOptions::default())
}

/// [`import`] with explicit options.
pub fn import_with(bytes: &[u8], options: ImportOptions) -> Result<TypedModel, ImportError> {
    let model = parse(bytes)?;
    let graph = main_subgraph(&model)?;
    let mut target = TypedModel::default();
    // TFLite tensor index -> value in the tract graph (a wire, or a constant kept aside so
    // that weights can be reshaped at import time without graph ops).
    let mut values: HashMap<i32, ops::Value> = HashMap::new();
    let inputs = graph
        .inputs()
        .ok_or_else(|| ImportError::Malformed("subgraph has no inputs".into()))?;
    for input in inputs.iter() {
        let (fact, name) = tensors::fact_of(&model, &graph, input)?;
        let wire = target.add_source(name, fact)?;
        values.insert(input, ops::Value::Wire(wire));
    }
    // How many times each tensor is read (by an operator or as a graph output): a result
    // read once may be folded into the operator that produces it.
    let mut uses: HashMap<i32, usize> = HashMap::new();
    for op in graph.operators().into_iter().flatten() {
        for i in op.inputs().into_iter().flatten() {
            *uses.entry(i).or_default() += 1;
        }
    }
    for o in graph.outputs().into_iter().flatten() {
        *uses.entry(o).or_default() += 1;
    }
    let mut cx = ops::Graph {
        target: &mut target,
        values: &mut values,
        uses: &uses,
    };
    for (ix, op) in graph.operators().into_iter().flatten().enumerate() {
        ops::translate(&model, &graph, &op, ix, &mut cx, options)?;
    }
    let mut outputs = tvec!();
    for output in graph.outputs().into_iter().flatten() {
        let value = values.get(&output).ok_or_else(|| {
            ImportError::Malformed(format!("output tensor {output} is never computed"))
        })?;
        outputs.push(value.wire(&mut target, &format!("output_{output}"))?);
    }
    target.select_output_outlets(&outputs)?;
    Ok(target)
}

fn parse(bytes: &[u8]) -> Result<tflite::Model<'_>, ImportError> {
    tflite::root_as_model(bytes).map_err(|e| ImportError::InvalidFlatbuffer(e.to_string()))
}

fn main_subgraph<'a>(model: &tflite::Model<'a>) -> Result<tflite::SubGraph<'a>, ImportError> {
    let subgraphs = model
        .subgraphs()
        .ok_or_else(|| ImportError::Malformed("no subgraphs".into()))?;
    if subgraphs.is_empty() {
        return Err(ImportError::Malformed("no subgraphs".into()));
    }
    Ok(subgraphs.get(0))
}
