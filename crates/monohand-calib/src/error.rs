//! Errors of the calibration.

use thiserror::Error;

/// Everything that can go wrong in a calibration.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CalibError {
    /// A board description that cannot be used (fewer than 2x2 inner corners, a square
    /// size that is not positive, ...).
    #[error("invalid board: {0}")]
    InvalidBoard(String),
    /// An image buffer whose size does not match its width and height.
    #[error("invalid image: {0}")]
    InvalidImage(String),
    /// Too few views were usable for a calibration.
    #[error("too few usable views: {usable} (need at least {needed})")]
    TooFewViews {
        /// Views that could be used.
        usable: usize,
        /// Views required.
        needed: usize,
    },
    /// Inputs that do not agree (views of different lengths, different image sizes, ...).
    #[error("inconsistent input: {0}")]
    Inconsistent(String),
    /// The estimate failed (a degenerate set of views, a solver that diverged, ...).
    #[error("calibration failed: {0}")]
    Failed(String),
}

/// Result alias for the calibration.
pub type CalibResult<T> = Result<T, CalibError>;
