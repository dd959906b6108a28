//! What `monohand run` reads: an image, a folder of images, a video file or a webcam,
//! frame after frame.

use anyhow::{bail, Result};
use monohand_media::video::{VideoInput, VideoReader};
use monohand_vision::image_io::{images_in_folder, load_photo, PhotoFocal, IMAGE_EXTENSIONS};
use monohand_vision::RgbImage;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// One input frame of one view.
#[derive(Debug)]
pub(crate) struct Frame {
    /// Index from 0.
    pub index: u64,
    /// File name of the image, if it came from one.
    pub source: Option<String>,
    /// Time of the frame, seconds (the video's clock; `index / 30` for images).
    pub timestamp_s: f64,
    /// The pixels, or why they could not be read.
    pub image: Result<RgbImage, String>,
    /// Milliseconds spent reading and decoding it.
    pub decode_ms: f64,
    /// The focal length the image file states in its EXIF (photos only).
    pub focal: Option<PhotoFocal>,
}

/// The kind of an input, decided from its name.
#[derive(Debug, Clone)]
pub(crate) enum InputKind {
    /// Image files, one frame each, in this order.
    Images(Vec<PathBuf>),
    /// A video file or a webcam.
    Video(VideoInput),
}

impl InputKind {
    /// `webcam:N`, a folder of images, an image file, or else a video file.
    pub fn parse(s: &str) -> Result<InputKind> {
        if s.starts_with("webcam:") {
            return match VideoInput::parse(s) {
                v @ VideoInput::Webcam(_) => Ok(InputKind::Video(v)),
                VideoInput::File(_) => bail!("{s:?}: a webcam is written webcam:N, e.g. webcam:0"),
            };
        }
        let path = Path::new(s);
        if path.is_dir() {
            let files = images_in_folder(path)?;
            if files.is_empty() {
                bail!(
                    "{s}: no images in this folder (looked for {})",
                    IMAGE_EXTENSIONS.join(", ")
                );
            }
            return Ok(InputKind::Images(files));
        }
        // A regular file, or a named pipe or device that a stream comes through.
        if std::fs::metadata(path).is_err() {
            bail!("{s}: no such file or folder");
        }
        let is_image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        Ok(if is_image {
            InputKind::Images(vec![path.to_path_buf()])
        } else {
            InputKind::Video(VideoInput::File(path.to_path_buf()))
        })
    }

    /// Whether consecutive frames show the same scene (video), so tracking makes sense.
    pub fn is_video(&self) -> bool {
        matches!(self, InputKind::Video(_))
    }
}

/// Frames of one view, in order.
pub(crate) enum FrameSource {
    /// Image files.
    Images { files: Vec<PathBuf>, next: usize },
    /// A running ffmpeg decoder; `None` once finished.
    Video { reader: Option<Box<VideoReader>> },
}

impl FrameSource {
    /// Opens an input (starts ffmpeg for a video, which counts as stalled after `stall`
    /// without a frame).
    pub fn open(kind: &InputKind, stall: Duration) -> Result<FrameSource> {
        Ok(match kind {
            InputKind::Images(files) => FrameSource::Images {
                files: files.clone(),
                next: 0,
            },
            InputKind::Video(v) => {
                let mut reader = VideoReader::open(v)?;
                reader.set_stall_timeout(stall);
                FrameSource::Video {
                    reader: Some(Box::new(reader)),
                }
            }
        })
    }

    /// Number of frames, when known up front.
    pub fn len_hint(&self) -> Option<u64> {
        match self {
            FrameSource::Images { files, .. } => Some(files.len() as u64),
            FrameSource::Video { reader, .. } => reader.as_ref().and_then(|r| r.info().frame_count),
        }
    }

    /// Frame rate, when known (videos).
    pub fn fps(&self) -> Option<f64> {
        match self {
            FrameSource::Images { .. } => None,
            FrameSource::Video { reader, .. } => reader.as_ref().and_then(|r| r.info().fps),
        }
    }

    /// The display rotation of a video (phone metadata, degrees; its frames come upright).
    pub fn rotation_deg(&self) -> i32 {
        match self {
            FrameSource::Images { .. } => 0,
            FrameSource::Video { reader, .. } => {
                reader.as_ref().map_or(0, |r| r.info().rotation_deg)
            }
        }
    }

    /// Frame size of a video, known before the first frame.
    pub fn video_size(&self) -> Option<(u32, u32)> {
        match self {
            FrameSource::Images { .. } => None,
            FrameSource::Video { reader, .. } => reader
                .as_ref()
                .map(|r| (r.info().width as u32, r.info().height as u32)),
        }
    }

    /// The next frame; `Ok(None)` at the end; `Err` when a video stops on an error (the
    /// frames before it were good).
    pub fn next_frame(&mut self) -> Result<Option<Frame>> {
        let t = std::time::Instant::now();
        match self {
            FrameSource::Images { files, next } => {
                let Some(path) = files.get(*next) else {
                    return Ok(None);
                };
                let index = *next as u64;
                *next += 1;
                let (image, focal) = match load_photo(path) {
                    Ok(p) => (Ok(p.image), p.focal),
                    Err(e) => (Err(e.to_string()), None),
                };
                Ok(Some(Frame {
                    index,
                    source: path.file_name().map(|n| n.to_string_lossy().into_owned()),
                    timestamp_s: index as f64 / 30.0,
                    image,
                    decode_ms: t.elapsed().as_secs_f64() * 1e3,
                    focal,
                }))
            }
            FrameSource::Video { reader } => {
                let Some(r) = reader.as_mut() else {
                    return Ok(None);
                };
                match r.next_frame() {
                    Ok(Some(f)) => Ok(Some(Frame {
                        index: f.index,
                        source: None,
                        timestamp_s: f.timestamp_s,
                        image: Ok(f.image),
                        decode_ms: t.elapsed().as_secs_f64() * 1e3,
                        focal: None,
                    })),
                    Ok(None) => {
                        *reader = None;
                        Ok(None)
                    }
                    Err(e) => {
                        *reader = None;
                        Err(e.into())
                    }
                }
            }
        }
    }
}
