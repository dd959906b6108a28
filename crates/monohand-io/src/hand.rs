//! A person's hand, measured once and reused: the hand file `monohand run --save-hand`
//! writes and `--hand` (in `run`, `lift`, `eval`, Python's `Hand`, the web options) reads.
//!
//! ```json
//! {"format": "monohand-hand/1", "source": "views", "scale": 0.931, "scale_sigma": 0.004,
//!  "hand_length_mm": 176.2, "side": "right", "views": 4, "frames": [0, 1, 2],
//!  "bone_lengths_mm": [31.2, null, ...], "bone_sigma_mm": [0.8, null, ...]}
//! ```
//!
//! - `scale`: the hand's size as a factor on the default adult hand (every bone times it),
//!   the one number the fit uses; `hand_length_mm` is the model's wrist-to-middle-fingertip
//!   length at that scale, said for people (the model's joints, not a ruler's landmarks:
//!   docs/absolute-depth.md).
//! - `scale_sigma`: its standard uncertainty (absent where unknown).
//! - `source`: `views` (measured by a calibrated rig: `--save-hand`) or `ruler` (from
//!   `--hand-length-mm`); `side`, `views` and `frames`: which hand, how many cameras and
//!   which frames it was measured on.
//! - `bone_lengths_mm` / `bone_sigma_mm`: each bone's length (the 20 bones wrist to
//!   thumb tip first, as [`monohand_core::hand_model::BONES`]) where the views triangulated
//!   it in enough frames, `null` elsewhere: what the views say of the proportions, recorded
//!   beside the size.

use crate::error::{name_of, read_text, IoError, IoResult};
use monohand_core::hand_model::HandSide;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The value of [`HandFile::format`].
pub const HAND_FORMAT: &str = "monohand-hand/1";

/// Where a hand file's size came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HandSource {
    /// Measured by two or more calibrated views (`monohand run --save-hand`).
    Views,
    /// A ruler's hand length (`--hand-length-mm`).
    Ruler,
}

impl HandSource {
    /// `"views"` or `"ruler"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            HandSource::Views => "views",
            HandSource::Ruler => "ruler",
        }
    }
}

/// A person's hand (the module docs give the file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandFile {
    /// [`HAND_FORMAT`].
    pub format: String,
    /// How the size was found.
    pub source: HandSource,
    /// The size: a factor on the default adult hand.
    pub scale: f64,
    /// The standard uncertainty of `scale`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_sigma: Option<f64>,
    /// The model's wrist-to-middle-fingertip length at `scale`, mm.
    pub hand_length_mm: f64,
    /// The hand it was measured on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<HandSide>,
    /// How many calibrated views measured it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub views: Option<usize>,
    /// The frames it was measured on (indices in the input).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frames: Vec<u64>,
    /// The ruler's length it came from, mm (`source` ruler).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ruler_mm: Option<f64>,
    /// Each bone's length where the views support it, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bone_lengths_mm: Option<[Option<f64>; 20]>,
    /// The standard uncertainty of each of those lengths, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bone_sigma_mm: Option<[Option<f64>; 20]>,
}

impl HandFile {
    /// A hand of `scale` from `source`, the model's length `hand_length_mm` at that scale,
    /// with nothing else known.
    pub fn new(source: HandSource, scale: f64, hand_length_mm: f64) -> HandFile {
        HandFile {
            format: HAND_FORMAT.to_string(),
            source,
            scale,
            scale_sigma: None,
            hand_length_mm,
            side: None,
            views: None,
            frames: Vec::new(),
            ruler_mm: None,
            bone_lengths_mm: None,
            bone_sigma_mm: None,
        }
    }

    /// Checks the numbers; `file` names it in errors.
    pub fn validate(&self, file: &str) -> IoResult<()> {
        let field = |name: &str, why: String| Err(IoError::field(file, name, why));
        if self.format != HAND_FORMAT {
            return field(
                "format",
                format!("{:?}, expected {HAND_FORMAT:?}", self.format),
            );
        }
        // The range of sizes a fit accepts is the session's (monohand::HAND_SCALE_RANGE).
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return field("scale", format!("{} is not a positive factor", self.scale));
        }
        if !(self.hand_length_mm.is_finite() && self.hand_length_mm > 0.0) {
            return field("hand_length_mm", "must be a positive number".into());
        }
        let positive = |x: &Option<f64>| x.is_none_or(|v| v.is_finite() && v >= 0.0);
        if !positive(&self.scale_sigma) {
            return field("scale_sigma", "must be a number >= 0".into());
        }
        for (name, values) in [
            ("bone_lengths_mm", &self.bone_lengths_mm),
            ("bone_sigma_mm", &self.bone_sigma_mm),
        ] {
            if values.is_some_and(|v| !v.iter().all(positive)) {
                return field(name, "must hold numbers >= 0 or null".into());
            }
        }
        Ok(())
    }
}

