//! The int8 calibration tables shipped with monohand ([`Int8Table`]: read, written and
//! checked) and the import of a network with them ([`import`]): what the networks take
//! ([`crate::TfliteNet`]), below them. How the tables are made, on the f32 pipeline, is
//! [`crate::int8`], which re-exports what is public here.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use tract_core::internal::*;

use crate::error::{Result, VisionError};
use crate::models::{sha256_hex, ModelFile};
use monohand_tflite::{MinMax, Precision};

/// The first line of every table.
const HEADER: &str = "monohand int8 calibration 1";

/// The tables shipped with monohand: the network each is for, and its text.
const SHIPPED: [(ModelFile, &str); 4] = [
    (
        ModelFile::PalmDetectionFull,
        include_str!("../int8/palm_detection_full.txt"),
    ),
    (
        ModelFile::PalmDetectionLite,
        include_str!("../int8/palm_detection_lite.txt"),
    ),
    (
        ModelFile::HandLandmarkFull,
        include_str!("../int8/hand_landmark_full.txt"),
    ),
    (
        ModelFile::HandLandmarkLite,
        include_str!("../int8/hand_landmark_lite.txt"),
    ),
];

/// The networks a table is shipped for (the face detector runs in f32).
pub fn quantized_networks() -> impl Iterator<Item = ModelFile> {
    SHIPPED.iter().map(|(f, _)| *f)
}

/// One network's calibration: the range of the input of each of its 1x1 convolutions and
/// of its stem.
#[derive(Debug, Clone, PartialEq)]
pub struct Int8Table {
    /// SHA-256 (lower-case hex) of the `.tflite` file the ranges were measured on.
    pub network_sha256: String,
    /// What the ranges were measured on, in a few words.
    pub frames: String,
    /// Input range of each 1x1 convolution and of the stem, by node name in the imported
    /// graph.
    pub ranges: BTreeMap<String, MinMax>,
}

pub(crate) fn bad(why: impl Into<String>) -> VisionError {
    VisionError::Calibration(why.into())
}

impl Int8Table {
    /// The table as text: the header, the network's checksum, the frames, one line per
    /// layer (`name min max`, each bound as the hex of its f32 bits then as a decimal for
    /// the reader), and the checksum of those lines.
    pub fn to_text(&self) -> String {
        let mut body = format!(
            "{HEADER}\nnetwork {}\nframes {}\n",
            self.network_sha256, self.frames
        );
        for (name, r) in &self.ranges {
            body.push_str(&format!(
                "{name} {:08x} {:08x} # {} {}\n",
                r.min.to_bits(),
                r.max.to_bits(),
                r.min,
                r.max
            ));
        }
        let sum = sha256_hex(body.as_bytes());
        format!("{body}checksum {sum}\n")
    }

    /// Reads [`to_text`](Self::to_text)'s format; an error if the header, a line or the
    /// checksum is wrong.
    pub fn parse(text: &str) -> Result<Int8Table> {
        let (body, last) = text
            .trim_end_matches('\n')
            .rsplit_once('\n')
            .ok_or_else(|| bad("an int8 table of fewer than two lines"))?;
        let body = format!("{body}\n");
        let sum = last
            .strip_prefix("checksum ")
            .ok_or_else(|| bad("an int8 table without its checksum line"))?;
        if sha256_hex(body.as_bytes()) != sum {
            return Err(bad("an int8 table whose checksum does not match its lines"));
        }
        let mut lines = body.lines();
        if lines.next() != Some(HEADER) {
            return Err(bad(format!("an int8 table not starting with {HEADER:?}")));
        }
        let field = |line: Option<&str>, key: &str| -> Result<String> {
            line.and_then(|l| l.strip_prefix(key))
                .and_then(|l| l.strip_prefix(' '))
                .map(str::to_owned)
                .ok_or_else(|| bad(format!("an int8 table without its {key:?} line")))
        };
        let network_sha256 = field(lines.next(), "network")?;
        let frames = field(lines.next(), "frames")?;
        let mut ranges = BTreeMap::new();
        for line in lines {
            let data = line.split('#').next().unwrap_or("");
            let parts: Vec<&str> = data.split_whitespace().collect();
            let bits = |s: &str| u32::from_str_radix(s, 16).ok().map(f32::from_bits);
            match parts[..] {
                [name, lo, hi] => match (bits(lo), bits(hi)) {
                    (Some(min), Some(max)) if min.is_finite() && max.is_finite() && min <= max => {
                        ranges.insert(name.to_owned(), MinMax { min, max });
                    }
                    _ => return Err(bad(format!("int8 table line {line:?}: not a range"))),
                },
                _ => return Err(bad(format!("int8 table line {line:?}: not `name min max`"))),
            }
        }
        Ok(Int8Table {
            network_sha256,
            frames,
            ranges,
        })
    }

