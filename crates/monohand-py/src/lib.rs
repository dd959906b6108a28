//! The CPython extension `monohand._monohand`: the session, the lifter, cameras and video
//! reading of the Rust crates, with NumPy arrays in and out. The Python package `monohand`
//! (`python/monohand`) re-exports it and adds tables and the Daft integration.
//!
//! The GIL is released while the networks run, while the fit runs and while ffmpeg
//! decodes, so Python threads (and Daft's workers) run side by side.
#![deny(missing_docs)]

mod wrist;

use monohand::engine::{Engine, EngineError, Input, Observer, Output, RunReport, Sink};
use monohand::records::fitted_record;
use monohand::vision::{HandPipeline, Precision};
use monohand::{Field, SessionError, SessionOptions, SettingsError};
use monohand_core::filtering::OneEuroParams;
use monohand_core::prelude::*;
use monohand_io::jsonl::{FrameRecord, HandRecord, PoseRecord, XrJointRecord};
use monohand_media::video::{VideoInput, VideoReader};
use numpy::ndarray::{Array2, Array3};
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyStopIteration, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyList;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex};

create_exception!(
    _monohand,
    MonohandError,
    PyRuntimeError,
    "A model, file, video or fit failed (the message says which and why)."
);

/// A refused setting, said with the argument's Python name.
fn settings_err(e: &SettingsError) -> PyErr {
    let name = match e.field {
        Field::MaxHands => "hands",
        Field::Smoothing | Field::SmoothMinCutoff | Field::SmoothBeta => "smoothing",
        other => other.name(),
    };
    PyValueError::new_err(format!("{name} {}", e.why))
}

fn session_err(e: SessionError) -> PyErr {
    match e {
        SessionError::Settings(e) => settings_err(&e),
        SessionError::Core(e) => PyValueError::new_err(e.to_string()),
        e @ (SessionError::Views { .. } | SessionError::FrameTime(_) | SessionError::NoCamera) => {
            PyValueError::new_err(e.to_string())
        }
        other => MonohandError::new_err(other.to_string()),
    }
}

fn engine_err(e: EngineError) -> PyErr {
    match e {
        EngineError::Settings(e) => settings_err(&e),
        EngineError::Session(e) => session_err(e),
        other => MonohandError::new_err(other.to_string()),
    }
}

fn io_err(e: monohand_io::IoError) -> PyErr {
    MonohandError::new_err(e.to_string())
}

fn core_err(e: CoreError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn side_name(side: HandSide) -> &'static str {
    match side {
        HandSide::Left => "left",
        HandSide::Right => "right",
    }
}

fn parse_side(side: &str) -> PyResult<HandSide> {
    match side.to_ascii_lowercase().as_str() {
        "left" | "l" => Ok(HandSide::Left),
        "right" | "r" => Ok(HandSide::Right),
        _ => Err(PyValueError::new_err(format!(
            "side must be 'left' or 'right', not {side:?}"
        ))),
    }
}

/// The default (population average) hands, left then right, scaled by `hand_scale`
/// ([`monohand::hand_skeletons`]).
fn skeletons(hand_scale: f64) -> PyResult<[HandSkeleton; 2]> {
    monohand::hand_skeletons(hand_scale, None).map_err(session_err)
}

/// The hands of a `hand=` (a `HandSize` or a hand file's path) or a `hand_scale=` (not
/// both; neither: the default size), and where their size came from.
fn sized_hands(
    hand: Option<&Bound<'_, PyAny>>,
    hand_scale: Option<f64>,
) -> PyResult<([HandSkeleton; 2], monohand::HandSizeSource)> {
    let hand = hand.map(PyHandSize::from_arg).transpose()?;
    // A `HandSize.from_length` is a ruler's length; one loaded, a hand file.
    let (file, ruler_mm) = match &hand {
        Some(h) if h.source == monohand::HandSizeSource::Ruler => (None, h.file.ruler_mm),
        Some(h) => (Some(&h.file), None),
        None => (None, None),
    };
    let given = monohand::GivenHandSize {
        file,
        ruler_mm,
        scale: hand_scale.map(monohand::HandScale::Fixed),
    };
    let (scale, source) = given.choose().map_err(|e| match e {
        monohand::HandSizeError::MoreThanOne(_) => {
            PyValueError::new_err("give hand= or hand_scale=, not both")
        }
        e @ monohand::HandSizeError::Scale(_) if given.file.is_none() => {
            PyValueError::new_err(format!("hand_scale: {e}"))
        }
        e => PyValueError::new_err(format!("hand: {e}")),
    })?;
    Ok((skeletons(scale.initial())?, source))
}

/// A person's hand, measured once and reused: the hand file of `monohand run --save-hand`
/// (docs/absolute-depth.md).
///
/// `HandSize.load(path)` reads one, `HandSize.from_length(mm)` makes one from a ruler's
/// hand length (the hand flat, wrist crease to the end of the middle finger), `save(path)`
/// writes it. `Session(hand=...)` and `Lifter(hand=...)` fit both hands at its size. (The
/// name `Hand` is the fitted hand a session returns.)
#[pyclass(module = "monohand._monohand", name = "HandSize", frozen)]
#[derive(Clone)]
struct PyHandSize {
    file: monohand_io::hand::HandFile,
    /// What the records say of it: `file` when loaded, `ruler` from a length.
    source: monohand::HandSizeSource,
}

impl PyHandSize {
    /// The hand size of `hand`: a `HandSize`, or a path to a hand file.
    fn from_arg(hand: &Bound<'_, PyAny>) -> PyResult<PyHandSize> {
        if let Ok(h) = hand.cast::<PyHandSize>() {
            return Ok(h.get().clone());
        }
        let path: std::path::PathBuf = hand.extract().map_err(|_| {
            PyValueError::new_err("hand must be a HandSize or the path of a hand file")
        })?;
        PyHandSize::load(path)
    }
}

