//! Translation of individual TFLite operators into tract-core operators.

use std::collections::HashMap;

use tract_core::internal::*;
use tract_core::ops::array::{Pad, PadMode, TypedConcat};
use tract_core::ops::change_axes::wire_with_rank_broadcast;
use tract_core::ops::cnn::{Conv, KernelFormat, MaxPool, PaddingSpec, PoolSpec};
use tract_core::ops::einsum::EinSum;
use tract_core::ops::math;
use tract_core::ops::nn::{
    sigmoid, CoordTransformer, DataFormat, Interpolator, Nearest, Reduce, Reducer, Resize,
};
use tract_tflite::tflite::{self, ActivationFunctionType, BuiltinOperator, Padding};

use super::pointwise::PointwiseConv;
use super::pointwise_common::Activation;
use super::{tensors, ImportError};

/// Names of the TFLite builtin operators [`super::import`] translates.
pub const SUPPORTED_OPERATORS: &[&str] = &[
    "DEQUANTIZE",
    "CONV_2D",
    "DEPTHWISE_CONV_2D",
    "PRELU",
    "ADD",
    "MAX_POOL_2D",
    "PAD",
    "RESIZE_BILINEAR",
    "RESHAPE",
    "CONCATENATION",
    "MEAN",
    "FULLY_CONNECTED",
    "LOGISTIC",
    "RELU",
    "RELU6",
];

/// A TFLite tensor as seen from the tract graph under construction.
#[derive(Clone, Debug)]
pub(super) enum Value {
    /// Computed by a node.
    Wire(OutletId),
    /// A constant (weights), kept out of the graph until an operator consumes it.
    Const(Arc<Tensor>),
}

impl Value {
    /// The value as a wire, adding a constant node if needed.
    pub(super) fn wire(&self, target: &mut TypedModel, name: &str) -> TractResult<OutletId> {
        match self {
            Value::Wire(w) => Ok(*w),
            Value::Const(t) => {
                let name = target.unique_name(name).to_string();
                target.add_const(name, t.clone())
            }
        }
    }
}

/// The builtin operator code of an operator, honouring the deprecated 8-bit field.
fn builtin_code(
    model: &tflite::Model,
    op: &tflite::Operator,
) -> Result<BuiltinOperator, ImportError> {
    let codes = model
        .operator_codes()
        .ok_or_else(|| ImportError::Malformed("no operator codes".into()))?;
    let ix = op.opcode_index() as usize;
    if ix >= codes.len() {
        return Err(ImportError::Malformed(format!(
            "opcode index {ix} out of range"
        )));
    }
    let code = codes.get(ix);
    Ok(BuiltinOperator(
        code.builtin_code()
            .0
            .max(code.deprecated_builtin_code() as i32),
    ))
}

/// Human-readable name of an operator's builtin code.
pub(super) fn operator_name(
    model: &tflite::Model,
    op: &tflite::Operator,
) -> Result<String, ImportError> {
    let code = builtin_code(model, op)?;
    Ok(code
        .variant_name()
        .map(str::to_string)
        .unwrap_or_else(|| format!("builtin #{}", code.0)))
}

/// The graph under construction, shared by all operator translations.
pub(super) struct Graph<'a> {
    /// The tract model.
    pub(super) target: &'a mut TypedModel,
    /// TFLite tensor index -> its value in `target`.
    pub(super) values: &'a mut HashMap<i32, Value>,
    /// TFLite tensor index -> how many times it is read (graph outputs count).
    pub(super) uses: &'a HashMap<i32, usize>,
}

/// Everything an operator translation needs.
struct Ctx<'a, 'm> {
    model: &'a tflite::Model<'m>,
    graph: &'a tflite::SubGraph<'m>,
    op: &'a tflite::Operator<'m>,
    target: &'a mut TypedModel,
    values: &'a mut HashMap<i32, Value>,
    uses: &'a HashMap<i32, usize>,
    prefix: String,
    inputs: Vec<i32>,
    options: super::ImportOptions,
}

impl Ctx<'_, '_> {
    fn value(&mut self, slot: usize) -> Result<Value, ImportError> {
        let id = *self.inputs.get(slot).ok_or_else(|| {
            ImportError::Malformed(format!("{}: missing input {slot}", self.prefix))
        })?;
        if let Some(v) = self.values.get(&id) {
            return Ok(v.clone());
        }
        let t = tensors::constant_of(self.model, self.graph, id)?.ok_or_else(|| {
            ImportError::Malformed(format!(
                "{}: input tensor {id} is neither computed nor constant",
                self.prefix
            ))
        })?;
        let v = Value::Const(t.into_arc_tensor());
        self.values.insert(id, v.clone());
        Ok(v)
    }

