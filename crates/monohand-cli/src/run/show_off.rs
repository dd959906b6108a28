//! `run --show` in a build without the `show` feature: refused with a clear message.

use anyhow::{bail, Result};
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_media::scene::Layers;
use monohand_vision::RgbImage;

/// Never built: `new` refuses.
pub(crate) enum Show {}

impl Show {
    /// Refuses: this build has no window.
    pub fn new(_layers: Layers) -> Result<Show> {
        bail!("--show: this monohand was built without the `show` feature (cargo build -p monohand-cli --features show)")
    }

    /// Unreachable (no `Show` exists).
    pub fn frame(&mut self, _: &RgbImage, _: &FrameRecord, _: &[Camera]) -> Result<bool> {
        match *self {}
    }

    /// Unreachable (no `Show` exists).
    pub fn hold(&mut self, _: &RgbImage, _: &FrameRecord, _: &[Camera]) -> Result<()> {
        match *self {}
    }
}
