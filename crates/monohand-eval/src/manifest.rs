//! The evaluation manifest: JSON Lines, one frame per line, that any dataset
//! can be converted to. Full description in `docs/evaluation.md`.
//!
//! ```text
//! {"sequence": "s1", "frame": 0, "images": ["img/0_l.png", "img/0_r.png"],
//!  "cameras": [{"fx": 822.8, "fy": 822.8, "cx": 318.5, "cy": 250.3, "width": 640, "height": 480},
//!              {"fx": 822.8, "fy": 822.8, "cx": 318.5, "cy": 250.3, "width": 640, "height": 480,
//!               "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [-120.054, 0, 0]}],
//!  "root": "wrist",
//!  "hands": [{"side": "left", "joints_3d": [[x, y, z], ... 21], "keypoints_2d": [[[u, v], ... 21], [[u, v, p], ... 21]]}]}
//! ```
//! (one line in the file). Required: `cameras` (at least one, each in the
//! project camera JSON of `docs/calibration.md`; the first is the reference,
//! the others carry `R`/`t`), `hands` (each with `side` and 21 `joints_3d` in
//! mm in the first camera's frame, OpenPose/MediaPipe order). Optional:
//! `sequence` (default ""), `frame` (default: the frame's position in its
//! sequence), `images` (paths relative to the manifest, one per camera),
//! `root` (`"wrist"`, the default, or `"palm_centre"`; the same on every
//! line), and per hand `keypoints_2d` (one list of 21 `[u, v]` or `[u, v, p]`
//! per camera). Unknown keys, wrong counts and non-finite numbers are errors
//! naming the line.

