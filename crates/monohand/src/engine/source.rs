//! Where the engine's frames come from: image files, a folder, a video file or a webcam
//! (through [`monohand_media::video`]), or a caller's own frames.

use super::EngineResult;
use crate::base::camera::StatedCamera;
use crate::base::errors::SourceError;
use monohand_media::video::{
    read_quicktime_metadata, FrameRecycler, QuickTimeError, VideoInput, VideoReader,
};
use monohand_vision::image_io::{images_in_folder, load_photo, IMAGE_EXTENSIONS};
use monohand_vision::RgbImage;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Why an input could not be opened, or does not fit the cameras and settings (nothing
/// was run).
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// `webcam:` without a device number.
    #[error("{spec:?}: a webcam is written webcam:N, e.g. webcam:0")]
    WebcamSyntax {
        /// As given.
        spec: String,
    },
    /// No such file or folder.
    #[error("{spec}: no such file or folder")]
    Missing {
        /// As given.
        spec: String,
    },
    /// A folder without images, or (a corpus) without videos or images.
    #[error("{}: no {what}", path.display())]
    EmptyFolder {
        /// The folder.
        path: PathBuf,
        /// What was looked for, and where ("images in this folder (looked for ..)").
        what: String,
    },
    /// A folder or file that could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The folder or file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A video or a folder could not be opened (the error and its causes).
    #[error("{0}")]
    Open(String),
    /// A keypoint file that could not be read, or holds a frame twice.
    #[error("{0}")]
    Keypoints(String),
    /// Not one camera per view.
    #[error("{cameras} camera(s) for {views} view(s){what}: give one {per} per view{order}")]
    CameraCount {
        /// Cameras given.
        cameras: usize,
        /// Views given.
        views: usize,
        /// What the views are (empty, or " of keypoints").
        what: &'static str,
        /// What is given per view ("calibration", "camera").
        per: &'static str,
        /// ", in the same order", or empty.
        order: &'static str,
    },
    /// Several views without their calibrations.
    #[error("several views need their calibrations, one per view (docs/calibration.md)")]
    Uncalibrated,
    /// A video turned upright by its rotation metadata, calibrated for its stored frames.
    #[error(
        "view {view}: the video is stored {h}x{w} and carries rotation metadata of {rotation} \
         degrees (a phone held upright), so its frames are decoded upright at {w}x{h}; the \
         calibration is for the stored {h}x{w} frames. Give a calibration of the upright \
         frames (fx and fy swapped, the principal point turned with the image), or strip the \
         rotation from the file (ffmpeg -i IN -c copy -metadata:s:v:0 rotate=0 OUT)"
    )]
    Rotated {
        /// The view, from 1.
        view: usize,
        /// Upright width.
        w: u32,
        /// Upright height.
        h: u32,
        /// The rotation, degrees.
        rotation: i32,
    },
    /// A video whose calibration cannot be scaled to its frames.
    #[error(
        "view {view}: the video is {}x{} but its calibration is for {}x{}, which cannot be \
         scaled to it ({source})",
        size.0, size.1, calibrated.0, calibrated.1
    )]
    OtherSize {
        /// The view, from 1.
        view: usize,
        /// The video's frame size.
        size: (u32, u32),
        /// The calibration's.
        calibrated: (u32, u32),
        /// Why.
        source: monohand_core::camera::ScaleError,
    },
    /// A video where images are wanted (`monohand detect`).
    #[error("{}: not an image; `monohand run` reads videos", path.display())]
    NotImages {
        /// The video.
        path: PathBuf,
    },
    /// No source at all.
    #[error("no input")]
    Nothing,
    /// The worker threads could not be started.
    #[error("could not start worker threads: {0}")]
    Threads(String),
}

