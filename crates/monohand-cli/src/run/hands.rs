//! The records `monohand run` writes, from the session's frames
//! ([`monohand::FittedFrame`]).

use monohand::FittedFrame;
use monohand_io::jsonl::FrameRecord;
use monohand_vision::RgbImage;

/// What `run` carries beside each frame through the session's stages.
pub(crate) struct FrameExtra {
    /// File name, if any.
    pub source: Option<String>,
    /// Whether the frame came from a video (its time is then written out).
    pub is_video: bool,
    /// The first view's image, for overlays.
    pub image: Option<RgbImage>,
    /// Time spent decoding, ms.
    pub decode_ms: f64,
}

/// A finished frame and, for overlays, its first view's image.
pub(crate) type Done = (FrameRecord, Option<RgbImage>);

/// The output record of a fitted frame.
pub(crate) fn record(done: &FittedFrame, extra: FrameExtra) -> Done {
    let vision = &done.vision;
    let mut record = monohand::records::fitted_record(done, extra.source);
    if extra.is_video {
        record.time_s = Some(vision.time_s);
    }
    record.timings_ms = Some(
        [
            ("decode".to_string(), extra.decode_ms),
            ("vision".to_string(), vision.vision_ms),
            ("fit".to_string(), done.fit_ms),
        ]
        .into_iter()
        .collect(),
    );
    (record, extra.image)
}
