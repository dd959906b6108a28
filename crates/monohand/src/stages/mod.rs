//! The middle layer: the stages between the networks and the records, each importing only
//! the bottom layer ([`crate::base`]) and the stages listed before it, never the engine or
//! the settings that drive it (each takes options of its own, which
//! [`crate::ResolvedSettings`] builds).
//!
//! - [`cameras`]: the camera of each view, frame by frame;
//! - [`crops`]: stages 1 and 2 over every view ([`crate::CropTracker`]);
//! - [`association`]: which hands of the views are one hand;
//! - [`offline`]: the offline smoother;
//! - [`fitter`]: stage 3 ([`crate::HandsFitter`]): the fit, the hands followed, the shape;
//! - [`rig_check`]: whether a rig's calibration still holds;
//! - [`records`]: the JSON Lines records of the frames.

pub mod association;
pub(crate) mod cameras;
pub(crate) mod crops;
pub(crate) mod fitter;
pub mod offline;
pub mod records;
pub mod rig_check;
