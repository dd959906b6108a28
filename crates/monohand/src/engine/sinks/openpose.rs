//! OpenPose JSON, one `{stem}_{frame:012}_keypoints.json` per frame in a folder.

use super::{Output, Sink, SinkError};
use monohand_io::export::write_openpose_frame;
use std::path::{Path, PathBuf};

/// Writes one OpenPose JSON file per frame, with `hand_*_keypoints_2d` and
/// `hand_*_keypoints_3d`.
#[derive(Debug)]
pub struct OpenPoseSink {
    dir: PathBuf,
    stem: String,
}

impl OpenPoseSink {
    /// Files `{stem}_{frame:012}_keypoints.json` in `dir` (created if missing).
    pub fn create(dir: &Path, stem: &str) -> Result<OpenPoseSink, SinkError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("{}: cannot create the folder: {e}", dir.display()))?;
        Ok(OpenPoseSink {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
        })
    }
}

impl Sink for OpenPoseSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        write_openpose_frame(&self.dir, &self.stem, frame.record)?;
        Ok(())
    }
}
