//! The hands drawn on the frames: a video file, a folder of PNG images, or one image file.

use super::{Output, Sink, SinkError};
use monohand_media::scene::{Layers, SceneRenderer};
use monohand_media::video::VideoWriter;
use monohand_vision::RgbImage;
use std::path::{Path, PathBuf};

/// Overlay paths with one of these extensions are videos; others are folders.
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mkv", "avi", "mov", "webm"];

/// Overlay paths with one of these extensions are one image file (one input image only).
pub const IMAGE_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg"];

/// Where the drawn frames go.
enum Target {
    /// Encoded on the fly (started at the first frame, when the size is known).
    Video {
        path: PathBuf,
        fps: f64,
        /// The encoder and its frame size.
        writer: Option<(VideoWriter, u32, u32)>,
    },
    /// `frame_000123.png` files.
    Folder(PathBuf),
    /// One image file (PNG or JPEG), for an input of one image.
    Image(PathBuf),
}

/// Draws each frame's hands (with the camera the frame was fitted with) and writes the
/// drawn frames.
pub struct OverlaySink {
    target: Target,
    layers: Layers,
    renderer: SceneRenderer,
    /// The frame being drawn, reused.
    canvas: RgbImage,
}

impl std::fmt::Debug for OverlaySink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("OverlaySink")
    }
}

impl OverlaySink {
    /// An overlay at `path`: a video for a video extension (encoded at `fps`), one image
    /// file for an image extension (only when `single_image`: the input is one image), else
    /// a folder of PNG files (created).
    pub fn create(
        path: &Path,
        fps: f64,
        single_image: bool,
        layers: Layers,
    ) -> Result<OverlaySink, SinkError> {
        let target = if has_extension(path, IMAGE_EXTENSIONS) {
            if !single_image {
                return Err(format!(
                    "{}: an image file holds one frame, and the input has more; give a folder \
                     (one PNG per frame) or a video name ({})",
                    path.display(),
                    VIDEO_EXTENSIONS.join(", ")
                )
                .into());
            }
            Target::Image(path.to_path_buf())
        } else if has_extension(path, VIDEO_EXTENSIONS) {
            Target::Video {
                path: path.to_path_buf(),
                fps,
                writer: None,
            }
        } else {
            if path.exists() && !path.is_dir() {
                return Err(format!(
                    "{}: not a folder, and not a video name ({})",
                    path.display(),
                    VIDEO_EXTENSIONS.join(", ")
                )
                .into());
            }
            std::fs::create_dir_all(path)
                .map_err(|e| format!("{}: cannot create the folder: {e}", path.display()))?;
            Target::Folder(path.to_path_buf())
        };
        Ok(OverlaySink {
            target,
            layers,
            renderer: SceneRenderer::default(),
            canvas: RgbImage::new(0, 0),
        })
    }
}

impl Sink for OverlaySink {
    fn wants_images(&self) -> bool {
        true
    }

    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        let Some(image) = frame.image else {
            return Ok(());
        };
        let record = frame.record;
        self.canvas.clone_from(image);
        let (w, h) = self.canvas.dimensions();
        self.renderer
            .draw_record(&mut self.canvas, record, frame.cameras, &self.layers);
        match &mut self.target {
            Target::Video { path, fps, writer } => {
                if writer.is_none() {
                    let v = VideoWriter::create(&*path, w as usize, h as usize, *fps)?;
                    *writer = Some((v, w, h));
                }
                if let Some((v, vw, vh)) = writer {
                    if (w, h) == (*vw, *vh) {
                        v.write(&self.canvas)?;
                    } else {
                        tracing::warn!(
                            "frame {}: size differs from the overlay video's; not drawn",
                            record.frame
                        );
                    }
                }
            }
            Target::Folder(dir) => save_image(
                &self.canvas,
                &dir.join(format!("frame_{:06}.png", record.frame)),
            )?,
            Target::Image(path) => save_image(&self.canvas, path)?,
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        if let Target::Video { writer, .. } = &mut self.target {
            if let Some((w, _, _)) = writer.take() {
                w.finish()?;
            }
        }
        Ok(())
    }
}

/// Whether `p` ends with one of `extensions` (any case).
pub fn has_extension(p: &Path, extensions: &[&str]) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| extensions.contains(&e.to_ascii_lowercase().as_str()))
}

/// Writes a frame as an image file (PNG or JPEG, by the name's extension), through
/// `.tmp-NAME` beside it and a rename, so a failed write leaves no damaged image.
fn save_image(frame: &RgbImage, path: &Path) -> Result<(), SinkError> {
    let name = path.file_name().unwrap_or(path.as_os_str());
    let mut tmp_name = std::ffi::OsString::from(".tmp-");
    tmp_name.push(name);
    let tmp = path.with_file_name(tmp_name);
    let written = frame
        .save(&tmp)
        .map_err(SinkError::from)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(SinkError::from));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written.map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}
