//! # monohand-calib
//!
//! Camera calibration from photographs of a printed chessboard, written here
//! (no OpenCV): find the board's inner corners with subpixel accuracy
//! ([`corners`]), then estimate a camera's intrinsics, lens distortion and each
//! view's pose by Zhang's closed-form start and a Levenberg-Marquardt
//! refinement ([`calibrate`]), and the poses between the cameras of a rig.
//!
//! Conventions are the project's (OpenCV's): x right, y down, z forward, pixel
//! centres at integer coordinates, millimetres. Images are borrowed, caller-owned
//! 8-bit grey buffers ([`GrayImage`]); this crate reads no files.

#![deny(missing_docs)]

pub mod board;
pub mod calibrate;
pub mod corners;
pub mod error;
pub mod image;
pub mod print;

pub use board::Board;
pub use error::{CalibError, CalibResult};
pub use image::GrayImage;
