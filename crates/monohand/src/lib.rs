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
//!
//! The modules stand in three layers, each importing only the ones below it:
//! - **bottom**, `base/`: the frame's data every stage passes on ([`VisionFrame`],
//!   [`FittedFrame`], the hand ids and guides, the cameras as stated) and each stage's
//!   errors;
//! - **middle**, `stages/`: the cameras, the crops ([`CropTracker`]), the views'
//!   [`association`], the [`offline`] smoother, the hands' fitter ([`HandsFitter`]: the fit,
//!   the hands followed, the shape learnt), the [`rig_check`] and the [`records`]. Each takes
//!   options of its own ([`CropSettings`], [`FitSettings`], [`OfflineSettings`]) and never
//!   the settings, the session or the engine;
//! - **top**: the [`settings`], resolved once into those options, the [`Session`], the
//!   [`Lifter`], the [`engine`] (sources, threads, sinks) and the [`calibration`].
#![deny(missing_docs)]

mod base;
pub mod calibration;
pub mod engine;
mod lifter;
mod session;
pub mod settings;
mod stages;

pub use base::camera::{CameraError, CameraOrigin, StatedCamera};
pub use base::errors::{SessionError, SessionResult};
pub use base::frame::{
    FittedFrame, FittedGuide, HandId, TrackedHand, ViewError, ViewHands, VisionFrame,
};
pub use base::notes::{Note, NoteTopic};
pub use lifter::{LiftedHand, Lifter};
pub use session::{Session, SessionOptions};
pub use settings::{
    Field, PrecisionChoice, RectifyCrops, ResolvedSettings, Settings, SettingsError,
    INT8_FROM_VIEWS,
};
pub use stages::crops::{CropSettings, CropTracker, GUIDE_MIN_INSIDE, SEED_GRID_PX};
pub use stages::fitter::fit::{
    fit_views, hand_skeletons, is_finite, learn_proportions, scale_from_ruler, FitOutcome,
    GivenHandSize, HandScale, HandScaleError, HandSizeError, HandSizeSource, RulerLengthError,
    HAND_SCALE_RANGE, RULER_OFFSET_MM,
};
pub use stages::fitter::options::{FitSettings, DEPTH_FILTER, FORGET_AFTER_FRAMES};
pub use stages::fitter::HandsFitter;
pub use stages::offline::OfflineSettings;
pub use stages::{association, offline, records, rig_check};

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
