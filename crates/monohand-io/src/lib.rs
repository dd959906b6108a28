//! # monohand-io
//!
//! File formats around [`monohand_core`]: camera calibrations, 2D keypoints
//! from detectors, the project's JSON Lines output and its exports. (Video and drawing on
//! frames are `monohand-media`'s.)
//! (Datasets' own files, such as STB's `.mat` labels, are read by `monohand-eval`.)
//!
//! - [`calibration`]: cameras from the project JSON, the WACV'18 JSON and
//!   OpenCV FileStorage YAML/XML, and a writer for the project JSON.
//! - [`openpose`]: OpenPose `--write_json` hand keypoints, read and written.
//! - [`skeleton`]: bone-length files for sizing the hand model.
//! - [`hand`]: a person's hand measured once (its size, its bones) and reused.
//! - [`jsonl`]: the project's JSON Lines output (one frame per line), read and written.
//! - [`export`]: CSV, OpenPose-style JSON with 3D, and an animated glTF (`.glb`) 3D view.
//! - [`sink`]: writing so that a failure (a full disk) leaves no damaged file.
//! - [`palette`]: the colours of the fingers and sides, shared with the overlays.
//!
//! Every fallible function returns [`IoError`], whose message names the file
//! and the field or line at fault.

#![deny(missing_docs)]

pub mod calibration;
pub mod error;
pub mod export;
pub mod hand;
pub mod hand_mesh;
pub mod jsonl;
#[cfg(feature = "lerobot")]
pub mod lerobot;
pub mod openpose;
pub mod palette;
pub mod sink;
pub mod skeleton;

pub use error::{IoError, IoResult};