#[pymethods]
impl PyHandSize {
    /// Reads a hand file.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<PyHandSize> {
        let file = monohand_io::hand::read_hand(&path).map_err(io_err)?;
        Ok(PyHandSize {
            file,
            source: monohand::HandSizeSource::File,
        })
    }

    /// The hand of a ruler's length in mm (the hand flat, from the wrist crease to the end
    /// of the middle finger).
    #[staticmethod]
    fn from_length(length_mm: f64) -> PyResult<PyHandSize> {
        let scale = monohand::scale_from_ruler(length_mm)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let model = HandSkeleton::default_for(HandSide::Right).hand_length() * scale;
        Ok(PyHandSize {
            file: monohand_io::hand::HandFile {
                ruler_mm: Some(length_mm),
                ..monohand_io::hand::HandFile::new(
                    monohand_io::hand::HandSource::Ruler,
                    scale,
                    model,
                )
            },
            source: monohand::HandSizeSource::Ruler,
        })
    }

    /// Writes the hand file (whole or not at all).
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        monohand_io::hand::write_hand(&path, &self.file).map_err(io_err)
    }

    /// The size as a factor on the default adult hand.
    #[getter]
    fn scale(&self) -> f64 {
        self.file.scale
    }

    /// The standard uncertainty of `scale` (None where unknown).
    #[getter]
    fn scale_sigma(&self) -> Option<f64> {
        self.file.scale_sigma
    }

    /// The model's wrist-to-middle-fingertip length at this size, mm.
    #[getter]
    fn hand_length_mm(&self) -> f64 {
        self.file.hand_length_mm
    }

    /// `"views"` (measured by a calibrated rig) or `"ruler"`.
    #[getter]
    fn source(&self) -> &'static str {
        self.file.source.as_str()
    }

    /// The side it was measured on (None for a ruler's).
    #[getter]
    fn side(&self) -> Option<&'static str> {
        self.file.side.map(side_name)
    }

    /// The frames it was measured on.
    #[getter]
    fn frames(&self) -> Vec<u64> {
        self.file.frames.clone()
    }

    /// Each bone's length where the views support it (None elsewhere), mm.
    #[getter]
    fn bone_lengths_mm(&self) -> Option<Vec<Option<f64>>> {
        self.file.bone_lengths_mm.map(|b| b.to_vec())
    }

    fn __repr__(&self) -> String {
        format!(
            "HandSize(scale={:.4}, hand_length_mm={:.1}, source={:?})",
            self.file.scale,
            self.file.hand_length_mm,
            self.file.source.as_str()
        )
    }
}

/// A record as plain Python lists, dicts and numbers: exactly what `monohand run` writes
/// to JSON Lines, read back by Python's own `json`.
fn as_python<'py>(py: Python<'py>, record: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(record).map_err(|e| MonohandError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A 21x3 array of rows of three numbers.
fn joints_array<'py>(py: Python<'py>, rows: &[[f64; 3]; NUM_JOINTS]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    // The shape matches the data by construction.
    let arr = Array2::from_shape_vec((NUM_JOINTS, 3), flat)
        .unwrap_or_else(|_| Array2::zeros((NUM_JOINTS, 3)));
    PyArray2::from_owned_array(py, arr)
}

/// A camera with a lens model (the pinhole, optionally with OpenCV's distortion, or
/// OpenCV's fisheye) at a pose in the reference frame.
///
/// `Camera(fx, fy, cx, cy, width, height, distortion=None, rotation=None,
/// translation_mm=None, model="pinhole")`, with `x_cam = rotation @ x_ref + translation_mm`
/// for the later cameras of a rig (the first is the reference); `Camera.generic(width,
/// height)` for footage of unknown origin; `Camera.load(path)` for a calibration file (the
/// project's JSON, the WACV'18 JSON, OpenCV YAML or XML, ROS camera_info, one camera of a
/// Kalibr chain as `FILE#camN`).
#[pyclass(module = "monohand._monohand", name = "Camera", frozen, eq)]
#[derive(Clone, Copy, PartialEq)]
struct PyCamera {
    inner: Camera,
}

