//! **monohand**: frames of one or several calibrated cameras in, tracked **absolute 3D
//! hands** out, in millimetres in the first camera's frame.
//!
//! This crate ties the vision front end ([`monohand_vision`]: hand detection and 2D
//! keypoints with MediaPipe's networks) to the geometry core ([`monohand_core`]: the 26-DoF
//! hand model and its Levenberg-Marquardt fit, usable alone), with what a video needs in
//! between: crop tracking, hand identities, a left/right vote, the association of views,
//! a tracker per hand, smoothing and the hand's size.
//!
//! - [`engine::Engine`]: the whole pipeline, sources of frames in (images, folders,
//!   videos, webcams, a caller's frames), sinks of records out (JSON Lines, CSV, OpenPose,
//!   overlays, glTF, or the caller's own), with decoding, networks and fit on threads of
//!   their own. `monohand run` is this engine.
//! - [`Session`]: images in, [`FittedFrame`]s out, on the calling thread.
//! - [`CropTracker`] and [`HandsFitter`]: the session's two stages, to run on threads of
//!   their own (as `monohand run` does).
//! - [`Lifter`]: 2D keypoints made elsewhere in, 3D out, with the same association policy
//!   ([`association`]).
//!
//! - [`records`]: the project's JSON Lines records of these results.
//! - [`calibration`]: a camera's or a rig's calibration from frames of a chessboard
//!   (`monohand calibrate`), over [`monohand_calib`].
//! - [`settings`]: the one resolved configuration every face fills in
//!   ([`Settings::resolve`]).
//!
//! A video file to 3D joints is `examples/video_to_3d.rs`.
#![deny(missing_docs)]

pub mod association;
pub mod calibration;
mod cameras;
mod clock;
mod crops;
pub mod engine;
mod error;
mod fit;
mod frame;
mod hands;
mod lifter;
mod notes;
pub mod offline;
pub mod records;
pub mod rig_check;
mod session;
pub mod settings;
mod shape;
mod tracks;

pub use cameras::StatedCamera;
pub use crops::{
    CropTracker, FittedGuide, HandId, ViewError, ViewHands, VisionFrame, GUIDE_MIN_INSIDE,
    SEED_GRID_PX,
};
pub use error::{SessionError, SessionResult};
pub use fit::{
    fit_views, hand_skeletons, is_finite, learn_proportions, scale_from_ruler, FitOutcome,
    GivenHandSize, HandScale, HandScaleError, HandSizeError, HandSizeSource, RulerLengthError,
    HAND_SCALE_RANGE, RULER_OFFSET_MM,
};
pub use frame::{CameraError, CameraOrigin, FittedFrame, TrackedHand};
pub use hands::{FitSettings, HandsFitter, DEPTH_FILTER, FORGET_AFTER_FRAMES};
pub use lifter::{LiftedHand, Lifter};
pub use notes::{Note, NoteTopic};
pub use offline::OfflineSettings;
pub use session::{Session, SessionOptions};
pub use settings::{Field, RectifyCrops, ResolvedSettings, Settings, SettingsError};

/// The geometry core (usable without networks).
pub use monohand_core as core;
pub use monohand_core::hand_model::HandSide;
/// The vision front end.
pub use monohand_vision as vision;
pub use monohand_vision::{DetectedHand, Detections, HandPipeline, RgbImage};

/// The types most users need.
pub mod prelude {
    pub use crate::{FittedFrame, Lifter, Session, SessionOptions, TrackedHand};
    pub use monohand_core::prelude::*;
}
