//! `Lifter`: 2D keypoints made elsewhere fitted to 3D.

use crate::camera::*;
use crate::convert::*;
use crate::errors::*;
use crate::hand::*;
use crate::hand_size::*;
use monohand_core::prelude::*;
use monohand_io::jsonl::HandRecord;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Fits 2D keypoints made elsewhere (OpenPose, MediaPipe, your own network) to absolute
/// 3D hands, frame after frame.
///
/// `Lifter(camera, tracking=True)`; `lift(keypoints_2d, side)` with `keypoints_2d` of
/// shape `(21, 2)` (confidence 1) or `(21, 3)` (x, y, confidence; joints under 0.1 are
/// ignored), in MediaPipe's joint order. With tracking each side's fit starts from its
/// previous one.
#[pyclass(module = "monohand._monohand", name = "Lifter")]
pub(crate) struct PyLifter {
    pub(crate) inner: monohand::Lifter,
}

pub(crate) fn to_keypoints(keypoints: PyReadonlyArray2<'_, f64>) -> PyResult<Keypoints2d> {
    let a = keypoints.as_array();
    if a.nrows() != NUM_JOINTS || !(a.ncols() == 2 || a.ncols() == 3) {
        return Err(PyValueError::new_err(format!(
            "keypoints_2d must be ({NUM_JOINTS}, 2) or ({NUM_JOINTS}, 3), not {:?}",
            a.shape()
        )));
    }
    let mut points = [[0.0; 3]; NUM_JOINTS];
    for (i, p) in points.iter_mut().enumerate() {
        *p = [
            a[[i, 0]],
            a[[i, 1]],
            if a.ncols() == 3 { a[[i, 2]] } else { 1.0 },
        ];
    }
    Keypoints2d::new(points).map_err(core_err)
}

#[pymethods]
impl PyLifter {
    #[new]
    #[pyo3(signature = (camera, tracking=true, hand_scale=None, hand=None))]
    fn new(
        camera: &Bound<'_, PyAny>,
        tracking: bool,
        hand_scale: Option<f64>,
        hand: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyLifter> {
        let cameras = to_cameras(Some(camera))?;
        Ok(PyLifter {
            inner: monohand::Lifter::new(
                cameras,
                sized_hands(hand, hand_scale)?.0,
                FitOptions::default(),
                tracking,
            )
            .map_err(session_err)?,
        })
    }

    /// Lifts one hand of one view: returns a `Hand` with `joints_3d_mm`, or raises
    /// `MonohandError` if it cannot be fitted (too few confident joints).
    #[pyo3(signature = (keypoints_2d, side="right"))]
    fn lift(
        &mut self,
        py: Python<'_>,
        keypoints_2d: PyReadonlyArray2<'_, f64>,
        side: &str,
    ) -> PyResult<PyHand> {
        let side = parse_side(side)?;
        let keypoints = to_keypoints(keypoints_2d)?;
        let obs = HandObservation {
            side,
            keypoints,
            cues: None,
        };
        let lifter = &mut self.inner;
        let lifted = py.detach(|| lifter.lift(&[std::slice::from_ref(&obs)]));
        let Some(hand) = lifted.into_iter().next() else {
            return Err(MonohandError::new_err("no hand to lift"));
        };
        match hand.outcome {
            monohand::FitOutcome::Fitted(fit) => Ok(PyHand {
                inner: HandRecord::from_fit(side, &keypoints, &fit),
            }),
            other => Err(MonohandError::new_err(format!("not fitted: {other:?}"))),
        }
    }
}