/// One frame of one view, as a source delivers it.
#[derive(Debug)]
pub struct SourceFrame {
    /// Index from 0.
    pub index: u64,
    /// File name of the image, if it came from one.
    pub source: Option<String>,
    /// Time of the frame, seconds (the video's clock; `index / 30` for images).
    pub timestamp_s: f64,
    /// The pixels, or why they could not be read (the run goes on with the next frame).
    pub image: Result<RgbImage, SourceError>,
    /// Milliseconds spent reading and decoding it.
    pub decode_ms: f64,
    /// What the file states about its camera: a photo's EXIF focal length, a video's
    /// QuickTime metadata (the same for each of its frames).
    pub focal: StatedCamera,
}

impl SourceFrame {
    /// A frame of the caller's own: its pixels and time, nothing stated of its camera.
    pub fn given(index: u64, timestamp_s: f64, image: RgbImage) -> SourceFrame {
        SourceFrame {
            index,
            source: None,
            timestamp_s,
            image: Ok(image),
            decode_ms: 0.0,
            focal: StatedCamera::None,
        }
    }
}

/// Frames of one view, in order.
pub trait FrameSource: Send {
    /// The next frame; `Ok(None)` at the end; `Err` when the input stops on an error (the
    /// frames before it were good).
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError>;
    /// The frame for the first view's frame `index` taken at `time_s` (its clock): a later
    /// view's frames are matched to the first's by index unless the source matches them by
    /// time ([`crate::engine::sync::align`]).
    fn frame_at(&mut self, index: u64, time_s: f64) -> Result<Option<SourceFrame>, SourceError> {
        let _ = (index, time_s);
        self.next_frame()
    }
    /// Whether consecutive frames show one scene (a video), so that tracking makes sense.
    fn is_video(&self) -> bool;
    /// Number of frames, when known up front.
    fn len_hint(&self) -> Option<u64> {
        None
    }
    /// Frame rate, when known (videos).
    fn fps(&self) -> Option<f64> {
        None
    }
    /// Frame size `(width, height)`, when known before the first frame (videos).
    fn video_size(&self) -> Option<(u32, u32)> {
        None
    }
    /// The display rotation of a video (phone metadata, degrees; its frames come upright).
    fn rotation_deg(&self) -> i32 {
        0
    }
    /// Where frames done with can be given back for reuse (videos: the reader's buffers).
    fn recycler(&self) -> Option<FrameRecycler> {
        None
    }
}

/// The kind of an input, decided from its name.
#[derive(Debug, Clone)]
pub enum Input {
    /// Image files, one frame each, in this order.
    Images(Vec<PathBuf>),
    /// A video file or a webcam.
    Video(VideoInput),
}

impl Input {
    /// `webcam:N`, a folder of images (file-name order), an image file, or else a video
    /// file (anything ffmpeg reads, a named pipe included).
    pub fn parse(s: &str) -> EngineResult<Input> {
        if s.starts_with("webcam:") {
            return match VideoInput::parse(s) {
                v @ VideoInput::Webcam(_) => Ok(Input::Video(v)),
                VideoInput::File(_) => Err(InputError::WebcamSyntax { spec: s.into() }.into()),
            };
        }
        let path = Path::new(s);
        if path.is_dir() {
            let files = images_in_folder(path).map_err(|e| InputError::Open(chain(&e)))?;
            if files.is_empty() {
                return Err(InputError::EmptyFolder {
                    path: path.into(),
                    what: format!(
                        "images in this folder (looked for {})",
                        IMAGE_EXTENSIONS.join(", ")
                    ),
                }
                .into());
            }
            return Ok(Input::Images(files));
        }
        // A regular file, or a named pipe or device that a stream comes through.
        if std::fs::metadata(path).is_err() {
            return Err(InputError::Missing { spec: s.into() }.into());
        }
        let is_image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        Ok(if is_image {
            Input::Images(vec![path.to_path_buf()])
        } else {
            Input::Video(VideoInput::File(path.to_path_buf()))
        })
    }

    /// Whether consecutive frames show the same scene (video), so tracking makes sense.
    pub fn is_video(&self) -> bool {
        matches!(self, Input::Video(_))
    }

    /// Whether the input is one image file.
    pub fn is_single_image(&self) -> bool {
        matches!(self, Input::Images(files) if files.len() == 1)
    }