#[pymethods]
impl PyCamera {
    #[new]
    #[pyo3(signature = (fx, fy, cx, cy, width, height, distortion=None, rotation=None, translation_mm=None, model="pinhole"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
        distortion: Option<Vec<f64>>,
        rotation: Option<[[f64; 3]; 3]>,
        translation_mm: Option<[f64; 3]>,
        model: &str,
    ) -> PyResult<PyCamera> {
        let model = LensModel::from_name(model).ok_or_else(|| {
            PyValueError::new_err(format!(
                "model {model:?} is not a lens model (\"pinhole\" or \"fisheye\")"
            ))
        })?;
        let distortion =
            Distortion::new(model, distortion.as_deref().unwrap_or(&[])).map_err(core_err)?;
        let mut extrinsics = Extrinsics::default();
        if let Some(r) = rotation {
            let m = nalgebra::Matrix3::from_fn(|i, j| r[i][j]);
            extrinsics.rotation = nalgebra::Rotation3::from_matrix_unchecked(m);
        }
        if let Some(t) = translation_mm {
            extrinsics.translation = nalgebra::Vector3::from(t);
        }
        let intrinsics = Intrinsics {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        };
        // Checks the numbers, and that the rotation is a proper rotation.
        let inner = Camera::new(intrinsics, distortion, extrinsics).map_err(core_err)?;
        Ok(PyCamera { inner })
    }

    /// A camera for footage of unknown origin: principal point at the centre, a 60 degree
    /// horizontal field of view. Absolute depth is then only as good as that guess.
    #[staticmethod]
    fn generic(width: u32, height: u32) -> PyResult<PyCamera> {
        Ok(PyCamera {
            inner: Camera::generic(width, height).map_err(core_err)?,
        })
    }

    /// The camera of a calibration file (`FILE#camN` for one camera of a Kalibr camera
    /// chain).
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<PyCamera> {
        Ok(PyCamera {
            inner: monohand_io::calibration::read_camera(&path).map_err(io_err)?,
        })
    }

    /// Focal length along x, pixels.
    #[getter]
    fn fx(&self) -> f64 {
        self.inner.intrinsics.fx
    }
    /// Focal length along y, pixels.
    #[getter]
    fn fy(&self) -> f64 {
        self.inner.intrinsics.fy
    }
    /// Principal point x, pixels (pixel centres at integers).
    #[getter]
    fn cx(&self) -> f64 {
        self.inner.intrinsics.cx
    }
    /// Principal point y, pixels.
    #[getter]
    fn cy(&self) -> f64 {
        self.inner.intrinsics.cy
    }
    /// Image width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.intrinsics.width
    }
    /// Image height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.intrinsics.height
    }
    /// The lens model: `"pinhole"` (OpenCV's radial-tangential distortion) or `"fisheye"`
    /// (OpenCV's fisheye, Kannala-Brandt).
    #[getter]
    fn model(&self) -> &'static str {
        self.inner.distortion.model.name()
    }
    /// The distortion coefficients as OpenCV lists them for the model (none for an ideal
    /// pinhole; `k1 k2 k3 k4` for a fisheye).
    #[getter]
    fn distortion(&self) -> Vec<f64> {
        self.inner.distortion.listed().to_vec()
    }
    /// The 3x3 rotation from the reference (first) camera's frame to this camera's:
    /// `x_cam = R x_ref + t`.
    #[getter]
    fn rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let m = self.inner.extrinsics.rotation.matrix();
        let arr = Array2::from_shape_fn((3, 3), |(i, j)| m[(i, j)]);
        PyArray2::from_owned_array(py, arr)
    }
    /// The translation `t` of `x_cam = R x_ref + t`, mm.
    #[getter]
    fn translation_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let t = self.inner.extrinsics.translation;
        PyArray1::from_slice(py, &[t.x, t.y, t.z])
    }
    /// The 3x3 intrinsic matrix.
    #[getter]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let i = &self.inner.intrinsics;
        let k = [[i.fx, 0.0, i.cx], [0.0, i.fy, i.cy], [0.0, 0.0, 1.0]];
        let flat: Vec<f64> = k.iter().flatten().copied().collect();
        let arr = Array2::from_shape_vec((3, 3), flat).unwrap_or_else(|_| Array2::eye(3));
        PyArray2::from_owned_array(py, arr)
    }
    /// Projects points `(N, 3)` in millimetres in the reference frame to pixels `(N, 2)`
    /// (NaN for points behind the camera).
    fn project<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = points.as_array();
        if p.ncols() != 3 {
            return Err(PyValueError::new_err(format!(
                "points must be (N, 3), not {:?}",
                p.shape()
            )));
        }
        let mut out = Array2::from_elem((p.nrows(), 2), f64::NAN);
        for (i, row) in p.rows().into_iter().enumerate() {
            let x = nalgebra::Vector3::new(row[0], row[1], row[2]);
            if let Some(px) = self.inner.project(&x) {
                out[[i, 0]] = px.x;
                out[[i, 1]] = px.y;
            }
        }
        Ok(PyArray2::from_owned_array(py, out))
    }
    fn __repr__(&self) -> String {
        let i = &self.inner.intrinsics;
        let lens = match self.inner.distortion.model {
            LensModel::Pinhole => String::new(),
            LensModel::Fisheye => format!(
                ", distortion={:?}, model=\"fisheye\"",
                self.inner.distortion.listed()
            ),
        };
        format!(
            "Camera(fx={}, fy={}, cx={}, cy={}, width={}, height={}{lens})",
            i.fx, i.fy, i.cx, i.cy, i.width, i.height
        )
    }
}

/// The fitted hand model's parameters: wrist translation (mm), rotation quaternion
/// `(x, y, z, w)` and the 20 joint angles (radians), in the project's parameter layout.
#[pyclass(module = "monohand._monohand", name = "Pose", frozen)]
#[derive(Clone)]
struct PyPose {
    inner: PoseRecord,
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
struct PyHand {
    inner: HandRecord,
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
        wrist::wrist_pose(py, &self.inner)
    }
    /// `(21, 3)`: the joints in the wrist frame, metres (`convention`: `"mano"`); `None`
    /// without 3D.
    #[pyo3(signature = (convention = "mano"))]
    fn joints_in_wrist_frame<'py>(
        &self,
        py: Python<'py>,
        convention: &str,
    ) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        wrist::joints_in_wrist_frame(py, &self.inner, convention)
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
    fn xr(&self) -> Option<std::borrow::Cow<'_, [XrJointRecord]>> {
        match &self.inner.xr_joints {
            Some(j) => Some(std::borrow::Cow::Borrowed(j.as_slice())),
            None => self.inner.xr_joints_of_fit().map(std::borrow::Cow::Owned),
        }
    }
}

/// Copies an `(H, W, 3)` uint8 array into an image (the networks crop from it).
fn to_image(array: &Bound<'_, PyAny>) -> PyResult<monohand::RgbImage> {
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

/// `None`, a `Camera`, or a sequence of them.
fn to_cameras(cameras: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Camera>> {
    let Some(c) = cameras else {
        return Ok(Vec::new());
    };
    if c.is_none() {
        return Ok(Vec::new());
    }
    if let Ok(cam) = c.cast::<PyCamera>() {
        return Ok(vec![cam.get().inner]);
    }
    let bad = || PyValueError::new_err("cameras must be a Camera or a list of Camera");
    c.try_iter()
        .map_err(|_| bad())?
        .map(|item| {
            let item = item?;
            let cam = item.cast::<PyCamera>().map_err(|_| bad())?;
            Ok(cam.get().inner)
        })
        .collect()
}

/// A bool as Python writes it.
fn py_bool(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}

/// The networks, loaded once and shared by any number of sessions (for example one per
/// video on a worker): `Models(hands=2, tracking=True, model_dir=None, heads=False,
/// mirror_pass=True, precision="f32")`. `tracking=False` is for independent images (one
/// extra landmark pass per hand). `mirror_pass=False` reads each crop once instead of also
/// reading its mirror image (faster, larger 3D error; docs/accuracy.md). `precision="int8"`
/// runs the palm and landmark networks' 1x1 convolutions in int8 (docs/performance.md).
#[pyclass(module = "monohand._monohand", name = "Models", frozen)]
struct PyModels {
    pipeline: Arc<HandPipeline>,
    hands: usize,
    tracking: bool,
    heads: bool,
    mirror_pass: bool,
    precision: Precision,
}

/// `precision=` of the Python API: "f32" or "int8".
fn precision_arg(precision: &str) -> PyResult<Precision> {
    precision
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("precision: {e}")))
}

