//! The graph passes of int8 ([`crate::Precision::Int8`]): measuring the input ranges of the
//! layers to code ([`int8_input_ranges`]), replacing the f32 1x1 convolutions and stems by
//! their int8 twins ([`quantize_pointwise`]) and having depthwise convolutions write the
//! codes their int8 reader takes ([`code_depthwise_results`]). Above every operator they
//! rewrite (the f32 and int8 convolutions, the depthwise ones, the PRELU).

use tract_core::internal::*;

use crate::int8::{MinMax, PointwiseConvInt8};

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
        let Some(input) = op.codable_input() else {
            continue;
        };
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
        let codes = crate::NhwcDepthwiseCodes::new(dw.clone(), input);
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
