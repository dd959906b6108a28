//! # monohand-media
//!
//! Pixels in and out: video files and webcams through the `ffmpeg` command-line tools
//! ([`video`]), and drawing hand skeletons, fitted models, boxes and labels on frames
//! ([`overlay`], [`scene`]; [`live`] and [`window`] for a live window). Frames are [`image::RgbImage`]s, the one
//! image type of the project. Errors are [`monohand_io::IoError`]s, which name the file and what ffmpeg said.

#![deny(missing_docs)]

pub mod live;
pub mod overlay;
pub mod scene;
pub mod video;
pub mod window;

pub use video::RgbImage;
