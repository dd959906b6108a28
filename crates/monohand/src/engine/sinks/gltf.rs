//! An animated glTF binary (.glb) of the 3D hands, which Blender or any glTF viewer plays.

use super::{Output, Sink, SinkError};
use monohand_io::export::{GltfHand, GltfWriter};
use std::path::Path;

/// Collects every frame's 3D hands and writes the animation at the end. Its scene camera
/// takes the field of view of the first fitted frame's camera.
pub struct GltfSink {
    writer: Option<GltfWriter>,
    camera_set: bool,
}

impl std::fmt::Debug for GltfSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GltfSink")
            .field("camera_set", &self.camera_set)
            .finish()
    }
}

impl GltfSink {
    /// A glTF at `path`, each hand drawn as `hand`.
    pub fn create(path: &Path, hand: GltfHand) -> Result<GltfSink, SinkError> {
        let mut writer = GltfWriter::new(path);
        writer.set_hand(hand)?;
        Ok(GltfSink {
            writer: Some(writer),
            camera_set: false,
        })
    }
}

impl Sink for GltfSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        let Some(g) = self.writer.as_mut() else {
            return Ok(());
        };
        if let (false, Some(c)) = (self.camera_set, frame.cameras.first()) {
            g.set_camera_from(c);
            self.camera_set = true;
        }
        let record = frame.record;
        let t = record.time_s.unwrap_or(record.frame as f64 / 30.0);
        if let Err(e) = g.add_record(t, record) {
            tracing::warn!("frame {}: not added to the glTF: {e}", record.frame);
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        if let Some(g) = self.writer.take() {
            g.finish()?;
        }
        Ok(())
    }
}
