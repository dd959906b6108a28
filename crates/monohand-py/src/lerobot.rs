//! LeRobot v3 datasets from Python: `Session.track(..., lerobot=DIR)` writes the tracked
//! input as a one-episode dataset, and `lerobot_dataset(parts, out)` joins such episodes
//! into one dataset (what `monohand.daft.track_corpus(lerobot=...)` does at its end).

use crate::convert::as_python;
use crate::errors::MonohandError;
use monohand::engine::{LeRobotSink, Sink};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// The sink of `track(lerobot=dir)`: a new dataset of `views` views at `fps`.
pub(crate) fn sink(
    dir: &Path,
    views: usize,
    fps: Option<f64>,
    task: &str,
    source: Option<&Path>,
) -> PyResult<Box<dyn Sink + Send>> {
    let sink = LeRobotSink::create(dir, views, fps.unwrap_or(30.0), task)
        .map_err(|e| MonohandError::new_err(format!("lerobot: {e}")))?
        .with_source(source);
    Ok(Box::new(sink))
}

/// Joins one-episode LeRobot datasets (`Session.track(..., lerobot=DIR)`'s) into one
/// dataset at `out`, episode `k` from `parts[k]` (their videos linked, else copied; an
/// `out` already there is replaced). An episode whose frame size or rate is not the
/// first's is left out. Returns a dict: `episodes`, `frames` and `left_out` (a list of
/// `(part, reason)`).
#[pyfunction]
pub(crate) fn lerobot_dataset<'py>(
    py: Python<'py>,
    parts: Vec<PathBuf>,
    out: PathBuf,
) -> PyResult<Bound<'py, PyAny>> {
    let made = py
        .detach(|| monohand_io::lerobot::assemble(&parts, &out))
        .map_err(|e| MonohandError::new_err(format!("lerobot: {e}")))?;
    let left_out: Vec<(String, String)> = made
        .left_out
        .iter()
        .map(|(p, why)| (p.display().to_string(), why.clone()))
        .collect();
    as_python(
        py,
        &serde_json::json!({"episodes": made.episodes, "frames": made.frames, "left_out": left_out}),
    )
}
