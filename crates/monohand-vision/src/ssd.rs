//! The single-shot detector shared by the palm and face detectors ([`SsdDetector`]): anchor
//! generation, box + keypoint decoding, sigmoid scores, and weighted non-maximum suppression — MediaPipe's
//! `SsdAnchorsCalculator`, `TensorsToDetectionsCalculator` and `NonMaxSuppressionCalculator`
//! for the configurations these models use (fixed anchor size 1, two anchors per cell).

use monohand_core::bbox::BBox;

/// An anchor centre in normalised input coordinates (its width and height are fixed to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// Centre x in `[0, 1]`.
    pub x: f32,
    /// Centre y in `[0, 1]`.
    pub y: f32,
}

/// SSD anchors for a square input of `input_size` pixels. Consecutive layers with the same
/// stride share one grid (as in MediaPipe), each layer contributing two anchors per cell
/// (aspect ratio 1 and the interpolated scale), all of size 1.
///
/// Palm detector: `input_size` 192, strides `[8, 16, 16, 16]` → 24·24·2 + 12·12·6 = 2016.
/// BlazeFace short range: 128, `[8, 16, 16, 16]` → 16·16·2 + 8·8·6 = 896.
pub fn ssd_anchors(input_size: usize, strides: &[usize]) -> Vec<Anchor> {
    let mut anchors = Vec::new();
    let mut layer = 0;
    while layer < strides.len() {
        let stride = strides[layer];
        let mut per_cell = 0;
        while layer < strides.len() && strides[layer] == stride {
            per_cell += 2;
            layer += 1;
        }
        let cells = input_size.div_ceil(stride);
        for y in 0..cells {
            for x in 0..cells {
                let a = Anchor {
                    x: (x as f32 + 0.5) / cells as f32,
                    y: (y as f32 + 0.5) / cells as f32,
                };
                anchors.extend(std::iter::repeat_n(a, per_cell));
            }
        }
    }
    anchors
}

/// A decoded detection in normalised input coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct RawDetection {
    /// Sigmoid score.
    pub score: f32,
    /// Box `[x_center, y_center, width, height]`.
    pub bbox: [f32; 4],
    /// Keypoints `[x, y]`.
    pub keypoints: Vec<[f32; 2]>,
}

impl RawDetection {
    /// The box as a [`BBox`] (normalised input coordinates).
    pub fn as_bbox(&self) -> BBox {
        let [cx, cy, w, h] = self.bbox.map(f64::from);
        BBox::from_centre_size([cx, cy], w, h)
    }

    /// Intersection over union with another detection's box.
    pub fn iou(&self, other: &RawDetection) -> f64 {
        self.as_bbox().iou(&other.as_bbox())
    }
}

/// Logistic function with MediaPipe's score clipping to ±100 before the exponential.
pub fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x.clamp(-100.0, 100.0)).exp())
}

/// Decodes raw regressors (`anchors.len() x coords`, values in input pixels relative to the
/// anchor) and raw score logits into detections scoring at least `min_score`.
///
/// Layout per anchor: `dx, dy, w, h, kx0, ky0, kx1, ky1, ...` (x before y).
pub fn decode(
    raw_boxes: &[f32],
    raw_scores: &[f32],
    anchors: &[Anchor],
    input_size: usize,
    num_keypoints: usize,
    min_score: f32,
) -> Vec<RawDetection> {
    let coords = 4 + 2 * num_keypoints;
    let s = input_size as f32;
    let mut out = Vec::new();
    for (i, (a, &logit)) in anchors.iter().zip(raw_scores).enumerate() {
        let score = sigmoid(logit);
        if score < min_score {
            continue;
        }
        let Some(r) = raw_boxes.get(i * coords..(i + 1) * coords) else {
            break;
        };
        let keypoints = (0..num_keypoints)
            .map(|k| [r[4 + 2 * k] / s + a.x, r[5 + 2 * k] / s + a.y])
            .collect();
        out.push(RawDetection {
            score,
            bbox: [r[0] / s + a.x, r[1] / s + a.y, r[2] / s, r[3] / s],
            keypoints,
        });
    }
    out
}

