//! The project's output: JSON Lines, one object per frame (see
//! `docs/output-format.md` for the exact schema).
//!
//! ```json
//! {"frame": 0, "source": "clip_000000000000_keypoints.json", "hands": [{"side": "right",
//!   "keypoints_2d": [[u, v, p], ...21], "joints_3d_mm": [[x, y, z], ...21],
//!   "pose": {"translation_mm": [x, y, z], "quaternion_xyzw": [x, y, z, w], "angles_rad": [...20]},
//!   "reprojection_error_px": 1.2, "converged": true, "iterations": 14}]}
//! ```
//!
//! [`JsonlWriter`] writes and flushes one line per frame, so an interrupted
//! run leaves a valid file up to the last complete frame. [`read_jsonl`] reads
//! it back, naming the line of any malformed record; only `keypoints_2d` is
//! required in a hand, so the same reader accepts 2D-only input for lifting.
//! Optional fields are left out when absent and unknown fields are ignored,
//! so files written by newer versions stay readable.
//!
//! ```
//! use monohand_io::jsonl::{read_jsonl, FrameRecord, HandRecord, JsonlWriter};
//! use monohand_core::prelude::*;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("out.jsonl");
//! let mut w = JsonlWriter::create(&path).unwrap();
//! let hand = HandRecord::from_keypoints(HandSide::Left, &Keypoints2d::default());
//! w.write_frame(&FrameRecord { frame: 0, hands: vec![hand], ..Default::default() }).unwrap();
//! drop(w);
//! let frames = read_jsonl(&path).unwrap();
//! assert_eq!(frames[0].hands[0].side, HandSide::Left);
//! ```

use crate::error::{name_of, IoError, IoResult};
use crate::sink::RecordSink;
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

/// The fitted pose parameters of a hand.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseRecord {
    /// Wrist position in the first camera's frame, mm.
    pub translation_mm: [f64; 3],
    /// Rotation from the hand frame to the first camera's frame, unit quaternion `[x, y, z, w]`.
    pub quaternion_xyzw: [f64; 4],
    /// The 20 joint angles, radians, in `monohand_core::hand_model::angle_names()` order.
    pub angles_rad: [f64; 20],
}

impl PoseRecord {
    /// From a fitted pose.
    pub fn from_pose(pose: &HandPose) -> PoseRecord {
        let q = pose.rotation.quaternion();
        PoseRecord {
            translation_mm: [pose.translation.x, pose.translation.y, pose.translation.z],
            quaternion_xyzw: [q.i, q.j, q.k, q.w],
            angles_rad: pose.angles,
        }
    }

    /// Back to a pose (the quaternion is normalised); `None` if a value is not
    /// finite or the quaternion is zero.
    pub fn to_pose(&self) -> Option<HandPose> {
        let all = self
            .translation_mm
            .iter()
            .chain(&self.quaternion_xyzw)
            .chain(&self.angles_rad);
        if all.into_iter().any(|v| !v.is_finite()) {
            return None;
        }
        let [x, y, z, w] = self.quaternion_xyzw;
        let q = Quaternion::new(w, x, y, z);
        if q.norm() < 1e-12 {
            return None;
        }
        Some(HandPose {
            translation: Vector3::from(self.translation_mm),
            rotation: UnitQuaternion::from_quaternion(q),
            angles: self.angles_rad,
        })
    }
}

/// One hand in one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandRecord {
    /// `"left"` or `"right"`.
    pub side: HandSide,
    /// The 2D keypoints of the first view, `[u, v, confidence]` in pixels.
    pub keypoints_2d: [[f64; 3]; NUM_JOINTS],
    /// The 21 fitted joints in the first camera's frame, mm.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub joints_3d_mm: Option<[[f64; 3]; NUM_JOINTS]>,
    /// The fitted pose parameters.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub pose: Option<PoseRecord>,
    /// Mean reprojection error of the fit over the joints used, pixels.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub reprojection_error_px: Option<f64>,
    /// Whether the solver met a stopping tolerance.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub converged: Option<bool>,
    /// Solver iterations.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub iterations: Option<usize>,
    /// Detection box in the first view (in JSON `[x_min, y_min, x_max, y_max]`, pixels).
    #[serde(rename = "box", skip_serializing_if = "Option::is_none", default)]
    pub bbox: Option<BBox>,
    /// Detection score in `[0, 1]`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub score: Option<f64>,
    /// Track identity, stable across frames.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub id: Option<u64>,
    /// Probability of `side` in `[0, 1]` according to a network on this frame (below 0.5
    /// when `side` was decided otherwise, e.g. by a vote over a tracked hand's frames).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub side_score: Option<f64>,
    /// The hand's oriented box in the first view (rotated with the hand).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub oriented_box: Option<OrientedBox>,
    /// The keypoint network's metric 3D in the first view, mm, relative to the hand, in the
    /// image's axes (MediaPipe's world landmarks). `lift` uses it as a cue when present.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub world_mm: Option<[[f64; 3]; NUM_JOINTS]>,
    /// The keypoint network's depth of each joint relative to the wrist, in image pixels,
    /// negative towards the camera (MediaPipe's landmark `z`). `lift` uses it when present.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub depth_px: Option<[f64; NUM_JOINTS]>,
    /// The hand size the fit used, with the 3D.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub hand_size: Option<HandSizeRecord>,
    /// With several cameras, how each view agreed with the fitted hand, one entry per
    /// camera in the order of the frame's `cameras` (absent with one camera or no 3D).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub views: Option<Vec<ViewFitRecord>>,
    /// The hand as OpenXR's 26 hand joints, in the frame of `joints_3d_mm`: written when
    /// asked ([`JsonlWriter::with_xr_joints`]), from the fit ([`HandRecord::xr_joints_of_fit`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub xr_joints: Option<Vec<XrJointRecord>>,
    /// The wrist's pose in the wrist frame retargeting reads (MANO's): written when asked
    /// ([`JsonlWriter::with_wrist_pose`]), from the fit ([`HandRecord::wrist_pose_of_fit`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub wrist_pose: Option<WristPoseRecord>,
    /// With one camera and a tracked hand: how firmly this frame's keypoints pinned the
    /// hand's distance, what the network's cues said of it, and what the filter over the
    /// track made of both ([`DistanceRecord`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub distance: Option<DistanceRecord>,
}

