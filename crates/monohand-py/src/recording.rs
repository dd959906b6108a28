//! The Rerun recording of `Session(rerun=...)`: one sink that `process` and every `track`
//! write to in turn.

use monohand::engine::{Output, Sink};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// A sink that several runs of the session write to in turn (its Rerun recording).
#[derive(Clone)]
pub(crate) struct SharedSink(pub(crate) Arc<Mutex<Box<dyn Sink + Send>>>);

impl SharedSink {
    pub(crate) fn lock(
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
pub(crate) fn rerun_sink(path: &std::path::Path, views: usize, scale: f64) -> PyResult<SharedSink> {
    let names = (1..=views.max(1)).map(|v| format!("view{v}")).collect();
    let sink = monohand::engine::RerunSink::create(path, names, scale)
        .map_err(|e| PyValueError::new_err(format!("rerun: {}: {e}", path.display())))?;
    Ok(SharedSink(Arc::new(Mutex::new(Box::new(sink)))))
}

/// Without the `rerun` feature: refused, saying why.
#[cfg(not(feature = "rerun"))]
pub(crate) fn rerun_sink(
    path: &std::path::Path,
    _views: usize,
    _scale: f64,
) -> PyResult<SharedSink> {
    Err(PyValueError::new_err(format!(
        "rerun: {}: this build of monohand has no Rerun recordings (the crate's `rerun` feature)",
        path.display()
    )))
}
