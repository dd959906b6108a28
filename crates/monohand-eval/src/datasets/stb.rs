//! The Stereo Hand Pose Benchmark (STB, Zhang et al. 2016) read natively.
//!
//! A folder is STB if it has `labels/*_BB.mat` (the Bumblebee stereo labels;
//! the `_SK.mat` RealSense labels are not used). Every such sequence is read,
//! in name order. Images are looked for in `images/SEQUENCE/` (the layout of
//! `shared/data/stb_b1counting`) or `SEQUENCE/` beside `labels/` (the official
//! release), as `BB_left_N.png` and `BB_right_N.png`; label-only folders are
//! fine for `--stage lift`. The cameras come from `camera_params.json` in the
//! folder if present, else from the published Bumblebee calibration.
//!
//! Conventions (see `docs/evaluation.md`): joints are reordered by
//! [`crate::stb`] into the OpenPose order with the **palm centre** at
//! index 0 ([`RootJoint::PalmCentre`]); all 21 points (palm centre + 20 finger
//! joints) are evaluated, as published STB numbers are; every sequence shows
//! the subject's **left** hand; the right camera sits `baseline` mm to the
//! right of the left one, which is the reference frame.

use crate::dataset::{Dataset, Frame, GtHand, RootJoint};
use crate::error::{EvalError, EvalResult};
use crate::metrics::to_joints;
use crate::stb::{stb_cameras, stb_cameras_from_str, StbSequence};
use monohand_core::prelude::*;
use std::path::{Path, PathBuf};

/// The published Bumblebee calibration, used when the folder has no `camera_params.json`.
pub const STB_DEFAULT_CAMERA_PARAMS: &str = r#"{"BB2Stereo": {"fx": 822.79041, "fy": 822.79041, "tx": 318.47345, "ty": 250.31296, "baseline": 120.054}}"#;

/// The hand shown in every STB sequence.
pub const STB_SIDE: HandSide = HandSide::Left;

/// The `*_BB.mat` label files of an STB folder, sorted by name.
pub fn label_files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir.join("labels"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.ends_with("_BB.mat"))
        })
        .collect();
    out.sort();
    out
}

/// True if `dir` looks like an STB folder (has `labels/*_BB.mat`).
pub fn is_stb_folder(dir: &Path) -> bool {
    !label_files(dir).is_empty()
}

/// The image folder of a sequence, in either layout, if it exists.
pub fn image_dir(dir: &Path, sequence: &str) -> Option<PathBuf> {
    [dir.join("images").join(sequence), dir.join(sequence)]
        .into_iter()
        .find(|d| d.is_dir())
}

/// Reads every sequence of an STB folder (see the module docs).
pub fn load_stb(dir: impl AsRef<Path>) -> EvalResult<Dataset> {
    let dir = dir.as_ref();
    let files = label_files(dir);
    if files.is_empty() {
        return Err(EvalError::dataset(
            dir,
            "no STB labels: expected labels/*_BB.mat",
        ));
    }
    let params = dir.join("camera_params.json");
    let (left, right) = if params.is_file() {
        stb_cameras(&params)?
    } else {
        stb_cameras_from_str(STB_DEFAULT_CAMERA_PARAMS, "built-in STB calibration")?
    };
    let mut frames = Vec::new();
    for f in &files {
        let name = f
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .trim_end_matches("_BB.mat")
            .to_string();
        let seq = StbSequence::load(f)?;
        let images = image_dir(dir, &name);
        for (i, fr) in seq.frames.iter().enumerate() {
            frames.push(Frame {
                sequence: name.clone(),
                index: i,
                images: images
                    .as_ref()
                    .map(|d| {
                        vec![
                            d.join(format!("BB_left_{i}.png")),
                            d.join(format!("BB_right_{i}.png")),
                        ]
                    })
                    .unwrap_or_default(),
                cameras: vec![left, right],
                hands: vec![GtHand {
                    side: STB_SIDE,
                    joints_3d: to_joints(&fr.joints),
                    keypoints_2d: None,
                }],
                crop: None,
            });
        }
    }
    Ok(Dataset {
        name: dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "STB".into()),
        source: dir.to_path_buf(),
        root: RootJoint::PalmCentre,
        frames,
        view_names: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mat::{to_bytes, MatArray};

    fn fake_labels(n: usize) -> Vec<u8> {
        // 21 points per frame, STB order, all distinct and finite.
        let data: Vec<f64> = (0..63 * n).map(|i| 100.0 + i as f64).collect();
        to_bytes(&[MatArray::new("handPara", vec![3, 21, n], data).unwrap()])
    }

    #[test]
    fn both_layouts_and_every_sequence() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(d.path().join("labels")).unwrap();
        std::fs::write(d.path().join("labels/B2Random_BB.mat"), fake_labels(3)).unwrap();
        std::fs::write(d.path().join("labels/B1Counting_BB.mat"), fake_labels(2)).unwrap();
        std::fs::write(d.path().join("labels/B1Counting_SK.mat"), fake_labels(4)).unwrap();
        // Official layout for one, shared-data layout for the other.
        std::fs::create_dir_all(d.path().join("B2Random")).unwrap();
        std::fs::create_dir_all(d.path().join("images/B1Counting")).unwrap();
        let ds = Dataset::load(d.path()).unwrap();
        assert_eq!(ds.root, RootJoint::PalmCentre);
        assert_eq!(ds.sequences(), vec!["B1Counting", "B2Random"]);
        assert_eq!(ds.frames.len(), 5);
        assert_eq!(
            ds.frames[1].images[1],
            d.path().join("images/B1Counting/BB_right_1.png")
        );
        assert_eq!(
            ds.frames[4].images[0],
            d.path().join("B2Random/BB_left_2.png")
        );
        // Built-in calibration: 120.054 mm baseline.
        let c = ds.frames[0].cameras[1].centre();
        assert!((c.x - 120.054).abs() < 1e-9);
        // Joint 0 is the STB palm centre (first label point).
        assert_eq!(ds.frames[0].hands[0].joints_3d[0], [100.0, 101.0, 102.0]);
    }

    #[test]
    fn empty_folder_is_not_stb() {
        let d = tempfile::tempdir().unwrap();
        let e = Dataset::load(d.path()).unwrap_err().to_string();
        assert!(e.contains("not a dataset"), "{e}");
        assert!(load_stb(d.path()).is_err());
    }
}