/// A hand's distance from one camera in one frame ([`HandRecord::distance`]), as
/// `monohand_core::fitting::DistanceEvidence` gives it: the depth in the camera of the
/// model's palm (the centroid of the wrist and the five fingers' bases), mm. The keypoints
/// leave the distance open along the viewing rays; the filter takes each frame's keypoints'
/// distance with its uncertainty and the cues' with a fixed one (docs/absolute-depth.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DistanceRecord {
    /// The distance of the fit with the keypoints alone (absent: that fit failed).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub keypoints_mm: Option<f64>,
    /// Its standard deviation, from that fit's own Gauss-Newton matrix: large where the
    /// keypoints cannot tell a nearer, more flexed hand from a farther, flatter one.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub keypoints_sigma_mm: Option<f64>,
    /// The distance of the fit with the network's 3D cues (absent: no cues this frame).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub cues_mm: Option<f64>,
    /// The filtered distance the frame's fit was held at (from a track's second frame on;
    /// `--offline` moves the written joints by what later frames say).
    pub fused_mm: f64,
    /// Its standard deviation.
    pub fused_sigma_mm: f64,
}

impl From<&monohand_core::fitting::DistanceEvidence> for DistanceRecord {
    fn from(e: &monohand_core::fitting::DistanceEvidence) -> DistanceRecord {
        DistanceRecord {
            keypoints_mm: e.keypoints_mm,
            keypoints_sigma_mm: e.keypoints_sigma_mm,
            cues_mm: e.cues_mm,
            fused_mm: e.fused_mm,
            fused_sigma_mm: e.fused_sigma_mm,
        }
    }
}

/// A hand's wrist pose ([`HandRecord::wrist_pose`]; `monohand_core::wrist` gives the
/// frame's convention and how it is made from the fit).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WristPoseRecord {
    /// The wrist frame's convention: `"mano"` (MANO's, as dex-retargeting documents it: +z
    /// from the wrist towards the fingers, +x out of the palm, +y = z × x).
    pub convention: String,
    /// The homogeneous transform from the wrist frame to the frame of `joints_3d_mm`, row
    /// by row (`[[r00, r01, r02, tx], ..., [0, 0, 0, 1]]`): its rotation's columns are the
    /// wrist frame's axes, its translation the wrist joint in metres.
    pub matrix_m: [[f64; 4]; 4],
}

impl WristPoseRecord {
    /// The record of a wrist pose.
    pub fn new(pose: &monohand_core::wrist::WristPose) -> WristPoseRecord {
        let m = pose.matrix_m();
        WristPoseRecord {
            convention: pose.convention.name().to_string(),
            matrix_m: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        }
    }
}

/// One of a hand's OpenXR joints ([`HandRecord::xr_joints`]; `monohand_core::xr` gives
/// their conventions: the axes, where the joints the model has not are put, the radii).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct XrJointRecord {
    /// The joint, in `XrHandJointEXT` order ([`monohand_core::xr::XR_JOINT_NAMES`]:
    /// `palm`, `wrist`, `thumb_metacarpal`, ..., `little_tip`).
    pub name: String,
    /// Position, mm.
    pub position_mm: [f64; 3],
    /// The rotation from the joint's axes into the record's frame, unit quaternion
    /// `[x, y, z, w]`: the joint's −Z runs along its bone towards the finger tip, its +Y
    /// out of the back of the hand, its +X = Y × Z.
    pub orientation_xyzw: [f64; 4],
    /// Distance from the joint to the skin, mm.
    pub radius_mm: f64,
}

/// The hand size a fit used ([`HandRecord::hand_size`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandSizeRecord {
    /// The model's wrist-to-middle-fingertip length, mm.
    pub length_mm: f64,
    /// The size as a factor on the default adult hand.
    pub scale: f64,
    /// Where it came from: `default` (the population average), `scale` (`--hand-scale`),
    /// `measured` (by the views: `--hand-scale auto`, `--save-hand`), `file` (`--hand`),
    /// `ruler` (`--hand-length-mm`).
    pub source: String,
}

