//! A calibrated multi-camera rig read natively, in the layout of `shared/data/table_rig_dev`
//! (a DexYCB-style capture: a hand grasping on a table, seen by RealSense cameras):
//!
//! - `cameras/<name>.json`: monohand camera JSON per view; the master camera has no `R`/`t`,
//!   the others map the master's frame into theirs (`X_cam = R X_master + t`);
//! - `images/<name>/color_NNNNNN.jpg`: the frames of each view, the same instants in every
//!   view;
//! - `labels_2d/<name>.json`: `{"frames": [[[u, v] | null; 21] | null, ...]}`, the manual 2D
//!   labels of each view (MediaPipe order), frame by frame;
//! - `reference_3d_mm.json`: `{"frames": [[[x, y, z] | null; 21], ...]}`, the 3D reference in
//!   the master camera's frame (mm), triangulated from the labels.
//!
//! One sequence (`table_rig`), one **right** hand, root = wrist. The frames are those with a
//! 3D reference (the first ones), each with every view's image and camera, the master first
//! and the others by name ([`Dataset::view_names`]). A joint the reference lacks is NaN: the
//! metrics leave it out ([`crate::metrics::labelled`]). A view's 2D labels are its
//! keypoints, confidence 1 where labelled and 0 elsewhere; [`Dataset::view`] turns the set
//! into one view's own (the frames in which it sees the hand's palm) for a mono evaluation.

use crate::dataset::{Dataset, Frame, GtHand, RootJoint};
use crate::error::{EvalError, EvalResult};
use monohand_core::prelude::*;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The sequence name every frame gets.
pub const SEQUENCE: &str = "table_rig";

/// The hand shown in the set.
pub const SIDE: HandSide = HandSide::Right;

/// The 3D reference file.
const REFERENCE: &str = "reference_3d_mm.json";

/// A file of per-frame points: `frames[f][j]`, a point or null, a frame or null.
#[derive(Deserialize)]
struct PerFrame {
    frames: Vec<Option<Vec<Option<Vec<f64>>>>>,
}

/// True if `dir` has this layout (a 3D reference, cameras, images and 2D labels).
pub fn is_table_rig_folder(dir: &Path) -> bool {
    ["cameras", "images", "labels_2d"]
        .iter()
        .all(|d| dir.join(d).is_dir())
        && dir.join(REFERENCE).is_file()
}

/// Reads a per-frame file of `D`-dimensional points.
fn read_points<const D: usize>(path: &Path) -> EvalResult<Vec<[Option<[f64; D]>; NUM_JOINTS]>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| EvalError::dataset(path, format!("cannot read: {e}")))?;
    let file: PerFrame = serde_json::from_str(&text)
        .map_err(|e| EvalError::dataset(path, format!("not per-frame points: {e}")))?;
    let bad = |f: usize, why: String| EvalError::dataset(path, format!("frame {f}: {why}"));
    file.frames
        .into_iter()
        .enumerate()
        .map(|(f, frame)| {
            let mut out = [None; NUM_JOINTS];
            let Some(joints) = frame else {
                return Ok(out);
            };
            if joints.len() != NUM_JOINTS {
                return Err(bad(f, format!("{} points, not {NUM_JOINTS}", joints.len())));
            }
            for (o, p) in out.iter_mut().zip(joints) {
                let Some(p) = p else { continue };
                let point: [f64; D] = p.try_into().map_err(|p: Vec<f64>| {
                    bad(f, format!("a point of {} numbers, not {D}", p.len()))
                })?;
                if point.iter().any(|x| !x.is_finite()) {
                    return Err(bad(f, "a point that is not finite".into()));
                }
                *o = Some(point);
            }
            Ok(out)
        })
        .collect()
}

