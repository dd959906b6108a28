//! The real-world test set of hand-graph-cnn (Ge et al. 2019) read natively, in the layout
//! of `shared/data/hand_graph_cnn_dev`: a folder with `labels.json` and `images/NNNNN.jpg`.
//!
//! `labels.json` holds the original 1280x720 camera (`camera`: `fx, fy, cx, cy, width,
//! height`) and per frame the image path, the crop box `crop_box_xywh` in original pixels
//! and `joints_3d_mm` (21 x `[x, y, z]`, mm, camera frame, OpenPose/MediaPipe order). Each
//! image is a square crop of the original frame resized to its own size, so each frame
//! gets **its own camera**: the original intrinsics scaled by `s = image_side / w` and
//! shifted by the box, `fx' = fx s, cx' = (cx - x) s` (same optical centre and axes, so the
//! 3D labels stay in that camera's frame, and tracking across frames is unaffected).
//!
//! One sequence (`hand_graph_cnn`), one **left** hand per frame, root = wrist. The labels'
//! joints follow their own convention (the wrist sits closer to the knuckles than
//! MediaPipe's wrist point), so wrist-relative errors carry a convention offset that
//! centroid-aligned and Procrustes-aligned errors mostly do not (`docs/evaluation.md`).

use crate::dataset::{CropOrigin, Dataset, Frame, GtHand, RootJoint};
use crate::error::{EvalError, EvalResult};
use monohand_core::prelude::*;
use serde::Deserialize;
use std::path::Path;

/// The sequence name every frame gets.
pub const SEQUENCE: &str = "hand_graph_cnn";

/// The hand shown in the set.
pub const SIDE: HandSide = HandSide::Left;

#[derive(Deserialize)]
struct Labels {
    /// The original 1280x720 camera (`fx, fy, cx, cy, width, height`).
    camera: Intrinsics,
    frames: Vec<LabelFrame>,
}

#[derive(Deserialize)]
struct LabelFrame {
    frame: usize,
    image: String,
    crop_box_xywh: [f64; 4],
    joints_3d_mm: [[f64; 3]; NUM_JOINTS],
}

/// True if `dir` has a `labels.json` in this layout (a `camera` and `frames` with crop boxes).
pub fn is_hand_graph_cnn_folder(dir: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(dir.join("labels.json")) else {
        return false;
    };
    serde_json::from_str::<Labels>(&text).is_ok()
}

/// The side in pixels of a crop image (they are square), read from the JPEG/PNG header.
fn crop_side(path: &Path) -> Option<u32> {
    let bytes = std::fs::read(path).ok()?;
    image_size(&bytes).filter(|(w, h)| w == h).map(|(w, _)| w)
}

/// Width and height from a PNG or baseline/progressive JPEG header.
fn image_size(b: &[u8]) -> Option<(u32, u32)> {
    if b.starts_with(b"\x89PNG\r\n\x1a\n") && b.len() >= 24 {
        let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        return Some((be(16), be(20)));
    }
    if !b.starts_with(&[0xFF, 0xD8]) {
        return None;
    }
    let mut i = 2;
    while i + 9 < b.len() {
        if b[i] != 0xFF {
            return None;
        }
        let marker = b[i + 1];
        let len = usize::from(u16::from_be_bytes([b[i + 2], b[i + 3]]));
        // Start-of-frame markers (not DHT 0xC4, JPG 0xC8, DAC 0xCC).
        if (0xC0..=0xCF).contains(&marker) && ![0xC4, 0xC8, 0xCC].contains(&marker) {
            let h = u16::from_be_bytes([b[i + 5], b[i + 6]]);
            let w = u16::from_be_bytes([b[i + 7], b[i + 8]]);
            return Some((u32::from(w), u32::from(h)));
        }
        i += 2 + len;
    }
    None
}