/// How one view of a calibrated rig agreed with a hand's fit: the rig's check of itself (a
/// camera bumped after its calibration, or a video out of sync, shows as a view whose
/// error stays far above the others').
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewFitRecord {
    /// Whether the view saw the hand and took part in its fit.
    pub used: bool,
    /// Mean distance in pixels between the view's keypoints (those the fit uses: the
    /// confident ones) and the recorded 3D joints projected through the view's camera;
    /// absent when the view did not see the hand.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub reprojection_error_px: Option<f64>,
    /// The mean of the same joints' `projected - observed` vectors `[du, dv]`, pixels: the
    /// part of the error common to every joint (random keypoint errors cancel in it; a
    /// turned camera or a late video shifts every joint alike).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub offset_px: Option<[f64; 2]>,
    /// Where in the view's image the same joints of the fitted hand project, their mean
    /// `[u, v]`, pixels: from one frame to the next, the hand's motion in the view, which a
    /// late video's offset follows.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub centre_px: Option<[f64; 2]>,
}

/// A rotated rectangle in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrientedBox {
    /// Centre `[u, v]`, pixels.
    pub center: [f64; 2],
    /// `[width, height]`, pixels.
    pub size: [f64; 2],
    /// Rotation in degrees, clockwise in the image (y down), of the box's height axis from
    /// "up": 0 is an upright hand with the fingers towards the top of the image.
    pub angle_deg: f64,
}

/// A detected head (used as context for the hands' sides, as in the paper).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeadRecord {
    /// Head box (in JSON `[x_min, y_min, x_max, y_max]`, pixels).
    #[serde(rename = "box")]
    pub bbox: BBox,
    /// Detection score in `[0, 1]`.
    pub score: f64,
}

impl HandRecord {
    /// A record with 2D keypoints only.
    pub fn from_keypoints(side: HandSide, keypoints: &Keypoints2d) -> HandRecord {
        HandRecord {
            side,
            keypoints_2d: keypoints.points,
            joints_3d_mm: None,
            pose: None,
            reprojection_error_px: None,
            converged: None,
            iterations: None,
            bbox: None,
            score: None,
            id: None,
            side_score: None,
            oriented_box: None,
            world_mm: None,
            depth_px: None,
            hand_size: None,
            views: None,
            xr_joints: None,
            wrist_pose: None,
            distance: None,
        }
    }

    /// The same record carrying the network's 3D cues (if any).
    pub fn with_cues(mut self, cues: Option<&NetworkCues>) -> HandRecord {
        self.world_mm = cues.and_then(|c| c.world_mm);
        self.depth_px = cues.and_then(|c| c.depth_px);
        self
    }

    /// The network's 3D cues, if the record has any (checked: finite numbers).
    pub fn cues(&self) -> Result<Option<NetworkCues>, CoreError> {
        let cues = NetworkCues {
            world_mm: self.world_mm,
            depth_px: self.depth_px,
        };
        if cues.is_empty() {
            return Ok(None);
        }
        cues.validate()?;
        Ok(Some(cues))
    }

    /// A record of a fit: the keypoints of the first view and the fit's results.
    pub fn from_fit(side: HandSide, keypoints: &Keypoints2d, fit: &FitResult) -> HandRecord {
        HandRecord {
            joints_3d_mm: Some(fit.joints_3d.map(|x| [x.x, x.y, x.z])),
            pose: Some(PoseRecord::from_pose(&fit.pose)),
            reprojection_error_px: Some(fit.reprojection_error_px),
            converged: Some(fit.converged),
            iterations: Some(fit.iterations),
            ..HandRecord::from_keypoints(side, keypoints)
        }
    }

    /// The 2D keypoints, checked (finite, confidence in `[0, 1]`).
    pub fn keypoints(&self) -> Result<Keypoints2d, CoreError> {
        Keypoints2d::new(self.keypoints_2d)
    }

    /// The 3D joints as vectors, if present.
    pub fn joints_3d(&self) -> Option<[Vector3<f64>; NUM_JOINTS]> {
        self.joints_3d_mm.map(|j| j.map(Vector3::from))
    }

    /// The hand's 26 OpenXR joints ([`monohand_core::xr::xr_joints`]) from its fit: at its
    /// `joints_3d_mm`, oriented by the default hand model's axes posed with its `pose`,
    /// with radii for its `hand_size` (the default adult hand's without one). The model's
    /// axes are the default's because a record does not hold its skeleton; a fit's size is
    /// its only difference from it unless the proportions were learnt (`FitSettings::
    /// proportion_frames`), which change bone lengths and not axes. `None` without 3D or a
    /// pose, or for joints no hand has (a bone of no length).
    pub fn xr_joints_of_fit(&self) -> Option<Vec<XrJointRecord>> {
        let joints = self.joints_3d()?;
        let pose = self.pose.as_ref()?.to_pose()?;
        let scale = self.hand_size.as_ref().map_or(1.0, |s| s.scale);
        let skeleton = HandSkeleton::default_for(self.side).scaled(scale).ok()?;
        let xr = monohand_core::xr::xr_joints(&skeleton, &pose, &joints)?;
        let record = |(j, name): (&monohand_core::xr::XrJoint, &str)| {
            let (p, q) = (j.position, j.orientation.quaternion());
            XrJointRecord {
                name: name.to_string(),
                position_mm: [p.x, p.y, p.z],
                orientation_xyzw: [q.i, q.j, q.k, q.w],
                radius_mm: j.radius,
            }
        };
        Some(
            xr.iter()
                .zip(monohand_core::xr::XR_JOINT_NAMES)
                .map(record)
                .collect(),
        )
    }