use crate::dataset::{Dataset, Frame, GtHand, RootJoint};
use crate::error::{EvalError, EvalResult};
use monohand_core::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct Line {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sequence: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    frame: Option<usize>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    images: Vec<String>,
    cameras: Vec<Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    root: Option<RootJoint>,
    hands: Vec<LineHand>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct LineHand {
    side: HandSide,
    joints_3d: Vec<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    keypoints_2d: Option<Vec<Vec<Vec<f64>>>>,
}

/// Reads a manifest file (see the module docs); image paths are resolved
/// against the manifest's folder.
pub fn read_manifest(path: impl AsRef<Path>) -> EvalResult<Dataset> {
    let path = path.as_ref();
    let file = std::fs::File::open(path).map_err(|error| {
        EvalError::Io(monohand_io::IoError::Read {
            path: path.to_path_buf(),
            error,
        })
    })?;
    let base = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut ds = parse_manifest(
        std::io::BufReader::new(file),
        &path.display().to_string(),
        &base,
    )?;
    ds.source = path.to_path_buf();
    ds.name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if ds.name == "manifest" {
        if let Some(p) = path.parent().and_then(|p| p.file_name()) {
            ds.name = p.to_string_lossy().into_owned();
        }
    }
    Ok(ds)
}

/// Parses manifest text; `file` names it in errors, `base` resolves image paths.
/// Blank lines are skipped; an empty manifest is an error.
pub fn parse_manifest(reader: impl BufRead, file: &str, base: &Path) -> EvalResult<Dataset> {
    let mut frames = Vec::new();
    let mut root: Option<(RootJoint, usize)> = None;
    let mut seq_count = std::collections::HashMap::<String, usize>::new();
    for (i, line) in reader.lines().enumerate() {
        let n = i + 1;
        let err = |message: String| EvalError::Manifest {
            file: file.to_string(),
            line: n,
            message,
        };
        let line = line.map_err(|e| err(format!("cannot read: {e}")))?;
        let text = line.trim();
        if text.is_empty() {
            continue;
        }
        let l: Line = serde_json::from_str(text).map_err(|e| err(e.to_string()))?;
        let r = l.root.unwrap_or(RootJoint::Wrist);
        match root {
            None => root = Some((r, n)),
            Some((r0, n0)) if r0 != r => {
                return Err(err(format!(
                "root {:?} differs from root {:?} of line {n0}: a manifest has one root convention",
                r.as_str(),
                r0.as_str()
            )))
            }
            _ => {}
        }
        let frame = parse_line(l, base, &mut seq_count).map_err(err)?;
        frames.push(frame);
    }
    let Some((root, _)) = root else {
        return Err(EvalError::Manifest {
            file: file.to_string(),
            line: 0,
            message: "no frames (empty manifest)".into(),
        });
    };
    Ok(Dataset {
        name: file.to_string(),
        source: PathBuf::from(file),
        root,
        frames,
        view_names: Vec::new(),
    })
}

fn parse_line(
    l: Line,
    base: &Path,
    seq_count: &mut std::collections::HashMap<String, usize>,
) -> Result<Frame, String> {
    let cameras = parse_cameras(&l.cameras)?;
    if !l.images.is_empty() && l.images.len() != cameras.len() {
        return Err(format!(
            "{} images for {} cameras: give one image per camera (or none)",
            l.images.len(),
            cameras.len()
        ));
    }
    if l.hands.is_empty() {
        return Err("\"hands\" is empty: every frame needs a labelled hand".into());
    }
    let hands = l
        .hands
        .into_iter()
        .enumerate()
        .map(|(h, hand)| parse_hand(h + 1, hand, cameras.len()))
        .collect::<Result<Vec<_>, _>>()?;
    let sequence = l.sequence.unwrap_or_default();
    let pos = seq_count.entry(sequence.clone()).or_insert(0);
    let index = l.frame.unwrap_or(*pos);
    *pos += 1;
    Ok(Frame {
        sequence,
        index,
        images: l.images.iter().map(|p| base.join(p)).collect(),
        cameras,
        hands,
        crop: None,
    })
}

/// The cameras of a line (the first is the reference frame: no extrinsics).
fn parse_cameras(values: &[Value]) -> Result<Vec<Camera>, String> {
    if values.is_empty() {
        return Err("\"cameras\" is empty: at least one camera is needed".into());
    }
    let mut cameras = Vec::with_capacity(values.len());
    for (c, v) in values.iter().enumerate() {
        if !v.is_object() {
            return Err(format!("camera {}: expected a JSON object", c + 1));
        }
        let cal = monohand_io::calibration::parse_calibration(&v.to_string(), "camera")
            .map_err(|e| format!("camera {}: {}", c + 1, strip_file(&e.to_string())))?;
        if c == 0 && !cal.camera.extrinsics.is_identity() {
            return Err("camera 1 is the reference frame and must have no R/t (extrinsics)".into());
        }
        cameras.push(cal.camera);
    }
    Ok(cameras)
}

/// Hand number `hn` (from 1) of a line with `n_cameras` cameras.
fn parse_hand(hn: usize, hand: LineHand, n_cameras: usize) -> Result<GtHand, String> {
    if hand.joints_3d.len() != NUM_JOINTS {
        return Err(format!(
            "hand {hn}: joints_3d has {} points, expected {NUM_JOINTS}",
            hand.joints_3d.len()
        ));
    }
    let mut joints = [[0.0; 3]; NUM_JOINTS];
    for (j, p) in hand.joints_3d.iter().enumerate() {
        if p.iter().any(|x| !x.is_finite()) {
            return Err(format!("hand {hn}: joints_3d[{j}] is not finite"));
        }
        joints[j] = *p;
    }
    let keypoints_2d = match hand.keypoints_2d {
        None => None,
        Some(views) => {
            if views.len() != n_cameras {
                return Err(format!(
                    "hand {hn}: keypoints_2d has {} views for {} cameras",
                    views.len(),
                    n_cameras
                ));
            }
            let views = views
                .iter()
                .enumerate()
                .map(|(v, pts)| parse_view_keypoints(hn, v + 1, pts))
                .collect::<Result<Vec<_>, _>>()?;
            Some(views)
        }
    };
    Ok(GtHand {
        side: hand.side,
        joints_3d: joints,
        keypoints_2d,
    })
}

/// The 2D keypoints of hand `hn` in view `vn` (both from 1): `[u, v]` or `[u, v, p]` each.
fn parse_view_keypoints(hn: usize, vn: usize, pts: &[Vec<f64>]) -> Result<Keypoints2d, String> {
    if pts.len() != NUM_JOINTS {
        return Err(format!(
            "hand {hn}: keypoints_2d view {vn}: {} points, expected {NUM_JOINTS}",
            pts.len()
        ));
    }
    let mut kp = [[0.0; 3]; NUM_JOINTS];
    for (j, p) in pts.iter().enumerate() {
        kp[j] = match p.as_slice() {
            [u, v] => [*u, *v, 1.0],
            [u, v, c] => [*u, *v, *c],
            _ => {
                return Err(format!(
                    "hand {hn}: keypoints_2d view {vn} point {j}: expected [u, v] or [u, v, p], got {} numbers",
                    p.len()
                ))
            }
        };
    }
    Keypoints2d::new(kp).map_err(|e| format!("hand {hn}: keypoints_2d view {vn}: {e}"))
}

/// Drops the "camera: " file prefix the io crate puts on calibration errors.
fn strip_file(msg: &str) -> &str {
    msg.strip_prefix("camera: ").unwrap_or(msg)
}

/// Writes a dataset as a manifest at `path`; image paths are written relative
/// to the manifest's folder where they lie under it, absolute otherwise.
pub fn write_manifest(path: impl AsRef<Path>, dataset: &Dataset) -> EvalResult<()> {
    let path = path.as_ref();
    let base = path.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for f in &dataset.frames {
        let line = Line {
            sequence: Some(f.sequence.clone()),
            frame: Some(f.index),
            images: f
                .images
                .iter()
                .map(|p| {
                    p.strip_prefix(base)
                        .unwrap_or(p)
                        .to_string_lossy()
                        .into_owned()
                })
                .collect(),
            cameras: f
                .cameras
                .iter()
                .map(monohand_io::calibration::camera_to_json)
                .collect(),
            root: Some(dataset.root),
            hands: f
                .hands
                .iter()
                .map(|h| LineHand {
                    side: h.side,
                    joints_3d: h.joints_3d.to_vec(),
                    keypoints_2d: h.keypoints_2d.as_ref().map(|views| {
                        views
                            .iter()
                            .map(|k| k.points.iter().map(|p| p.to_vec()).collect())
                            .collect()
                    }),
                })
                .collect(),
        };
        let text = serde_json::to_string(&line).map_err(|e| {
            EvalError::write(
                path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e),
            )
        })?;
        out.extend_from_slice(text.as_bytes());
        out.push(b'\n');
    }
    let mut file = std::fs::File::create(path).map_err(|e| EvalError::write(path, e))?;
    file.write_all(&out).map_err(|e| EvalError::write(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAM: &str =
        r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480}"#;

    fn joints() -> String {
        let pts: Vec<String> = (0..21)
            .map(|j| format!("[{}, {}, 500]", j, 2 * j))
            .collect();
        format!("[{}]", pts.join(", "))
    }

    fn line(extra: &str) -> String {
        format!(
            r#"{{"sequence": "s", "cameras": [{CAM}], "hands": [{{"side": "right", "joints_3d": {}}}]{extra}}}"#,
            joints()
        )
    }

    fn parse(text: &str) -> EvalResult<Dataset> {
        parse_manifest(text.as_bytes(), "m.jsonl", Path::new("/data"))
    }

    #[test]
    fn minimal_lines_parse() {
        let text = format!("{}\n\n{}\n", line(""), line(r#", "images": ["a.png"]"#));
        let ds = parse(&text).unwrap();
        assert_eq!(ds.frames.len(), 2);
        assert_eq!(ds.root, RootJoint::Wrist);
        assert_eq!(ds.frames[1].index, 1);
        assert_eq!(ds.frames[1].images, vec![PathBuf::from("/data/a.png")]);
        assert_eq!(ds.frames[0].hands[0].joints_3d[3], [3.0, 6.0, 500.0]);
        assert_eq!(ds.frames[0].hands[0].side, HandSide::Right);
    }

    #[test]
    fn malformed_lines_name_their_line() {
        let cases = [
            (line(r#", "extra": 1"#), "unknown field"),
            (
                line(r#", "images": ["a.png", "b.png"]"#),
                "2 images for 1 cameras",
            ),
            (line(r#", "root": "elbow""#), "unknown variant"),
            (
                line("").replace("[0, 0, 500], ", ""),
                "joints_3d has 20 points",
            ),
            (line(r#", "frame": -1"#), "invalid value"),
            (line("").replace("\"fx\": 800", "\"fx\": -800"), "camera 1"),
            (
                line("").replace(&format!("[{CAM}]"), "[]"),
                "at least one camera",
            ),
            ("{not json".to_string(), "key must be a string"),
        ];
        for (bad, want) in cases {
            let text = format!("{}\n{}\n", line(""), bad);
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.starts_with("m.jsonl: line 2: "), "{e}");
            assert!(e.contains(want), "{e} should say {want}");
        }
        let e = parse("").unwrap_err().to_string();
        assert!(e.contains("no frames"), "{e}");
        let e = parse(&format!(
            "{}\n{}\n",
            line(""),
            line(r#", "root": "palm_centre""#)
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 2") && e.contains("line 1"), "{e}");
    }

    #[test]
    fn keypoints_2d_are_checked() {
        let kp: Vec<String> = (0..21).map(|j| format!("[{j}, 1]")).collect();
        let good = line("").replace(
            r#""side": "right","#,
            &format!(r#""side": "right", "keypoints_2d": [[{}]],"#, kp.join(", ")),
        );
        let ds = parse(&good).unwrap();
        let k = ds.frames[0].hands[0].keypoints_2d.as_ref().unwrap();
        assert_eq!(k[0].points[5], [5.0, 1.0, 1.0]);
        let bad = good.replace("[3, 1]", "[3, 1, 2]");
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("confidence"), "{e}");
        let bad = good.replace("[[[0, 1]", "[[[0]");
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.contains("expected [u, v] or [u, v, p]"), "{e}");
    }

    #[test]
    fn write_then_read_is_identity() {
        let dir = tempfile::tempdir().unwrap();
        let kp: Vec<String> = (0..21).map(|j| format!("[{j}, 1, 0.5]")).collect();
        let text = format!(
            "{}\n",
            line(r#", "images": ["x/a.png"], "root": "palm_centre""#).replace(
                r#""side": "right","#,
                &format!(r#""side": "right", "keypoints_2d": [[{}]],"#, kp.join(", ")),
            )
        );
        let ds = parse_manifest(text.as_bytes(), "m", dir.path()).unwrap();
        let p = dir.path().join("out.jsonl");
        write_manifest(&p, &ds).unwrap();
        let back = read_manifest(&p).unwrap();
        assert_eq!(back.frames, ds.frames);
        assert_eq!(back.root, RootJoint::PalmCentre);
        let written = std::fs::read_to_string(&p).unwrap();
        assert!(written.contains("\"x/a.png\""), "{written}");
    }
}