/// Weighted non-maximum suppression (MediaPipe's `WEIGHTED` algorithm): detections are
/// taken in decreasing score order; each one absorbs every remaining detection overlapping it
/// with IoU above `iou_threshold`, and its box and keypoints become the score-weighted mean of
/// the group while its score stays the group's best.
pub fn weighted_nms(mut dets: Vec<RawDetection>, iou_threshold: f32) -> Vec<RawDetection> {
    dets.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut out = Vec::new();
    while !dets.is_empty() {
        let top = dets[0].clone();
        let (group, rest): (Vec<_>, Vec<_>) = dets
            .into_iter()
            .partition(|d| d.iou(&top) > f64::from(iou_threshold));
        dets = rest;
        let group = if group.is_empty() {
            vec![top.clone()]
        } else {
            group
        };
        let total: f32 = group.iter().map(|d| d.score).sum();
        let mut merged = top.clone();
        merged.bbox = [0.0; 4];
        merged.keypoints.iter_mut().for_each(|k| *k = [0.0, 0.0]);
        for d in &group {
            let w = d.score / total;
            for (m, v) in merged.bbox.iter_mut().zip(d.bbox) {
                *m += w * v;
            }
            for (m, v) in merged.keypoints.iter_mut().zip(&d.keypoints) {
                m[0] += w * v[0];
                m[1] += w * v[1];
            }
        }
        out.push(merged);
    }
    out
}

/// One detection of an [`SsdDetector`], in image pixels (continuous coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct SsdDetection<const K: usize> {
    /// Score in `[0, 1]`.
    pub score: f32,
    /// The box (continuous coordinates).
    pub bbox: BBox,
    /// The `K` keypoints `[x, y]`.
    pub keypoints: [[f64; 2]; K],
}

/// A single-shot detector of MediaPipe's kind (BlazePalm, BlazeFace) with `K` keypoints:
/// a square letterboxed input, two anchors per cell at strides 8, 16, 16, 16, a box and
/// `K` keypoints per anchor, weighted non-maximum suppression. The palm and face detectors
/// are this with their own outputs.
#[derive(Debug, Clone)]
pub struct SsdDetector<const K: usize> {
    net: crate::network::TfliteNet,
    anchors: Vec<Anchor>,
    size: usize,
    normalization: crate::warp::Normalization,
    name: &'static str,
}

impl<const K: usize> SsdDetector<K> {
    /// Wraps a loaded network; `name` names it in errors.
    pub fn new(
        net: crate::network::TfliteNet,
        normalization: crate::warp::Normalization,
        name: &'static str,
    ) -> crate::error::Result<Self> {
        let [_, h, w, c] = net.input_shape();
        if h != w || c != 3 {
            return Err(crate::error::VisionError::ModelOutput(format!(
                "{name} input {h}x{w}x{c}, expected square RGB"
            )));
        }
        Ok(SsdDetector {
            anchors: ssd_anchors(h, &[8, 16, 16, 16]),
            net,
            size: h,
            normalization,
            name,
        })
    }

    /// The letterboxed input tensor for `img` and the map from input pixels to image pixels.
    pub fn preprocess(
        &self,
        img: &image::RgbImage,
    ) -> crate::error::Result<(tract_core::prelude::Tensor, crate::geometry::Affine2)> {
        let to_image = crate::geometry::letterbox_to_image(img.width(), img.height(), self.size);
        let input = self
            .net
            .input_with(|buf| self.letterbox_into(img, &to_image, buf))?;
        Ok((input, to_image))
    }

    /// Warps the letterboxed image into `buf`, a `size x size x 3` network input.
    fn letterbox_into(
        &self,
        img: &image::RgbImage,
        to_image: &crate::geometry::Affine2,
        buf: &mut [f32],
    ) {
        crate::warp::warp_into(img, to_image, self.size, self.size, self.normalization, buf)
    }