    /// The hand's wrist pose in MANO's wrist frame ([`monohand_core::wrist::wrist_pose`])
    /// from its fit: at its `joints_3d_mm`'s wrist, turned as its `pose`'s hand frame.
    /// `None` without 3D or a pose.
    pub fn wrist_pose_of_fit(&self) -> Option<WristPoseRecord> {
        let joints = self.joints_3d()?;
        let pose = self.pose.as_ref()?.to_pose()?;
        let mano = monohand_core::wrist::WristConvention::Mano;
        Some(WristPoseRecord::new(&monohand_core::wrist::wrist_pose(
            &pose, &joints, mano,
        )?))
    }

    /// The name of the first non-finite number, if any (JSON cannot hold NaN or infinity).
    fn non_finite_field(&self) -> Option<&'static str> {
        if bad(self.keypoints_2d.iter().flatten()) {
            return Some("keypoints_2d");
        }
        if self.joints_3d_mm.is_some_and(|j| bad(j.iter().flatten())) {
            return Some("joints_3d_mm");
        }
        if let Some(p) = &self.pose {
            let it = p
                .translation_mm
                .iter()
                .chain(&p.quaternion_xyzw)
                .chain(&p.angles_rad);
            if bad(it) {
                return Some("pose");
            }
        }
        if self.reprojection_error_px.is_some_and(|e| !e.is_finite()) {
            return Some("reprojection_error_px");
        }
        if self.bbox.is_some_and(|b| !b.is_finite()) {
            return Some("box");
        }
        if self.score.is_some_and(|s| !s.is_finite()) {
            return Some("score");
        }
        if self.side_score.is_some_and(|s| !s.is_finite()) {
            return Some("side_score");
        }
        if let Some(b) = &self.oriented_box {
            if bad(b.center.iter().chain(&b.size).chain([&b.angle_deg])) {
                return Some("oriented_box");
            }
        }
        if self.world_mm.is_some_and(|w| bad(w.iter().flatten())) {
            return Some("world_mm");
        }
        if self.depth_px.is_some_and(|d| bad(d.iter())) {
            return Some("depth_px");
        }
        let xr = self.xr_joints.iter().flatten();
        let xr_numbers = xr.flat_map(|j| {
            j.position_mm
                .iter()
                .chain(&j.orientation_xyzw)
                .chain([&j.radius_mm])
        });
        if bad(xr_numbers) {
            return Some("xr_joints");
        }
        if bad(self
            .wrist_pose
            .iter()
            .flat_map(|w| w.matrix_m.iter().flatten()))
        {
            return Some("wrist_pose");
        }
        let views = self.views.iter().flatten();
        let offsets = views.clone().filter_map(|v| v.offset_px.as_ref()).flatten();
        if bad(views.filter_map(|v| v.reprojection_error_px.as_ref())) || bad(offsets) {
            return Some("views");
        }
        None
    }
}

/// True if an iterator yields a non-finite number.
fn bad<'a>(mut it: impl Iterator<Item = &'a f64>) -> bool {
    it.any(|x| !x.is_finite())
}

/// One frame: its index, where it came from, and its hands.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Frame index, from 0.
    pub frame: u64,
    /// The input the frame came from (file name), if known.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub source: Option<String>,
    /// Time of the frame in the input video, seconds, when it came from one.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub time_s: Option<f64>,
    /// Image size `[width, height]` of the first view, pixels, when known.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub image_size: Option<[u32; 2]>,
    /// The camera of each view that the hands were fitted with, in the views' order (none
    /// when the frame was not fitted, as in `detect`'s records).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub cameras: Vec<CameraRecord>,
    /// The hands (possibly none).
    #[serde(default)]
    pub hands: Vec<HandRecord>,
    /// Detected heads, when head detection ran.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub heads: Vec<HeadRecord>,
    /// Why this frame has no result (it could not be read or processed); the run went on.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<String>,
    /// Per-stage processing times, milliseconds.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub timings_ms: Option<BTreeMap<String, f64>>,
    /// The arithmetic the networks ran in when it was not f32 (`"int8"`); absent: f32.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub precision: Option<String>,
}

impl FrameRecord {
    /// The same frame with every fitted hand's OpenXR joints
    /// ([`HandRecord::xr_joints_of_fit`]; hands that have them keep theirs).
    pub fn with_xr_joints(mut self) -> FrameRecord {
        for h in &mut self.hands {
            if h.xr_joints.is_none() {
                h.xr_joints = h.xr_joints_of_fit();
            }
        }
        self
    }

    /// The same frame with every fitted hand's wrist pose
    /// ([`HandRecord::wrist_pose_of_fit`]; hands that have one keep theirs).
    pub fn with_wrist_pose(mut self) -> FrameRecord {
        for h in &mut self.hands {
            if h.wrist_pose.is_none() {
                h.wrist_pose = h.wrist_pose_of_fit();
            }
        }
        self
    }
}

