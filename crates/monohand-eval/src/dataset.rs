//! The in-memory form every dataset is converted to: frames with cameras,
//! image paths and ground-truth hands.
//!
//! The readers ([`crate::manifest`], [`crate::datasets`]) build these types; reading a
//! dataset whatever its kind, [`Dataset::load`], is in [`crate::datasets`].

use crate::error::{EvalError, EvalResult};
use crate::metrics::Joints;
use monohand_core::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// What joint 0 of the ground truth is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RootJoint {
    /// The wrist, as in OpenPose / MediaPipe (the default).
    Wrist,
    /// The palm centre, as in STB (which has no wrist label).
    PalmCentre,
}

impl RootJoint {
    /// `"wrist"` or `"palm_centre"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            RootJoint::Wrist => "wrist",
            RootJoint::PalmCentre => "palm_centre",
        }
    }
}

/// One ground-truth hand of a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct GtHand {
    /// Left or right.
    pub side: HandSide,
    /// 21 joints, mm, in the first camera's frame, OpenPose/MediaPipe order
    /// (joint 0 per [`Dataset::root`]).
    pub joints_3d: Joints,
    /// Optional ground-truth 2D keypoints, one set per camera (pixels, with a
    /// confidence; 0 = not labelled). When absent the 3D joints are projected.
    pub keypoints_2d: Option<Vec<Keypoints2d>>,
}

/// One frame: its cameras, images and hands.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The sequence the frame belongs to ("" if the dataset has none).
    pub sequence: String,
    /// The frame's index in its sequence.
    pub index: usize,
    /// One image per camera (resolved paths), or empty for label-only data.
    pub images: Vec<PathBuf>,
    /// The cameras; the first is the reference frame, the others carry
    /// extrinsics mapping the first camera's frame into theirs.
    pub cameras: Vec<Camera>,
    /// The labelled hands.
    pub hands: Vec<GtHand>,
    /// Set when the frame's one image is a crop of a larger frame: that frame's camera and
    /// where the crop was cut. `--stage full` pastes the crop back to run the sequence as
    /// the video it came from.
    pub crop: Option<CropOrigin>,
}

/// Where a crop image was cut from ([`Frame::crop`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CropOrigin {
    /// The camera of the original frame (the 3D labels are in its frame, as in the crop's).
    pub camera: Camera,
    /// The crop's box in the original frame's pixels: `x, y, width, height`.
    pub box_xywh: [f64; 4],
    /// The crop image's side in pixels (the box is resized to it).
    pub side: u32,
}

impl CropOrigin {
    /// A point of the original frame in the crop's pixels.
    pub fn to_crop(&self, u: f64, v: f64) -> (f64, f64) {
        let [x, y, w, _] = self.box_xywh;
        let s = f64::from(self.side) / w;
        ((u - x) * s, (v - y) * s)
    }
}

impl Frame {
    /// The ground-truth 2D keypoints of a hand in a view: the labelled ones if
    /// the dataset has them, else the 3D joints projected (confidence 1; a
    /// joint behind the camera gets confidence 0).
    pub fn gt_keypoints(&self, hand: usize, view: usize) -> Keypoints2d {
        let h = &self.hands[hand];
        if let Some(k) = h.keypoints_2d.as_ref().and_then(|k| k.get(view)) {
            return *k;
        }
        project_joints(&self.cameras[view], &h.joints_3d)
    }
}

/// Joints of the palm: the wrist and the base of each finger (the thumb's CMC).
pub const PALM_JOINTS: [usize; 6] = [0, 1, 5, 9, 13, 17];

/// Whether 2D labels show a hand's palm: at least 3 of its 6 joints ([`PALM_JOINTS`])
/// labelled. A view that shows only fingers entering its edge does not see the hand as a
/// palm detector must (the rig's labels mark every joint inside the image).
pub fn sees_palm(labels: &Keypoints2d) -> bool {
    PALM_JOINTS
        .iter()
        .filter(|&&j| labels.points[j][2] > 0.0)
        .count()
        >= 3
}

