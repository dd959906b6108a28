//! A Rerun recording (`.rrd`) of a run: every camera's intrinsics, pose and image, the 2D
//! keypoints in each view, the fitted 3D hands and each hand's distance over time, on one
//! timeline. `rerun hands.rrd` opens it; Rerun's own readers (the `rerun-sdk` wheel's
//! `rerun.dataframe`) read it back. Built with the `rerun` feature.
//!
//! Entities (3D in **metres**, in the first camera's frame, x right, y down, z forward):
//!
//! - `cameras/<name>`: the camera's pose (`Transform3D`, camera from world: the
//!   calibration's `R` and `t`), static;
//! - `cameras/<name>/image`: its `Pinhole` (static) and each frame's image (JPEG);
//! - `cameras/<name>/image/keypoints` and `.../bones`: each frame's 2D keypoints of every
//!   hand that view sees, as points and one line strip per finger;
//! - `hands/<id>/joints` and `hands/<id>/bones`: the fitted 21 joints and the fingers;
//! - `hands/<id>/distance_mm`: the hand's distance from the first camera (its joints'
//!   centre), millimetres.
//!
//! Timelines: `frame` (the frame index) and `time` (the frame's time in the video, for
//! videos). Every camera's image and keypoints get a row each frame (empty keypoints when
//! the view sees no hand), so every frame is a time point.

use super::{Output, Sink, SinkError};
use crate::base::frame::FittedFrame;
use monohand_core::camera::Camera;
use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_io::jsonl::{FrameRecord, HandRecord};
use monohand_io::palette::{side_color, FINGER_COLORS};
use monohand_vision::RgbImage;
use re_sdk as rr;
use re_types::archetypes as a;
use re_types::components::{Color, MediaType, TransformRelation, ViewCoordinates};
use std::path::Path;

/// JPEG quality of the images in the recording (about 40 kB a 640x480 frame).
const JPEG_QUALITY: u8 = 85;

/// Keypoints below this confidence are not drawn (as the overlay).
const MIN_CONFIDENCE: f64 = 0.3;

/// Writes a run into a Rerun recording file.
pub struct RerunSink {
    stream: rr::RecordingStream,
    /// Each view's entity name (`cameras/<name>`).
    names: Vec<String>,
    /// Each image is scaled by this before it is stored (1: as decoded).
    image_scale: f64,
    /// The cameras logged so far (their calibration is static: logged again only if
    /// it changes).
    logged: Vec<Option<Camera>>,
}

impl std::fmt::Debug for RerunSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RerunSink")
            .field("names", &self.names)
            .field("image_scale", &self.image_scale)
            .finish()
    }
}