/// Reads and checks a hand file.
pub fn read_hand(path: impl AsRef<Path>) -> IoResult<HandFile> {
    let path = path.as_ref();
    parse_hand(&read_text(path)?, &name_of(path))
}

/// Parses and checks hand-file JSON; `file` names it in errors.
pub fn parse_hand(text: &str, file: &str) -> IoResult<HandFile> {
    let hand: HandFile = serde_json::from_str(text).map_err(|e| IoError::json(file, &e))?;
    hand.validate(file)?;
    Ok(hand)
}

/// Writes a hand file (checked first), whole or not at all
/// ([`crate::sink::write_file_atomically`]).
pub fn write_hand(path: impl AsRef<Path>, hand: &HandFile) -> IoResult<()> {
    let path = path.as_ref();
    hand.validate(&name_of(path))?;
    let mut text =
        serde_json::to_string_pretty(hand).map_err(|e| IoError::json(name_of(path), &e))?;
    text.push('\n');
    crate::sink::write_file_atomically(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured() -> HandFile {
        let mut bones = [None; 20];
        bones[4] = Some(88.5);
        HandFile {
            scale_sigma: Some(0.004),
            side: Some(HandSide::Right),
            views: Some(4),
            frames: vec![0, 1, 2],
            bone_lengths_mm: Some(bones),
            bone_sigma_mm: Some(bones.map(|b| b.map(|_| 0.7))),
            ..HandFile::new(HandSource::Views, 0.931, 176.2)
        }
    }

    #[test]
    fn a_hand_file_round_trips_and_is_checked() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("hand.json");
        write_hand(&path, &measured()).expect("write");
        assert_eq!(read_hand(&path).expect("read"), measured());
        let text = std::fs::read_to_string(&path).expect("text");
        assert!(text.contains("\"source\": \"views\"") && text.contains("\"side\": \"right\""));
        // A ruler's hand: the optional fields are left out.
        let ruler = HandFile {
            ruler_mm: Some(180.0),
            ..HandFile::new(HandSource::Ruler, 0.95, 179.0)
        };
        write_hand(&path, &ruler).expect("write");
        assert_eq!(read_hand(&path).expect("read"), ruler);
        assert!(!std::fs::read_to_string(&path)
            .expect("text")
            .contains("frames"));
    }

    #[test]
    fn bad_hand_files_say_what_is_wrong() {
        let good = serde_json::to_value(measured()).expect("json");
        let spoil = |key: &str, value: serde_json::Value| {
            let mut v = good.clone();
            v[key] = value;
            parse_hand(&v.to_string(), "hand.json")
                .expect_err(key)
                .to_string()
        };
        assert!(spoil("scale", (-0.5).into()).contains("scale"));
        assert!(spoil("scale", serde_json::Value::Null).contains("hand.json"));
        assert!(spoil("format", "other".into()).contains("format"));
        assert!(spoil("hand_length_mm", (-1.0).into()).contains("hand_length_mm"));
        assert!(spoil("source", "guess".into()).contains("hand.json"));
        let mut bones = vec![serde_json::Value::Null; 20];
        bones[0] = (-2.0).into();
        assert!(spoil("bone_lengths_mm", bones.into()).contains("bone_lengths_mm"));
        assert!(parse_hand("not json", "hand.json").is_err());
        // Nothing is written for a bad hand, and an old file stays whole.
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("hand.json");
        write_hand(&path, &measured()).expect("write");
        let bad = HandFile {
            scale: f64::NAN,
            ..measured()
        };
        assert!(write_hand(&path, &bad).is_err());
        assert_eq!(read_hand(&path).expect("still whole"), measured());
    }
}