    fn has_input(&self, slot: usize) -> bool {
        self.inputs.get(slot).is_some_and(|&id| id >= 0)
    }

    fn konst(&mut self, slot: usize) -> Result<Arc<Tensor>, ImportError> {
        match self.value(slot)? {
            Value::Const(t) => Ok(t),
            Value::Wire(w) => match self.target.outlet_fact(w)?.konst.clone() {
                Some(t) => Ok(t),
                None => Err(ImportError::Malformed(format!(
                    "{}: input {slot} must be constant",
                    self.prefix
                ))),
            },
        }
    }

    fn wire(&mut self, slot: usize) -> Result<OutletId, ImportError> {
        let v = self.value(slot)?;
        let name = format!("{}.in{slot}", self.prefix);
        Ok(v.wire(self.target, &name)?)
    }

    fn add_const(&mut self, suffix: &str, t: Tensor) -> Result<OutletId, ImportError> {
        let name = self
            .target
            .unique_name(format!("{}.{suffix}", self.prefix))
            .to_string();
        Ok(self.target.add_const(name, t)?)
    }

    fn node(
        &mut self,
        suffix: &str,
        op: impl Into<Box<dyn TypedOp>>,
        inputs: &[OutletId],
    ) -> Result<OutletId, ImportError> {
        let name = self
            .target
            .unique_name(format!("{}.{suffix}", self.prefix))
            .to_string();
        Ok(self.target.wire_node(name, op, inputs)?[0])
    }

    fn broadcast(
        &mut self,
        suffix: &str,
        op: impl Into<Box<dyn TypedOp>>,
        inputs: &[OutletId],
    ) -> Result<OutletId, ImportError> {
        let name = self
            .target
            .unique_name(format!("{}.{suffix}", self.prefix))
            .to_string();
        Ok(wire_with_rank_broadcast(name, self.target, op, inputs)?[0])
    }

    fn activation(
        &mut self,
        wire: OutletId,
        f: ActivationFunctionType,
    ) -> Result<OutletId, ImportError> {
        match f {
            ActivationFunctionType::NONE => Ok(wire),
            ActivationFunctionType::RELU => self.relu(wire, None),
            ActivationFunctionType::RELU6 => self.relu(wire, Some(6.0)),
            other => Err(ImportError::UnsupportedOperator(format!(
                "fused activation {other:?}"
            ))),
        }
    }

    fn relu(&mut self, wire: OutletId, cap: Option<f32>) -> Result<OutletId, ImportError> {
        let zero = self.add_const("zero", tensor0(0f32))?;
        let mut y = self.broadcast("relu", math::max(), &[wire, zero])?;
        if let Some(cap) = cap {
            let c = self.add_const("cap", tensor0(cap))?;
            y = self.broadcast("relu_cap", math::min(), &[y, c])?;
        }
        Ok(y)
    }
}

fn padding(p: Padding) -> Result<PaddingSpec, ImportError> {
    match p {
        Padding::SAME => Ok(PaddingSpec::SameUpper),
        Padding::VALID => Ok(PaddingSpec::Valid),
        other => Err(ImportError::Malformed(format!("padding {other:?}"))),
    }
}

fn options_missing(what: &str) -> ImportError {
    ImportError::Malformed(format!("{what} operator without its options"))
}

/// A stride, dilation or window size from an operator's options: at least 1.
fn at_least_one(v: i32, what: &str, prefix: &str) -> Result<usize, ImportError> {
    if v >= 1 {
        Ok(v as usize)
    } else {
        Err(ImportError::Malformed(format!(
            "{prefix}: {what} {v} (must be at least 1)"
        )))
    }
}

/// An axis of a tensor of rank `rank`, counted from the end when negative (TFLite's
/// convention): an error unless `-rank <= axis < rank`.
fn axis_in(axis: i64, rank: usize, what: &str, prefix: &str) -> Result<usize, ImportError> {
    let r = rank as i64;
    let a = if axis < 0 { axis + r } else { axis };
    if (0..r).contains(&a) {
        Ok(a as usize)
    } else {
        Err(ImportError::Malformed(format!(
            "{prefix}: {what} axis {axis} out of range for rank {rank}"
        )))
    }
}