    /// Decoding, NMS and mapping back to the image of raw network outputs.
    pub fn postprocess<S: AsRef<[f32]>>(
        &self,
        out: &[S],
        to_image: &crate::geometry::Affine2,
        min_score: f32,
        nms_iou: f32,
    ) -> crate::error::Result<Vec<SsdDetection<K>>> {
        let n = self.anchors.len();
        let (boxes, scores) = match out {
            [b, s] if b.as_ref().len() == n * (4 + 2 * K) && s.as_ref().len() == n => {
                (b.as_ref(), s.as_ref())
            }
            _ => {
                return Err(crate::error::VisionError::ModelOutput(format!(
                    "{} outputs are not [{n}x{}, {n}]",
                    self.name,
                    4 + 2 * K
                )))
            }
        };
        let raw = decode(boxes, scores, &self.anchors, self.size, K, min_score);
        let s = self.size as f64;
        Ok(weighted_nms(raw, nms_iou)
            .into_iter()
            .map(|d| {
                let p = |x: f32, y: f32| to_image.apply([x as f64 * s, y as f64 * s]);
                // The corners in f32, as the network's numbers are (MediaPipe's arithmetic).
                let [cx, cy, w, h] = d.bbox;
                let a = p(cx - w / 2.0, cy - h / 2.0);
                let b = p(cx + w / 2.0, cy + h / 2.0);
                let mut keypoints = [[0.0; 2]; K];
                for (k, v) in keypoints.iter_mut().zip(&d.keypoints) {
                    *k = p(v[0], v[1]);
                }
                SsdDetection {
                    score: d.score,
                    bbox: BBox::new(a[0], a[1], b[0], b[1]),
                    keypoints,
                }
            })
            .collect())
    }

    /// Detections in `img`, best first.
    pub fn detect(
        &self,
        img: &image::RgbImage,
        min_score: f32,
        nms_iou: f32,
    ) -> crate::error::Result<Vec<SsdDetection<K>>> {
        let to_image = crate::geometry::letterbox_to_image(img.width(), img.height(), self.size);
        // The letterboxed crop straight into the network's reused input buffer.
        self.net.run_pooled(
            |buf| self.letterbox_into(img, &to_image, buf),
            |out| {
                let outputs: [&[f32]; 2] = out.first()?;
                self.postprocess(&outputs, &to_image, min_score, nms_iou)
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn palm_and_face_anchor_counts() {
        let palm = ssd_anchors(192, &[8, 16, 16, 16]);
        assert_eq!(palm.len(), 2016);
        assert_eq!(
            palm[0],
            Anchor {
                x: 0.5 / 24.0,
                y: 0.5 / 24.0
            }
        );
        assert_eq!(palm[1], palm[0]);
        assert_eq!(
            palm[1152],
            Anchor {
                x: 0.5 / 12.0,
                y: 0.5 / 12.0
            }
        );
        assert_eq!(palm[1157], palm[1152]);
        assert_ne!(palm[1158], palm[1152]);
        assert_eq!(ssd_anchors(128, &[8, 16, 16, 16]).len(), 896);
    }

    #[test]
    fn decoding_offsets_from_anchor() {
        let anchors = [Anchor { x: 0.5, y: 0.25 }];
        let raw = [19.2, -19.2, 96.0, 48.0, 0.0, 9.6];
        let d = decode(&raw, &[2.0], &anchors, 192, 1, 0.5);
        assert_eq!(d.len(), 1);
        let d = &d[0];
        assert!((d.score - sigmoid(2.0)).abs() < 1e-7);
        let want = [0.6, 0.15, 0.5, 0.25];
        for (g, w) in d.bbox.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{:?}", d.bbox);
        }
        assert!((d.keypoints[0][1] - 0.3).abs() < 1e-6);
        assert!(decode(&raw, &[-1.0], &anchors, 192, 1, 0.5).is_empty());
    }

    #[test]
    fn weighted_nms_merges_overlaps_and_keeps_separate_boxes() {
        let d = |score, cx| RawDetection {
            score,
            bbox: [cx, 0.5, 0.2, 0.2],
            keypoints: vec![[cx, 0.5]],
        };
        let out = weighted_nms(vec![d(0.6, 0.52), d(0.9, 0.5), d(0.8, 0.1)], 0.3);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].score, 0.9);
        let want = (0.9 * 0.5 + 0.6 * 0.52) / 1.5;
        assert!((out[0].bbox[0] - want).abs() < 1e-6);
        assert!((out[0].keypoints[0][0] - want).abs() < 1e-6);
        assert_eq!(out[1].bbox[0], 0.1);
    }
}
