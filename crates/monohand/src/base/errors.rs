//! The errors every stage may give or pass on: a frame's source ([`SourceError`]), a setting
//! ([`SettingsError`], naming its [`Field`]) and the session's ([`SessionError`]).

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
    Settings(#[from] SettingsError),
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

/// Why a frame, or the rest of an input, could not be read. Cloned into each view's frame
/// and said in its record (`error`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SourceError {
    /// An image file that could not be read or decoded (the run goes on with the next).
    #[error("{0}")]
    Image(String),
    /// A video or webcam stopped on an error (ffmpeg failed or was killed, a stall); the
    /// frames before it were good.
    #[error("{0}")]
    Video(String),
    /// A later view ended before the first one.
    #[error("view {view} has no more frames")]
    ViewEnded {
        /// The view, from 1.
        view: usize,
    },
    /// A later view stopped on an error.
    #[error("view {view}: {source}")]
    View {
        /// The view, from 1.
        view: usize,
        /// Its error.
        source: Box<SourceError>,
    },
    /// A source of the caller's own could not deliver (its message).
    #[error("{0}")]
    Other(String),
}

/// A setting a face fills in, as [`SettingsError`] names it (each face maps it to its own
/// flag or argument name: `--detect-every`, `detect_every=`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// Whether frames are tracked ([`crate::FitSettings::tracking`]).
    Tracking,
    /// [`crate::Settings::detect_every`].
    DetectEvery,
    /// [`crate::Settings::threads`].
    Threads,
    /// The most hands per image ([`monohand_vision::PipelineOptions::max_hands`]).
    MaxHands,
    /// The presence threshold ([`monohand_vision::PipelineOptions::min_presence`]).
    MinPresence,
    /// The landmark network's mirror pass ([`monohand_vision::landmarks::LandmarkOptions`]).
    MirrorPass,
    /// Whether heads are detected (a pipeline's face detector).
    Heads,
    /// The networks' arithmetic ([`monohand_vision::PipelineOptions::precision`]).
    Precision,
    /// The networks' other options ([`monohand_vision::PipelineOptions`]).
    Pipeline,
    /// The fitter's options ([`crate::FitSettings::options`]).
    FitOptions,
    /// The hand's size ([`crate::HandScale`], [`crate::hand_skeletons`]).
    HandScale,
    /// The One Euro filter of [`crate::FitSettings::smoothing`] (asked for at all).
    Smoothing,
    /// Its minimum cutoff frequency.
    SmoothMinCutoff,
    /// Its speed coefficient.
    SmoothBeta,
    /// The offline smoother ([`crate::FitSettings::offline`]).
    Offline,
    /// The depth filter ([`crate::FitSettings::depth_filter`]).
    DepthFilter,
}

impl Field {
    /// The setting's name in the library (a face says its own).
    pub fn name(self) -> &'static str {
        match self {
            Field::Tracking => "tracking",
            Field::DetectEvery => "detect_every",
            Field::Threads => "threads",
            Field::MaxHands => "max_hands",
            Field::MinPresence => "min_presence",
            Field::MirrorPass => "mirror_pass",
            Field::Heads => "heads",
            Field::Precision => "precision",
            Field::Pipeline => "pipeline",
            Field::FitOptions => "fit_options",
            Field::HandScale => "hand_scale",
            Field::Smoothing => "smoothing",
            Field::SmoothMinCutoff => "smoothing.min_cutoff",
            Field::SmoothBeta => "smoothing.beta",
            Field::Offline => "offline",
            Field::DepthFilter => "depth_filter",
        }
    }
}

/// A setting refused: which one, and why (`why` reads after the setting's name: "must be
/// at least 1").
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{} {why}", field.name())]
pub struct SettingsError {
    /// The setting.
    pub field: Field,
    /// Why it was refused, to follow the setting's name.
    pub why: String,
}

impl SettingsError {
    /// `field` refused because `why`.
    pub fn new(field: Field, why: impl Into<String>) -> SettingsError {
        SettingsError {
            field,
            why: why.into(),
        }
    }
}
