//! Regression tests for the `.tflite` importer's checks of operator options: real MediaPipe
//! networks with one option forged (an axis out of range, a stride of 0 or below, a
//! fully-connected weight with no columns) are refused with an error naming the problem.
//! Before these checks the forged values were cast or indexed unchecked (a panic, or a
//! stride of 4 billion); the random mutations of `fuzz_tflite.rs` had not reached them
//! (docs/fuzzing.md).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand_vision::tflite_import::import;
use monohand_vision::{ModelFile, ModelStore};
use tract_tflite::tflite::{self, BuiltinOperator};

fn model(file: ModelFile) -> Vec<u8> {
    let store = ModelStore::new(None).expect("model cache directory");
    if let Err(e) = store.fetch() {
        panic!("these tests need the MediaPipe models: {e}");
    }
    store.load(file).expect("load model")
}

fn opcode(model: &tflite::Model, op: &tflite::Operator) -> BuiltinOperator {
    let code = model
        .operator_codes()
        .expect("operator codes")
        .get(op.opcode_index() as usize);
    code.builtin_code()
        .max(BuiltinOperator(code.deprecated_builtin_code() as i32))
}

/// The model's main graph and the address of its first byte (to turn a field's address
/// into a position in the file).
fn main_graph(bytes: &[u8]) -> (tflite::Model<'_>, tflite::SubGraph<'_>, usize) {
    let m = tflite::root_as_model(bytes).expect("a valid model");
    let graph = m.subgraphs().expect("subgraphs").get(0);
    (m, graph, bytes.as_ptr() as usize)
}

/// Every operator of the main graph with its opcode.
fn operators(bytes: &[u8]) -> Vec<(BuiltinOperator, tflite::Operator<'_>)> {
    let (m, graph, _) = main_graph(bytes);
    graph
        .operators()
        .expect("operators")
        .iter()
        .map(|op| (opcode(&m, &op), op))
        .collect()
}

/// Byte position of field `slot` of the table at `tab` (the field must be stored).
fn field_pos(tab: &flatbuffers::Table<'_>, slot: flatbuffers::VOffsetT) -> usize {
    let off = tab.vtable().get(slot) as usize;
    assert!(off > 0, "field {slot} is not stored in this table");
    tab.loc() + off
}

fn with_i32(bytes: &[u8], pos: usize, v: i32) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[pos..pos + 4].copy_from_slice(&v.to_le_bytes());
    b
}

fn refused(bytes: &[u8], expect: &str) {
    match import(bytes) {
        Ok(_) => panic!("the forged model was accepted (expected an error with {expect:?})"),
        Err(e) => {
            let msg = e.to_string();
            println!("refused: {msg}");
            assert!(
                msg.contains(expect),
                "error {msg:?} does not say {expect:?}"
            );
        }
    }
}

#[test]
fn a_concatenation_axis_out_of_range_is_refused() {
    let bytes = model(ModelFile::PalmDetectionFull);
    let pos = operators(&bytes)
        .iter()
        .find_map(|(code, op)| {
            let o = op.builtin_options_as_concatenation_options()?;
            (*code == BuiltinOperator::CONCATENATION)
                .then(|| field_pos(&o._tab, tflite::ConcatenationOptions::VT_AXIS))
        })
        .expect("the palm detector concatenates");
    import(&bytes).expect("the unforged model imports");
    for axis in [3, 99, -4, -99, i32::MIN] {
        refused(&with_i32(&bytes, pos, axis), "axis");
    }
}

#[test]
fn a_convolution_stride_below_one_is_refused() {
    let bytes = model(ModelFile::HandLandmarkFull);
    let ops = operators(&bytes);
    let conv = ops
        .iter()
        .find_map(|(code, op)| {
            let o = op.builtin_options_as_conv_2_doptions()?;
            (*code == BuiltinOperator::CONV_2D)
                .then(|| field_pos(&o._tab, tflite::Conv2DOptions::VT_STRIDE_H))
        })
        .expect("a convolution");
    let depthwise = ops
        .iter()
        .find_map(|(code, op)| {
            let o = op.builtin_options_as_depthwise_conv_2_doptions()?;
            (*code == BuiltinOperator::DEPTHWISE_CONV_2D)
                .then(|| field_pos(&o._tab, tflite::DepthwiseConv2DOptions::VT_STRIDE_W))
        })
        .expect("a depthwise convolution");
    for stride in [0, -1, i32::MIN] {
        refused(&with_i32(&bytes, conv, stride), "stride");
        refused(&with_i32(&bytes, depthwise, stride), "stride");
    }
}

