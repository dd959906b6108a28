//! The bottom layer: the frame's data that every stage passes on and the errors every stage
//! may give, imported by the stages above and importing nothing of theirs.
//!
//! - [`frame`]: hand identities, what the networks found ([`crate::VisionFrame`]), the hands
//!   fitted in 3D ([`crate::FittedFrame`]) and the guides from one to the next crops;
//! - [`camera`]: what a file states about its camera, where a camera in use came from, why
//!   one could not be made;
//! - [`errors`]: a source's, a setting's and the session's errors;
//! - [`notes`]: messages for the user;
//! - [`clock`]: the clock the stages are timed with.

pub(crate) mod camera;
pub(crate) mod clock;
pub(crate) mod errors;
pub(crate) mod frame;
pub(crate) mod notes;
