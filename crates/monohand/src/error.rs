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
    /// A setting was refused ([`crate::settings`]).
    #[error(transparent)]
    Settings(#[from] crate::settings::SettingsError),
    /// A frame's images do not match the session's cameras.
    #[error("{images} image(s) for {cameras} camera(s): give one image per camera, in order")]
    Views {
        /// Images given.
        images: usize,
        /// Cameras of the session.
        cameras: usize,
    },
    /// A frame's time is NaN or infinite.
    #[error("frame time {0} is not finite")]
    FrameTime(f64),
    /// Lifting was asked for without a camera.
    #[error("lifting needs at least one camera")]
    NoCamera,
}

/// Result type of the session.
pub type SessionResult<T> = std::result::Result<T, SessionError>;
