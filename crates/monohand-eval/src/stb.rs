//! The Stereo Hand Pose Tracking Benchmark (STB, Zhang et al. 2016): 3D labels
//! and the Bumblebee stereo camera.
//!
//! # Joint order and the missing wrist
//!
//! STB labels 21 points per frame, in millimetres in the **left** camera frame,
//! in its own order: 0 palm centre, 1-4 little MCP..tip, 5-8 ring, 9-12
//! middle, 13-16 index, 17-20 thumb (base..tip). [`StbSequence::load`]
//! reorders them into monohand's order
//! ([`monohand_core::hand_model::JOINT_NAMES`]); the thumb base maps to our
//! thumb CMC (index 1).
//!
//! **STB has no wrist.** Index 0 of [`StbFrame::joints`] holds the STB
//! **palm centre**, which lies roughly 40 mm from the wrist towards the
//! middle-finger knuckle. Do not compare it with a fitted wrist, and do not
//! feed it to a fitter as a wrist observation: evaluate on indices 1..21, or
//! compare palm centres computed the same way on both sides.
//!
//! ```no_run
//! use monohand_eval::stb::{stb_cameras, StbSequence};
//! let seq = StbSequence::load("../shared/data/stb_b1counting/labels/B1Counting_BB.mat")?;
//! let (left, right) = stb_cameras("../shared/data/stb_b1counting/camera_params.json")?;
//! let tip = seq.frames[0].joints[8]; // index fingertip, mm, left camera frame
//! let px_left = left.project(&tip);
//! let px_right = right.project(&tip);
//! # Ok::<(), monohand_io::IoError>(())
//! ```

use crate::mat::MatFile;
use monohand_core::prelude::*;
use monohand_io::error::{name_of, read_text};
use monohand_io::{IoError, IoResult};
use nalgebra::{Rotation3, Vector3};
use std::path::Path;

/// Index in our joint array that holds the STB palm centre (in place of the wrist).
pub const PALM_CENTRE: usize = 0;

/// Width of the STB Bumblebee images, pixels.
pub const STB_IMAGE_WIDTH: u32 = 640;
/// Height of the STB Bumblebee images, pixels.
pub const STB_IMAGE_HEIGHT: u32 = 480;

/// For each of our 21 joints, the STB label index it comes from.
///
/// Ours: 0 wrist (here: STB palm centre), 1-4 thumb, 5-8 index, 9-12 middle,
/// 13-16 ring, 17-20 little. STB: 0 palm, 1-4 little, 5-8 ring, 9-12 middle,
/// 13-16 index, 17-20 thumb; each finger base to tip in both.
pub const STB_INDEX_FOR_OURS: [usize; NUM_JOINTS] = [
    0, // palm centre (no wrist in STB)
    17, 18, 19, 20, // thumb
    13, 14, 15, 16, // index
    9, 10, 11, 12, // middle
    5, 6, 7, 8, // ring
    1, 2, 3, 4, // little
];

/// The name of the STB label variable.
pub const STB_VARIABLE: &str = "handPara";

/// One labelled frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StbFrame {
    /// The 21 joints in **our** order, mm, left camera frame; index 0 is the
    /// STB **palm centre**, not a wrist (see the module docs).
    pub joints: [Vector3<f64>; NUM_JOINTS],
}

impl StbFrame {
    /// The 20 bone lengths in [`monohand_core::hand_model::BONES`] order, mm.
    /// The first bone of each finger starts at the palm centre (not a wrist).
    pub fn bone_lengths(&self) -> [f64; 20] {
        std::array::from_fn(|i| {
            let (a, b) = monohand_core::hand_model::BONES[i];
            (self.joints[b] - self.joints[a]).norm()
        })
    }
}

/// A labelled STB sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct StbSequence {
    /// The frames in file order.
    pub frames: Vec<StbFrame>,
}

impl StbSequence {
    /// Reads the labels of one sequence (`labels/<Seq>_BB.mat` or `_SK.mat`):
    /// variable `handPara` of shape `[3, 21, N]`.
    pub fn load(labels_mat_path: impl AsRef<Path>) -> IoResult<StbSequence> {
        let path = labels_mat_path.as_ref();
        let mat = MatFile::open(path)?;
        Self::from_mat(&mat, &name_of(path))
    }