/// Translates operator number `ix` of the subgraph, recording its output in `values`.
pub(super) fn translate(
    model: &tflite::Model,
    graph: &tflite::SubGraph,
    op: &tflite::Operator,
    ix: usize,
    g: &mut Graph,
    options: super::ImportOptions,
) -> Result<(), ImportError> {
    let code = builtin_code(model, op)?;
    let inputs: Vec<i32> = op.inputs().map(|v| v.iter().collect()).unwrap_or_default();
    let outputs: Vec<i32> = op.outputs().map(|v| v.iter().collect()).unwrap_or_default();
    let &[output] = outputs.as_slice() else {
        return Err(ImportError::Malformed(format!(
            "operator {ix} has {} outputs",
            outputs.len()
        )));
    };
    let out_shape = tensors::shape_of(graph, output)?;
    let prefix = format!("{ix}.{}", tensors::name_of(graph, output)?);
    let mut cx = Ctx {
        model,
        graph,
        op,
        target: g.target,
        values: g.values,
        uses: g.uses,
        prefix,
        inputs,
        options,
    };
    let value = match code {
        BuiltinOperator::DEQUANTIZE => dequantize(&mut cx)?,
        BuiltinOperator::CONV_2D => Value::Wire(conv(&mut cx, false)?),
        BuiltinOperator::DEPTHWISE_CONV_2D => Value::Wire(conv(&mut cx, true)?),
        BuiltinOperator::PRELU => Value::Wire(prelu(&mut cx)?),
        BuiltinOperator::ADD => Value::Wire(add(&mut cx)?),
        BuiltinOperator::MAX_POOL_2D => Value::Wire(max_pool(&mut cx)?),
        BuiltinOperator::PAD => Value::Wire(pad(&mut cx)?),
        BuiltinOperator::RESIZE_BILINEAR => Value::Wire(resize_bilinear(&mut cx, &out_shape)?),
        BuiltinOperator::RESHAPE => Value::Wire(reshape(&mut cx, &out_shape)?),
        BuiltinOperator::CONCATENATION => Value::Wire(concatenation(&mut cx, &out_shape)?),
        BuiltinOperator::MEAN => Value::Wire(mean(&mut cx)?),
        BuiltinOperator::FULLY_CONNECTED => Value::Wire(fully_connected(&mut cx, &out_shape)?),
        BuiltinOperator::LOGISTIC => {
            let x = cx.wire(0)?;
            Value::Wire(cx.node("sigmoid", sigmoid(), &[x])?)
        }
        BuiltinOperator::RELU => {
            let x = cx.wire(0)?;
            Value::Wire(cx.relu(x, None)?)
        }
        BuiltinOperator::RELU6 => {
            let x = cx.wire(0)?;
            Value::Wire(cx.relu(x, Some(6.0))?)
        }
        other => {
            return Err(ImportError::UnsupportedOperator(
                other
                    .variant_name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("#{}", other.0)),
            ))
        }
    };
    finish(cx, output, &out_shape, value)
}

/// DEQUANTIZE: fp16 weights were widened when read, so a constant stays as it is (nothing
/// runs at inference); a wire is cast to f32.
fn dequantize(cx: &mut Ctx) -> Result<Value, ImportError> {
    Ok(match cx.value(0)? {
        Value::Const(t) => Value::Const(t),
        Value::Wire(w) => {
            Value::Wire(cx.node("cast", tract_core::ops::cast::cast(f32::datum_type()), &[w])?)
        }
    })
}

/// ADD: a residual connection fused into the project's own operator where it can be,
/// else a broadcast addition and its fused activation.
fn add(cx: &mut Ctx) -> Result<OutletId, ImportError> {
    let f = cx
        .op
        .builtin_options_as_add_options()
        .map(|o| o.fused_activation_function());
    if let Some(y) = fuse_residual(cx, f.unwrap_or(ActivationFunctionType::NONE))? {
        return Ok(y);
    }
    let (a, b) = (cx.wire(0)?, cx.wire(1)?);
    let y = cx.broadcast("add", math::add(), &[a, b])?;
    cx.activation(y, f.unwrap_or(ActivationFunctionType::NONE))
}

/// RESHAPE to the model's output shape `out_shape`.
fn reshape(cx: &mut Ctx, out_shape: &[usize]) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let from: TVec<TDim> = cx.target.outlet_fact(x)?.shape.to_tvec();
    let to: TVec<TDim> = out_shape.iter().map(|d| d.to_dim()).collect();
    cx.node("reshape", AxisOp::Reshape(0, from, to), &[x])
}

