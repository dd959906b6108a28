//! The error type of the evaluation library.

use monohand_core::CoreError;
use monohand_io::IoError;
use std::path::PathBuf;
use thiserror::Error;

/// Everything that can go wrong loading a dataset, evaluating or writing a report.
#[derive(Debug, Error)]
pub enum EvalError {
    /// A dataset file could not be read or parsed by the io crate.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A manifest line is malformed (1-based line number).
    #[error("{file}: line {line}: {message}")]
    Manifest {
        /// The manifest file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line.
        message: String,
    },
    /// The dataset path is neither a manifest nor an STB folder, or holds nothing usable.
    #[error("{}: {message}", path.display())]
    Dataset {
        /// The path given as the dataset.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The geometry core refused something (skeleton, camera, options).
    #[error("{context}: {error}")]
    Core {
        /// What was being done.
        context: String,
        /// The core's verdict.
        error: CoreError,
    },
    /// The settings of an evaluation are impossible.
    #[error("invalid settings: {0}")]
    Settings(String),
    /// The fit's settings were refused by the library's one check ([`monohand::Settings::resolve`],
    /// and for the lift stage [`monohand::ResolvedSettings::lifting`]); the field says which.
    #[error("{0}")]
    Refused(monohand::SettingsError),
    /// The keypoint detector of the full stage failed.
    #[error("detector: {0}")]
    Detector(String),
    /// A report file could not be written.
    #[error("{}: cannot write: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        error: std::io::Error,
    },
    /// A step of an evaluation failed; `context` says which.
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// What went wrong.
        #[source]
        source: Box<EvalError>,
    },
    /// A plot could not be drawn.
    #[error("{}: cannot draw plot: {message}", path.display())]
    Plot {
        /// The PNG file.
        path: PathBuf,
        /// What the plotting library said.
        message: String,
    },
}

/// Result alias for this crate.
pub type EvalResult<T> = Result<T, EvalError>;

impl EvalError {
    /// The refused setting behind this error, through its contexts: a face maps its field
    /// to its own flag.
    pub fn refused_setting(&self) -> Option<&monohand::SettingsError> {
        match self {
            EvalError::Refused(e) => Some(e),
            EvalError::Context { source, .. } => source.refused_setting(),
            _ => None,
        }
    }

    pub(crate) fn core(context: impl Into<String>, error: CoreError) -> EvalError {
        EvalError::Core {
            context: context.into(),
            error,
        }
    }

    pub(crate) fn context(self, context: impl Into<String>) -> EvalError {
        EvalError::Context {
            context: context.into(),
            source: Box::new(self),
        }
    }

    pub(crate) fn dataset(path: impl Into<PathBuf>, message: impl Into<String>) -> EvalError {
        EvalError::Dataset {
            path: path.into(),
            message: message.into(),
        }
    }

    pub(crate) fn write(path: impl Into<PathBuf>, error: std::io::Error) -> EvalError {
        EvalError::Write {
            path: path.into(),
            error,
        }
    }
}