/// Projects 21 joints into a camera (confidence 1, or 0 behind the camera).
pub fn project_joints(camera: &Camera, joints: &Joints) -> Keypoints2d {
    let mut kp = Keypoints2d::default();
    for (j, p) in joints.iter().enumerate() {
        if let Some(px) = camera.project(&nalgebra::Vector3::new(p[0], p[1], p[2])) {
            kp.points[j] = [px.x, px.y, 1.0];
        }
    }
    kp
}

/// A dataset: frames in order, grouped by sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// A short name (folder or manifest name).
    pub name: String,
    /// Where it was read from.
    pub source: PathBuf,
    /// What joint 0 is.
    pub root: RootJoint,
    /// The frames, sequences contiguous.
    pub frames: Vec<Frame>,
    /// The views' names in camera order (a rig's camera serials), or empty where the
    /// dataset names none.
    pub view_names: Vec<String>,
}

impl Dataset {
    /// The sequence names in order of first appearance.
    pub fn sequences(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for f in &self.frames {
            if out.last() != Some(&f.sequence.as_str()) && !out.contains(&f.sequence.as_str()) {
                out.push(&f.sequence);
            }
        }
        out
    }

    /// The largest number of cameras of any frame.
    pub fn max_cameras(&self) -> usize {
        self.frames
            .iter()
            .map(|f| f.cameras.len())
            .max()
            .unwrap_or(0)
    }

    /// View `v` alone, as a dataset of one camera for a mono evaluation: each frame keeps
    /// that view's camera (with its extrinsics: the 3D stays in the dataset's frame) and
    /// image, and the hands that view sees: whose palm its 2D labels show
    /// ([`sees_palm`]; every hand where the dataset has no 2D labels). Frames where the
    /// view sees no hand stay, without hands, so that a tracked run still sees the
    /// sequence as its video.
    pub fn view(&self, v: usize) -> EvalResult<Dataset> {
        let frames = self
            .frames
            .iter()
            .map(|f| {
                let camera = *f.cameras.get(v).ok_or_else(|| {
                    EvalError::Settings(format!(
                        "view {} of {}: frame {} of sequence {:?} has {} camera(s)",
                        v + 1,
                        self.name,
                        f.index,
                        f.sequence,
                        f.cameras.len()
                    ))
                })?;
                let hands = f
                    .hands
                    .iter()
                    .filter_map(|h| match &h.keypoints_2d {
                        None => Some(h.clone()),
                        Some(k) => {
                            let kp = k.get(v).copied().unwrap_or_default();
                            sees_palm(&kp).then(|| GtHand {
                                keypoints_2d: Some(vec![kp]),
                                ..h.clone()
                            })
                        }
                    })
                    .collect();
                Ok(Frame {
                    sequence: f.sequence.clone(),
                    index: f.index,
                    images: f.images.get(v).cloned().into_iter().collect(),
                    cameras: vec![camera],
                    hands,
                    crop: if v == 0 { f.crop } else { None },
                })
            })
            .collect::<EvalResult<Vec<Frame>>>()?;
        Ok(Dataset {
            name: self.name.clone(),
            source: self.source.clone(),
            root: self.root,
            frames,
            view_names: vec![self.view_name(v)],
        })
    }

    /// The name of view `v`: [`Dataset::view_names`]' entry, else `view N` (from 1).
    pub fn view_name(&self, v: usize) -> String {
        self.view_names
            .get(v)
            .cloned()
            .unwrap_or_else(|| format!("view {}", v + 1))
    }

    /// Number of labelled hands over all frames.
    pub fn num_hands(&self) -> usize {
        self.frames.iter().map(|f| f.hands.len()).sum()
    }

    /// Keeps every `step`-th frame of each sequence, then at most `max` frames in all.
    pub fn subsample(&mut self, step: usize, max: Option<usize>) {
        let step = step.max(1);
        let mut seq_pos = std::collections::HashMap::<String, usize>::new();
        self.frames.retain(|f| {
            let c = seq_pos.entry(f.sequence.clone()).or_insert(0);
            let keep = (*c).is_multiple_of(step);
            *c += 1;
            keep
        });
        if let Some(m) = max {
            self.frames.truncate(m);
        }
    }
}