/// CONCATENATION of every input along the options' axis, and its fused activation.
fn concatenation(cx: &mut Ctx, out_shape: &[usize]) -> Result<OutletId, ImportError> {
    let o = cx
        .op
        .builtin_options_as_concatenation_options()
        .ok_or_else(|| options_missing("CONCATENATION"))?;
    let axis = axis_in(
        o.axis() as i64,
        out_shape.len(),
        "CONCATENATION",
        &cx.prefix,
    )?;
    let wires = (0..cx.inputs.len())
        .map(|i| cx.wire(i))
        .collect::<Result<Vec<_>, _>>()?;
    let y = cx.node("concat", TypedConcat { axis }, &wires)?;
    cx.activation(y, o.fused_activation_function())
}

/// Checks the shape tract infers for an operator's result against the model's, and records
/// the result.
fn finish(cx: Ctx, output: i32, out_shape: &[usize], value: Value) -> Result<(), ImportError> {
    if let Value::Wire(w) = &value {
        let fact = cx.target.outlet_fact(*w)?;
        let got: Option<Vec<usize>> = fact.shape.as_concrete().map(|s| s.to_vec());
        if got.as_deref() != Some(out_shape) {
            return Err(ImportError::Malformed(format!(
                "{}: tract infers shape {:?}, the model says {out_shape:?}",
                cx.prefix, fact.shape
            )));
        }
    }
    cx.values.insert(output, value);
    Ok(())
}

/// The settings of a `CONV_2D` or `DEPTHWISE_CONV_2D`, read from its options and checked.
struct ConvParams {
    /// The kernel's shape: OHWI, or 1HWC for a depthwise kernel.
    ks: Vec<usize>,
    /// Channels of the (NHWC) input.
    in_channels: usize,
    /// Channels of the output.
    out_channels: usize,
    /// TFLite's padding.
    pad: Padding,
    /// The same padding for tract.
    padding: PaddingSpec,
    /// Strides (height, width), at least 1.
    strides: [usize; 2],
    /// Dilations (height, width), at least 1.
    dilations: [usize; 2],
    /// The fused activation.
    act: ActivationFunctionType,
    /// Convolution groups: the input channels for a depthwise convolution, else 1.
    group: usize,
}

/// `CONV_2D` (kernel OHWI) and `DEPTHWISE_CONV_2D` (kernel 1HW(C·M), M = 1 here).
fn conv(cx: &mut Ctx, depthwise: bool) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let kernel = cx.konst(1)?;
    let p = conv_params(cx, depthwise, x, kernel.shape().to_vec())?;
    let bias = if cx.has_input(2) {
        cx.konst(2)?.into_tensor()
    } else {
        Tensor::zero::<f32>(&[p.out_channels])?
    };
    if depthwise && cx.options.fast_depthwise && p.dilations == [1, 1] {
        return fast_depthwise(cx, x, kernel, bias, &p);
    }
    if !depthwise {
        if let Some(y) = fast_conv(cx, x, &kernel, &bias, &p)? {
            return Ok(y);
        }
    }
    tract_conv(cx, x, kernel, bias, p)
}

/// Reads and checks the options and kernel shape `ks` of a convolution of the wire `x`.
fn conv_params(
    cx: &Ctx,
    depthwise: bool,
    x: OutletId,
    ks: Vec<usize>,
) -> Result<ConvParams, ImportError> {
    if ks.len() != 4 {
        return Err(ImportError::Malformed(format!(
            "{}: kernel shape {ks:?}",
            cx.prefix
        )));
    }
    let in_channels = cx
        .target
        .outlet_fact(x)?
        .shape
        .as_concrete()
        .and_then(|s| s.get(3).copied())
        .ok_or_else(|| ImportError::Malformed(format!("{}: input must be NHWC", cx.prefix)))?;
    let (pad, strides, dilations, act, group, out_channels) = if depthwise {
        let o = cx
            .op
            .builtin_options_as_depthwise_conv_2_doptions()
            .ok_or_else(|| options_missing("DEPTHWISE_CONV_2D"))?;
        if ks[3] != in_channels || o.depth_multiplier() > 1 {
            return Err(ImportError::UnsupportedOperator(format!(
                "DEPTHWISE_CONV_2D with depth multiplier {} (only 1 is supported)",
                o.depth_multiplier()
            )));
        }
        (
            o.padding(),
            [o.stride_h(), o.stride_w()],
            [o.dilation_h_factor(), o.dilation_w_factor()],
            o.fused_activation_function(),
            in_channels,
            ks[3],
        )
    } else {
        let o = cx
            .op
            .builtin_options_as_conv_2_doptions()
            .ok_or_else(|| options_missing("CONV_2D"))?;
        if ks[3] != in_channels {
            return Err(ImportError::Malformed(format!(
                "{}: grouped convolution",
                cx.prefix
            )));
        }
        (
            o.padding(),
            [o.stride_h(), o.stride_w()],
            [o.dilation_h_factor(), o.dilation_w_factor()],
            o.fused_activation_function(),
            1,
            ks[0],
        )
    };
    let strides = [
        at_least_one(strides[0], "stride", &cx.prefix)?,
        at_least_one(strides[1], "stride", &cx.prefix)?,
    ];
    let dilations = [
        at_least_one(dilations[0], "dilation", &cx.prefix)?,
        at_least_one(dilations[1], "dilation", &cx.prefix)?,
    ];
    if ks[1] == 0 || ks[2] == 0 {
        return Err(ImportError::Malformed(format!(
            "{}: empty kernel {ks:?}",
            cx.prefix
        )));
    }
    Ok(ConvParams {
        padding: padding(pad)?,
        ks,
        in_channels,
        out_channels,
        pad,
        strides,
        dilations,
        act,
        group,
    })
}

