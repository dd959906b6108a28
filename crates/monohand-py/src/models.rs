//! `Models`: the networks, loaded once and shared by sessions.

use crate::convert::*;
use crate::errors::*;
use monohand::vision::{HandPipeline, Precision};
use monohand::SessionOptions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::Arc;

/// The networks, loaded once and shared by any number of sessions (for example one per
/// video on a worker): `Models(hands=2, tracking=True, model_dir=None, heads=False,
/// mirror_pass=True, precision="f32")`. `tracking=False` is for independent images (one
/// extra landmark pass per hand). `mirror_pass=False` reads each crop once instead of also
/// reading its mirror image (faster, larger 3D error; docs/accuracy.md). `precision="int8"`
/// runs the palm and landmark networks' 1x1 convolutions in int8 (docs/performance.md).
#[pyclass(module = "monohand._monohand", name = "Models", frozen)]
pub(crate) struct PyModels {
    pub(crate) pipeline: Arc<HandPipeline>,
    pub(crate) hands: usize,
    pub(crate) tracking: bool,
    pub(crate) heads: bool,
    pub(crate) mirror_pass: bool,
    pub(crate) precision: Precision,
}

/// `precision=` of the Python API: "f32" or "int8" (a `Precision`), or for a session also
/// "auto" (a `monohand::PrecisionChoice`).
pub(crate) fn precision_arg<P: std::str::FromStr<Err = String>>(precision: &str) -> PyResult<P> {
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
        let precision: Precision = precision_arg(precision)?;
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
    pub(crate) fn __repr__(&self) -> String {
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