/// The views: each camera's name and camera, the master (no extrinsics) first, then by name.
fn read_cameras(dir: &Path) -> EvalResult<Vec<(String, Camera)>> {
    let folder = dir.join("cameras");
    let entries = std::fs::read_dir(&folder)
        .map_err(|e| EvalError::dataset(&folder, format!("cannot list: {e}")))?;
    let mut cameras = Vec::new();
    for entry in entries {
        let path = entry
            .map_err(|e| EvalError::dataset(&folder, format!("cannot list: {e}")))?
            .path();
        if path.extension().and_then(|e| e.to_str()) != Some("json") {
            continue;
        }
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let camera = monohand_io::calibration::read_camera(&path)
            .map_err(|e| EvalError::dataset(&path, e.to_string()))?;
        cameras.push((name, camera));
    }
    cameras.sort_by(|a, b| {
        (!a.1.extrinsics.is_identity(), &a.0).cmp(&(!b.1.extrinsics.is_identity(), &b.0))
    });
    match cameras.first() {
        None => Err(EvalError::dataset(&folder, "no camera file (*.json)")),
        Some((name, c)) if !c.extrinsics.is_identity() => Err(EvalError::dataset(
            &folder,
            format!("no master camera: every camera has extrinsics ({name} among them)"),
        )),
        Some(_) => Ok(cameras),
    }
}