/// A depthwise convolution (dilation 1) of `x` as the importer's own NHWC operator, its
/// activation fused in when enabled.
fn fast_depthwise(
    cx: &mut Ctx,
    x: OutletId,
    kernel: Arc<Tensor>,
    bias: Tensor,
    p: &ConvParams,
) -> Result<OutletId, ImportError> {
    let ks = &p.ks;
    let [_, kh, kw, c] = [ks[0], ks[1], ks[2], ks[3]];
    let kernel = kernel.into_tensor().into_shape(&[kh, kw, c])?;
    let fused = match p.act {
        _ if !cx.options.fused_depthwise_activation => None,
        ActivationFunctionType::RELU => Some(Activation::Relu),
        ActivationFunctionType::RELU6 => Some(Activation::Relu6),
        _ => None,
    };
    let op = super::depthwise::NhwcDepthwise {
        kernel: kernel.into_arc_tensor(),
        bias: bias.into_arc_tensor(),
        strides: (p.strides[0], p.strides[1]),
        same: p.pad == Padding::SAME,
        activation: fused.unwrap_or_default(),
        register_blocked: cx.options.register_blocked_depthwise,
        split: cx.options.split_rows,
    };
    let y = cx.node("depthwise", op, &[x])?;
    match fused {
        Some(_) => Ok(y),
        None => cx.activation(y, p.act),
    }
}

/// A (not depthwise) convolution of `x` as the importer's own [`PointwiseConv`] (1x1,
/// stride 1) or [`super::conv::NhwcConv`] where they apply; `None` where they do not.
fn fast_conv(
    cx: &mut Ctx,
    x: OutletId,
    kernel: &Tensor,
    bias: &Tensor,
    p: &ConvParams,
) -> Result<Option<OutletId>, ImportError> {
    let (ks, strides) = (&p.ks, p.strides);
    if cx.options.fast_pointwise
        && ks[1] == 1
        && ks[2] == 1
        && strides == [1, 1]
        && PointwiseConv::fast_kernel_available()
    {
        // 1x1 stride 1: padding and dilation change nothing.
        let act = match p.act {
            ActivationFunctionType::NONE => Some(Activation::None),
            ActivationFunctionType::RELU => Some(Activation::Relu),
            ActivationFunctionType::RELU6 => Some(Activation::Relu6),
            _ => None,
        };
        if let Some(act) = act {
            let op = PointwiseConv::new(kernel, bias, act)?.with_split(cx.options.split_rows);
            return cx.node("pointwise", op, &[x]).map(Some);
        }
    }
    let fused = match p.act {
        ActivationFunctionType::NONE => Some(Activation::None),
        ActivationFunctionType::RELU => Some(Activation::Relu),
        ActivationFunctionType::RELU6 => Some(Activation::Relu6),
        _ => None,
    };
    if let Some(act) = fused.filter(|_| {
        cx.options.fast_conv
            && !(ks[1] == 1 && ks[2] == 1 && strides == [1, 1])
            && p.dilations == [1, 1]
            && ks[1] * ks[2] * ks[3] <= 512
            && PointwiseConv::fast_kernel_available()
    }) {
        let op = super::conv::NhwcConv::new(
            kernel,
            bias,
            (strides[0], strides[1]),
            p.pad == Padding::SAME,
            act,
        )?
        .with_split(cx.options.split_rows);
        return cx.node("conv", op, &[x]).map(Some);
    }
    Ok(None)
}

