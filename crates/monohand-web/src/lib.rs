//! **monohand-web**: monohand in the browser.
//!
//! RGBA frames (a canvas' `ImageData`) in, tracked absolute 3D hands out, as the records
//! `monohand run` writes (docs/output-format.md): the same palm detector and landmark
//! network (MediaPipe's weights through monohand's `.tflite` importer on tract), the same
//! session ([`monohand::Session`]: crop tracking, identities, the left/right vote, the fit
//! warm-started from the last frame) and the same record writer. Nothing here is a copy of
//! the native pipeline; this crate only turns bytes into the session's inputs and its
//! frames into JSON.
//!
//! [`Tracker`] is the whole of it in Rust (it builds and is tested natively too); the
//! WebAssembly build adds the JavaScript class `WebTracker` over it (module `js`; it compiles
//! natively too, for the lints, but only runs in wasm32), which `web/monohand.js` wraps for
//! pages. How to build and test it:
//! `crates/monohand-web/README.md`.
#![deny(missing_docs)]

mod error;
mod js;
pub mod mesh;

pub use error::WebError;

/// `initThreadPool(n)` for JavaScript: starts rayon's pool of `n` Web Workers sharing the
/// module's memory (the threaded module only, feature `threads`; the page must be
/// cross-origin isolated). `web/worker.js` calls it once, before making the tracker.
#[cfg(all(target_arch = "wasm32", feature = "threads"))]
pub use wasm_bindgen_rayon::init_thread_pool;

/// `startOperatorTeam(threads)` for JavaScript (the threaded module only): starts the team
/// that shares one network's large operators between `threads` threads (the tracker's and
/// `threads - 1` helpers, each keeping one of rayon's Web Workers for itself, so the pool
/// must have that many more than the mirror pass needs), as natively, where the team's
/// helpers are std threads, which WebAssembly lacks. The results are the same bits. Returns
/// the team's size. `web/worker.js` calls it once, after `initThreadPool`.
#[cfg(all(target_arch = "wasm32", feature = "threads"))]
#[wasm_bindgen::prelude::wasm_bindgen(js_name = startOperatorTeam)]
pub fn start_operator_team(threads: usize) -> usize {
    monohand_vision::tflite_import::start_team(threads, &|_, helper| {
        rayon::spawn(helper);
        true
    })
}

use monohand::{FittedFrame, Session, SessionOptions};
use monohand_core::camera::{Camera, Intrinsics};
use monohand_io::jsonl::FrameRecord;
use monohand_vision::models::sha256_hex;
use monohand_vision::{HandPipeline, ModelFile, NetworkBytes, RgbImage};
use std::path::Path;
use std::sync::Arc;

/// What a page may set, as JSON (every field optional):
/// `{"hands": 2, "detect_every": 10, "mirror_pass": true, "precision": "f32", "camera":
/// {"fx": .., "fy": .., "cx": .., "cy": .., "width": .., "height": ..}, "hand": {..a hand
/// file..}, "hand_length_mm": 180, "xr_joints": true}`.
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerOptions {
    /// The most hands per frame (default: the session's, 2).
    pub hands: Option<usize>,
    /// Look for new hands every this many frames while tracking (default: the session's, 10).
    pub detect_every: Option<usize>,
    /// Whether the landmark network also reads each crop's mirror image (default: the
    /// session's, on; off is `run --no-mirror-pass`: one network pass a hand instead of two,
    /// as MediaPipe does, at a higher 3D error, docs/accuracy.md).
    pub mirror_pass: Option<bool>,
    /// The networks' arithmetic, `"f32"` (the default) or `"int8"` (`run --precision`).
    pub precision: Option<String>,
    /// The camera's intrinsics, for frames of its size; without them, the generic 60
    /// degree camera for the frames' size, said once in the notes (as the CLI does).
    pub camera: Option<Intrinsics>,
    /// The person's hand, the content of a hand file (`run --save-hand`, `run --hand`):
    /// both hands are fitted at its size.
    pub hand: Option<monohand_io::hand::HandFile>,
    /// A ruler's hand length, mm (`run --hand-length-mm`; not with `hand`).
    pub hand_length_mm: Option<f64>,
    /// Whether each fitted hand's record carries its 26 OpenXR joints (`xr_joints`, as
    /// `run --xr-joints` writes them; default off). `web/monohand.js`'s `webxrJoints`
    /// turns them into WebXR's 25.
    pub xr_joints: Option<bool>,
}

impl TrackerOptions {
    /// Options from a page's JSON text (empty: the defaults).
    pub fn from_json(text: &str) -> Result<TrackerOptions, WebError> {
        if text.trim().is_empty() {
            return Ok(TrackerOptions::default());
        }
        serde_json::from_str(text).map_err(|e| WebError::Options(e.to_string()))
    }
}

