//! The error type of every reader and writer in this crate.

use monohand_core::CoreError;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Everything that can go wrong reading or writing a file.
///
/// Every variant names the file (as the caller gave it, or `<memory>` for
/// in-memory input) and, where it makes sense, the field or line at fault, so
/// that a message such as
/// `cam.yml: field camera_matrix: expected a 3x3 matrix, got 2x3` can be shown
/// to a user as is.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file could not be opened or read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        error: std::io::Error,
    },
    /// The file could not be created or written.
    #[error("{}: cannot write: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        error: std::io::Error,
    },
    /// The file is not valid JSON (or not the expected JSON shape).
    #[error("{file}: invalid JSON at line {line}, column {column}: {message}")]
    Json {
        /// The file.
        file: String,
        /// 1-based line of the problem (0 if unknown).
        line: usize,
        /// 1-based column of the problem (0 if unknown).
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// A field is missing or has an impossible value.
    #[error("{file}: field {field}: {message}")]
    Field {
        /// The file.
        file: String,
        /// The field (key, variable or element) at fault.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// The file states something this reader does not understand, such as a lens model
    /// it does not implement: refused rather than read as something else.
    #[error("{file}: {field} {value:?} is not supported ({supported})")]
    Unsupported {
        /// The file.
        file: String,
        /// The key that states it (`distortion_model`, `camera_model`, ...).
        field: String,
        /// What the file states.
        value: String,
        /// What is understood instead.
        supported: String,
    },
    /// The file is not in the expected format at all (bad header, truncated, ...).
    #[error("{file}: {message}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// One line of a line-oriented file (JSON Lines) is malformed.
    #[error("{file}: line {line}: {message}")]
    Line {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line.
        message: String,
    },
    /// An external tool (`ffmpeg`, `ffprobe`) is not installed or not on `PATH`.
    #[error(
        "{tool} not found: install FFmpeg (Debian/Ubuntu: apt-get install ffmpeg; \
         macOS: brew install ffmpeg) or set MONOHAND_FFMPEG / MONOHAND_FFPROBE to the executables"
    )]
    ToolMissing {
        /// The executable that could not be started.
        tool: String,
    },
    /// A video could not be opened, decoded or encoded; `message` ends with what ffmpeg said.
    #[error("{input}: {message}")]
    Video {
        /// The video file (or webcam) as given.
        input: String,
        /// What went wrong, including ffmpeg's own error output.
        message: String,
    },
    /// The numbers were read but describe an impossible camera, skeleton or keypoint set.
    #[error("{file}: {error}")]
    Core {
        /// The file.
        file: String,
        /// The geometry core's verdict.
        error: CoreError,
    },
}

/// Result alias for this crate.
pub type IoResult<T> = Result<T, IoError>;

/// The display name used for a path in error messages.
pub fn name_of(path: &Path) -> String {
    path.display().to_string()
}

impl IoError {
    /// A [`IoError::Field`] error.
    pub fn field(
        file: impl Into<String>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> IoError {
        IoError::Field {
            file: file.into(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// An [`IoError::Unsupported`] error.
    pub fn unsupported(
        file: impl Into<String>,
        field: impl Into<String>,
        value: impl Into<String>,
        supported: impl Into<String>,
    ) -> IoError {
        IoError::Unsupported {
            file: file.into(),
            field: field.into(),
            value: value.into(),
            supported: supported.into(),
        }
    }

    /// A [`IoError::Format`] error.
    pub fn format(file: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::Format {
            file: file.into(),
            message: message.into(),
        }
    }

    /// A [`IoError::Json`] error from a serde_json error.
    pub fn json(file: impl Into<String>, e: &serde_json::Error) -> IoError {
        IoError::Json {
            file: file.into(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        }
    }

    /// A [`IoError::Core`] error.
    pub fn core(file: impl Into<String>, source: CoreError) -> IoError {
        IoError::Core {
            file: file.into(),
            error: source,
        }
    }
}

/// Reads a whole file, mapping the error to [`IoError::Read`].
pub fn read_bytes(path: &Path) -> IoResult<Vec<u8>> {
    std::fs::read(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })
}

/// Reads a whole text file, mapping the error to [`IoError::Read`].
pub fn read_text(path: &Path) -> IoResult<String> {
    std::fs::read_to_string(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })
}
