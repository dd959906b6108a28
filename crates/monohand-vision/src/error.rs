//! Error type of the vision front end.

use std::path::PathBuf;

use monohand_tflite::ImportError;

/// Everything that can go wrong between an image file and detected hands.
#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    /// The image file could not be read from disk.
    #[error("cannot read image {path}: {source}")]
    ImageRead {
        /// File that failed.
        path: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The bytes are not a decodable image (corrupt, truncated or an unsupported format).
    #[error("cannot decode image {what}: {reason}")]
    ImageDecode {
        /// File name or a description of the buffer.
        what: String,
        /// Decoder's explanation.
        reason: String,
    },
    /// The image is decodable but unusable (e.g. too small to contain a hand).
    #[error("image {what} is unusable: {reason}")]
    ImageUnusable {
        /// File name or a description of the buffer.
        what: String,
        /// Why.
        reason: String,
    },
    /// The pipeline's options are impossible.
    #[error("invalid options: {0}")]
    Options(String),
    /// The network weights are missing and could not be fetched.
    #[error("model weights unavailable: {0}")]
    ModelFetch(String),
    /// A weights file on disk does not have the pinned SHA-256 sum.
    #[error("checksum mismatch for {path}: expected {expected}, found {found}; delete the file and run `monohand models fetch` again")]
    Checksum {
        /// File checked.
        path: PathBuf,
        /// Pinned sum.
        expected: String,
        /// Actual sum.
        found: String,
    },
    /// A model file could not be translated into a tract graph.
    #[error("cannot import model {path}: {source}")]
    Import {
        /// Model file.
        path: PathBuf,
        /// Importer error.
        source: ImportError,
    },
    /// tract failed while optimising or running a network.
    #[error("inference failed: {0}")]
    Inference(String),
    /// A network's int8 calibration is missing, damaged or cannot be applied.
    #[error("int8: {0}")]
    Calibration(String),
    /// A model produced outputs of an unexpected shape.
    #[error("unexpected model output: {0}")]
    ModelOutput(String),
    /// Filesystem error while managing the model cache.
    #[error("I/O error on {path}: {source}")]
    Io {
        /// Path involved.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
}

impl From<tract_core::prelude::TractError> for VisionError {
    fn from(e: tract_core::prelude::TractError) -> Self {
        VisionError::Inference(format!("{e:#}"))
    }
}

/// Result alias of this crate.
pub type Result<T, E = VisionError> = std::result::Result<T, E>;