    /// Extracts the labels from an already-read `.mat` file; `file` names it in errors.
    pub fn from_mat(mat: &MatFile, file: &str) -> IoResult<StbSequence> {
        let a = mat.get(STB_VARIABLE).ok_or_else(|| {
            IoError::field(
                file,
                STB_VARIABLE,
                "variable not found (is this an STB label file?)",
            )
        })?;
        let d = &a.dims;
        let frames = match d.as_slice() {
            [3, 21] => 1,
            [3, 21, n] => *n,
            _ => {
                return Err(IoError::field(
                    file,
                    STB_VARIABLE,
                    format!("expected dimensions [3, 21, N], got {d:?}"),
                ))
            }
        };
        let mut out = Vec::with_capacity(frames);
        for f in 0..frames {
            let base = 63 * f;
            let mut joints = [Vector3::zeros(); NUM_JOINTS];
            for (ours, &stb) in STB_INDEX_FOR_OURS.iter().enumerate() {
                let o = base + 3 * stb;
                let v = Vector3::new(a.data[o], a.data[o + 1], a.data[o + 2]);
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(IoError::field(
                        file,
                        format!("{STB_VARIABLE}(:, {}, {})", stb + 1, f + 1),
                        "value is not finite",
                    ));
                }
                joints[ours] = v;
            }
            out.push(StbFrame { joints });
        }
        Ok(StbSequence { frames: out })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True if there are no frames.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}

fn number(v: &serde_json::Value, file: &str, field: &str) -> IoResult<f64> {
    let x = v
        .get(field.rsplit('.').next().unwrap_or(field))
        .ok_or_else(|| IoError::field(file, field, "missing"))?
        .as_f64()
        .ok_or_else(|| IoError::field(file, field, "not a number"))?;
    if !x.is_finite() {
        return Err(IoError::field(file, field, "not finite"));
    }
    Ok(x)
}

/// The STB Bumblebee stereo pair from a `camera_params.json` (key `BB2Stereo`:
/// `fx`, `fy`, `tx` = cx, `ty` = cy, `baseline` in mm), 640x480, no distortion.
///
/// The left camera is the reference frame; the right camera is the left one
/// translated by `+baseline` along x, i.e. its extrinsics translation is
/// `(-baseline, 0, 0)` (`X_right = X_left - (baseline, 0, 0)`).
pub fn stb_cameras(camera_params_json: impl AsRef<Path>) -> IoResult<(Camera, Camera)> {
    let path = camera_params_json.as_ref();
    let file = name_of(path);
    let text = read_text(path)?;
    stb_cameras_from_str(&text, &file)
}

