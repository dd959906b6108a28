//! # monohand-vision
//!
//! The vision front end of monohand: finds hands (and heads) in RGB images and gives 21 2D
//! hand keypoints per hand, using MediaPipe's pretrained palm detector, hand-landmark model
//! and BlazeFace, run in pure Rust with tract through the project's own TFLite importer
//! (the `monohand-tflite` crate, re-exported as [`tflite_import`]).
//!
//! ```no_run
//! use monohand_vision::{HandPipeline, ModelOptions, PipelineOptions};
//! let pipeline = HandPipeline::new(&ModelOptions { detect_heads: true, ..Default::default() }, PipelineOptions::default())?;
//! let found = pipeline.detect_file(std::path::Path::new("hand.jpg"))?;
//! for hand in &found.hands {
//!     println!("{:?} {:.2} wrist at {:?}", hand.side, hand.detection_score, hand.keypoints.points[0]);
//! }
//! # Ok::<(), monohand_vision::VisionError>(())
//! ```
//!
//! Weights are fetched from the PyPI wheel `mediapipe==0.10.14` on first use ([`models`]).
//!
//! **Pixel conventions.** What [`HandPipeline`] returns ([`Detections`], [`DetectedHand`],
//! [`DetectedHead`]; their boxes are `monohand_core::bbox::BBox`) is in pixel-centre
//! coordinates, the centre of the first pixel at `(0, 0)` as in OpenCV and OpenPose, like
//! everything in the project's files. The network layer below it, where crops are cut
//! and network outputs mapped back ([`palm`], [`face`], [`ssd`], [`landmarks`], [`warp`],
//! [`geometry`], and the plug-in traits [`HandDetector`] and [`KeypointEstimator`] with
//! [`HandRegion`] and [`HandKeypoints`]), works in continuous coordinates (pixel `i` covers
//! `[i, i+1)`), the networks' own; the pipeline converts between the two at its boundary
//! only ([`geometry::to_pixel_centres`]).
#![deny(missing_docs)]

pub mod error;
pub mod face;
pub mod geometry;
pub mod heatmap;
pub mod image_io;
pub mod int8;
mod int8_tables;
mod keypoints;
pub mod landmarks;
pub mod models;
pub mod network;
pub mod palm;
pub mod pipeline;
pub mod rectify;
mod reduce;
pub mod sensor_db;
pub mod ssd;
/// The `.tflite` importer (the `monohand-tflite` crate).
pub use monohand_tflite as tflite_import;
pub mod warp;

pub use error::{Result, VisionError};
/// Re-exported so callers can build inputs without depending on `image` themselves.
pub use image::RgbImage;
pub use models::{ModelFile, ModelStore};
pub use monohand_tflite::Precision;
pub use network::{NetOutputs, NetState, TfliteNet};
pub use pipeline::{
    CropSeed, DetectedHand, DetectedHead, Detections, HandDetector, HandKeypoints, HandPipeline,
    HandRegion, KeypointEstimator, ModelOptions, ModelVariant, NetworkBytes, PipelineOptions,
};