/// A convolution of `x` as tract's [`Conv`], then its activation.
fn tract_conv(
    cx: &mut Ctx,
    x: OutletId,
    kernel: Arc<Tensor>,
    bias: Tensor,
    p: ConvParams,
) -> Result<OutletId, ImportError> {
    let pool_spec = PoolSpec {
        data_format: DataFormat::NHWC,
        kernel_shape: tvec!(p.ks[1], p.ks[2]),
        padding: p.padding,
        strides: Some(tvec!(p.strides[0], p.strides[1])),
        dilations: Some(tvec!(p.dilations[0], p.dilations[1])),
        input_channels: p.in_channels,
        output_channels: p.out_channels,
    };
    // tract's OHWI carries the group on I: a depthwise kernel 1xHxWxC with group C is
    // exactly TFLite's layout.
    let k = cx.add_const("kernel", kernel.into_tensor())?;
    let b = cx.add_const("bias", bias)?;
    let op = Conv {
        pool_spec,
        kernel_fmt: KernelFormat::OHWI,
        group: p.group,
        q_params: None,
    };
    let y = cx.node("conv", op, &[x, k, b])?;
    cx.activation(y, p.act)
}

/// `PRELU`: `max(x, 0) + alpha * min(x, 0)`, alpha broadcast over the channel axis.
fn prelu(cx: &mut Ctx) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    if cx.options.fused_prelu {
        if let Value::Const(alpha) = cx.value(1)? {
            // Slopes shaped [1, ..., 1, C] broadcast along the channel axis only.
            let shape = alpha.shape();
            let channels = shape.last().copied().unwrap_or(1);
            let x_channels = cx
                .target
                .outlet_fact(x)?
                .shape
                .last()
                .and_then(|d| d.to_usize().ok());
            if shape.iter().rev().skip(1).all(|&d| d == 1) && x_channels == Some(channels) {
                let alpha = alpha
                    .cast_to::<f32>()?
                    .into_owned()
                    .into_shape(&[channels])?;
                if let Some((node, op)) = fusable_pointwise(cx, 0, x)? {
                    if !op.has_prelu() {
                        cx.target.node_mut(node).op = Box::new(op.with_prelu(&alpha)?);
                        return Ok(x);
                    }
                }
                let op = super::prelu::ChannelPrelu {
                    alpha: alpha.into_arc_tensor(),
                };
                return cx.node("prelu", op, &[x]);
            }
        }
    }
    let alpha = cx.wire(1)?;
    let zero = cx.add_const("zero", tensor0(0f32))?;
    let pos = cx.broadcast("pos", math::max(), &[x, zero])?;
    let neg = cx.broadcast("neg", math::min(), &[x, zero])?;
    let scaled = cx.broadcast("scaled", math::mul(), &[neg, alpha])?;
    cx.broadcast("prelu", math::add(), &[pos, scaled])
}

/// The [`PointwiseConv`] node computing input `slot` (the wire `w`) if its epilogue may take
/// in the current operator: fusion enabled, the tensor read by this operator only (and not a
/// graph output).
fn fusable_pointwise(
    cx: &Ctx,
    slot: usize,
    w: OutletId,
) -> Result<Option<(usize, PointwiseConv)>, ImportError> {
    if !cx.options.fused_pointwise_epilogue {
        return Ok(None);
    }
    let Some(&id) = cx.inputs.get(slot) else {
        return Ok(None);
    };
    if cx.uses.get(&id) != Some(&1) || w.slot != 0 {
        return Ok(None);
    }
    Ok(cx
        .target
        .node(w.node)
        .op_as::<PointwiseConv>()
        .map(|op| (w.node, op.clone())))
}

/// `ADD` of a [`PointwiseConv`]'s result (read by nothing else, no residual nor PRELU yet)
/// and another computed tensor of the same shape: the addition and its activation `f` go
/// into the convolution's epilogue, the other tensor becoming its second input.
fn fuse_residual(cx: &mut Ctx, f: ActivationFunctionType) -> Result<Option<OutletId>, ImportError> {
    let act = match f {
        ActivationFunctionType::NONE => Activation::None,
        ActivationFunctionType::RELU => Activation::Relu,
        ActivationFunctionType::RELU6 => Activation::Relu6,
        _ => return Ok(None),
    };
    if cx.inputs.len() != 2 {
        return Ok(None);
    }
    for slot in 0..2 {
        let (Value::Wire(w), Value::Wire(other)) = (cx.value(slot)?, cx.value(1 - slot)?) else {
            continue;
        };
        let Some((node, op)) = fusable_pointwise(cx, slot, w)? else {
            continue;
        };
        if op.has_residual() || op.has_prelu() || other.node == node {
            continue;
        }
        let same_shape = {
            let a = cx
                .target
                .outlet_fact(w)?
                .shape
                .as_concrete()
                .map(|s| s.to_vec());
            let b = cx
                .target
                .outlet_fact(other)?
                .shape
                .as_concrete()
                .map(|s| s.to_vec());
            a.is_some() && a == b
        };
        if !same_shape {
            continue;
        }
        // The convolution's result is read by this ADD only, so `other` cannot depend on it:
        // the new edge keeps the graph acyclic even when `other` is computed later.
        cx.target.node_mut(node).op = Box::new(op.with_residual(act));
        cx.target.add_edge(other, InletId::new(node, 1))?;
        return Ok(Some(w));
    }
    Ok(None)
}

