//! Errors of the session.

use monohand_core::CoreError;
use monohand_vision::VisionError;

/// What can go wrong in a [`crate::Session`] or a [`crate::Lifter`].
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// A camera, skeleton or fit option was refused by the geometry core.
    #[error(transparent)]
    Core(#[from] CoreError),
    /// The networks could not be loaded or run.
    #[error(transparent)]
    Vision(#[from] VisionError),
    /// The call does not fit the session (wrong number of views, bad options).
    #[error("{0}")]
    Invalid(String),
}

/// Result type of the session.
pub type SessionResult<T> = std::result::Result<T, SessionError>;
