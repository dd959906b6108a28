//! The io crate's file errors, built here for the dataset files eval parses itself
//! (MATLAB `.mat`, STB labels).

use monohand_core::CoreError;
use monohand_io::{IoError, IoResult};
use std::path::Path;

/// The display name used for a path in error messages.
pub(crate) fn name_of(path: &Path) -> String {
    path.display().to_string()
}

/// Constructors of [`IoError`] for eval's parsers.
pub(crate) trait FileError {
    /// A field with a bad value.
    fn field(file: impl Into<String>, field: impl Into<String>, message: impl Into<String>)
        -> Self;
    /// A file that is not in the expected format.
    fn format(file: impl Into<String>, message: impl Into<String>) -> Self;
    /// A JSON syntax error.
    fn json(file: impl Into<String>, e: &serde_json::Error) -> Self;
    /// Something the geometry core refused.
    fn core(file: impl Into<String>, source: CoreError) -> Self;
}

impl FileError for IoError {
    fn field(
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

    fn format(file: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::Format {
            file: file.into(),
            message: message.into(),
        }
    }

    fn json(file: impl Into<String>, e: &serde_json::Error) -> IoError {
        IoError::Json {
            file: file.into(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        }
    }

    fn core(file: impl Into<String>, source: CoreError) -> IoError {
        IoError::Core {
            file: file.into(),
            error: source,
        }
    }
}

/// Reads a whole file.
pub(crate) fn read_bytes(path: &Path) -> IoResult<Vec<u8>> {
    std::fs::read(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })
}

/// Reads a whole text file.
pub(crate) fn read_text(path: &Path) -> IoResult<String> {
    std::fs::read_to_string(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })
}