/// Reads the folder (see the module docs). Frames whose image is missing keep their labels
/// and get the camera of a 256-pixel crop, so `--stage lift` works on labels alone.
pub fn load_hand_graph_cnn(dir: impl AsRef<Path>) -> EvalResult<Dataset> {
    let dir = dir.as_ref();
    let path = dir.join("labels.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| EvalError::dataset(&path, format!("cannot read: {e}")))?;
    let labels: Labels = serde_json::from_str(&text)
        .map_err(|e| EvalError::dataset(&path, format!("not hand-graph-cnn labels: {e}")))?;
    let c = &labels.camera;
    let original = Camera::pinhole(c.fx, c.fy, c.cx, c.cy, c.width, c.height)
        .map_err(|e| EvalError::core("labels.json camera", e))?;
    let mut frames = Vec::with_capacity(labels.frames.len());
    for f in &labels.frames {
        let [x, y, w, h] = f.crop_box_xywh;
        if !(w > 0.0 && h > 0.0 && (w - h).abs() < 1e-6) {
            return Err(EvalError::dataset(
                &path,
                format!(
                    "frame {}: crop box {:?} is not a positive square",
                    f.frame, f.crop_box_xywh
                ),
            ));
        }
        let image = dir.join(&f.image);
        let side = crop_side(&image).unwrap_or(256);
        let s = f64::from(side) / w;
        let k = &original.intrinsics;
        let camera = Camera::pinhole(
            k.fx * s,
            k.fy * s,
            (k.cx - x) * s,
            (k.cy - y) * s,
            side,
            side,
        )
        .map_err(|e| EvalError::core(format!("frame {} crop camera", f.frame), e))?;
        if f.joints_3d_mm.iter().flatten().any(|v| !v.is_finite()) {
            return Err(EvalError::dataset(
                &path,
                format!("frame {}: non-finite 3D label", f.frame),
            ));
        }
        frames.push(Frame {
            sequence: SEQUENCE.to_string(),
            index: f.frame,
            images: if image.is_file() {
                vec![image]
            } else {
                Vec::new()
            },
            cameras: vec![camera],
            hands: vec![GtHand {
                side: SIDE,
                joints_3d: f.joints_3d_mm,
                keypoints_2d: None,
            }],
            crop: Some(CropOrigin {
                camera: original,
                box_xywh: f.crop_box_xywh,
                side,
            }),
        });
    }
    if frames.is_empty() {
        return Err(EvalError::dataset(&path, "no frames"));
    }
    Ok(Dataset {
        name: super::folder_name(dir, SEQUENCE),
        source: dir.to_path_buf(),
        root: RootJoint::Wrist,
        frames,
        view_names: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_sizes_from_headers() {
        let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
        png.extend_from_slice(&640u32.to_be_bytes());
        png.extend_from_slice(&480u32.to_be_bytes());
        assert_eq!(image_size(&png), Some((640, 480)));
        // SOI, an APP0 segment of length 4, then SOF0 with height 200, width 300.
        let jpg = [
            0xFF, 0xD8, 0xFF, 0xE0, 0, 4, 0, 0, 0xFF, 0xC0, 0, 11, 8, 0, 200, 1, 44, 3, 0, 0,
        ];
        assert_eq!(image_size(&jpg), Some((300, 200)));
        assert_eq!(image_size(b"not an image"), None);
    }

    #[test]
    fn crop_camera_projects_labels_like_the_original_shifted_and_scaled() {
        let dir = tempfile::tempdir().expect("tempdir");
        let labels = r#"{"camera": {"fx": 900, "fy": 910, "cx": 640, "cy": 360, "width": 1280, "height": 720},
            "frames": [{"frame": 0, "image": "images/00000.jpg", "crop_box_xywh": [400, 100, 512, 512],
            "joints_3d_mm": [[10, 20, 400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],
            [0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400],
            [0,0,400],[0,0,400],[0,0,400],[0,0,400],[0,0,400]]}]}"#;
        std::fs::write(dir.path().join("labels.json"), labels).expect("write");
        assert!(is_hand_graph_cnn_folder(dir.path()));
        let d = load_hand_graph_cnn(dir.path()).expect("load");
        let f = &d.frames[0];
        assert!(f.images.is_empty(), "no image on disk");
        let p = f.cameras[0]
            .project(&nalgebra::Vector3::new(10.0, 20.0, 400.0))
            .expect("in front");
        // Original pixel (900*10/400 + 640, 910*20/400 + 360) = (662.5, 405.5); crop: minus
        // the box corner, times 256/512.
        assert!((p.x - (662.5 - 400.0) * 0.5).abs() < 1e-9, "{p}");
        assert!((p.y - (405.5 - 100.0) * 0.5).abs() < 1e-9, "{p}");
        assert_eq!(d.root, RootJoint::Wrist);
        assert_eq!(f.hands[0].side, HandSide::Left);
    }
}
