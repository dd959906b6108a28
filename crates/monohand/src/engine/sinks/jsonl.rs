//! JSON Lines, one record per frame (docs/output-format.md).

use super::{Output, Sink, SinkError};
use monohand_io::jsonl::JsonlWriter;
use monohand_io::IoResult;
use std::path::Path;

/// Writes each frame's record as one JSON line, flushed as it goes.
#[derive(Debug)]
pub struct JsonlSink(JsonlWriter);

impl JsonlSink {
    /// Creates (or truncates) a file.
    pub fn create(path: &Path) -> IoResult<JsonlSink> {
        Ok(JsonlSink(JsonlWriter::create(path)?))
    }

    /// Writes to standard output.
    pub fn stdout() -> JsonlSink {
        JsonlSink(JsonlWriter::stdout())
    }

    /// [`JsonlSink::create`], or [`JsonlSink::stdout`] for the path `-`.
    pub fn open(path: &Path) -> IoResult<JsonlSink> {
        match path.as_os_str() == "-" {
            true => Ok(JsonlSink::stdout()),
            false => JsonlSink::create(path),
        }
    }

    /// With `on`, each fitted hand is written with its OpenXR joints (`xr_joints`,
    /// [`JsonlWriter::with_xr_joints`]; `--xr-joints`). Off by default.
    pub fn with_xr_joints(self, on: bool) -> JsonlSink {
        JsonlSink(self.0.with_xr_joints(on))
    }

    /// With `on`, each fitted hand is written with its wrist pose in MANO's wrist frame
    /// (`wrist_pose`, [`JsonlWriter::with_wrist_pose`]; `--wrist-pose`). Off by default.
    pub fn with_wrist_pose(self, on: bool) -> JsonlSink {
        JsonlSink(self.0.with_wrist_pose(on))
    }
}

impl Sink for JsonlSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        Ok(self.0.write_frame(frame.record)?)
    }
}