#[pymethods]
impl PyModels {
    #[new]
    #[pyo3(signature = (hands=2, tracking=true, model_dir=None, heads=false, mirror_pass=true, precision="f32"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        hands: usize,
        tracking: bool,
        model_dir: Option<std::path::PathBuf>,
        heads: bool,
        mirror_pass: bool,
        precision: &str,
    ) -> PyResult<PyModels> {
        if hands == 0 {
            return Err(PyValueError::new_err("at least one hand per frame"));
        }
        let precision = precision_arg(precision)?;
        let mut options = SessionOptions::default()
            .hands(hands)
            .heads(heads)
            .mirror_pass(mirror_pass)
            .precision(precision);
        if let Some(dir) = model_dir {
            options = options.model_dir(dir);
        }
        let options = options.tracking(tracking);
        let pipeline = py
            .detach(|| monohand::Session::load_pipeline(&options))
            .map_err(session_err)?;
        Ok(PyModels {
            pipeline: Arc::new(pipeline),
            hands,
            tracking,
            heads,
            mirror_pass,
            precision,
        })
    }

    /// The networks' arithmetic: "f32" or "int8".
    #[getter]
    fn precision(&self) -> &'static str {
        self.precision.name()
    }

    /// The most hands per frame.
    #[getter]
    fn hands(&self) -> usize {
        self.hands
    }
    /// Whether they are set up for video tracking.
    #[getter]
    fn tracking(&self) -> bool {
        self.tracking
    }
    /// Whether the landmark network also reads each crop's mirror image.
    #[getter]
    fn mirror_pass(&self) -> bool {
        self.mirror_pass
    }
    fn __repr__(&self) -> String {
        format!(
            "Models(hands={}, tracking={}, heads={}, mirror_pass={}, precision={:?})",
            self.hands,
            py_bool(self.tracking),
            py_bool(self.heads),
            py_bool(self.mirror_pass),
            self.precision.name()
        )
    }
}

/// Frames in, tracked absolute 3D hands out.
///
/// `Session(cameras=None, hands=2, tracking=True, ...)`: `cameras` is a `Camera`, a list
/// of them (a calibrated rig, the first the reference), or `None` (a generic camera for the
/// image size; the 3D is then only as absolute as that guess). `hand_scale` sizes the
/// average adult hand (0.9 for a small hand; the absolute depth scales with it). Use it as
/// a context manager,
/// and call `process(image, time_s)` once per frame in order. `rerun="hands.rrd"` writes
/// every frame of the session (`process`'s and `track`'s) into a Rerun recording, as
/// `monohand run --rerun` does (images scaled by `rerun_image_scale`); it is complete once
/// the session is closed.
#[pyclass(module = "monohand._monohand", name = "Session")]
struct PySession {
    inner: Option<monohand::Session>,
    next_time: f64,
    /// The same pipeline, cameras and settings as the engine `track` runs.
    engine: Arc<Engine>,
    /// The Rerun recording every frame also goes to.
    rerun: Option<SharedSink>,
}

/// A sink that several runs of the session write to in turn (its Rerun recording).
#[derive(Clone)]
struct SharedSink(Arc<Mutex<Box<dyn Sink + Send>>>);

impl SharedSink {
    fn lock(
        &self,
    ) -> Result<std::sync::MutexGuard<'_, Box<dyn Sink + Send>>, monohand::engine::SinkError> {
        self.0
            .lock()
            .map_err(|_| "the recording failed in another thread".into())
    }
}

impl Sink for SharedSink {
    fn wants_images(&self) -> bool {
        true
    }

    fn wants_every_view(&self) -> bool {
        true
    }

    fn write(&mut self, frame: &Output<'_>) -> Result<(), monohand::engine::SinkError> {
        self.lock()?.write(frame)
    }
}

/// The Rerun recording of `Session(rerun=...)`.
#[cfg(feature = "rerun")]
fn rerun_sink(path: &std::path::Path, views: usize, scale: f64) -> PyResult<SharedSink> {
    let names = (1..=views.max(1)).map(|v| format!("view{v}")).collect();
    let sink = monohand::engine::RerunSink::create(path, names, scale)
        .map_err(|e| PyValueError::new_err(format!("rerun: {}: {e}", path.display())))?;
    Ok(SharedSink(Arc::new(Mutex::new(Box::new(sink)))))
}

/// Without the `rerun` feature: refused, saying why.
#[cfg(not(feature = "rerun"))]
fn rerun_sink(path: &std::path::Path, _views: usize, _scale: f64) -> PyResult<SharedSink> {
    Err(PyValueError::new_err(format!(
        "rerun: {}: this build of monohand has no Rerun recordings (the crate's `rerun` feature)",
        path.display()
    )))
}

impl PySession {
    fn session(&mut self) -> PyResult<&mut monohand::Session> {
        self.inner
            .as_mut()
            .ok_or_else(|| PyValueError::new_err("the session is closed"))
    }
}

