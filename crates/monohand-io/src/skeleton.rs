//! Bone-length files for choosing the hand model's size.
//!
//! A JSON file with the 20 bone lengths in millimetres, in
//! [`monohand_core::hand_model::BONES`] order (per finger thumb, index, middle,
//! ring, little: wrist-to-base, then the three phalanges), either as a plain
//! array or as `{"bone_lengths_mm": [...]}`:
//!
//! ```
//! let l = monohand_io::skeleton::parse_bone_lengths(
//!     r#"{"bone_lengths_mm": [35, 40, 30, 25, 90, 45, 25, 20, 88, 48, 28, 22,
//!                              84, 44, 27, 21, 80, 35, 20, 19]}"#,
//!     "bones.json",
//! ).unwrap();
//! assert_eq!(l[5], 45.0);
//! ```

use crate::error::{name_of, read_text, IoError, IoResult};
use serde_json::Value;
use std::path::Path;

/// The key of the object form.
pub const BONE_LENGTHS_KEY: &str = "bone_lengths_mm";

/// Reads a bone-length file.
pub fn read_bone_lengths(path: impl AsRef<Path>) -> IoResult<[f64; 20]> {
    let path = path.as_ref();
    parse_bone_lengths(&read_text(path)?, &name_of(path))
}

/// Parses bone-length JSON; `file` names it in errors.
pub fn parse_bone_lengths(text: &str, file: &str) -> IoResult<[f64; 20]> {
    let v: Value = serde_json::from_str(text).map_err(|e| IoError::json(file, &e))?;
    let (arr, field) = match &v {
        Value::Array(a) => (a, "(top-level array)"),
        Value::Object(o) => match o.get(BONE_LENGTHS_KEY) {
            Some(Value::Array(a)) => (a, BONE_LENGTHS_KEY),
            Some(_) => {
                return Err(IoError::field(
                    file,
                    BONE_LENGTHS_KEY,
                    "expected an array of 20 numbers",
                ))
            }
            None => return Err(IoError::field(file, BONE_LENGTHS_KEY, "missing")),
        },
        _ => {
            return Err(IoError::format(
                file,
                "expected an array of 20 bone lengths or {\"bone_lengths_mm\": [...]}",
            ))
        }
    };
    if arr.len() != 20 {
        return Err(IoError::field(
            file,
            field,
            format!("expected 20 bone lengths (mm), got {}", arr.len()),
        ));
    }
    let mut out = [0.0; 20];
    for (i, x) in arr.iter().enumerate() {
        let l = x
            .as_f64()
            .filter(|l| l.is_finite() && *l > 0.0)
            .ok_or_else(|| {
                IoError::field(
                    file,
                    format!("{field}[{i}]"),
                    format!("expected a positive length in mm, got {x}"),
                )
            })?;
        out[i] = l;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forms_and_errors() {
        let a: Vec<f64> = (1..=20).map(|i| i as f64 * 2.0).collect();
        let plain = parse_bone_lengths(&serde_json::to_string(&a).unwrap(), "b.json").unwrap();
        assert_eq!(plain[19], 40.0);
        let e = parse_bone_lengths("[1, 2]", "b.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("b.json") && e.contains("got 2"), "{e}");
        let mut bad = a.clone();
        bad[3] = -1.0;
        let e = parse_bone_lengths(
            &serde_json::json!({"bone_lengths_mm": bad}).to_string(),
            "b.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("bone_lengths_mm[3]"), "{e}");
        assert!(parse_bone_lengths("{}", "b.json").is_err());
        assert!(parse_bone_lengths("3", "b.json").is_err());
    }
}
