//! `Hand.wrist_pose()` and `Hand.joints_in_wrist_frame()`: a fitted hand as robot-hand
//! retargeting reads it (dex-retargeting's MANO wrist frame, in metres;
//! `monohand_core::wrist` defines the frame).

use monohand_core::wrist::{WristConvention, WristPose};
use monohand_io::jsonl::HandRecord;
use numpy::ndarray::Array2;
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The hand's wrist pose from its fit (its `joints_3d_mm` and `pose`), or `None` without
/// them.
fn of_fit(hand: &HandRecord, convention: WristConvention) -> Option<(WristPose, [f64; 63])> {
    let joints = hand.joints_3d()?;
    let pose = hand.pose.as_ref()?.to_pose()?;
    let wrist = monohand_core::wrist::wrist_pose(&pose, &joints, convention)?;
    let local = monohand_core::wrist::joints_in_wrist_frame(&pose, &joints, convention)?;
    let mut flat = [0.0; 63];
    for (row, p) in flat.chunks_exact_mut(3).zip(&local) {
        row.copy_from_slice(p.as_slice());
    }
    Some((wrist, flat))
}

/// `(4, 4)`: the transform from the wrist frame (MANO's) to the camera's, metres.
pub(crate) fn wrist_pose<'py>(
    py: Python<'py>,
    hand: &HandRecord,
) -> Option<Bound<'py, PyArray2<f64>>> {
    let (wrist, _) = of_fit(hand, WristConvention::Mano)?;
    let m = wrist.matrix_m();
    Some(PyArray2::from_owned_array(
        py,
        Array2::from_shape_fn((4, 4), |(r, c)| m[(r, c)]),
    ))
}

/// `(21, 3)`: the joints in the wrist frame of `convention`, metres; a convention that is
/// not known is a `ValueError`.
pub(crate) fn joints_in_wrist_frame<'py>(
    py: Python<'py>,
    hand: &HandRecord,
    convention: &str,
) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
    let convention: WristConvention =
        convention
            .parse()
            .map_err(|e: monohand_core::wrist::UnknownConvention| {
                PyValueError::new_err(e.to_string())
            })?;
    Ok(of_fit(hand, convention).map(|(_, flat)| {
        PyArray2::from_owned_array(py, Array2::from_shape_fn((21, 3), |(j, k)| flat[3 * j + k]))
    }))
}
