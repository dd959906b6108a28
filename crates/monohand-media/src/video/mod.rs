//! Video in and out through the `ffmpeg` and `ffprobe` command-line tools.
//!
//! No codec library is linked: [`VideoReader`] runs
//! `ffmpeg -i INPUT -f rawvideo -pix_fmt rgb24 -` and reads packed RGB frames
//! from its standard output (for 8-bit 4:2:0 video, the commonest kind, `-pix_fmt
//! yuv420p`, converted to RGB on its reading thread: half the bytes, see [`Yuv420`]); [`VideoWriter`] runs
//! `ffmpeg -f rawvideo -pix_fmt rgb24 -s WxH -r FPS -i - ... OUT` and writes
//! frames to its standard input; [`probe`] asks `ffprobe` for the size, frame
//! rate, frame count and codec of the first video stream. Anything ffmpeg can
//! decode is accepted (MP4/MOV, MKV/WebM, AVI, MPEG-TS, image files and image
//! sequences such as `img_%04d.png`), and a Linux webcam is read with the input
//! string `webcam:N` (`-f v4l2 -i /dev/videoN`, see [`VideoInput`]).
//!
//! The tools must be on `PATH` (Debian/Ubuntu: `apt-get install ffmpeg`, which
//! provides both), or named by the environment variables `MONOHAND_FFMPEG` and
//! `MONOHAND_FFPROBE`; when they are missing every function returns
//! [`IoError::ToolMissing`], which says what to install.
//!
//! Errors never hang or panic: ffmpeg's standard error is drained on a thread
//! (so a chatty ffmpeg cannot block on a full pipe) and its last lines are put
//! into [`IoError::Video`]. A corrupt or truncated video yields its decodable
//! frames first and then an error; an unreadable file fails in [`probe`] /
//! [`VideoReader::open`].
//!
//! ```no_run
//! use monohand_media::video::{VideoInput, VideoReader, VideoWriter};
//! let mut reader = VideoReader::open(&VideoInput::parse("clip.mp4")).unwrap();
//! let info = reader.info().clone();
//! let mut writer = VideoWriter::create("out.mp4", info.width, info.height, info.fps_or_default()).unwrap();
//! for frame in &mut reader {
//!     let frame = frame.unwrap();
//!     // ... draw on frame.image ...
//!     writer.write(&frame.image).unwrap();
//! }
//! writer.finish().unwrap();
//! ```
//!
//! The camera a QuickTime or MP4 file states in its own metadata (an iPhone's focal
//! length, lens, make and model) is read without ffmpeg, from the file's boxes:
//! [`read_quicktime_metadata`].
//!
//! The code is in one file per concern: `tools.rs` (finding the executables, what
//! they support, what they said), `input.rs` ([`VideoInput`]), `probe.rs` (ffprobe and
//! [`VideoInfo`]), `reader.rs` ([`VideoReader`]), `yuv.rs` (4:2:0 YUV to RGB),
//! `writer.rs` ([`VideoWriter`]) and `quicktime.rs` (the metadata boxes); everything
//! public is re-exported here.
//!
//! [`probe`]: fn@probe
//! [`IoError::ToolMissing`]: monohand_io::IoError::ToolMissing
//! [`IoError::Video`]: monohand_io::IoError::Video

mod input;
mod probe;
mod quicktime;
mod reader;
mod tools;
mod writer;
mod yuv;

pub use input::VideoInput;
pub use probe::{parse_probe_json, probe, probe_with, VideoInfo, DEFAULT_FPS, MAX_FRAME_PIXELS};
pub use quicktime::{
    parse_quicktime_metadata, read_quicktime_metadata, MetadataItem, MetadataValue, QuickTimeError,
    QuickTimeMetadata, VideoCameraTags, KEY_FOCAL_35MM, KEY_LENS_MODEL, KEY_MAKE, KEY_MODEL,
    MAX_VALUE_BYTES,
};
pub use reader::{reader_args, FrameRecycler, VideoFrame, VideoReader, DEFAULT_STALL_TIMEOUT};
pub use tools::{FfmpegFeatures, FfmpegTools};
pub use writer::{writer_args, Encoder, VideoWriter};
pub use yuv::{yuv420_frame_len, yuv420_to_rgb, Yuv420, YuvMatrix};

/// The one image type of the project: packed 8-bit RGB, rows top to bottom (the `image`
/// crate's buffer, which the vision front end takes too).
pub use image::RgbImage;
