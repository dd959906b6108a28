//! Where the engine's records go. Every output is a [`Sink`]; a new output format is one
//! file here (or the caller's own type).

mod csv;
mod gltf;
mod jsonl;
#[cfg(feature = "lerobot")]
mod lerobot;
mod openpose;
mod overlay;
#[cfg(feature = "rerun")]
mod rerun;
mod window;

pub use self::csv::CsvSink;
pub use gltf::GltfSink;
pub use jsonl::JsonlSink;
#[cfg(feature = "lerobot")]
pub use lerobot::LeRobotSink;
pub use openpose::OpenPoseSink;
pub use overlay::{has_extension, OverlaySink, IMAGE_EXTENSIONS, VIDEO_EXTENSIONS};
#[cfg(feature = "rerun")]
pub use rerun::{RerunError, RerunSink};
pub use window::WindowSink;

use crate::base::frame::FittedFrame;
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_vision::RgbImage;

/// Why a sink could not write: its own error, whatever its type.
pub type SinkError = Box<dyn std::error::Error + Send + Sync>;

/// One finished frame, as the sinks see it.
#[derive(Debug, Clone, Copy)]
pub struct Output<'a> {
    /// The frame's record (what `monohand run` writes as JSON Lines).
    pub record: &'a FrameRecord,
    /// The first view's image, when a sink asked for images ([`Sink::wants_images`]).
    pub image: Option<&'a RgbImage>,
    /// The camera of each view the frame was fitted with (empty when it was not fitted:
    /// draw with a generic camera for the image size then). Sinks that draw use these, so
    /// that the drawing matches the fit.
    pub cameras: &'a [Camera],
    /// The images of the other views (the second first), when a sink asked for every
    /// view's ([`Sink::wants_every_view`]; `None`: that view's image could not be read).
    pub other_images: &'a [Option<RgbImage>],
    /// The frame as the fit left it, with every view's detections (`None` for records
    /// not made by the fit: `detect`, `lift`).
    pub fitted: Option<&'a FittedFrame>,
}

/// An output of the engine: receives every frame in order, then `finish` once.
///
/// When a sink fails, the engine stops, calls `finish` on every other sink and returns the
/// error: each sink must leave whole frames only behind it.
pub trait Sink {
    /// Whether this sink needs the frames' pixels (the engine then keeps the first view's
    /// image for it).
    fn wants_images(&self) -> bool {
        false
    }

    /// Whether this sink needs every view's pixels (the engine then keeps them all, in
    /// [`Output::other_images`] beside the first view's).
    fn wants_every_view(&self) -> bool {
        false
    }

    /// Writes one frame.
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError>;

    /// Closes the output (a video is finalised so that it plays, a glTF written).
    fn finish(&mut self) -> Result<(), SinkError> {
        Ok(())
    }
}