/// Reads the folder (see the module docs).
pub fn load_table_rig(dir: impl AsRef<Path>) -> EvalResult<Dataset> {
    let dir = dir.as_ref();
    let reference = read_points::<3>(&dir.join(REFERENCE))?;
    let cameras = read_cameras(dir)?;
    let mut labels = Vec::with_capacity(cameras.len());
    for (name, _) in &cameras {
        let path = dir.join("labels_2d").join(format!("{name}.json"));
        let views = read_points::<2>(&path)?;
        if views.len() < reference.len() {
            return Err(EvalError::dataset(
                &path,
                format!(
                    "labels for {} frames, the 3D reference has {}",
                    views.len(),
                    reference.len()
                ),
            ));
        }
        labels.push(views);
    }
    let image = |name: &str, f: usize| -> PathBuf {
        dir.join("images")
            .join(name)
            .join(format!("color_{f:06}.jpg"))
    };
    let frames = reference
        .iter()
        .enumerate()
        .map(|(f, joints)| {
            let keypoints = labels
                .iter()
                .map(|view| Keypoints2d {
                    points: view[f].map(|p| p.map_or([0.0; 3], |[u, v]| [u, v, 1.0])),
                })
                .collect();
            let images: Vec<PathBuf> = cameras.iter().map(|(n, _)| image(n, f)).collect();
            Frame {
                sequence: SEQUENCE.to_string(),
                index: f,
                images: if images.iter().all(|p| p.is_file()) {
                    images
                } else {
                    Vec::new()
                },
                cameras: cameras.iter().map(|(_, c)| *c).collect(),
                hands: vec![GtHand {
                    side: SIDE,
                    joints_3d: joints.map(|p| p.unwrap_or([f64::NAN; 3])),
                    keypoints_2d: Some(keypoints),
                }],
                crop: None,
            }
        })
        .collect::<Vec<_>>();
    if frames.is_empty() {
        return Err(EvalError::dataset(dir.join(REFERENCE), "no frames"));
    }
    Ok(Dataset {
        name: super::folder_name(dir, SEQUENCE),
        source: dir.to_path_buf(),
        root: RootJoint::Wrist,
        frames,
        view_names: cameras.into_iter().map(|(n, _)| n).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rig of two cameras, the second turned, with two frames: in the second frame the
    /// second view labels two fingertips only, and the 3D reference lacks one joint.
    fn write_rig(dir: &Path) {
        for d in ["cameras", "images/a", "images/b", "labels_2d"] {
            std::fs::create_dir_all(dir.join(d)).expect("mkdir");
        }
        std::fs::write(
            dir.join("cameras/b.json"),
            r#"{"fx": 600, "fy": 600, "cx": 320, "cy": 240, "width": 640, "height": 480,
                "R": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], "t": [0, 0, 500]}"#,
        )
        .expect("write");
        std::fs::write(
            dir.join("cameras/z.json"),
            r#"{"fx": 610, "fy": 610, "cx": 320, "cy": 240, "width": 640, "height": 480}"#,
        )
        .expect("write");
        let point = |p: &str| format!("[{}]", vec![p; NUM_JOINTS].join(","));
        let mut missing = vec!["[10, 20, 400]"; NUM_JOINTS];
        missing[3] = "null";
        std::fs::write(
            dir.join(REFERENCE),
            format!(
                r#"{{"frames": [{}, [{}]]}}"#,
                point("[10, 20, 400]"),
                missing.join(",")
            ),
        )
        .expect("write");
        let two = format!(
            r#"{{"frames": [{}, {}]}}"#,
            point("[1, 2]"),
            point("[3, 4]")
        );
        std::fs::write(dir.join("labels_2d/z.json"), &two).expect("write");
        // View b: every joint in frame 0, the fingers alone (no palm joint) in frame 1.
        let mut fingers = vec!["null"; NUM_JOINTS];
        fingers[8] = "[7, 8]";
        fingers[12] = "[9, 10]";
        let one = format!(
            r#"{{"frames": [{}, [{}]]}}"#,
            point("[5, 6]"),
            fingers.join(",")
        );
        std::fs::write(dir.join("labels_2d/b.json"), one).expect("write");
    }

    #[test]
    fn reads_the_master_first_missing_joints_as_nan_and_each_view_alone() {
        let dir = tempfile::tempdir().expect("tempdir");
        write_rig(dir.path());
        assert!(is_table_rig_folder(dir.path()));
        let d = load_table_rig(dir.path()).expect("load");
        assert_eq!(d.view_names, ["z", "b"], "the master (no extrinsics) first");
        assert_eq!(d.frames.len(), 2);
        assert!(d.frames[0].images.is_empty(), "no image on disk");
        assert!(d.frames[0].cameras[0].extrinsics.is_identity());
        let h = &d.frames[1].hands[0];
        assert_eq!(h.side, HandSide::Right);
        assert!(h.joints_3d[3][0].is_nan() && h.joints_3d[4] == [10.0, 20.0, 400.0]);
        let kp = h.keypoints_2d.as_ref().expect("2D labels");
        assert_eq!(kp[0].points[0], [3.0, 4.0, 1.0]);
        assert_eq!(kp[1].points[0], [0.0, 0.0, 0.0], "no wrist label in view b");
        assert_eq!(kp[1].points[8], [7.0, 8.0, 1.0]);
        // View b alone: its camera (with its extrinsics), and only the frame it labels.
        let b = d.view(1).expect("view 1");
        assert_eq!(b.view_names, ["b"]);
        assert_eq!(b.frames.len(), 2, "every frame stays, for tracking");
        assert_eq!(b.frames[0].hands.len(), 1);
        assert!(b.frames[1].hands.is_empty(), "b sees no palm in frame 1");
        assert_eq!(b.frames[0].cameras, vec![d.frames[0].cameras[1]]);
        assert_eq!(b.frames[0].gt_keypoints(0, 0).points[0], [5.0, 6.0, 1.0]);
        assert!(d.view(2).is_err());
    }

    #[test]
    fn a_rig_without_a_master_or_with_short_labels_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        write_rig(dir.path());
        std::fs::write(dir.path().join("labels_2d/z.json"), r#"{"frames": [null]}"#)
            .expect("write");
        let e = load_table_rig(dir.path()).expect_err("short labels");
        assert!(e.to_string().contains("labels for 1 frames"), "{e}");
        std::fs::remove_file(dir.path().join("cameras/z.json")).expect("rm");
        let e = load_table_rig(dir.path()).expect_err("no master");
        assert!(e.to_string().contains("no master camera"), "{e}");
    }
}