/// Where a camera came from (in JSON: `file`, `file-scaled`, `exif`, `exif+sensor-db`,
/// `video-metadata`, `generic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CameraSource {
    /// A calibration the user gave (a file, or a camera object in Python), as given.
    #[serde(rename = "file")]
    File,
    /// A calibration the user gave for another image size of the same shape, scaled to the
    /// frames' size.
    #[serde(rename = "file-scaled")]
    FileScaled,
    /// The focal length the image file states in its EXIF (its 35 mm equivalent, or its
    /// focal length in mm with the sensor's focal plane resolution), principal point at the
    /// centre.
    #[serde(rename = "exif")]
    Exif,
    /// The focal length in mm the image file states in its EXIF, with the width of the
    /// camera's sensor from the sensor database (by EXIF make and model), principal point at
    /// the centre.
    #[serde(rename = "exif+sensor-db")]
    ExifSensorDb,
    /// The 35 mm-equivalent focal length the video file states in its QuickTime metadata
    /// (`com.apple.quicktime.camera.focal_length.35mm_equivalent`, as iPhones write it),
    /// principal point at the centre.
    #[serde(rename = "video-metadata")]
    VideoMetadata,
    /// The generic guess for the image size (60 degree horizontal field of view).
    #[serde(rename = "generic")]
    Generic,
}

impl CameraSource {
    /// The name in the records (`exif+sensor-db`).
    pub fn name(self) -> &'static str {
        match self {
            CameraSource::File => "file",
            CameraSource::FileScaled => "file-scaled",
            CameraSource::Exif => "exif",
            CameraSource::ExifSensorDb => "exif+sensor-db",
            CameraSource::VideoMetadata => "video-metadata",
            CameraSource::Generic => "generic",
        }
    }
}

impl std::fmt::Display for CameraSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The intrinsics of the camera a view was fitted with, where they came from and why: in
/// JSON `fx, fy, cx, cy, width, height, source[, reason]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraRecord {
    /// Focal lengths, principal point and image size, pixels.
    #[serde(flatten)]
    pub intrinsics: monohand_core::camera::Intrinsics,
    /// The lens model (`"pinhole"` or `"fisheye"`), when the camera is not an ideal
    /// pinhole: as its calibration JSON states it ([`crate::calibration::camera_to_json`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub model: Option<String>,
    /// Its distortion coefficients, with `model` (OpenCV's order; a fisheye's k1..k4).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub dist: Option<Vec<f64>>,
    /// Where the camera came from.
    pub source: CameraSource,
    /// Why this source and not a better one (a stated EXIF focal length that failed its
    /// checks, a calibration scaled from another size, a field of view outside 5-150
    /// degrees that the user's calibration gives): absent when there is nothing to say.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub reason: Option<String>,
    /// How late this view's video started against the first view's, seconds, when the
    /// views were matched by time (`run --sync`); absent: matched by frame index.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub time_offset_s: Option<f64>,
}

impl CameraRecord {
    /// The record of a camera's intrinsics and lens, with no reason.
    pub fn new(camera: &monohand_core::camera::Camera, source: CameraSource) -> CameraRecord {
        let lens = (!camera.distortion.is_ideal()).then_some(&camera.distortion);
        CameraRecord {
            intrinsics: camera.intrinsics,
            model: lens.map(|d| d.model.name().to_string()),
            dist: lens.map(|d| d.listed().to_vec()),
            source,
            reason: None,
            time_offset_s: None,
        }
    }

    /// The same record with the reason for its source.
    pub fn with_reason(mut self, reason: Option<String>) -> CameraRecord {
        self.reason = reason;
        self
    }
}

/// Writes [`FrameRecord`]s as JSON Lines, flushing after every line.
///
/// A file is cut back to its last whole line when a write fails (a full disk), so
/// it always parses.
pub struct JsonlWriter {
    out: RecordSink,
    lines: usize,
    xr_joints: bool,
    wrist_pose: bool,
}

impl std::fmt::Debug for JsonlWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JsonlWriter")
            .field("name", &self.out.name())
            .field("lines", &self.lines)
            .field("xr_joints", &self.xr_joints)
            .field("wrist_pose", &self.wrist_pose)
            .finish()
    }
}

impl JsonlWriter {
    /// Creates (or truncates) a file.
    pub fn create(path: impl AsRef<Path>) -> IoResult<JsonlWriter> {
        Ok(JsonlWriter {
            out: RecordSink::create(path.as_ref())?,
            lines: 0,
            xr_joints: false,
            wrist_pose: false,
        })
    }

    /// Writes to standard output.
    pub fn stdout() -> JsonlWriter {
        JsonlWriter::new(Box::new(std::io::stdout()), "<stdout>")
    }

    /// Writes to any sink; `name` is used in errors.
    pub fn new(sink: Box<dyn Write>, name: &str) -> JsonlWriter {
        JsonlWriter {
            out: RecordSink::new(sink, name),
            lines: 0,
            xr_joints: false,
            wrist_pose: false,
        }
    }

    /// With `on`, every fitted hand is written with its OpenXR joints
    /// ([`HandRecord::xr_joints`], made by [`HandRecord::xr_joints_of_fit`] where the
    /// record has none). Off by default: they more than double a fitted hand's line.
    pub fn with_xr_joints(mut self, on: bool) -> JsonlWriter {
        self.xr_joints = on;
        self
    }

    /// With `on`, every fitted hand is written with its wrist pose
    /// ([`HandRecord::wrist_pose`], made by [`HandRecord::wrist_pose_of_fit`] where the
    /// record has none). Off by default.
    pub fn with_wrist_pose(mut self, on: bool) -> JsonlWriter {
        self.wrist_pose = on;
        self
    }

    /// Number of frames written.
    pub fn frames_written(&self) -> usize {
        self.lines
    }