#[test]
fn a_mean_axis_out_of_range_is_refused() {
    // The landmark networks end in a global average (MEAN over the two image axes).
    let bytes = model(ModelFile::HandLandmarkFull);
    let (m, graph, base) = main_graph(&bytes);
    let tensors = graph.tensors().expect("tensors");
    let buffers = m.buffers().expect("buffers");
    let pos = operators(&bytes)
        .iter()
        .find(|(code, _)| *code == BuiltinOperator::MEAN)
        .map(|(_, op)| {
            let axes = tensors.get(op.inputs().expect("inputs").get(1) as usize);
            let data = buffers
                .get(axes.buffer() as usize)
                .data()
                .expect("constant axes");
            data.bytes().as_ptr() as usize - base
        })
        .expect("a MEAN");
    for axis in [4, 7, -5, i32::MAX] {
        refused(&with_i32(&bytes, pos, axis), "MEAN axis");
    }
}

#[test]
fn a_fully_connected_weight_without_columns_is_refused() {
    let bytes = model(ModelFile::HandLandmarkFull);
    let (_, graph, base) = main_graph(&bytes);
    let tensors = graph.tensors().expect("tensors");
    let ops = operators(&bytes);
    // The weight of the first FULLY_CONNECTED, and the fp16 tensor it is dequantized from.
    let weight = ops
        .iter()
        .find(|(code, _)| *code == BuiltinOperator::FULLY_CONNECTED)
        .map(|(_, op)| op.inputs().expect("inputs").get(1))
        .expect("a FULLY_CONNECTED");
    let source = ops
        .iter()
        .find(|(code, op)| {
            *code == BuiltinOperator::DEQUANTIZE && op.outputs().expect("outputs").get(0) == weight
        })
        .map(|(_, op)| op.inputs().expect("inputs").get(0))
        .unwrap_or(weight);
    assert_ne!(
        source, weight,
        "MediaPipe stores the weight in fp16 behind a DEQUANTIZE"
    );
    // The stored fp16 weight with no columns: refused where its buffer is read (its size no
    // longer matches), before the fully connected layer's own check (a divisor of 0).
    let shape = tensors.get(source as usize).shape().expect("a shape");
    assert_eq!(shape.len(), 2, "a [out, in] weight");
    let columns = shape.bytes().as_ptr() as usize - base + 4;
    refused(&with_i32(&bytes, columns, 0), ", 0] of F16");
    // The dequantized tensor's own shape is not read (the importer takes the shape of the
    // value it dequantized): forging it changes nothing.
    let shape = tensors.get(weight as usize).shape().expect("a shape");
    let columns = shape.bytes().as_ptr() as usize - base + 4;
    import(&with_i32(&bytes, columns, 0)).expect("the dequantized tensor's shape is not read");
}

#[test]
fn a_constant_whose_forged_shape_overflows_is_refused() {
    // The first 4-D constant (a convolution kernel, stored in fp16) with every dimension
    // forged to 2^31 - 1: the product of its dimensions overflows, which the importer must
    // catch rather than wrap or panic on.
    let bytes = model(ModelFile::HandLandmarkFull);
    let (m, graph, base) = main_graph(&bytes);
    let buffers = m.buffers().expect("buffers");
    let shape = graph
        .tensors()
        .expect("tensors")
        .iter()
        .find(|t| {
            t.shape().is_some_and(|s| s.len() == 4)
                && buffers.get(t.buffer() as usize).data().is_some()
        })
        .and_then(|t| t.shape())
        .expect("a constant kernel");
    let start = shape.bytes().as_ptr() as usize - base;
    let mut forged = bytes.clone();
    for k in 0..4 {
        forged[start + 4 * k..start + 4 * k + 4].copy_from_slice(&i32::MAX.to_le_bytes());
    }
    refused(&forged, "is too large");
}