#[pymethods]
impl PySession {
    #[new]
    #[pyo3(signature = (cameras=None, hands=2, tracking=true, model_dir=None, smoothing=false, heads=false, detect_every=10, models=None, hand_scale=None, mirror_pass=true, rectify_crops="off", precision="f32", hand=None, rerun=None, rerun_image_scale=1.0, fitted_crops=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        cameras: Option<&Bound<'_, PyAny>>,
        hands: usize,
        tracking: bool,
        model_dir: Option<std::path::PathBuf>,
        smoothing: bool,
        heads: bool,
        detect_every: usize,
        models: Option<PyRef<'_, PyModels>>,
        hand_scale: Option<f64>,
        mirror_pass: bool,
        rectify_crops: &str,
        precision: &str,
        hand: Option<&Bound<'_, PyAny>>,
        rerun: Option<std::path::PathBuf>,
        rerun_image_scale: f64,
        fitted_crops: bool,
    ) -> PyResult<PySession> {
        let (skeletons, hand_size) = sized_hands(hand, hand_scale)?;
        let cameras = to_cameras(cameras)?;
        let rerun = rerun
            .map(|p| rerun_sink(&p, cameras.len(), rerun_image_scale))
            .transpose()?;
        let precision = precision_arg(precision)?;
        let rectify = rectify_crops
            .parse()
            .map_err(|e| PyValueError::new_err(format!("rectify_crops: {e}")))?;
        let mut options = SessionOptions::default()
            .hands(hands)
            .tracking(tracking)
            .heads(heads)
            .mirror_pass(mirror_pass)
            .precision(precision)
            .skeletons(skeletons)
            .smoothing(smoothing.then(OneEuroParams::default))
            .detect_every(detect_every);
        options.settings.rectify = rectify;
        options.settings.fitted_crops = fitted_crops;
        options.settings.fit.hand_size = hand_size;
        let resolved = options
            .settings
            .clone()
            .resolve()
            .map_err(|e| settings_err(&e))?;
        if let Some(dir) = model_dir {
            options = options.model_dir(dir);
        }
        let pipeline = match models {
            Some(m) => {
                if (m.hands, m.tracking, m.heads, m.mirror_pass, m.precision)
                    != (hands, tracking, heads, mirror_pass, precision)
                {
                    return Err(PyValueError::new_err(format!(
                        "the session asks for hands={hands}, tracking={}, heads={}, \
                         mirror_pass={}, precision={:?} but the models were loaded with {}",
                        py_bool(tracking),
                        py_bool(heads),
                        py_bool(mirror_pass),
                        precision.name(),
                        m.__repr__()
                    )));
                }
                Arc::clone(&m.pipeline)
            }
            // Loading (and on first use fetching) the networks takes a while: let Python run.
            None => Arc::new(
                py.detach(|| monohand::Session::load_pipeline(&options))
                    .map_err(session_err)?,
            ),
        };
        let engine =
            Engine::new(Arc::clone(&pipeline), cameras.clone(), resolved).map_err(engine_err)?;
        let inner =
            monohand::Session::with_pipeline(cameras, pipeline, options).map_err(session_err)?;
        Ok(PySession {
            inner: Some(inner),
            next_time: 0.0,
            engine: Arc::new(engine),
            rerun,
        })
    }

    /// Tracks a whole input, `monohand run`'s way: `path` is a video file (anything ffmpeg
    /// reads), an image, a folder of images or `webcam:N`. Decoding, the networks and the
    /// fit run on threads of their own, without the GIL, as in `monohand run` (the same
    /// engine). Returns an iterator over the frames, in order, each a `TrackedFrame`; at
    /// most a few frames wait in memory. Each call starts from a fresh state (its own
    /// tracks and ids), apart from `process`'s. An input that ends on an error raises
    /// `MonohandError` after its good frames. `offline=True` is `monohand run --offline`:
    /// each frame is refitted with the frames after it too (needs a tracking session).
    #[pyo3(signature = (path, max_frames=None, offline=false))]
    fn track(
        &mut self,
        py: Python<'_>,
        path: String,
        max_frames: Option<u64>,
        offline: bool,
    ) -> PyResult<PyFrameStream> {
        self.session()?;
        let engine = (*self.engine)
            .clone()
            .with_max_frames(max_frames)
            .with_offline(offline)
            .map_err(engine_err)?;
        let source = py
            .detach(|| {
                Input::parse(&path).and_then(|i| i.open(monohand::engine::DEFAULT_STALL_TIMEOUT))
            })
            .map_err(|e| MonohandError::new_err(e.to_string()))?;
        let (tx, rx) = sync_channel::<FrameRecord>(8);
        let watch = Arc::new(Watch::default());
        let observer = Arc::clone(&watch);
        let rerun = self.rerun.clone();
        let worker = std::thread::Builder::new()
            .name("monohand-track".into())
            .spawn(move || {
                let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(ChannelSink(tx))];
                sinks.extend(rerun.map(|r| Box::new(r) as Box<dyn Sink>));
                engine.run(vec![source], &mut sinks, &*observer)
            })
            .map_err(|e| MonohandError::new_err(format!("could not start a thread: {e}")))?;
        Ok(PyFrameStream {
            rx: Some(Mutex::new(rx)),
            worker: Some(worker),
            watch,
            report: None,
        })
    }

    /// Processes one frame: `image` is an `(H, W, 3)` uint8 RGB array, or a list of them,
    /// one per camera. `time_s` is the frame's time in seconds (default: 30 fps). Returns
    /// the frame's hands.
    #[pyo3(signature = (image, time_s=None))]
    fn process(
        &mut self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<Vec<PyHand>> {
        Ok(self
            .process_record(py, image, time_s)?
            .hands
            .into_iter()
            .map(|inner| PyHand { inner })
            .collect())
    }

    /// Like `process`, but returns the whole frame record (as `monohand run` writes it) as
    /// a dict, with the heads and any per-frame error.
    #[pyo3(signature = (image, time_s=None))]
    fn process_dict<'py>(
        &mut self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let record = self.process_record(py, image, time_s)?;
        as_python(py, &record)
    }

    /// Messages for the user since the last call (assumptions made, hand size found).
    fn notes(&mut self) -> PyResult<Vec<String>> {
        Ok(self.session()?.take_notes())
    }

    /// The cameras in use (a generic one once the first image told its size, if none
    /// was given).
    #[getter]
    fn cameras(&mut self) -> PyResult<Vec<PyCamera>> {
        Ok(self
            .session()?
            .cameras()
            .iter()
            .map(|&inner| PyCamera { inner })
            .collect())
    }

    /// Frees the networks and completes the Rerun recording; later calls raise.
    fn close(&mut self) -> PyResult<()> {
        self.inner = None;
        if let Some(r) = self.rerun.take() {
            r.lock()
                .and_then(|mut s| s.finish())
                .map_err(|e| MonohandError::new_err(format!("rerun: {e}")))?;
        }
        Ok(())
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close()?;
        Ok(false)
    }
}

