//! The Python exception `MonohandError` and the conversions of the crates' errors into
//! Python's.

use monohand::engine::EngineError;
use monohand::{Field, SessionError, SettingsError};
use monohand_core::prelude::*;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _monohand,
    MonohandError,
    PyRuntimeError,
    "A model, file, video or fit failed (the message says which and why)."
);

/// A refused setting, said with the argument's Python name.
pub(crate) fn settings_err(e: &SettingsError) -> PyErr {
    let name = match e.field {
        Field::MaxHands => "hands",
        Field::Smoothing | Field::SmoothMinCutoff | Field::SmoothBeta => "smoothing",
        other => other.name(),
    };
    PyValueError::new_err(format!("{name} {}", e.why))
}

pub(crate) fn session_err(e: SessionError) -> PyErr {
    match e {
        SessionError::Settings(e) => settings_err(&e),
        SessionError::Core(e) => PyValueError::new_err(e.to_string()),
        e @ (SessionError::Views { .. } | SessionError::FrameTime(_) | SessionError::NoCamera) => {
            PyValueError::new_err(e.to_string())
        }
        other => MonohandError::new_err(other.to_string()),
    }
}

pub(crate) fn engine_err(e: EngineError) -> PyErr {
    match e {
        EngineError::Settings(e) => settings_err(&e),
        EngineError::Session(e) => session_err(e),
        other => MonohandError::new_err(other.to_string()),
    }
}

pub(crate) fn io_err(e: monohand_io::IoError) -> PyErr {
    MonohandError::new_err(e.to_string())
}

pub(crate) fn core_err(e: CoreError) -> PyErr {
    PyValueError::new_err(e.to_string())
}