    /// Writes one frame as one line and flushes it. Non-finite numbers are
    /// refused (JSON has no NaN) with the hand and field named.
    pub fn write_frame(&mut self, frame: &FrameRecord) -> IoResult<()> {
        let added;
        let frame = match (self.xr_joints, self.wrist_pose) {
            (false, false) => frame,
            (xr, wrist) => {
                let mut f = frame.clone();
                if xr {
                    f = f.with_xr_joints();
                }
                if wrist {
                    f = f.with_wrist_pose();
                }
                added = f;
                &added
            }
        };
        let mut line = frame_json(frame, self.out.name())?;
        line.push('\n');
        self.out.append(line.as_bytes())?;
        self.lines += 1;
        Ok(())
    }
}

/// One frame as one line of JSON Lines, without the newline: what [`JsonlWriter`] writes
/// (and the browser build hands to the page). Non-finite numbers are refused (JSON has no
/// NaN) with the hand and field named; `name` names the output in errors.
pub fn frame_json(frame: &FrameRecord, name: &str) -> IoResult<String> {
    for (i, h) in frame.hands.iter().enumerate() {
        if let Some(field) = h.non_finite_field() {
            return Err(IoError::field(
                name,
                format!("frame {} hands[{i}].{field}", frame.frame),
                "contains a non-finite number",
            ));
        }
    }
    serde_json::to_string(frame).map_err(|e| IoError::json(name, &e))
}

/// Parses JSON Lines text; blank lines are skipped. `file` names it in errors,
/// which give the 1-based line number of a malformed record.
pub fn parse_jsonl(reader: impl BufRead, file: &str) -> IoResult<Vec<FrameRecord>> {
    let mut out = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        let line = line.map_err(|e| IoError::Line {
            file: file.to_string(),
            line: i + 1,
            message: format!("cannot read: {e}"),
        })?;
        if line.trim().is_empty() {
            continue;
        }
        let rec: FrameRecord = serde_json::from_str(&line).map_err(|e| IoError::Line {
            file: file.to_string(),
            line: i + 1,
            message: format!("invalid frame record: {e}"),
        })?;
        out.push(rec);
    }
    Ok(out)
}