impl PySession {
    fn process_record(
        &mut self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<FrameRecord> {
        let images: Vec<monohand::RgbImage> = if let Ok(list) = image.cast::<PyList>() {
            list.iter().map(|i| to_image(&i)).collect::<PyResult<_>>()?
        } else {
            vec![to_image(image)?]
        };
        let t = time_s.unwrap_or(self.next_time);
        self.next_time = t + 1.0 / 30.0;
        let session = self.session()?;
        let mut done = py
            .detach(|| {
                let refs: Vec<&monohand::RgbImage> = images.iter().collect();
                session.process(&refs, t)
            })
            .map_err(session_err)?;
        // Without the stereo hand-size measurement (not offered here) every frame comes
        // back at once.
        let Some(frame) = done.pop() else {
            return Err(MonohandError::new_err("the session kept the frame back"));
        };
        let mut record = fitted_record(&frame, None);
        record.time_s = Some(t);
        if let Some(e) = record.error.take() {
            return Err(MonohandError::new_err(e));
        }
        if let Some(rerun) = &self.rerun {
            let mut views = images.into_iter().map(Some);
            let first = views.next().flatten();
            let others: Vec<Option<monohand::RgbImage>> = views.collect();
            let output = Output {
                record: &record,
                image: first.as_ref(),
                cameras: &frame.cameras,
                other_images: &others,
                fitted: Some(&frame),
            };
            rerun
                .lock()
                .and_then(|mut s| s.write(&output))
                .map_err(|e| MonohandError::new_err(format!("rerun: {e}")))?;
        }
        Ok(record)
    }
}

/// The engine's side of a `track` call: Python's wish to stop, and the notes for the user.
#[derive(Default)]
struct Watch {
    stop: AtomicBool,
    notes: Mutex<Vec<String>>,
}

impl Observer for Watch {
    fn cancelled(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn note(&self, note: &monohand::Note) {
        if let Ok(mut n) = self.notes.lock() {
            n.push(note.message.clone());
        }
    }
}

/// Hands each record to Python's iterator; a full queue makes the engine wait.
struct ChannelSink(SyncSender<FrameRecord>);

impl Sink for ChannelSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), monohand::engine::SinkError> {
        self.0
            .send(frame.record.clone())
            .map_err(|_| "the iterator over the frames was closed".into())
    }
}

/// One frame of `Session.track`: `index`, `time_s` (for videos), `hands`, `error` (why
/// the frame could not be read, else `None`), `cameras` (the camera of each view the
/// hands were fitted with, as dicts) and `to_dict()`, the whole record as `monohand run`
/// writes it.
#[pyclass(module = "monohand._monohand", name = "TrackedFrame", frozen)]
struct PyTrackedFrame {
    record: FrameRecord,
}

#[pymethods]
impl PyTrackedFrame {
    /// Frame index, from 0.
    #[getter]
    fn index(&self) -> u64 {
        self.record.frame
    }
    /// Time of the frame in the video, seconds (`None` for independent images).
    #[getter]
    fn time_s(&self) -> Option<f64> {
        self.record.time_s
    }
    /// The frame's hands.
    #[getter]
    fn hands(&self) -> Vec<PyHand> {
        self.record
            .hands
            .iter()
            .map(|h| PyHand { inner: h.clone() })
            .collect()
    }
    /// Why the frame has no result, else `None`.
    #[getter]
    fn error(&self) -> Option<String> {
        self.record.error.clone()
    }
    /// The camera of each view the frame was fitted with (`fx, fy, cx, cy, width, height,
    /// source`), as dicts.
    #[getter]
    fn cameras<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        as_python(py, &self.record.cameras)
    }
    /// The whole record, as `monohand run` writes it (docs/output-format.md).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        as_python(py, &self.record)
    }
    fn __repr__(&self) -> String {
        format!(
            "TrackedFrame(index={}, hands={})",
            self.record.frame,
            self.record.hands.len()
        )
    }
}

/// The frames of a `Session.track` call, in order, as they are done.
#[pyclass(module = "monohand._monohand", name = "FrameStream")]
struct PyFrameStream {
    /// In a mutex only because Python objects must be shareable between threads.
    rx: Option<Mutex<Receiver<FrameRecord>>>,
    worker: Option<std::thread::JoinHandle<monohand::engine::EngineResult<RunReport>>>,
    watch: Arc<Watch>,
    report: Option<RunReport>,
}

impl PyFrameStream {
    /// Waits for the engine to end and keeps its report; its error, if any.
    fn join(&mut self, py: Python<'_>) -> PyResult<()> {
        self.rx = None;
        let Some(worker) = self.worker.take() else {
            return Ok(());
        };
        let result = py
            .detach(|| worker.join())
            .map_err(|_| MonohandError::new_err("the engine's thread failed"))?;
        let report = result.map_err(|e| MonohandError::new_err(monohand::engine::chain(&e)))?;
        let input_error = report.input_error.clone();
        self.report = Some(report);
        match input_error {
            Some(e) => Err(MonohandError::new_err(e.to_string())),
            None => Ok(()),
        }
    }
}

#[pymethods]
impl PyFrameStream {
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<PyTrackedFrame> {
        let Some(rx) = self.rx.as_ref() else {
            return Err(PyStopIteration::new_err(()));
        };
        let next = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv().ok(),
            Err(_) => None,
        });
        match next {
            Some(record) => Ok(PyTrackedFrame { record }),
            None => {
                self.join(py)?;
                Err(PyStopIteration::new_err(()))
            }
        }
    }

    /// Messages for the user so far (assumptions made, hand size found).
    fn notes(&self) -> Vec<String> {
        self.watch
            .notes
            .lock()
            .map(|n| n.clone())
            .unwrap_or_default()
    }

    /// Totals once the stream has ended (`frames`, `frames_with_hands`, `hands`,
    /// `hands_3d`, `mean_reprojection_px`, `unreadable`, `seconds`, `fps`), else `None`.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(r) = &self.report else {
            return Ok(None);
        };
        let json = serde_json::json!({
            "frames": r.frames,
            "frames_with_hands": r.frames_with_hands,
            "hands": r.hands,
            "hands_3d": r.hands_3d,
            "mean_reprojection_px": r.mean_reprojection_px(),
            "unreadable": r.unreadable,
            "seconds": r.seconds,
            "fps": r.frames as f64 / r.seconds.max(1e-9),
        });
        as_python(py, &json).map(Some)
    }

    /// Stops the engine (the frame in flight is finished) and waits for it.
    fn close(&mut self, py: Python<'_>) {
        self.watch.stop.store(true, Ordering::Relaxed);
        self.rx = None;
        let _ = self.join(py);
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.close(py);
        false
    }
}

