//! Reading TFLite tensors: shapes and element types of graph inputs, and constant buffers
//! (weights), which are widened from fp16 to f32 as they are read.

use tract_core::internal::*;
use tract_tflite::tflite;

use super::ImportError;

/// Element type of a TFLite tensor, restricted to what these models carry.
fn datum_type(t: tflite::TensorType) -> Result<DatumType, ImportError> {
    Ok(match t {
        tflite::TensorType::FLOAT32 => DatumType::F32,
        tflite::TensorType::FLOAT16 => DatumType::F16,
        tflite::TensorType::INT32 => DatumType::I32,
        tflite::TensorType::INT64 => DatumType::I64,
        other => {
            return Err(ImportError::Malformed(format!(
                "tensor element type {other:?} is not supported (float models only)"
            )))
        }
    })
}

fn tensor<'a>(graph: &tflite::SubGraph<'a>, id: i32) -> Result<tflite::Tensor<'a>, ImportError> {
    let tensors = graph
        .tensors()
        .ok_or_else(|| ImportError::Malformed("subgraph has no tensors".into()))?;
    let ix = usize::try_from(id)
        .ok()
        .filter(|&ix| ix < tensors.len())
        .ok_or_else(|| ImportError::Malformed(format!("tensor index {id} out of range")))?;
    Ok(tensors.get(ix))
}

/// Static shape of a tensor (TFLite shapes here are fully known).
pub(super) fn shape_of(graph: &tflite::SubGraph, id: i32) -> Result<Vec<usize>, ImportError> {
    let t = tensor(graph, id)?;
    t.shape()
        .map(|s| s.iter().collect::<Vec<i32>>())
        .unwrap_or_default()
        .into_iter()
        .map(|d| {
            usize::try_from(d)
                .map_err(|_| ImportError::Malformed(format!("dynamic dimension in tensor {id}")))
        })
        .collect()
}

/// Name of a tensor, for node names.
pub(super) fn name_of<'a>(graph: &tflite::SubGraph<'a>, id: i32) -> Result<&'a str, ImportError> {
    Ok(tensor(graph, id)?.name().unwrap_or("tensor"))
}

/// The tract fact (f32 for fp16 tensors) and name of a graph input.
pub(super) fn fact_of<'a>(
    _model: &tflite::Model<'a>,
    graph: &tflite::SubGraph<'a>,
    id: i32,
) -> Result<(TypedFact, &'a str), ImportError> {
    let t = tensor(graph, id)?;
    let mut dt = datum_type(t.type_())?;
    if dt == DatumType::F16 {
        dt = DatumType::F32;
    }
    Ok((dt.fact(shape_of(graph, id)?), name_of(graph, id)?))
}

/// The constant value stored in a tensor's buffer, if it has one. fp16 data is returned as f32.
pub(super) fn constant_of(
    model: &tflite::Model,
    graph: &tflite::SubGraph,
    id: i32,
) -> Result<Option<Tensor>, ImportError> {
    let t = tensor(graph, id)?;
    let buffer_ix = t.buffer() as usize;
    if buffer_ix == 0 {
        return Ok(None);
    }
    let buffers = model
        .buffers()
        .ok_or_else(|| ImportError::Malformed("model has no buffers".into()))?;
    if buffer_ix >= buffers.len() {
        return Err(ImportError::Malformed(format!(
            "buffer {buffer_ix} out of range"
        )));
    }
    let Some(data) = buffers.get(buffer_ix).data() else {
        return Ok(None);
    };
    let bytes = data.bytes();
    let shape = shape_of(graph, id)?;
    let dt = datum_type(t.type_())?;
    // Checked: forged dimensions (each up to 2^31 - 1) could overflow the product.
    let size = shape
        .iter()
        .try_fold(dt.size_of(), |n, &d| n.checked_mul(d))
        .ok_or_else(|| {
            ImportError::Malformed(format!("tensor {id}: shape {shape:?} is too large"))
        })?;
    if bytes.len() != size {
        return Err(ImportError::Malformed(format!(
            "tensor {id}: buffer of {} bytes for shape {shape:?} of {dt:?}",
            bytes.len()
        )));
    }
    let tensor = match dt {
        DatumType::F32 => {
            Tensor::from_shape(&shape, &le_words::<4, f32>(bytes, f32::from_le_bytes))?
        }
        DatumType::F16 => {
            let values = le_words::<2, f32>(bytes, |b| f16::from_le_bytes(b).to_f32());
            Tensor::from_shape(&shape, &values)?
        }
        DatumType::I32 => {
            Tensor::from_shape(&shape, &le_words::<4, i32>(bytes, i32::from_le_bytes))?
        }
        DatumType::I64 => {
            Tensor::from_shape(&shape, &le_words::<8, i64>(bytes, i64::from_le_bytes))?
        }
        other => {
            return Err(ImportError::Malformed(format!(
                "constant of type {other:?}"
            )))
        }
    };
    Ok(Some(tensor))
}

/// Decodes a little-endian buffer word by word (TFLite buffers carry no alignment guarantee).
fn le_words<const N: usize, T>(bytes: &[u8], f: impl Fn([u8; N]) -> T) -> Vec<T> {
    bytes
        .chunks_exact(N)
        .map(|c| {
            let mut w = [0u8; N];
            w.copy_from_slice(c);
            f(w)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn little_endian_words_decode() {
        let bytes = [0x00, 0x3c, 0x00, 0xc0]; // fp16 1.0, -2.0
        let v = le_words::<2, f32>(&bytes, |b| f16::from_le_bytes(b).to_f32());
        assert_eq!(v, vec![1.0, -2.0]);
    }
}