    /// The table shipped for the network whose `.tflite` bytes have SHA-256 `sha256`, if
    /// there is one.
    pub fn shipped_for(sha256: &str) -> Option<Result<Int8Table>> {
        let (_, text) = SHIPPED.iter().find(|(f, _)| f.sha256() == sha256)?;
        Some(Int8Table::parse(text).and_then(|t| {
            if t.network_sha256 == sha256 {
                Ok(t)
            } else {
                Err(bad("a shipped int8 table names another network"))
            }
        }))
    }
}

/// The network `bytes` (named `origin` in errors) imported, in `precision`: unchanged in
/// f32; in int8, every 1x1 convolution (and the stem) the shipped table has a range for
/// replaced by its int8 twin. Returns the graph (not yet optimised) and how many layers run in int8. An
/// error if int8 is asked of a network with no shipped table, or if none of its layers
/// could be replaced (a CPU without the fast 1x1 operator).
pub fn import(
    bytes: &[u8],
    origin: &Path,
    options: monohand_tflite::ImportOptions,
    precision: Precision,
) -> Result<(TypedModel, usize)> {
    let mut model =
        monohand_tflite::import_with(bytes, options).map_err(|source| VisionError::Import {
            path: origin.into(),
            source,
        })?;
    if precision == Precision::F32 {
        return Ok((model, 0));
    }
    let table = Int8Table::shipped_for(&sha256_hex(bytes)).ok_or_else(|| {
        bad(format!(
            "{}: no int8 calibration for this network (int8 runs the palm and landmark \
             networks of MediaPipe 0.10.14; use precision f32)",
            origin.display()
        ))
    })??;
    let ranges: HashMap<String, MinMax> = table.ranges.into_iter().collect();
    let replaced = monohand_tflite::quantize_pointwise(&mut model, &ranges, |_, _| false)?;
    if replaced == 0 {
        return Err(bad(format!(
            "{}: no layer could run in int8 on this CPU (the int8 layers replace the fast 1x1 \
             operator, which needs AVX2 + FMA or WebAssembly simd128); use precision f32",
            origin.display()
        )));
    }
    Ok((model, replaced))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Int8Table {
        let mut ranges = BTreeMap::new();
        ranges.insert(
            "conv_a".to_owned(),
            MinMax {
                min: -0.25,
                max: 6.0,
            },
        );
        ranges.insert(
            "conv_b".to_owned(),
            MinMax {
                min: 0.0,
                max: 1.0e-3,
            },
        );
        Int8Table {
            network_sha256: "ab".repeat(32),
            frames: "two test ranges".into(),
            ranges,
        }
    }

    #[test]
    fn a_table_reads_back_bit_for_bit() {
        let t = table();
        let text = t.to_text();
        assert!(text.starts_with(HEADER));
        assert_eq!(Int8Table::parse(&text).expect("parse"), t);
    }

    #[test]
    fn a_changed_line_fails_the_checksum() {
        let text = table().to_text().replace("conv_b", "conv_c");
        let e = Int8Table::parse(&text).expect_err("changed");
        assert!(e.to_string().contains("checksum"), "{e}");
        assert!(Int8Table::parse("").is_err());
        assert!(Int8Table::parse("checksum 00\n").is_err());
    }

    #[test]
    fn every_shipped_table_reads_and_names_its_network() {
        for (file, _) in SHIPPED {
            let t = Int8Table::shipped_for(file.sha256())
                .expect("shipped")
                .expect("valid");
            assert_eq!(t.network_sha256, file.sha256());
            assert!(t.ranges.len() >= 10, "{file:?}: {} layers", t.ranges.len());
        }
        assert!(Int8Table::shipped_for(ModelFile::FaceDetectionShortRange.sha256()).is_none());
    }
}