/// Reads a JSON Lines file written by [`JsonlWriter`] (or by hand, with 2D keypoints only).
pub fn read_jsonl(path: impl AsRef<Path>) -> IoResult<Vec<FrameRecord>> {
    let path = path.as_ref();
    let f = std::fs::File::open(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })?;
    parse_jsonl(BufReader::new(f), &name_of(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit_like() -> FitResult {
        let mut angles = [0.0; 20];
        angles[5] = 0.7;
        let pose = HandPose {
            translation: Vector3::new(10.0, -20.0, 480.0),
            rotation: UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
            angles,
        };
        let joints = std::array::from_fn(|j| Vector3::new(j as f64, 0.5, 500.0 - j as f64));
        FitResult {
            pose,
            joints_3d: joints,
            model_joints_3d: joints,
            reprojection_error_px: 1.25,
            iterations: 17,
            converged: true,
            cost: 3.0,
            used_observations: 21,
        }
    }

    #[test]
    fn round_trip_and_optional_fields() {
        let mut kp = Keypoints2d::default();
        kp.points[3] = [100.0, 200.0, 0.75];
        let fit = fit_like();
        let rec = HandRecord::from_fit(HandSide::Right, &kp, &fit);
        let frame = FrameRecord {
            frame: 7,
            source: Some("f.json".into()),
            hands: vec![rec.clone()],
            image_size: Some([640, 480]),
            heads: vec![HeadRecord {
                bbox: BBox::new(1.0, 2.0, 30.0, 40.0),
                score: 0.9,
            }],
            ..Default::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("o.jsonl");
        let mut w = JsonlWriter::create(&p).unwrap();
        w.write_frame(&frame).unwrap();
        w.write_frame(&FrameRecord {
            frame: 8,
            ..Default::default()
        })
        .unwrap();
        // Flushed per line: readable while the writer is still open.
        let back = read_jsonl(&p).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0], frame);
        assert!(back[1].hands.is_empty());
        assert_eq!(w.frames_written(), 2);
        let pose = back[0].hands[0].pose.unwrap().to_pose().unwrap();
        assert!((pose.rotation.angle_to(&fit.pose.rotation)) < 1e-12);
        assert_eq!(pose.angles, fit.pose.angles);
        assert_eq!(back[0].hands[0].joints_3d().unwrap()[4], fit.joints_3d[4]);
        // Absent optional fields are not written.
        let text = std::fs::read_to_string(&p).unwrap();
        let second = text.lines().nth(1).unwrap();
        assert_eq!(second, r#"{"frame":8,"hands":[]}"#);
        // The only "box" is the head's: the hand has none.
        assert!(!text.contains("timings_ms") && text.matches("\"box\"").count() == 1);
    }

    #[test]
    fn a_frame_says_its_cameras_flat_and_reads_them_back() {
        let camera = monohand_core::camera::Camera::generic(640, 480).unwrap();
        let frame = FrameRecord {
            frame: 3,
            cameras: vec![CameraRecord::new(&camera, CameraSource::Exif)],
            ..FrameRecord::default()
        };
        let text = serde_json::to_string(&frame).unwrap();
        let f = 320.0 / 30f64.to_radians().tan();
        let want = format!(
            r#""cameras":[{{"fx":{f:?},"fy":{f:?},"cx":319.5,"cy":239.5,"width":640,"height":480,"source":"exif"}}]"#
        );
        assert!(text.contains(&want), "{text}");
        let back: FrameRecord = serde_json::from_str(&text).unwrap();
        assert_eq!(back, frame);
        // The finer sources, and a reason, read back.
        for (source, name) in [
            (CameraSource::File, "file"),
            (CameraSource::FileScaled, "file-scaled"),
            (CameraSource::Exif, "exif"),
            (CameraSource::ExifSensorDb, "exif+sensor-db"),
            (CameraSource::VideoMetadata, "video-metadata"),
            (CameraSource::Generic, "generic"),
        ] {
            let rec = CameraRecord::new(&camera, source).with_reason(Some("why".into()));
            let text = serde_json::to_string(&rec).unwrap();
            assert!(
                text.ends_with(&format!(r#""source":"{name}","reason":"why"}}"#)),
                "{text}"
            );
            assert_eq!(source.to_string(), name);
            assert_eq!(serde_json::from_str::<CameraRecord>(&text).unwrap(), rec);
        }
        // A lens is said as its calibration states it: the model and its coefficients.
        let fisheye = monohand_core::camera::Camera::new(
            camera.intrinsics,
            monohand_core::camera::Distortion::fisheye([0.02, -0.005, 0.0, 0.0]).unwrap(),
            monohand_core::camera::Extrinsics::default(),
        )
        .unwrap();
        let rec = CameraRecord::new(&fisheye, CameraSource::File);
        let text = serde_json::to_string(&rec).unwrap();
        assert!(
            text.contains(
                r#""height":480,"model":"fisheye","dist":[0.02,-0.005,0.0,0.0],"source":"file""#
            ),
            "{text}"
        );
        assert_eq!(serde_json::from_str::<CameraRecord>(&text).unwrap(), rec);
        // Frames without a fit (detect's records) leave the field out.
        let bare = serde_json::to_string(&FrameRecord::default()).unwrap();
        assert!(!bare.contains("cameras"), "{bare}");
    }

    #[test]
    fn reader_accepts_2d_only_and_newer_fields() {
        let kp: Vec<[f64; 3]> = (0..21).map(|j| [j as f64, 1.0, 0.5]).collect();
        let text = format!(
            "{}\n\n{}\n",
            serde_json::json!({"frame": 0, "hands": [{"side": "left", "keypoints_2d": kp}]}),
            serde_json::json!({"frame": 1, "hands": [{"side": "right", "keypoints_2d": kp,
                "box": [1, 2, 3, 4], "score": 0.9, "id": 3, "future_field": {"a": 1}}],
                "timings_ms": {"detect": 4.5}})
        );
        let frames = parse_jsonl(text.as_bytes(), "in.jsonl").unwrap();
        assert_eq!(frames.len(), 2);
        assert_eq!(
            frames[0].hands[0].keypoints().unwrap().points[5],
            [5.0, 1.0, 0.5]
        );
        assert_eq!(frames[1].hands[0].bbox, Some(BBox::new(1.0, 2.0, 3.0, 4.0)));
        assert_eq!(frames[1].timings_ms.as_ref().unwrap()["detect"], 4.5);
    }

    #[test]
    fn malformed_lines_are_reported_with_their_number() {
        let good = r#"{"frame": 0, "hands": []}"#;
        let text = format!("{good}\n{good}\n{{\"frame\": 2, \"hands\": [{{\"side\": \"up\"}}]}}\n");
        let e = parse_jsonl(text.as_bytes(), "x.jsonl")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.jsonl: line 3:"), "{e}");
        let short: Vec<[f64; 3]> = vec![[0.0; 3]; 20];
        let text = format!(
            "{good}\n{}\n",
            serde_json::json!({"frame": 1, "hands": [{"side": "left", "keypoints_2d": short}]})
        );
        let e = parse_jsonl(text.as_bytes(), "x.jsonl")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("21"), "{e}");
        let e = parse_jsonl("{\"frame\": 0, \"hands\": [".as_bytes(), "t.jsonl")
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.jsonl: line 1"), "{e}");
        assert!(read_jsonl("/nonexistent/in.jsonl").is_err());
    }

    #[test]
    fn the_wrist_pose_is_written_when_asked_and_read_back() {
        let mut fit = fit_like();
        let sk = HandSkeleton::default_for(HandSide::Right);
        fit.joints_3d = forward_kinematics(&sk, &fit.pose);
        let hand = HandRecord::from_fit(HandSide::Right, &Keypoints2d::default(), &fit);
        let unfitted = HandRecord::from_keypoints(HandSide::Left, &Keypoints2d::default());
        let frame = FrameRecord {
            frame: 4,
            hands: vec![hand, unfitted],
            ..Default::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("wrist.jsonl");
        let mut w = JsonlWriter::create(&p)
            .unwrap()
            .with_wrist_pose(true)
            .with_xr_joints(true);
        w.write_frame(&frame).unwrap();
        let back = read_jsonl(&p).unwrap().remove(0);
        assert!(back.hands[1].wrist_pose.is_none(), "no fit, no wrist pose");
        assert!(
            back.hands[0].xr_joints.is_some(),
            "both when both are asked"
        );
        let rec = back.hands[0].wrist_pose.as_ref().unwrap();
        // The core's numbers, row by row, in metres.
        let mano = monohand_core::wrist::WristConvention::Mano;
        let want = monohand_core::wrist::wrist_pose(&fit.pose, &fit.joints_3d, mano)
            .unwrap()
            .matrix_m();
        assert_eq!(rec.convention, "mano");
        for (r, row) in rec.matrix_m.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert_eq!(*v, want[(r, c)], "({r}, {c})");
            }
        }
        assert_eq!(rec.matrix_m[3], [0.0, 0.0, 0.0, 1.0]);
        let t = Vector3::new(rec.matrix_m[0][3], rec.matrix_m[1][3], rec.matrix_m[2][3]);
        assert!((t * 1000.0 - fit.joints_3d[0]).norm() < 1e-9);
        // In JSON: an object with the convention and four rows of four.
        let text = std::fs::read_to_string(&p).unwrap();
        let value: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        let entry = &value["hands"][0]["wrist_pose"];
        assert_eq!(entry["convention"], "mano");
        assert_eq!(entry["matrix_m"].as_array().unwrap().len(), 4);
        assert_eq!(entry["matrix_m"][2].as_array().unwrap().len(), 4);
        // Off by default: a plain writer's line has no such field.
        let plain = frame_json(&frame, "mem").unwrap();
        assert!(!plain.contains("wrist_pose"));
        assert_eq!(
            back,
            frame.clone().with_xr_joints().with_wrist_pose(),
            "read back as written"
        );
        // A NaN in it is refused like any other.
        let mut bad = frame.with_wrist_pose();
        bad.hands[0].wrist_pose.as_mut().unwrap().matrix_m[1][2] = f64::NAN;
        let e = frame_json(&bad, "mem").unwrap_err().to_string();
        assert!(e.contains("hands[0].wrist_pose"), "{e}");
    }

    #[test]
    fn xr_joints_are_written_when_asked_and_read_back() {
        let mut fit = fit_like();
        let sk = HandSkeleton::default_for(HandSide::Left)
            .scaled(0.93)
            .unwrap();
        fit.joints_3d = forward_kinematics(&sk, &fit.pose);
        let mut hand = HandRecord::from_fit(HandSide::Left, &Keypoints2d::default(), &fit);
        hand.hand_size = Some(HandSizeRecord {
            length_mm: sk.hand_length(),
            scale: 0.93,
            source: "scale".into(),
        });
        let unfitted = HandRecord::from_keypoints(HandSide::Right, &Keypoints2d::default());
        let frame = FrameRecord {
            frame: 2,
            hands: vec![hand, unfitted],
            ..Default::default()
        };
        let mut plain = JsonlWriter::new(Box::new(Vec::new()), "mem");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("xr.jsonl");
        let mut xr = JsonlWriter::create(&p).unwrap().with_xr_joints(true);
        plain.write_frame(&frame).unwrap();
        xr.write_frame(&frame).unwrap();
        let back = read_jsonl(&p).unwrap().remove(0);
        let joints = back.hands[0].xr_joints.as_ref().unwrap();
        assert_eq!(joints.len(), 26);
        assert!(back.hands[1].xr_joints.is_none(), "no fit, no joints");
        // The same numbers as the core gives for the fit's hand, in the same order.
        let want = monohand_core::xr::xr_joints(&sk, &fit.pose, &fit.joints_3d).unwrap();
        for (i, (j, w)) in joints.iter().zip(&want).enumerate() {
            assert_eq!(j.name, monohand_core::xr::XR_JOINT_NAMES[i]);
            assert!((Vector3::from(j.position_mm) - w.position).norm() < 1e-9);
            let q = w.orientation.quaternion();
            assert_eq!(j.orientation_xyzw, [q.i, q.j, q.k, q.w]);
            assert!((j.radius_mm - w.radius).abs() < 1e-12);
        }
        assert_eq!(joints[10].name, "index_tip");
        assert_eq!(Vector3::from(joints[10].position_mm), fit.joints_3d[8]);
        // Without the field the line is the plain writer's: nothing else changes, and a
        // reader that does not know the field reads the rest as before.
        let text = std::fs::read_to_string(&p).unwrap();
        let mut value: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        let entry = &value["hands"][0]["xr_joints"][1];
        assert_eq!(entry["name"], "wrist");
        assert!(entry["position_mm"].is_array() && entry["radius_mm"].is_f64());
        value["hands"][0]
            .as_object_mut()
            .unwrap()
            .remove("xr_joints");
        let expected = frame_json(&frame, "mem").unwrap();
        assert_eq!(
            value,
            serde_json::from_str::<serde_json::Value>(&expected).unwrap()
        );
        assert!(!expected.contains("xr_joints"));
        assert_eq!(back.with_xr_joints(), frame.clone().with_xr_joints());
        // A NaN among them is refused like any other.
        let mut bad = frame.with_xr_joints();
        bad.hands[0].xr_joints.as_mut().unwrap()[3].radius_mm = f64::NAN;
        let e = plain.write_frame(&bad).unwrap_err().to_string();
        assert!(e.contains("hands[0].xr_joints"), "{e}");
    }

    #[test]
    fn writer_refuses_non_finite_numbers() {
        let mut fit = fit_like();
        fit.joints_3d[2].x = f64::NAN;
        let rec = HandRecord::from_fit(HandSide::Left, &Keypoints2d::default(), &fit);
        let mut w = JsonlWriter::new(Box::new(Vec::new()), "mem");
        let e = w
            .write_frame(&FrameRecord {
                frame: 3,
                hands: vec![rec],
                ..Default::default()
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("frame 3 hands[0].joints_3d_mm"), "{e}");
        assert_eq!(w.frames_written(), 0);
    }
}