    /// Opens the input: starts ffmpeg for a video, which counts as stalled after `stall`
    /// without a frame.
    pub fn open(&self, stall: Duration) -> EngineResult<Box<dyn FrameSource>> {
        Ok(match self {
            Input::Images(files) => Box::new(ImageFiles::new(files.clone())),
            Input::Video(v) => Box::new(VideoSource::open(v, stall)?),
        })
    }
}

/// Image files, one frame each (their EXIF orientation applied, their EXIF focal length
/// read).
#[derive(Debug)]
pub struct ImageFiles {
    files: Vec<PathBuf>,
    next: usize,
}

impl ImageFiles {
    /// These files, in this order.
    pub fn new(files: Vec<PathBuf>) -> ImageFiles {
        ImageFiles { files, next: 0 }
    }
}

impl FrameSource for ImageFiles {
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        let t = Instant::now();
        let Some(path) = self.files.get(self.next) else {
            return Ok(None);
        };
        let index = self.next as u64;
        self.next += 1;
        let (image, focal) = match load_photo(path) {
            Ok(p) => (Ok(p.image), p.focal.into()),
            Err(e) => (Err(SourceError::Image(e.to_string())), StatedCamera::None),
        };
        Ok(Some(SourceFrame {
            index,
            source: path.file_name().map(|n| n.to_string_lossy().into_owned()),
            timestamp_s: index as f64 / 30.0,
            image,
            decode_ms: t.elapsed().as_secs_f64() * 1e3,
            focal,
        }))
    }

    fn is_video(&self) -> bool {
        false
    }

    fn len_hint(&self) -> Option<u64> {
        Some(self.files.len() as u64)
    }
}

/// A video file or webcam decoded by ffmpeg.
pub struct VideoSource {
    /// `None` once finished.
    reader: Option<Box<VideoReader>>,
    /// What the file's metadata states about its camera.
    stated: StatedCamera,
}

impl std::fmt::Debug for VideoSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoSource")
            .field("open", &self.reader.is_some())
            .finish()
    }
}

impl VideoSource {
    /// Starts ffmpeg on `input`; a source that delivers no frame for `stall` counts as
    /// stalled and ends with an error. A QuickTime or MP4 file's camera metadata is read
    /// first ([`stated_camera`]).
    pub fn open(input: &VideoInput, stall: Duration) -> EngineResult<VideoSource> {
        let stated = stated_camera(input);
        let mut reader = VideoReader::open(input).map_err(|e| InputError::Open(chain(&e)))?;
        reader.set_stall_timeout(stall);
        Ok(VideoSource {
            reader: Some(Box::new(reader)),
            stated,
        })
    }
}

/// What a video file states about its camera: its QuickTime metadata when it states a
/// focal length (an iPhone's video), else nothing. Only a regular file is read (a named
/// pipe's bytes are ffmpeg's); a file that is not QuickTime or MP4 states nothing, and one
/// whose metadata is damaged states nothing either, with a warning in the log.
pub fn stated_camera(input: &VideoInput) -> StatedCamera {
    let VideoInput::File(path) = input else {
        return StatedCamera::None;
    };
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return StatedCamera::None;
    }
    match read_quicktime_metadata(path) {
        Ok(meta) => {
            let tags = meta.camera();
            if tags.focal_35mm.is_some() {
                StatedCamera::QuickTime(Arc::new(tags))
            } else {
                StatedCamera::None
            }
        }
        Err(QuickTimeError::NotQuickTime { .. }) => StatedCamera::None,
        Err(e) => {
            tracing::warn!(
                "{}: its QuickTime metadata was not read ({e}); no camera from it",
                path.display()
            );
            StatedCamera::None
        }
    }
}