/// Why a recording could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RerunError {
    /// The image scale is not in (0, 1].
    #[error("the image scale must be above 0 and at most 1, not {0}")]
    Scale(f64),
    /// Two views have the same name.
    #[error("two views are named {0:?}: each camera needs a name of its own")]
    Names(String),
    /// Rerun's recording stream failed.
    #[error(transparent)]
    Stream(#[from] rr::RecordingStreamError),
    /// An image could not be encoded.
    #[error("a frame's image could not be encoded: {0}")]
    Image(#[from] image::ImageError),
}

impl RerunSink {
    /// A recording at `path`; `names` name the views' cameras in order (views past them
    /// are `view<N>`, from 1), each image is scaled by `image_scale` (in (0, 1]).
    pub fn create(
        path: &Path,
        names: Vec<String>,
        image_scale: f64,
    ) -> Result<RerunSink, RerunError> {
        if !(image_scale > 0.0 && image_scale <= 1.0) {
            return Err(RerunError::Scale(image_scale));
        }
        for (k, n) in names.iter().enumerate() {
            if names[..k].contains(n) {
                return Err(RerunError::Names(n.clone()));
            }
        }
        let stream = rr::RecordingStreamBuilder::new("monohand").save(path)?;
        // The first camera's axes: x right, y down, z forward.
        stream.log_static("/", &a::ViewCoordinates::RDF())?;
        Ok(RerunSink {
            stream,
            names,
            image_scale,
            logged: Vec::new(),
        })
    }

    /// View `v`'s entity, `cameras/<name>`.
    fn camera_path(&self, v: usize) -> String {
        match self.names.get(v) {
            Some(n) => format!("cameras/{n}"),
            None => format!("cameras/view{}", v + 1),
        }
    }

    /// Logs view `v`'s camera, static, the first time and whenever it changes.
    fn log_camera(&mut self, v: usize, camera: &Camera) -> Result<(), RerunError> {
        if self.logged.len() <= v {
            self.logged.resize(v + 1, None);
        }
        if self.logged[v].as_ref() == Some(camera) {
            return Ok(());
        }
        let path = self.camera_path(v);
        let e = &camera.extrinsics;
        let r = e.rotation.matrix();
        // Rerun's 3x3 is column major.
        let columns: [f32; 9] = std::array::from_fn(|k| r[(k % 3, k / 3)] as f32);
        let t = e.translation / 1000.0;
        let pose = a::Transform3D::from_translation_mat3x3(
            [t.x as f32, t.y as f32, t.z as f32],
            re_types::datatypes::Mat3x3(columns),
        )
        .with_relation(TransformRelation::ChildFromParent);
        self.stream.log_static(path.as_str(), &pose)?;
        let s = self.image_scale;
        let k = &camera.intrinsics;
        let size = [
            (f64::from(k.width) * s) as f32,
            (f64::from(k.height) * s) as f32,
        ];
        let (fx, fy) = ((k.fx * s) as f32, (k.fy * s) as f32);
        // Pixel centres at integers (the project's) to Rerun's at half-integers.
        let (cx, cy) = (((k.cx + 0.5) * s) as f32, ((k.cy + 0.5) * s) as f32);
        // Column major, as Rerun's matrices.
        let pinhole = a::Pinhole::new([[fx, 0.0, 0.0], [0.0, fy, 0.0], [cx, cy, 1.0]])
            .with_resolution(size)
            .with_camera_xyz(ViewCoordinates::RDF)
            .with_image_plane_distance(0.3);
        self.stream.log_static(format!("{path}/image"), &pinhole)?;
        self.logged[v] = Some(*camera);
        Ok(())
    }

    /// View `v`'s image, scaled and encoded as JPEG.
    fn log_image(&self, v: usize, image: &RgbImage) -> Result<(), RerunError> {
        let scaled;
        let image = if self.image_scale < 1.0 {
            let w = ((f64::from(image.width()) * self.image_scale).round() as u32).max(1);
            let h = ((f64::from(image.height()) * self.image_scale).round() as u32).max(1);
            scaled = image::imageops::resize(image, w, h, image::imageops::FilterType::Triangle);
            &scaled
        } else {
            image
        };
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, JPEG_QUALITY)
            .encode_image(image)?;
        let encoded = a::EncodedImage::from_file_contents(jpeg).with_media_type(MediaType::JPEG);
        self.stream
            .log(format!("{}/image", self.camera_path(v)), &encoded)?;
        Ok(())
    }

    /// The 2D keypoints every hand has in view `v` (in the image's pixels as stored).
    fn log_keypoints(
        &self,
        v: usize,
        hands: &[(HandSide, [[f64; 3]; NUM_JOINTS])],
    ) -> Result<(), RerunError> {
        let s = self.image_scale;
        let mut points = Vec::new();
        let mut colors = Vec::new();
        let mut strips = Vec::new();
        let mut strip_colors = Vec::new();
        for (side, kp) in hands {
            let px = |j: usize| [((kp[j][0] + 0.5) * s) as f32, ((kp[j][1] + 0.5) * s) as f32];
            for j in (0..NUM_JOINTS).filter(|&j| kp[j][2] >= MIN_CONFIDENCE) {
                points.push(px(j));
                colors.push(Color::from_rgb(
                    side_color(*side)[0],
                    side_color(*side)[1],
                    side_color(*side)[2],
                ));
            }
            for (f, c) in FINGER_COLORS.iter().enumerate() {
                let chain = [0, 4 * f + 1, 4 * f + 2, 4 * f + 3, 4 * f + 4];
                if chain.iter().all(|&j| kp[j][2] >= MIN_CONFIDENCE) {
                    strips.push(chain.map(px).to_vec());
                    strip_colors.push(Color::from_rgb(c[0], c[1], c[2]));
                }
            }
        }
        let path = format!("{}/image", self.camera_path(v));
        let keypoints = a::Points2D::new(points)
            .with_colors(colors)
            .with_radii([2.5f32]);
        self.stream.log(format!("{path}/keypoints"), &keypoints)?;
        let bones = a::LineStrips2D::new(strips)
            .with_colors(strip_colors)
            .with_radii([1.0f32]);
        self.stream.log(format!("{path}/bones"), &bones)?;
        Ok(())
    }

    /// One fitted hand: its joints and fingers in metres, and its distance in mm.
    fn log_hand(
        &self,
        hand: &HandRecord,
        joints: &[[f64; 3]; NUM_JOINTS],
    ) -> Result<(), RerunError> {
        let path = match hand.id {
            Some(id) => format!("hands/{id}"),
            None => format!("hands/{}", hand.side),
        };
        let m = |j: usize| {
            let [x, y, z] = joints[j];
            [
                (x / 1000.0) as f32,
                (y / 1000.0) as f32,
                (z / 1000.0) as f32,
            ]
        };
        let [r, g, b] = side_color(hand.side);
        let points = a::Points3D::new((0..NUM_JOINTS).map(m))
            .with_colors([Color::from_rgb(r, g, b)])
            .with_radii([0.004f32]);
        self.stream.log(format!("{path}/joints"), &points)?;
        let strips: Vec<Vec<[f32; 3]>> = (0..5)
            .map(|f| {
                [0, 4 * f + 1, 4 * f + 2, 4 * f + 3, 4 * f + 4]
                    .map(m)
                    .to_vec()
            })
            .collect();
        let colors = FINGER_COLORS.map(|[r, g, b]| Color::from_rgb(r, g, b));
        let bones = a::LineStrips3D::new(strips)
            .with_colors(colors)
            .with_radii([0.002f32]);
        self.stream.log(format!("{path}/bones"), &bones)?;
        let centre = (0..3).map(|a| joints.iter().map(|j| j[a]).sum::<f64>() / NUM_JOINTS as f64);
        let distance = centre.map(|c| c * c).sum::<f64>().sqrt();
        self.stream
            .log(format!("{path}/distance_mm"), &a::Scalars::single(distance))?;
        Ok(())
    }

    /// Each view's hands' keypoints: the first view's from the record (its hands, the
    /// association's side), the others' from the fit's detections.
    fn view_keypoints(
        record: &FrameRecord,
        fitted: Option<&FittedFrame>,
        views: usize,
    ) -> Vec<Vec<(HandSide, [[f64; 3]; NUM_JOINTS])>> {
        let mut out: Vec<Vec<_>> = vec![Vec::new(); views.max(1)];
        out[0] = record
            .hands
            .iter()
            .filter(|h| h.keypoints_2d.iter().any(|p| p[2] > 0.0))
            .map(|h| (h.side, h.keypoints_2d))
            .collect();
        let Some(f) = fitted else {
            return out;
        };
        for hand in &f.hands {
            for &(v, k) in hand.views.iter().filter(|&&(v, _)| v > 0) {
                let detected = f.vision.views.get(v).and_then(|r| r.as_ref().ok());
                if let (Some(d), Some(slot)) = (
                    detected.and_then(|d| d.detections.hands.get(k)),
                    out.get_mut(v),
                ) {
                    slot.push((hand.side, d.keypoints.points));
                }
            }
        }
        out
    }
}

impl Sink for RerunSink {
    fn wants_images(&self) -> bool {
        true
    }

    fn wants_every_view(&self) -> bool {
        true
    }

    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        let record = frame.record;
        self.stream.set_time_sequence("frame", record.frame as i64);
        if let Some(t) = record.time_s {
            self.stream.set_duration_secs("time", t);
        }
        for (v, camera) in frame.cameras.iter().enumerate() {
            self.log_camera(v, camera)?;
        }
        let views = frame.cameras.len().max(1 + frame.other_images.len());
        let images =
            std::iter::once(frame.image).chain(frame.other_images.iter().map(Option::as_ref));
        for (v, image) in images.enumerate() {
            if let Some(image) = image {
                self.log_image(v, image)?;
            }
        }
        for (v, hands) in Self::view_keypoints(record, frame.fitted, views)
            .iter()
            .enumerate()
        {
            self.log_keypoints(v, hands)?;
        }
        for hand in &record.hands {
            if let Some(joints) = &hand.joints_3d_mm {
                self.log_hand(hand, joints)?;
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        self.stream.flush_blocking()?;
        Ok(())
    }
}