/// The hand size the options give (`hand` or `hand_length_mm`), and where it came from
/// (the choice is the library's, [`monohand::GivenHandSize`]); `None`: the default hand.
fn hand_size(
    options: &TrackerOptions,
) -> Result<Option<(f64, monohand::HandSizeSource)>, WebError> {
    let given = monohand::GivenHandSize {
        file: options.hand.as_ref(),
        ruler_mm: options.hand_length_mm,
        scale: None,
    };
    match given.choose() {
        Ok((_, monohand::HandSizeSource::Default)) => Ok(None),
        Ok((scale, source)) => Ok(Some((scale.initial(), source))),
        Err(monohand::HandSizeError::MoreThanOne(_)) => Err(WebError::Options(
            "give hand or hand_length_mm, not both".into(),
        )),
        Err(monohand::HandSizeError::Ruler(e)) => {
            Err(WebError::Options(format!("hand_length_mm: {e}")))
        }
        Err(e) => Err(WebError::Options(format!("hand: {e}"))),
    }
}

/// The file among `candidates` whose pinned checksum `bytes` have.
fn identify(
    bytes: &[u8],
    what: &'static str,
    candidates: &[ModelFile],
) -> Result<ModelFile, WebError> {
    let found = sha256_hex(bytes);
    candidates
        .iter()
        .copied()
        .find(|f| f.sha256() == found)
        .ok_or_else(|| WebError::Weights {
            what,
            bytes: bytes.len(),
            found,
            expected: candidates
                .iter()
                .map(|f| f.file_name())
                .collect::<Vec<_>>()
                .join(" or "),
        })
}

/// A video's hands, frame by frame, on the calling thread (the browser's main thread or a
/// worker).
pub struct Tracker {
    session: Session,
    /// Records with their OpenXR joints ([`TrackerOptions::xr_joints`]).
    xr_joints: bool,
}

impl Tracker {
    /// Loads the networks from the bytes of MediaPipe's palm detector and hand landmark
    /// `.tflite` files (full or lite, told by their checksums) and starts a tracking
    /// session with `options`.
    pub fn new(palm: &[u8], landmark: &[u8], options: TrackerOptions) -> Result<Tracker, WebError> {
        let palm_file = identify(
            palm,
            "palm detector",
            &[ModelFile::PalmDetectionFull, ModelFile::PalmDetectionLite],
        )?;
        let landmark_file = identify(
            landmark,
            "hand landmark",
            &[ModelFile::HandLandmarkFull, ModelFile::HandLandmarkLite],
        )?;
        let mut session_options = SessionOptions::default();
        if let Some(n) = options.hands {
            session_options = session_options.hands(n);
        }
        if let Some(n) = options.detect_every {
            session_options = session_options.detect_every(n);
        }
        if let Some(on) = options.mirror_pass {
            session_options = session_options.mirror_pass(on);
        }
        if let Some(p) = &options.precision {
            let p = p
                .parse()
                .map_err(|e: String| WebError::Options(format!("precision: {e}")))?;
            session_options = session_options.precision(p);
        }
        if let Some((scale, source)) = hand_size(&options)? {
            let skeletons = monohand::hand_skeletons(scale, None)
                .map_err(|e| WebError::Options(format!("hand: {e}")))?;
            session_options = session_options.skeletons(skeletons);
            session_options.settings.fit.hand_size = source;
        }
        let resolved = session_options
            .settings
            .clone()
            .resolve()
            .map_err(|e| settings_error(&e))?;
        let pipeline = HandPipeline::from_bytes(
            NetworkBytes {
                palm: (palm, Path::new(palm_file.file_name())),
                landmark: (landmark, Path::new(landmark_file.file_name())),
                face: None,
            },
            resolved.pipeline(),
        )
        .map_err(monohand::SessionError::from)?;
        let cameras = match options.camera {
            Some(i) => vec![Camera::pinhole(i.fx, i.fy, i.cx, i.cy, i.width, i.height)
                .map_err(|e| WebError::Options(format!("camera: {e}")))?],
            None => Vec::new(),
        };
        let session = Session::with_pipeline(cameras, Arc::new(pipeline), session_options)?;
        Ok(Tracker {
            session,
            xr_joints: options.xr_joints.unwrap_or(false),
        })
    }