impl FrameSource for VideoSource {
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        let t = Instant::now();
        let Some(r) = self.reader.as_mut() else {
            return Ok(None);
        };
        match r.next_frame() {
            Ok(Some(f)) => Ok(Some(SourceFrame {
                index: f.index,
                source: None,
                timestamp_s: f.timestamp_s,
                image: Ok(f.image),
                decode_ms: t.elapsed().as_secs_f64() * 1e3,
                focal: self.stated.clone(),
            })),
            Ok(None) => {
                self.reader = None;
                Ok(None)
            }
            Err(e) => {
                self.reader = None;
                Err(SourceError::Video(chain(&e)))
            }
        }
    }

    fn is_video(&self) -> bool {
        true
    }

    fn len_hint(&self) -> Option<u64> {
        self.reader.as_ref().and_then(|r| r.info().frame_count)
    }

    fn fps(&self) -> Option<f64> {
        self.reader.as_ref().and_then(|r| r.info().fps)
    }

    fn video_size(&self) -> Option<(u32, u32)> {
        self.reader
            .as_ref()
            .map(|r| (r.info().width as u32, r.info().height as u32))
    }

    fn rotation_deg(&self) -> i32 {
        self.reader.as_ref().map_or(0, |r| r.info().rotation_deg)
    }

    fn recycler(&self) -> Option<FrameRecycler> {
        self.reader.as_ref().map(|r| r.recycler())
    }
}

/// A caller's own frames: `(image, time in seconds)` pairs, as from a camera SDK or
/// another decoder. `video` says whether they are consecutive frames of one scene.
pub struct CallerFrames<I> {
    frames: I,
    next: u64,
    video: bool,
}

impl<I> CallerFrames<I> {
    /// Frames from `frames`, numbered from 0.
    pub fn new(frames: I, video: bool) -> CallerFrames<I> {
        CallerFrames {
            frames,
            next: 0,
            video,
        }
    }
}

impl<I> FrameSource for CallerFrames<I>
where
    I: Iterator<Item = (RgbImage, f64)> + Send,
{
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        let Some((image, timestamp_s)) = self.frames.next() else {
            return Ok(None);
        };
        let index = self.next;
        self.next += 1;
        Ok(Some(SourceFrame::given(index, timestamp_s, image)))
    }

    fn is_video(&self) -> bool {
        self.video
    }
}

/// An error and its causes, `outer: inner: ...` (each cause once).
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !s.contains(&text) {
            s.push_str(": ");
            s.push_str(&text);
        }
        cause = c.source();
    }
    s
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../monohand-media/tests/data/quicktime")
            .join(name)
    }

    /// A video states its camera when its metadata has a focal length; a video without
    /// it, a damaged one, another format, a folder and a webcam state nothing.
    #[test]
    fn a_video_states_the_camera_its_metadata_has() {
        let StatedCamera::QuickTime(tags) =
            stated_camera(&VideoInput::File(fixture("iphone_int.mov")))
        else {
            panic!("no camera stated");
        };
        assert_eq!(tags.focal_35mm_mm(), Some(Ok(24.0)));
        assert_eq!(tags.model.as_deref(), Some("iPhone 15 Pro"));
        let dir = tempfile::tempdir().unwrap();
        let whole = std::fs::read(fixture("iphone_int.mov")).unwrap();
        let cut = dir.path().join("cut.mov");
        std::fs::write(&cut, &whole[..whole.len() - 100]).unwrap();
        let text = dir.path().join("notes.mkv");
        std::fs::write(&text, b"not a movie at all").unwrap();
        for input in [
            VideoInput::File(fixture("plain.mov")),
            VideoInput::File(fixture("movie_keys_ffmpeg.mov")),
            VideoInput::File(cut),
            VideoInput::File(text),
            VideoInput::File(dir.path().to_path_buf()),
            VideoInput::File(dir.path().join("absent.mov")),
            VideoInput::parse("webcam:0"),
        ] {
            assert_eq!(stated_camera(&input), StatedCamera::None, "{input:?}");
        }
    }

    /// A named pipe is not opened (opening one without a writer would wait forever, and
    /// its bytes are ffmpeg's to read).
    #[cfg(unix)]
    #[test]
    fn a_named_pipe_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("stream.mov");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        assert_eq!(stated_camera(&VideoInput::File(fifo)), StatedCamera::None);
    }
}