impl Drop for PyFrameStream {
    fn drop(&mut self) {
        // The engine stops at its next frame: its sink fails once the queue is gone.
        self.watch.stop.store(true, Ordering::Relaxed);
    }
}

/// Fits 2D keypoints made elsewhere (OpenPose, MediaPipe, your own network) to absolute
/// 3D hands, frame after frame.
///
/// `Lifter(camera, tracking=True)`; `lift(keypoints_2d, side)` with `keypoints_2d` of
/// shape `(21, 2)` (confidence 1) or `(21, 3)` (x, y, confidence; joints under 0.1 are
/// ignored), in MediaPipe's joint order. With tracking each side's fit starts from its
/// previous one.
#[pyclass(module = "monohand._monohand", name = "Lifter")]
struct PyLifter {
    inner: monohand::Lifter,
}

fn to_keypoints(keypoints: PyReadonlyArray2<'_, f64>) -> PyResult<Keypoints2d> {
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

/// One decoded video frame: `index`, `time_s` and `image`, an `(H, W, 3)` uint8 RGB array
/// (handed over from the decoder without a copy).
#[pyclass(module = "monohand._monohand", name = "Frame", frozen, get_all)]
struct PyFrame {
    /// Frame index, from 0.
    index: u64,
    /// Nominal time, seconds (`index / fps`).
    time_s: f64,
    /// The pixels.
    image: Py<PyArray3<u8>>,
}

/// Frames a [`PyVideoReader`] decodes ahead of its caller: while Python processes one
/// frame, up to this many more are decoded and waiting (about 0.9 MB each at 640x480).
const DECODE_AHEAD: usize = 3;

/// What the decoding thread hands over: a frame, the end (`None`), or the error that ended
/// the video.
type Decoded = monohand_io::IoResult<Option<monohand_media::video::VideoFrame>>;

/// The frames of a video file (anything ffmpeg reads), decoded by an ffmpeg child process.
///
/// A thread of its own reads the frames from ffmpeg, [`DECODE_AHEAD`] ahead of the caller
/// (a bounded channel: it waits when they are not taken), so that decoding runs while
/// Python processes the frame before; taking a frame waits with the GIL released.
#[pyclass(module = "monohand._monohand", name = "VideoReader")]
struct PyVideoReader {
    /// The stream's description; `None` once closed or ended.
    info: Option<monohand_media::video::VideoInfo>,
    /// The decoded frames (in a mutex only to keep the class `Sync`; `&mut self` reaches
    /// it without locking).
    frames: Option<Mutex<Receiver<Decoded>>>,
    /// The decoding thread, which owns the reader (and so ffmpeg).
    decoder: Option<std::thread::JoinHandle<()>>,
}

impl PyVideoReader {
    /// Stops decoding: the thread's next hand-over fails, it ends and drops the reader,
    /// which stops ffmpeg; waits for that (a frame's decoding at most).
    fn stop(&mut self) {
        self.info = None;
        self.frames = None;
        if let Some(t) = self.decoder.take() {
            let _ = t.join();
        }
    }
}

impl Drop for PyVideoReader {
    fn drop(&mut self) {
        self.stop();
    }
}

#[pymethods]
impl PyVideoReader {
    #[new]
    fn new(py: Python<'_>, path: String) -> PyResult<PyVideoReader> {
        let input = VideoInput::parse(&path);
        let mut reader = py.detach(|| VideoReader::open(&input)).map_err(io_err)?;
        let info = reader.info().clone();
        let (tx, rx) = sync_channel::<Decoded>(DECODE_AHEAD);
        let decoder = std::thread::Builder::new()
            .name("monohand-video".into())
            .spawn(move || loop {
                let next = reader.next_frame();
                let more = matches!(next, Ok(Some(_)));
                if tx.send(next).is_err() || !more {
                    return;
                }
            })
            .map_err(|e| {
                MonohandError::new_err(format!("cannot start the decoding thread: {e}"))
            })?;
        Ok(PyVideoReader {
            info: Some(info),
            frames: Some(Mutex::new(rx)),
            decoder: Some(decoder),
        })
    }

    /// Frames per second (30 if the file does not say).
    #[getter]
    fn fps(&self) -> PyResult<f64> {
        self.info
            .as_ref()
            .map(|i| i.fps_or_default())
            .ok_or_else(|| PyValueError::new_err("the reader is closed"))
    }

    /// `(width, height)` of the frames.
    #[getter]
    fn size(&self) -> PyResult<(usize, usize)> {
        self.info
            .as_ref()
            .map(|i| (i.width, i.height))
            .ok_or_else(|| PyValueError::new_err("the reader is closed"))
    }

    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<PyFrame> {
        let Some(frames) = self.frames.as_mut() else {
            return Err(PyStopIteration::new_err(()));
        };
        let rx = match frames.get_mut() {
            Ok(rx) => rx,
            Err(poisoned) => poisoned.into_inner(),
        };
        // The thread's last message is the end or an error, after which it is not asked
        // again: a closed channel here means it panicked.
        // `move`: the closure owns the `&mut` (Send), not a shared `&Receiver` (not Sync).
        let Ok(next) = py.detach(move || rx.recv()) else {
            py.detach(|| self.stop());
            return Err(MonohandError::new_err("the video's decoding thread failed"));
        };
        match next {
            Ok(Some(f)) => {
                let (w, h) = f.image.dimensions();
                let arr = Array3::from_shape_vec((h as usize, w as usize, 3), f.image.into_raw())
                    .map_err(|e| MonohandError::new_err(e.to_string()))?;
                Ok(PyFrame {
                    index: f.index,
                    time_s: f.timestamp_s,
                    image: PyArray3::from_owned_array(py, arr).unbind(),
                })
            }
            Ok(None) => {
                py.detach(|| self.stop());
                Err(PyStopIteration::new_err(()))
            }
            Err(e) => {
                py.detach(|| self.stop());
                Err(io_err(e))
            }
        }
    }

    /// Stops ffmpeg.
    fn close(&mut self, py: Python<'_>) {
        py.detach(|| self.stop());
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.close(py);
        false
    }
}

/// Makes sure the networks' weights are in the cache (fetching MediaPipe's wheel with pip
/// on first use, checksummed) and returns the cache folder: `model_dir`, else
/// `$MONOHAND_MODEL_DIR`, else the user cache, as for the command-line tool.
#[pyfunction]
#[pyo3(signature = (model_dir=None))]
fn fetch_models(py: Python<'_>, model_dir: Option<std::path::PathBuf>) -> PyResult<String> {
    let vision = |e: monohand::vision::VisionError| MonohandError::new_err(e.to_string());
    let store = monohand::vision::models::ModelStore::new(model_dir).map_err(vision)?;
    py.detach(|| store.fetch()).map_err(vision)?;
    Ok(store.dir().display().to_string())
}

/// Calibrates a camera (`input`: a folder of images, image files, a video or `webcam:N`)
/// or a rig (`views`: one input per camera) from frames of a printed chessboard, as
/// `monohand calibrate` does; writes the files when `output` is given. Returns a dict:
/// `cameras` (each camera's JSON, as written), `summary` (the lines `monohand calibrate`
/// prints), `report` (the Markdown report) and `written` (the files' paths).
#[pyfunction]
#[pyo3(signature = (input=None, *, views=None, board, square_mm, output=None, model="standard", opencv_yaml=false, report=None, max_views=40, subpix_window=None, keep_all_views=false))]
#[allow(clippy::too_many_arguments)]
fn calibrate<'py>(
    py: Python<'py>,
    input: Option<Bound<'py, PyAny>>,
    views: Option<Vec<std::path::PathBuf>>,
    board: &str,
    square_mm: f64,
    output: Option<std::path::PathBuf>,
    model: &str,
    opencv_yaml: bool,
    report: Option<std::path::PathBuf>,
    max_views: usize,
    subpix_window: Option<usize>,
    keep_all_views: bool,
) -> PyResult<Bound<'py, PyAny>> {
    use monohand::calibration as cal;
    let value = |what: &str, e: String| PyValueError::new_err(format!("{what}: {e}"));
    let (cols, rows) = cal::parse_board_size(board).map_err(|e| value("board", e.to_string()))?;
    let board =
        cal::Board::new(cols, rows, square_mm).map_err(|e| value("board", e.to_string()))?;
    let path_text = |p: &std::path::Path| p.to_string_lossy().to_string();
    let (names, rig): (Vec<String>, bool) = match (input, views) {
        (Some(_), Some(_)) => return Err(PyValueError::new_err("give input or views, not both")),
        (None, Some(v)) => (v.iter().map(|p| path_text(p)).collect(), true),
        (Some(i), None) => match i.extract::<Vec<std::path::PathBuf>>() {
            Ok(list) if !i.is_instance_of::<pyo3::types::PyString>() => {
                (list.iter().map(|p| path_text(p)).collect(), false)
            }
            _ => (vec![path_text(&i.extract::<std::path::PathBuf>()?)], false),
        },
        (None, None) => {
            return Err(PyValueError::new_err(
                "give input (one camera) or views (a rig)",
            ))
        }
    };
    let mut settings = cal::CalibrateSettings::new(board);
    settings.max_views = max_views.max(3);
    settings.half_window = subpix_window;
    settings.options.model = model.parse().map_err(|e: String| value("model", e))?;
    if keep_all_views {
        settings.options.outlier_factor = f64::INFINITY;
    }
    let run = || -> Result<(cal::Calibrated, Vec<std::path::PathBuf>), cal::CalibrateError> {
        let inputs = cal::camera_inputs(&names, rig)?;
        let c = cal::calibrate(&inputs, &settings, &mut |_| true)?;
        let written = match &output {
            Some(path) => cal::write_outputs(
                &c,
                &cal::Outputs {
                    path: path.clone(),
                    opencv_yaml,
                    report: report.clone(),
                },
            )?,
            None => Vec::new(),
        };
        Ok((c, written))
    };
    let (c, written) = py
        .detach(run)
        .map_err(|e| MonohandError::new_err(e.to_string()))?;
    let date = cal::date_utc();
    let cameras: Vec<serde_json::Value> = (0..c.cameras.len())
        .map(|k| {
            monohand_io::calibration::calibrated_camera_json(
                &c.cameras[k].camera,
                &cal::camera_info(&c, k, &date),
            )
        })
        .collect();
    let result = serde_json::json!({
        "cameras": cameras,
        "summary": cal::summary(&c),
        "report": cal::markdown_report(&c, &[]),
        "written": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    as_python(py, &result)
}

/// The native part of the `monohand` package.
#[pymodule]
fn _monohand(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCamera>()?;
    m.add_class::<PyPose>()?;
    m.add_class::<PyHand>()?;
    m.add_class::<PyHandSize>()?;
    m.add_class::<PyModels>()?;
    m.add_class::<PySession>()?;
    m.add_class::<PyLifter>()?;
    m.add_class::<PyFrame>()?;
    m.add_class::<PyTrackedFrame>()?;
    m.add_class::<PyFrameStream>()?;
    m.add_class::<PyVideoReader>()?;
    m.add_function(wrap_pyfunction!(fetch_models, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add("MonohandError", m.py().get_type::<MonohandError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("NUM_JOINTS", NUM_JOINTS)?;
    let names: Vec<&str> = monohand_core::hand_model::JOINT_NAMES.to_vec();
    m.add("JOINT_NAMES", names)?;
    m.add("XR_JOINT_NAMES", monohand_core::xr::XR_JOINT_NAMES.to_vec())?;
    Ok(())
}