/// [`stb_cameras`] on the JSON text; `file` names it in errors.
pub fn stb_cameras_from_str(text: &str, file: &str) -> IoResult<(Camera, Camera)> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| IoError::json(file, &e))?;
    let bb = v
        .get("BB2Stereo")
        .ok_or_else(|| IoError::field(file, "BB2Stereo", "missing"))?;
    let fx = number(bb, file, "BB2Stereo.fx")?;
    let fy = number(bb, file, "BB2Stereo.fy")?;
    let cx = number(bb, file, "BB2Stereo.tx")?;
    let cy = number(bb, file, "BB2Stereo.ty")?;
    let baseline = number(bb, file, "BB2Stereo.baseline")?;
    let left = Camera::pinhole(fx, fy, cx, cy, STB_IMAGE_WIDTH, STB_IMAGE_HEIGHT)
        .map_err(|e| IoError::core(file, e))?;
    let right = left.with_extrinsics(Extrinsics {
        rotation: Rotation3::identity(),
        translation: Vector3::new(-baseline, 0.0, 0.0),
    });
    Ok((left, right))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mat::{to_bytes, MatArray};
    use std::path::PathBuf;

    fn shared(rel: &str) -> Option<PathBuf> {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data/stb_b1counting")
            .join(rel);
        if p.exists() {
            Some(p)
        } else {
            panic!(
                "STB test data not found at {} (the shared data directory is absent)",
                p.display()
            )
        }
    }

    #[test]
    fn mapping_is_a_permutation() {
        let mut seen = [false; NUM_JOINTS];
        for &s in &STB_INDEX_FOR_OURS {
            assert!(!seen[s]);
            seen[s] = true;
        }
    }

    #[test]
    fn real_labels_load_and_reorder() {
        let Some(path) = shared("labels/B1Counting_BB.mat") else {
            return;
        };
        let seq = StbSequence::load(&path).unwrap();
        assert_eq!(seq.len(), 1500);
        let f0 = &seq.frames[0];
        let palm = f0.joints[PALM_CENTRE];
        assert!(
            (palm - Vector3::new(126.50, 56.84, 664.35)).norm() < 0.02,
            "{palm}"
        );
        // Fixed skeleton: the same bone lengths in every frame.
        let b0 = f0.bone_lengths();
        // index MCP-PIP and palm-centre-to-middle-MCP.
        assert!((b0[5] - 34.0).abs() < 0.05, "index MCP-PIP {}", b0[5]);
        assert!((b0[8] - 39.05).abs() < 0.05, "palm-middle MCP {}", b0[8]);
        for f in &seq.frames {
            let b = f.bone_lengths();
            for i in 0..20 {
                assert!(
                    (b[i] - b0[i]).abs() < 0.5,
                    "bone {i}: {} vs {}",
                    b[i],
                    b0[i]
                );
            }
        }
        // Our order: bases are the joints nearest the palm centre in each finger,
        // fingertips the farthest; the thumb is the finger farthest from the little finger.
        for finger in Finger::ALL {
            let j = finger.joints();
            let d: Vec<f64> = j.iter().map(|&k| (f0.joints[k] - palm).norm()).collect();
            assert!(d[0] < d[3], "{finger:?}: base {} tip {}", d[0], d[3]);
        }
        let little_mcp = f0.joints[17];
        let gap = |k: usize| (f0.joints[k] - little_mcp).norm();
        assert!(
            gap(5) > gap(9) && gap(9) > gap(13),
            "MCP order across the hand"
        );
        // All labels in front of the camera and inside the image.
        let (left, right) = shared("camera_params.json")
            .map(|p| stb_cameras(p).unwrap())
            .unwrap();
        for x in &f0.joints {
            for cam in [&left, &right] {
                let px = cam.project(x).unwrap();
                assert!((0.0..640.0).contains(&px.x) && (0.0..480.0).contains(&px.y));
            }
        }
    }

    #[test]
    fn cameras_from_real_file() {
        let Some(path) = shared("camera_params.json") else {
            return;
        };
        let (l, r) = stb_cameras(&path).unwrap();
        assert_eq!(l.intrinsics.fx, 822.79041);
        assert_eq!(l.intrinsics.cx, 318.47345);
        assert_eq!(l.intrinsics.cy, 250.31296);
        assert_eq!((l.intrinsics.width, l.intrinsics.height), (640, 480));
        assert!((r.centre() - Vector3::new(120.054, 0.0, 0.0)).norm() < 1e-12);
        // Disparity fx * b / z.
        let x = Vector3::new(0.0, 0.0, 600.0);
        let disp = l.project(&x).unwrap().x - r.project(&x).unwrap().x;
        assert!((disp - 822.79041 * 120.054 / 600.0).abs() < 1e-9);
    }

    #[test]
    fn bad_inputs_name_file_and_field() {
        let e = stb_cameras_from_str(
            r#"{"BB2Stereo": {"fx": 1, "fy": 1, "tx": 0, "ty": 0}}"#,
            "c.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("c.json") && e.contains("baseline"), "{e}");
        let e = stb_cameras_from_str(
            r#"{"BB2Stereo": {"fx": -5, "fy": 1, "tx": 0, "ty": 0, "baseline": 1}}"#,
            "c.json",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("c.json") && e.contains("focal"), "{e}");
        assert!(stb_cameras_from_str("{", "c.json").is_err());
        let m = MatFile::from_bytes(
            &to_bytes(&[MatArray::new("handPara", vec![3, 20], vec![0.0; 60]).unwrap()]),
            "x.mat",
        )
        .unwrap();
        let e = StbSequence::from_mat(&m, "x.mat").unwrap_err().to_string();
        assert!(e.contains("x.mat") && e.contains("handPara"), "{e}");
        let m = MatFile::from_bytes(
            &to_bytes(&[MatArray::new("other", vec![3, 21], vec![0.0; 63]).unwrap()]),
            "y.mat",
        )
        .unwrap();
        assert!(StbSequence::from_mat(&m, "y.mat").is_err());
    }
}
