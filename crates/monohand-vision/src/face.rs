//! BlazeFace (short range) for head boxes: letterboxed 128x128 input in `[-1, 1]`, 896 SSD
//! anchors, a face box and 6 face keypoints (right eye, left eye, nose tip, mouth centre, right
//! ear tragion, left ear tragion). The head box is the face box widened and raised to cover
//! hair and ears (a fixed geometric rule, see [`HEAD_FROM_FACE`]), used as context only.
//!
//! The short-range model is meant for faces filling a good part of the frame (within ~2 m of
//! a webcam); small faces in crowd photos are missed.

use image::RgbImage;
use monohand_core::bbox::BBox;

use crate::error::Result;
use crate::network::TfliteNet;
use crate::ssd::SsdDetector;
use crate::warp::Normalization;

/// Default minimum face score (see [`FaceDetector::min_score`]).
pub const DEFAULT_MIN_FACE_SCORE: f32 = 0.7;

/// Head box from face box: `[width factor, height factor, upward shift in face heights]`.
pub const HEAD_FROM_FACE: [f64; 3] = [1.6, 1.9, 0.25];

/// A face / head found in an image (image pixels, continuous coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct HeadDetection {
    /// Detector score in `[0, 1]`.
    pub score: f32,
    /// The face box as detected.
    pub face_box: BBox,
    /// The head box derived from it.
    pub head_box: BBox,
    /// Six face keypoints `[x, y]`.
    pub keypoints: [[f64; 2]; 6],
}

/// The face detection network (BlazeFace): an [`SsdDetector`] with 6 keypoints.
#[derive(Debug, Clone)]
pub struct FaceDetector {
    ssd: SsdDetector<6>,
    /// Minimum score. MediaPipe uses 0.5; on the project's photos every detection between 0.5
    /// and 0.65 was a false positive (a raised palm, a pan, a torso) and every real face scored
    /// above 0.72, so the default is [`DEFAULT_MIN_FACE_SCORE`].
    pub min_score: f32,
}

/// Overlap above which two faces are one (MediaPipe's face detection graph: 0.3).
const FACE_NMS_IOU: f32 = 0.3;

impl FaceDetector {
    /// Wraps a loaded face detection network.
    pub fn new(net: TfliteNet) -> Result<Self> {
        Ok(FaceDetector {
            ssd: SsdDetector::new(net, Normalization::SIGNED, "face detector")?,
            min_score: DEFAULT_MIN_FACE_SCORE,
        })
    }

    /// Faces in `img`, best first.
    pub fn detect(&self, img: &RgbImage) -> Result<Vec<HeadDetection>> {
        let found = self.ssd.detect(img, self.min_score, FACE_NMS_IOU)?;
        Ok(found
            .into_iter()
            .map(|d| HeadDetection {
                score: d.score,
                face_box: d.bbox,
                head_box: head_from_face(d.bbox),
                keypoints: d.keypoints,
            })
            .collect())
    }
}

/// Applies [`HEAD_FROM_FACE`] to a face box.
pub fn head_from_face(f: BBox) -> BBox {
    let (w, h) = (f.width(), f.height());
    let [cx, cy] = f.centre();
    BBox::from_centre_size(
        [cx, cy - HEAD_FROM_FACE[2] * h],
        w * HEAD_FROM_FACE[0],
        h * HEAD_FROM_FACE[1],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_box_contains_face_box_and_extends_upwards() {
        let f = BBox::new(100.0, 100.0, 150.0, 160.0);
        let h = head_from_face(f);
        assert!(h.x_min < f.x_min && h.y_min < f.y_min && h.x_max > f.x_max);
        assert!(h.y_max >= f.y_max - 1e-9);
        assert!(f.y_min - h.y_min > h.y_max - f.y_max);
        assert!((h.fraction_covered_by(&f) - f.area() / h.area()).abs() < 1e-12);
    }
}
