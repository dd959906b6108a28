//! What is known of a frame's camera before the 3D stage chooses one: what its file states
//! ([`StatedCamera`]), and, once chosen, where it came from ([`CameraOrigin`]) or why it
//! could not be made ([`CameraError`]).

use std::sync::Arc;

use monohand_core::CoreError;
use monohand_io::jsonl::CameraSource;
use monohand_media::video::VideoCameraTags;
use monohand_vision::image_io::ExifFocal;

/// What the file a frame came from states about its camera, for frames without a
/// calibration: a photo's EXIF focal length (already read for its image), or a video's
/// QuickTime metadata (the same for all its frames, read for each frame's size).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum StatedCamera {
    /// Nothing stated (a video without camera metadata, a caller's frames, a photo without
    /// a focal length in its EXIF).
    #[default]
    None,
    /// What a photo's EXIF gave ([`ExifFocal`]).
    Exif(ExifFocal),
    /// A video's QuickTime metadata that states a focal length
    /// ([`monohand_media::video::read_quicktime_metadata`]).
    QuickTime(Arc<VideoCameraTags>),
}

impl From<ExifFocal> for StatedCamera {
    fn from(f: ExifFocal) -> StatedCamera {
        match f {
            ExifFocal::None => StatedCamera::None,
            f => StatedCamera::Exif(f),
        }
    }
}

/// Why a frame's cameras could not be made: it gets no 3D ([`crate::FittedFrame::error`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A view's calibration does not fit its image size.
    #[error("view {view}: {source}; no 3D for this frame")]
    Calibration {
        /// The view, from 1.
        view: usize,
        /// Why it cannot be scaled.
        source: monohand_core::camera::ScaleError,
    },
    /// The camera of a photo's size is not possible.
    #[error(transparent)]
    Photo(#[from] CoreError),
}

/// Where a camera in use came from, and why that source and not a better one.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraOrigin {
    /// The source, as the records name it.
    pub source: CameraSource,
    /// Why: a stated EXIF focal length that failed its checks, a calibration scaled from
    /// another size, a field of view outside 5-150 degrees that the user's calibration
    /// gives (`None`: nothing to say).
    pub reason: Option<String>,
}

impl CameraOrigin {
    pub(crate) fn new(source: CameraSource, reason: Option<String>) -> CameraOrigin {
        CameraOrigin { source, reason }
    }
}
