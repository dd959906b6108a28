//! `Camera`: a calibrated camera and its lens, loaded, made and written.

use crate::errors::*;
use monohand_core::prelude::*;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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
pub(crate) struct PyCamera {
    pub(crate) inner: Camera,
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

/// `None`, a `Camera`, or a sequence of them.
pub(crate) fn to_cameras(cameras: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Camera>> {
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