fn max_pool(cx: &mut Ctx) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let o = cx
        .op
        .builtin_options_as_pool_2_doptions()
        .ok_or_else(|| options_missing("MAX_POOL_2D"))?;
    let channels = cx
        .target
        .outlet_fact(x)?
        .shape
        .as_concrete()
        .and_then(|s| s.get(3).copied())
        .ok_or_else(|| ImportError::Malformed("pool input".into()))?;
    let kernel = (
        at_least_one(o.filter_height(), "window height", &cx.prefix)?,
        at_least_one(o.filter_width(), "window width", &cx.prefix)?,
    );
    let strides = (
        at_least_one(o.stride_h(), "stride", &cx.prefix)?,
        at_least_one(o.stride_w(), "stride", &cx.prefix)?,
    );
    let pool_spec = PoolSpec {
        data_format: DataFormat::NHWC,
        kernel_shape: tvec!(kernel.0, kernel.1),
        padding: padding(o.padding())?,
        strides: Some(tvec!(strides.0, strides.1)),
        dilations: None,
        input_channels: channels,
        output_channels: channels,
    };
    let y = if cx.options.fast_pool {
        let op = super::pool::NhwcMaxPool {
            kernel,
            strides,
            same: pool_spec.padding == PaddingSpec::SameUpper,
            pad_channels: 0,
        };
        cx.node("maxpool", op, &[x])?
    } else {
        cx.node(
            "maxpool",
            MaxPool {
                pool_spec,
                with_index_outputs: None,
            },
            &[x],
        )?
    };
    cx.activation(y, o.fused_activation_function())
}

fn pad(cx: &mut Ctx) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let pads = cx.konst(1)?;
    let pads = pads.cast_to::<i64>()?;
    let flat = pads.try_as_plain_ram()?.as_slice::<i64>()?;
    let pads: Vec<(usize, usize)> = flat
        .chunks_exact(2)
        .map(|c| (c[0].max(0) as usize, c[1].max(0) as usize))
        .collect();
    // Zero channels after a max pool that nothing else reads: written by the pool itself.
    if let [(0, 0), (0, 0), (0, 0), (0, extra)] = pads[..] {
        if let Some(&id) = cx.inputs.first() {
            if cx.uses.get(&id) == Some(&1) && x.slot == 0 {
                if let Some(pool) = cx.target.node(x.node).op_as::<super::pool::NhwcMaxPool>() {
                    let mut pool = pool.clone();
                    pool.pad_channels += extra;
                    let fact = {
                        let input = cx.target.node(x.node).inputs[0];
                        let input = cx.target.outlet_fact(input)?.clone();
                        pool.output_facts(&[&input])?.remove(0)
                    };
                    let node = cx.target.node_mut(x.node);
                    node.op = Box::new(pool);
                    node.outputs[0].fact = fact;
                    return Ok(x);
                }
            }
        }
    }
    let mode = PadMode::Constant(Arc::new(tensor0(0f32)));
    cx.node("pad", Pad { pads, mode }, &[x])
}

fn resize_bilinear(cx: &mut Ctx, out_shape: &[usize]) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let o = cx
        .op
        .builtin_options_as_resize_bilinear_options()
        .ok_or_else(|| options_missing("RESIZE_BILINEAR"))?;
    let coord_transformer = if o.align_corners() {
        CoordTransformer::AlignCorners
    } else if o.half_pixel_centers() {
        CoordTransformer::HalfPixel
    } else {
        CoordTransformer::Asymmetric
    };
    if cx.options.fast_resize && out_shape.len() == 4 {
        let op = super::resize::NhwcResizeBilinear {
            coord_transformer,
            size: (out_shape[1], out_shape[2]),
        };
        return cx.node("resize", op, &[x]);
    }
    let sizes: Vec<i64> = out_shape.iter().map(|&d| d as i64).collect();
    let sizes = cx.add_const("sizes", tensor1(&sizes))?;
    let op = Resize {
        coord_transformer,
        interpolator: Interpolator::Linear,
        nearest: Nearest::Floor,
        optional_scales_input: None,
        optional_sizes_input: Some(1),
    };
    cx.node("resize", op, &[x, sizes])
}

