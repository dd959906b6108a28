//! Conversions between the crates' values and Python's: sides, records as Python objects,
//! joint arrays, images.

use crate::errors::*;
use monohand_core::prelude::*;
use numpy::ndarray::Array2;
use numpy::{PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub(crate) fn side_name(side: HandSide) -> &'static str {
    match side {
        HandSide::Left => "left",
        HandSide::Right => "right",
    }
}

pub(crate) fn parse_side(side: &str) -> PyResult<HandSide> {
    match side.to_ascii_lowercase().as_str() {
        "left" | "l" => Ok(HandSide::Left),
        "right" | "r" => Ok(HandSide::Right),
        _ => Err(PyValueError::new_err(format!(
            "side must be 'left' or 'right', not {side:?}"
        ))),
    }
}

/// A record as plain Python lists, dicts and numbers: exactly what `monohand run` writes
/// to JSON Lines, read back by Python's own `json`.
pub(crate) fn as_python<'py>(
    py: Python<'py>,
    record: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(record).map_err(|e| MonohandError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A 21x3 array of rows of three numbers.
pub(crate) fn joints_array<'py>(
    py: Python<'py>,
    rows: &[[f64; 3]; NUM_JOINTS],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    // The shape matches the data by construction.
    let arr = Array2::from_shape_vec((NUM_JOINTS, 3), flat)
        .unwrap_or_else(|_| Array2::zeros((NUM_JOINTS, 3)));
    PyArray2::from_owned_array(py, arr)
}

/// Copies an `(H, W, 3)` uint8 array into an image (the networks crop from it).
pub(crate) fn to_image(array: &Bound<'_, PyAny>) -> PyResult<monohand::RgbImage> {
    let array = array.cast::<PyArray3<u8>>().map_err(|_| {
        PyValueError::new_err("an image must be a numpy uint8 array of shape (H, W, 3), RGB")
    })?;
    let ro = array.try_readonly()?;
    let shape = ro.shape();
    if shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "an image must be (H, W, 3) RGB with H, W > 0, not {shape:?}"
        )));
    }
    let (h, w) = (shape[0], shape[1]);
    let data = match ro.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => ro.as_array().iter().copied().collect(),
    };
    let too_big = || PyValueError::new_err(format!("image {w}x{h} is too large"));
    monohand::RgbImage::from_raw(
        u32::try_from(w).map_err(|_| too_big())?,
        u32::try_from(h).map_err(|_| too_big())?,
        data,
    )
    .ok_or_else(too_big)
}

/// A bool as Python writes it.
pub(crate) fn py_bool(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}
