//! `Pose` and `Hand`: a fitted hand as NumPy arrays.

use crate::convert::*;
use monohand_io::jsonl::{HandRecord, PoseRecord, XrJointRecord};
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

/// The fitted hand model's parameters: wrist translation (mm), rotation quaternion
/// `(x, y, z, w)` and the 20 joint angles (radians), in the project's parameter layout.
#[pyclass(module = "monohand._monohand", name = "Pose", frozen)]
#[derive(Clone)]
pub(crate) struct PyPose {
    pub(crate) inner: PoseRecord,
}

#[pymethods]
impl PyPose {
    /// Wrist position, mm, in the first camera's frame.
    #[getter]
    fn translation_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.translation_mm)
    }
    /// Hand rotation as a unit quaternion `(x, y, z, w)`.
    #[getter]
    fn quaternion_xyzw<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.quaternion_xyzw)
    }
    /// The 20 joint angles, radians (thumb to little finger, 4 each).
    #[getter]
    fn angles_rad<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.angles_rad)
    }
    fn __repr__(&self) -> String {
        let t = self.inner.translation_mm;
        format!(
            "Pose(translation_mm=[{:.1}, {:.1}, {:.1}], ...)",
            t[0], t[1], t[2]
        )
    }
}

/// One hand of a frame: the networks' 2D and the fitted absolute 3D.
///
/// The fields are those of a `hands` entry of `monohand run`'s JSON Lines output, with
/// arrays as NumPy arrays; `to_dict()` gives exactly that entry.
#[pyclass(module = "monohand._monohand", name = "Hand", frozen)]
#[derive(Clone)]
pub(crate) struct PyHand {
    pub(crate) inner: HandRecord,
}

#[pymethods]
impl PyHand {
    /// Identity over the frames of a session (`None` from `lift`).
    #[getter]
    fn id(&self) -> Option<u64> {
        self.inner.id
    }
    /// `"left"` or `"right"`, voted over the hand's frames.
    #[getter]
    fn side(&self) -> &'static str {
        side_name(self.inner.side)
    }
    /// Probability the network gives to the side (`None` without a network).
    #[getter]
    fn side_score(&self) -> Option<f64> {
        self.inner.side_score
    }
    /// Detection (presence) score in `[0, 1]`.
    #[getter]
    fn score(&self) -> Option<f64> {
        self.inner.score
    }
    /// Box around the keypoints, `(x0, y0, x1, y1)` pixels.
    #[getter]
    fn bbox(&self) -> Option<(f64, f64, f64, f64)> {
        self.inner
            .bbox
            .map(|b| (b.x_min, b.y_min, b.x_max, b.y_max))
    }
    /// `(21, 3)`: pixel x, y and confidence per joint (wrist, then 4 per finger, thumb to
    /// little), in the first camera's image.
    #[getter]
    fn keypoints_2d<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        joints_array(py, &self.inner.keypoints_2d)
    }
    /// `(21, 3)`: absolute 3D joints, mm, in the first camera's frame (x right, y down,
    /// z forward); `None` when the hand could not be fitted.
    #[getter]
    fn joints_3d_mm<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner
            .joints_3d_mm
            .as_ref()
            .map(|j| joints_array(py, j))
    }
    /// The fitted model parameters, or `None`.
    #[getter]
    fn pose(&self) -> Option<PyPose> {
        self.inner.pose.map(|inner| PyPose { inner })
    }
    /// Mean distance between the keypoints and the fitted joints' projections, pixels.
    #[getter]
    fn reprojection_error_px(&self) -> Option<f64> {
        self.inner.reprojection_error_px
    }
    /// Whether the fit met its tolerance.
    #[getter]
    fn converged(&self) -> Option<bool> {
        self.inner.converged
    }
    /// Levenberg-Marquardt iterations of the fit.
    #[getter]
    fn iterations(&self) -> Option<usize> {
        self.inner.iterations
    }
    /// `(21, 3)`: the landmark network's own wrist-relative 3D ("world" landmarks), mm.
    #[getter]
    fn world_mm<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner.world_mm.as_ref().map(|j| joints_array(py, j))
    }
    /// `(21,)`: the landmark network's relative depth per joint, pixels of its crop.
    #[getter]
    fn depth_px<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .depth_px
            .as_ref()
            .map(|d| PyArray1::from_slice(py, d))
    }
    /// `(26, 7)`: the hand as OpenXR's 26 hand joints (`XR_JOINT_NAMES`, in
    /// `XrHandJointEXT` order), each `x, y, z` (mm, the frame of `joints_3d_mm`) and its
    /// orientation `qx, qy, qz, qw` (from the joint's axes: -Z along its bone towards the
    /// finger tip, +Y out of the back of the hand); `None` without 3D.
    #[getter]
    fn xr_joints<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        let joints = self.xr()?;
        let flat: Vec<f64> = joints
            .iter()
            .flat_map(|j| j.position_mm.into_iter().chain(j.orientation_xyzw))
            .collect();
        let arr = Array2::from_shape_vec((joints.len(), 7), flat).ok()?;
        Some(PyArray2::from_owned_array(py, arr))
    }
    /// `(26,)`: each OpenXR joint's distance to the skin, mm (`xr_joints`' order); `None`
    /// without 3D.
    #[getter]
    fn xr_radii<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        let radii: Vec<f64> = self.xr()?.iter().map(|j| j.radius_mm).collect();
        Some(PyArray1::from_vec(py, radii))
    }
    /// `(4, 4)`: the wrist's pose, metres, in the first camera's frame: the transform from
    /// MANO's wrist frame (dex-retargeting's) to the camera's; `None` without 3D.
    fn wrist_pose<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        crate::wrist::wrist_pose(py, &self.inner)
    }
    /// `(21, 3)`: the joints in the wrist frame, metres (`convention`: `"mano"`); `None`
    /// without 3D.
    #[pyo3(signature = (convention = "mano"))]
    fn joints_in_wrist_frame<'py>(
        &self,
        py: Python<'py>,
        convention: &str,
    ) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        crate::wrist::joints_in_wrist_frame(py, &self.inner, convention)
    }
    /// With one camera and a tracked hand: the palm's distance from the camera, mm, as this
    /// frame's fits and the filter over the track gave it, a dict (`keypoints_mm`,
    /// `keypoints_sigma_mm`, `cues_mm`, `fused_mm`, `fused_sigma_mm`: docs/output-format.md,
    /// "distance object"); `None` otherwise.
    #[getter]
    fn distance<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .distance
            .as_ref()
            .map(|d| as_python(py, d))
            .transpose()
    }
    /// The hand as `monohand run` writes it to JSON Lines (plain lists and numbers).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        as_python(py, &self.inner)
    }
    fn __repr__(&self) -> String {
        let z = self.inner.joints_3d_mm.map_or("no 3D".to_string(), |j| {
            format!("wrist at z={:.0} mm", j[0][2])
        });
        format!(
            "Hand(id={}, side={}, {z})",
            self.inner.id.map_or("None".to_string(), |i| i.to_string()),
            side_name(self.inner.side)
        )
    }
}

impl PyHand {
    /// The record's OpenXR joints, or those of its fit
    /// ([`HandRecord::xr_joints_of_fit`]).
    pub(crate) fn xr(&self) -> Option<std::borrow::Cow<'_, [XrJointRecord]>> {
        match &self.inner.xr_joints {
            Some(j) => Some(std::borrow::Cow::Borrowed(j.as_slice())),
            None => self.inner.xr_joints_of_fit().map(std::borrow::Cow::Owned),
        }
    }
}
