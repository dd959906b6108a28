//! MediaPipe palm detector: letterboxed 192x192 input in `[0, 1]`, 2016 SSD anchors, 7 palm
//! keypoints, and the conversion of a palm detection into the rotated, enlarged square region
//! the landmark model crops (MediaPipe's `DetectionsToRectsCalculator` +
//! `RectTransformationCalculator` with scale 2.6 and shift_y −0.5).

use image::RgbImage;
use monohand_core::bbox::BBox;

use crate::error::Result;
use crate::geometry::{normalize_angle, Affine2, RotatedRect};
use crate::network::TfliteNet;
use crate::ssd::{SsdDetection, SsdDetector};
use crate::warp::Normalization;

/// Index of the wrist among the 7 palm keypoints.
pub const PALM_WRIST: usize = 0;
/// Index of the middle-finger MCP among the 7 palm keypoints.
pub const PALM_MIDDLE_MCP: usize = 2;
/// ROI enlargement around the palm box.
pub const ROI_SCALE: f64 = 2.6;
/// ROI shift along the hand's up axis, in palm-box heights (negative: towards the fingers).
pub const ROI_SHIFT_Y: f64 = -0.5;

/// A palm found in an image, in image pixels (continuous coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct PalmDetection {
    /// Detector score in `[0, 1]`.
    pub score: f32,
    /// Axis-aligned palm box.
    pub bbox: BBox,
    /// The 7 palm keypoints (wrist, index MCP, middle MCP, ring MCP, pinky MCP, thumb CMC,
    /// thumb MCP — MediaPipe's order).
    pub keypoints: [[f64; 2]; 7],
}

impl PalmDetection {
    /// Rotation that turns the wrist → middle-MCP direction to point up in the crop.
    pub fn rotation(&self) -> f64 {
        let [x0, y0] = self.keypoints[PALM_WRIST];
        let [x1, y1] = self.keypoints[PALM_MIDDLE_MCP];
        normalize_angle(std::f64::consts::FRAC_PI_2 - (-(y1 - y0)).atan2(x1 - x0))
    }

    /// The square region handed to the landmark model: the palm box turned by
    /// [`Self::rotation`], shifted half a box towards the fingers and enlarged 2.6 times
    /// around its long side.
    pub fn hand_roi(&self) -> RotatedRect {
        let (w, h) = (self.bbox.width(), self.bbox.height());
        let [cx, cy] = self.bbox.centre();
        let r = self.rotation();
        let (s, c) = r.sin_cos();
        let center = [cx - h * ROI_SHIFT_Y * s, cy + h * ROI_SHIFT_Y * c];
        let side = w.max(h) * ROI_SCALE;
        RotatedRect {
            center,
            width: side,
            height: side,
            rotation: r,
        }
    }
}

/// Score and overlap thresholds of the palm detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PalmOptions {
    /// Minimum sigmoid score (MediaPipe: 0.5).
    pub min_score: f32,
    /// IoU above which detections are merged (MediaPipe: 0.3).
    pub nms_iou: f32,
}

impl Default for PalmOptions {
    fn default() -> Self {
        PalmOptions {
            min_score: 0.5,
            nms_iou: 0.3,
        }
    }
}

/// The palm detection network: an [`SsdDetector`] with 7 keypoints.
#[derive(Debug, Clone)]
pub struct PalmDetector {
    ssd: SsdDetector<7>,
    /// Thresholds.
    pub options: PalmOptions,
}

impl PalmDetector {
    /// Wraps a loaded palm detection network.
    pub fn new(net: TfliteNet, options: PalmOptions) -> Result<Self> {
        Ok(PalmDetector {
            ssd: SsdDetector::new(net, Normalization::UNIT, "palm detector")?,
            options,
        })
    }

    /// The letterboxed input tensor for `img` and the map from input pixels to image pixels.
    pub fn preprocess(&self, img: &RgbImage) -> Result<(tract_core::prelude::Tensor, Affine2)> {
        self.ssd.preprocess(img)
    }

    /// Palms in `img`, best first.
    pub fn detect(&self, img: &RgbImage) -> Result<Vec<PalmDetection>> {
        let found = self
            .ssd
            .detect(img, self.options.min_score, self.options.nms_iou)?;
        Ok(found.into_iter().map(PalmDetection::from).collect())
    }

    /// Decoding, NMS and mapping back to the image of raw network outputs.
    pub fn postprocess<S: AsRef<[f32]>>(
        &self,
        out: &[S],
        to_image: &Affine2,
    ) -> Result<Vec<PalmDetection>> {
        let found =
            self.ssd
                .postprocess(out, to_image, self.options.min_score, self.options.nms_iou)?;
        Ok(found.into_iter().map(PalmDetection::from).collect())
    }
}

impl From<SsdDetection<7>> for PalmDetection {
    fn from(d: SsdDetection<7>) -> PalmDetection {
        PalmDetection {
            score: d.score,
            bbox: d.bbox,
            keypoints: d.keypoints,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn palm(wrist: [f64; 2], middle: [f64; 2]) -> PalmDetection {
        let mut keypoints = [[0.0; 2]; 7];
        keypoints[PALM_WRIST] = wrist;
        keypoints[PALM_MIDDLE_MCP] = middle;
        PalmDetection {
            score: 0.9,
            bbox: BBox::new(90.0, 90.0, 110.0, 110.0),
            keypoints,
        }
    }

    #[test]
    fn upright_hand_has_no_rotation_and_roi_moves_up() {
        let p = palm([100.0, 110.0], [100.0, 90.0]);
        assert!(p.rotation().abs() < 1e-12);
        let roi = p.hand_roi();
        assert!((roi.center[0] - 100.0).abs() < 1e-9);
        assert!((roi.center[1] - 90.0).abs() < 1e-9);
        assert!((roi.width - 52.0).abs() < 1e-9);
    }

    #[test]
    fn hand_pointing_right_turns_a_quarter_and_roi_moves_right() {
        let p = palm([90.0, 100.0], [110.0, 100.0]);
        assert!((p.rotation() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let roi = p.hand_roi();
        assert!((roi.center[0] - 110.0).abs() < 1e-9, "{:?}", roi.center);
        assert!((roi.center[1] - 100.0).abs() < 1e-9);
        // The crop's up direction points along the fingers.
        let m = roi.crop_to_image(224, 224);
        let up = m.apply_vector([0.0, -1.0]);
        assert!(up[0] > 0.0 && up[1].abs() < 1e-9);
    }
}
