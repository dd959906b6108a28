//! Errors of the geometry core.

use thiserror::Error;

/// Everything that can go wrong in the geometry core.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// A camera whose numbers are impossible (non-positive focal length, NaN, ...).
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// A skeleton with impossible geometry (negative bone length, NaN, ...).
    #[error("invalid hand skeleton: {0}")]
    InvalidSkeleton(String),
    /// Keypoints that cannot be used (NaN coordinates, confidence outside [0, 1], ...).
    #[error("invalid keypoints: {0}")]
    InvalidKeypoints(String),
    /// Too few usable joints for a fit.
    #[error(
        "too few usable joints: {usable} with confidence >= {threshold} (need at least {needed})"
    )]
    TooFewJoints {
        /// Joints that passed the confidence threshold.
        usable: usize,
        /// The confidence threshold.
        threshold: f64,
        /// Joints required.
        needed: usize,
    },
    /// The number of views and observations disagree.
    #[error("view mismatch: {0}")]
    ViewMismatch(String),
    /// Invalid fitting options.
    #[error("invalid fit options: {0}")]
    InvalidOptions(String),
}

/// Result alias for the geometry core.
pub type CoreResult<T> = Result<T, CoreError>;