/// `MEAN` in float: a sum, then one multiplication by the reciprocal count.
fn mean(cx: &mut Ctx) -> Result<OutletId, ImportError> {
    let x = cx.wire(0)?;
    let shape: Vec<usize> = cx
        .target
        .outlet_fact(x)?
        .shape
        .as_concrete()
        .map(|s| s.to_vec())
        .ok_or_else(|| ImportError::Malformed("MEAN input".into()))?;
    let axes = cx.konst(1)?.cast_to::<i64>()?.into_owned();
    let mut axes: Vec<usize> = axes
        .try_as_plain_ram()?
        .as_slice::<i64>()?
        .iter()
        .map(|&a| axis_in(a, shape.len(), "MEAN", &cx.prefix))
        .collect::<Result<_, _>>()?;
    axes.sort_unstable();
    axes.dedup();
    let keep_dims = cx
        .op
        .builtin_options_as_reducer_options()
        .map(|o| o.keep_dims())
        .unwrap_or(false);
    let count: usize = axes.iter().map(|&a| shape[a]).product();
    let mut y = cx.node(
        "sum",
        Reduce {
            axes: axes.iter().copied().collect(),
            reducer: Reducer::Sum,
        },
        &[x],
    )?;
    if !keep_dims {
        for &a in axes.iter().rev() {
            y = cx.node("rm_axis", AxisOp::Rm(a), &[y])?;
        }
    }
    let recip = cx.add_const("recip_count", tensor0(1.0 / count as f32))?;
    cx.broadcast("mean", math::mul(), &[y, recip])
}

/// `FULLY_CONNECTED`: `x · Wᵀ + b` with W stored `[out, in]`, input flattened to `[-1, in]`.
fn fully_connected(cx: &mut Ctx, out_shape: &[usize]) -> Result<OutletId, ImportError> {
    let o = cx
        .op
        .builtin_options_as_fully_connected_options()
        .ok_or_else(|| options_missing("FULLY_CONNECTED"))?;
    let mut x = cx.wire(0)?;
    let w = cx.konst(1)?;
    let ws = w.shape().to_vec();
    if ws.len() != 2 {
        return Err(ImportError::Malformed(format!(
            "{}: weights {ws:?}",
            cx.prefix
        )));
    }
    let in_shape: TVec<TDim> = cx.target.outlet_fact(x)?.shape.to_tvec();
    let total: usize = in_shape
        .iter()
        .map(|d| {
            d.to_usize()
                .map_err(|e| ImportError::Malformed(format!("dynamic FC input: {e}")))
        })
        .product::<Result<usize, ImportError>>()?;
    if ws[1] == 0 || !total.is_multiple_of(ws[1]) {
        return Err(ImportError::Malformed(format!(
            "{}: an input of {total} values does not split into rows of {} (weights {ws:?})",
            cx.prefix, ws[1]
        )));
    }
    if in_shape.len() != 2 || in_shape[1] != ws[1].to_dim() {
        let to = tvec!((total / ws[1]).to_dim(), ws[1].to_dim());
        x = cx.node("flatten", AxisOp::Reshape(0, in_shape, to), &[x])?;
    }
    let wk = cx.add_const("weights", w.into_tensor())?;
    let axes = "bi,oi->bo".parse()?;
    let mut y = cx.node(
        "matmul",
        EinSum {
            axes,
            operating_dt: f32::datum_type(),
            q_params: None,
        },
        &[x, wk],
    )?;
    if cx.has_input(2) {
        let b = cx.konst(2)?.into_tensor();
        let b = cx.add_const("bias", b)?;
        y = cx.broadcast("bias_add", math::add(), &[y, b])?;
    }
    y = cx.activation(y, o.fused_activation_function())?;
    let got: TVec<TDim> = cx.target.outlet_fact(y)?.shape.to_tvec();
    let want: TVec<TDim> = out_shape.iter().map(|d| d.to_dim()).collect();
    if got != want {
        y = cx.node("reshape_out", AxisOp::Reshape(0, got, want), &[y])?;
    }
    Ok(y)
}
