//! The CPython extension `monohand._monohand`: the session, the lifter, cameras and video
//! reading of the Rust crates, with NumPy arrays in and out. The Python package `monohand`
//! (`python/monohand`) re-exports it and adds tables and the Daft integration.
//!
//! The GIL is released while the networks run, while the fit runs and while ffmpeg
//! decodes, so Python threads (and Daft's workers) run side by side.
#![deny(missing_docs)]

mod camera;
mod convert;
mod errors;
mod frames;
mod hand;
mod hand_size;
mod lerobot;
mod lifter;
mod models;
mod recording;
mod session;
mod sync;
mod video;
mod wrist;

use crate::camera::*;
use crate::convert::*;
use crate::errors::*;
use crate::hand::*;
use crate::hand_size::*;
use crate::lifter::*;
use crate::models::*;
use crate::session::*;
use crate::video::*;
use monohand_core::prelude::*;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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
    m.add_function(wrap_pyfunction!(lerobot::lerobot_dataset, m)?)?;
    m.add("MonohandError", m.py().get_type::<MonohandError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("NUM_JOINTS", NUM_JOINTS)?;
    let names: Vec<&str> = monohand_core::hand_model::JOINT_NAMES.to_vec();
    m.add("JOINT_NAMES", names)?;
    m.add("XR_JOINT_NAMES", monohand_core::xr::XR_JOINT_NAMES.to_vec())?;
    Ok(())
}
