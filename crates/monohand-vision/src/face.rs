//! BlazeFace (short range) for head boxes: letterboxed 128x128 input in `[-1, 1]`, 896 SSD
//! anchors, a face box and 6 face keypoints (right eye, left eye, nose tip, mouth centre, right
//! ear tragion, left ear tragion). The head box is the face box widened and raised to cover
//! hair and ears (a fixed geometric rule, see [`HEAD_FROM_FACE`]), used as context only.
//!
//! The short-range model is meant for faces filling a good part of the frame (within ~2 m of
//! a webcam); small faces in crowd photos are missed.

use image::RgbImage;

use crate::error::{Result, VisionError};
use crate::geometry::letterbox_to_image;
use crate::network::TfliteNet;
use crate::ssd::{decode, ssd_anchors, weighted_nms, Anchor};
use crate::warp::{warp_into, Normalization};

/// Default minimum face score (see [`FaceDetector::min_score`]).
pub const DEFAULT_MIN_FACE_SCORE: f32 = 0.7;

/// Head box from face box: `[width factor, height factor, upward shift in face heights]`.
pub const HEAD_FROM_FACE: [f64; 3] = [1.6, 1.9, 0.25];

/// A face / head found in an image (image pixels, continuous coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct HeadDetection {
    /// Detector score in `[0, 1]`.
    pub score: f32,
    /// The face box `[xmin, ymin, xmax, ymax]` as detected.
    pub face_box: [f64; 4],
    /// The head box `[xmin, ymin, xmax, ymax]` derived from it.
    pub head_box: [f64; 4],
    /// Six face keypoints `[x, y]`.
    pub keypoints: [[f64; 2]; 6],
}

/// The face detection network.
#[derive(Debug, Clone)]
pub struct FaceDetector {
    net: TfliteNet,
    anchors: Vec<Anchor>,
    size: usize,
    /// Minimum score. MediaPipe uses 0.5; on the project's photos every detection between 0.5
    /// and 0.65 was a false positive (a raised palm, a pan, a torso) and every real face scored
    /// above 0.72, so the default is [`DEFAULT_MIN_FACE_SCORE`].
    pub min_score: f32,
}

impl FaceDetector {
    /// Wraps an imported `face_detection_short_range.tflite`.
    pub fn new(net: TfliteNet) -> Result<Self> {
        let [_, h, w, c] = net.input_shape();
        if h != w || c != 3 {
            return Err(VisionError::ModelOutput(format!(
                "face detector input {h}x{w}x{c}"
            )));
        }
        Ok(FaceDetector {
            anchors: ssd_anchors(h, &[8, 16, 16, 16]),
            net,
            size: h,
            min_score: DEFAULT_MIN_FACE_SCORE,
        })
    }

    /// Faces in `img`, best first.
    pub fn detect(&self, img: &RgbImage) -> Result<Vec<HeadDetection>> {
        let to_image = letterbox_to_image(img.width(), img.height(), self.size);
        let input = self.net.input_with(|buf| {
            warp_into(
                img,
                &to_image,
                self.size,
                self.size,
                Normalization::SIGNED,
                buf,
            )
        })?;
        let out = self.net.run(input)?;
        let (boxes, scores) = match out.as_slice() {
            [b, s] if b.len() == self.anchors.len() * 16 && s.len() == self.anchors.len() => (b, s),
            _ => {
                return Err(VisionError::ModelOutput(
                    "face detector outputs are not [896x16, 896]".into(),
                ))
            }
        };
        let raw = decode(boxes, scores, &self.anchors, self.size, 6, self.min_score);
        let s = self.size as f64;
        Ok(weighted_nms(raw, 0.3)
            .into_iter()
            .map(|d| {
                let p = |x: f32, y: f32| to_image.apply([x as f64 * s, y as f64 * s]);
                let [cx, cy, w, h] = d.bbox;
                let a = p(cx - w / 2.0, cy - h / 2.0);
                let b = p(cx + w / 2.0, cy + h / 2.0);
                let mut keypoints = [[0.0; 2]; 6];
                for (k, v) in keypoints.iter_mut().zip(&d.keypoints) {
                    *k = p(v[0], v[1]);
                }
                let face_box = [a[0], a[1], b[0], b[1]];
                HeadDetection {
                    score: d.score,
                    face_box,
                    head_box: head_from_face(face_box),
                    keypoints,
                }
            })
            .collect())
    }
}

/// Applies [`HEAD_FROM_FACE`] to a face box.
pub fn head_from_face(f: [f64; 4]) -> [f64; 4] {
    let (w, h) = (f[2] - f[0], f[3] - f[1]);
    let cx = (f[0] + f[2]) / 2.0;
    let cy = (f[1] + f[3]) / 2.0 - HEAD_FROM_FACE[2] * h;
    let (hw, hh) = (w * HEAD_FROM_FACE[0] / 2.0, h * HEAD_FROM_FACE[1] / 2.0);
    [cx - hw, cy - hh, cx + hw, cy + hh]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_box_contains_face_box_and_extends_upwards() {
        let f = [100.0, 100.0, 150.0, 160.0];
        let h = head_from_face(f);
        assert!(h[0] < f[0] && h[1] < f[1] && h[2] > f[2] && h[3] >= f[3] - 1e-9);
        assert!(f[1] - h[1] > h[3] - f[3]);
    }
}