    /// Tracks the hands in one frame of `width` x `height` RGBA pixels (row by row, 4 bytes a
    /// pixel, as a canvas' `ImageData`; alpha is ignored) at `time_s` seconds, and returns
    /// the records of the frames now done (this one; see [`Session::process`]).
    pub fn process_rgba(
        &mut self,
        rgba: &[u8],
        width: u32,
        height: u32,
        time_s: f64,
    ) -> Result<Vec<FrameRecord>, WebError> {
        let image = rgb_from_rgba(rgba, width, height)?;
        let done = self.session.process(&[&image], time_s)?;
        Ok(done.iter().map(|d| record(d, self.xr_joints)).collect())
    }

    /// The records of the frames still kept back, at the end of the input.
    pub fn finish(&mut self) -> Vec<FrameRecord> {
        let xr_joints = self.xr_joints;
        let done = self.session.finish();
        done.iter().map(|d| record(d, xr_joints)).collect()
    }

    /// Messages for the user since the last call (the camera assumed, for one).
    pub fn take_notes(&mut self) -> Vec<String> {
        self.session.take_notes()
    }
}

/// A refused setting, said with the page's option name.
fn settings_error(e: &monohand::SettingsError) -> WebError {
    let name = match e.field {
        monohand::Field::MaxHands => "hands",
        other => other.name(),
    };
    WebError::Options(format!("{name} {}", e.why))
}

/// A frame's record as `monohand run` writes it for a video (its time, the `vision` and
/// `fit` timings; the page decoded the frame, so no `decode`), with the hands' OpenXR
/// joints when `xr_joints` (as `run --xr-joints`).
fn record(done: &FittedFrame, xr_joints: bool) -> FrameRecord {
    let r = monohand::records::timed_record(done, None, true, None);
    if xr_joints {
        r.with_xr_joints()
    } else {
        r
    }
}

/// The records as one JSON array, each written as `monohand run` writes its lines.
pub fn records_json(records: &[FrameRecord]) -> Result<String, WebError> {
    let mut out = String::from("[");
    for (i, r) in records.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push_str(&monohand_io::jsonl::frame_json(r, "monohand-web")?);
    }
    out.push(']');
    Ok(out)
}

/// The RGB image of an RGBA buffer, checked against its size.
fn rgb_from_rgba(rgba: &[u8], width: u32, height: u32) -> Result<RgbImage, WebError> {
    let pixels = (width as usize)
        .checked_mul(height as usize)
        .filter(|&n| n > 0)
        .ok_or_else(|| WebError::Frame(format!("a {width}x{height} frame has no pixels")))?;
    if pixels.checked_mul(4) != Some(rgba.len()) {
        return Err(WebError::Frame(format!(
            "{} bytes for a {width}x{height} RGBA frame (expected {})",
            rgba.len(),
            pixels.saturating_mul(4)
        )));
    }
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| WebError::Frame(format!("cannot make a {width}x{height} image")))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic
    use super::*;

    #[test]
    fn rgba_to_rgb_drops_alpha_and_checks_the_size() {
        let rgba = [1, 2, 3, 255, 4, 5, 6, 0];
        let img = rgb_from_rgba(&rgba, 2, 1).unwrap();
        assert_eq!(img.as_raw(), &[1, 2, 3, 4, 5, 6]);
        assert!(matches!(
            rgb_from_rgba(&rgba, 1, 1),
            Err(WebError::Frame(m)) if m.contains("8 bytes for a 1x1")
        ));
        assert!(rgb_from_rgba(&[], 0, 5).is_err());
        assert!(rgb_from_rgba(&[], u32::MAX, u32::MAX).is_err());
    }

    #[test]
    fn weights_that_are_not_the_networks_are_refused_by_name() {
        let err = Tracker::new(b"<html>404</html>", b"", TrackerOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("palm detector weights (16 bytes"), "{err}");
        assert!(
            err.contains("palm_detection_full.tflite or palm_detection_lite.tflite"),
            "{err}"
        );
    }

    #[test]
    fn options_are_read_from_json_and_unknown_fields_refused() {
        let o = TrackerOptions::from_json(r#"{"hands": 1, "mirror_pass": false, "camera": {"fx": 500, "fy": 500, "cx": 320, "cy": 240, "width": 640, "height": 480}}"#).unwrap();
        assert_eq!(o.hands, Some(1));
        assert_eq!(o.mirror_pass, Some(false));
        assert_eq!(o.camera.unwrap().width, 640);
        assert_eq!(o.xr_joints, None);
        let o = TrackerOptions::from_json(r#"{"xr_joints": true}"#).unwrap();
        assert_eq!(o.xr_joints, Some(true));
        assert!(TrackerOptions::from_json("").unwrap().hands.is_none());
        assert!(TrackerOptions::from_json(r#"{"hand": 1}"#).is_err());
    }
}
