//! Heatmap keypoint networks (OpenPose-hand style): one heatmap per joint, keypoint = peak
//! with sub-pixel refinement, confidence = peak value.
//!
//! [`decode_heatmaps`] is the pure decoding step. With the `onnx` feature,
//! [`OnnxHeatmapEstimator`] runs any ONNX model given by path whose output is
//! `[1, J, H, W]` heatmaps (J ≥ 21; extra channels such as OpenPose's background are ignored)
//! on the same rotated hand crop as the MediaPipe model, as a [`crate::KeypointEstimator`].
//! Networks trained on one side only are fed a mirrored crop for the other side (the crop is
//! flipped by the warp itself, and coordinates are mapped back through the same flip).

use crate::landmarks::NUM_LANDMARKS;

/// Peak of each of the first 21 heatmaps in `data` (`channels x height x width`, row-major):
/// `[x, y, peak]` in heatmap cells (continuous coordinates: cell `i` spans `[i, i+1)`), refined
/// by a parabola through the peak and its two neighbours along each axis (offset clamped to
/// ±0.5 cell).
///
/// Returns `None` if there are fewer than 21 channels or the sizes disagree.
pub fn decode_heatmaps(
    data: &[f32],
    channels: usize,
    height: usize,
    width: usize,
) -> Option<[[f64; 3]; NUM_LANDMARKS]> {
    if channels < NUM_LANDMARKS
        || data.len() != channels * height * width
        || height == 0
        || width == 0
    {
        return None;
    }
    let mut out = [[0.0; 3]; NUM_LANDMARKS];
    for (j, o) in out.iter_mut().enumerate() {
        let map = &data[j * height * width..(j + 1) * height * width];
        let (best, &peak) = map.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        let (bx, by) = (best % width, best / width);
        let at = |x: usize, y: usize| map[y * width + x] as f64;
        let refine = |l: Option<f64>, c: f64, r: Option<f64>| -> f64 {
            match (l, r) {
                (Some(l), Some(r)) => {
                    let denom = l - 2.0 * c + r;
                    if denom < -1e-12 {
                        (0.5 * (l - r) / denom).clamp(-0.5, 0.5)
                    } else {
                        0.0
                    }
                }
                _ => 0.0,
            }
        };
        let c = peak as f64;
        let dx = refine(
            (bx > 0).then(|| at(bx - 1, by)),
            c,
            (bx + 1 < width).then(|| at(bx + 1, by)),
        );
        let dy = refine(
            (by > 0).then(|| at(bx, by - 1)),
            c,
            (by + 1 < height).then(|| at(bx, by + 1)),
        );
        *o = [bx as f64 + 0.5 + dx, by as f64 + 0.5 + dy, c];
    }
    Some(out)
}

/// The input size of a network written `WxH` (e.g. `368x368`, `256X192`), both positive.
pub fn parse_input_size(s: &str) -> Option<(usize, usize)> {
    let parse = |t: &str| t.trim().parse::<usize>().ok().filter(|&n| n > 0);
    let (w, h) = s.split_once(['x', 'X'])?;
    Some((parse(w)?, parse(h)?))
}

#[cfg(feature = "onnx")]
pub use onnx_model::{HeatmapModelConfig, OnnxHeatmapEstimator};

#[cfg(feature = "onnx")]
mod onnx_model {
    use std::path::Path;

    use image::RgbImage;
    use monohand_core::hand_model::HandSide;
    use tract_onnx::prelude::*;

    use super::decode_heatmaps;
    use crate::error::{Result, VisionError};
    use crate::geometry::Affine2;
    use crate::landmarks::NUM_LANDMARKS;
    use crate::pipeline::{HandKeypoints, HandRegion, KeypointEstimator};
    use crate::warp::{warp_into, Normalization};

    /// How to feed an ONNX heatmap network.
    #[derive(Clone, Debug, PartialEq)]
    pub struct HeatmapModelConfig {
        /// Input width and height in pixels (OpenPose hand: 368 x 368).
        pub input_size: (usize, usize),
        /// Normalisation of 0..255 values (OpenPose: `x/256 − 0.5`).
        pub normalization: Normalization,
        /// Whether the network expects BGR channel order (OpenPose/Caffe models do).
        pub bgr: bool,
        /// The only side the network was trained on, if any; the other side is mirrored.
        pub trained_side: Option<HandSide>,
    }

    impl Default for HeatmapModelConfig {
        fn default() -> Self {
            HeatmapModelConfig {
                input_size: (368, 368),
                normalization: Normalization {
                    scale: 1.0 / 256.0,
                    offset: -0.5,
                },
                bgr: true,
                trained_side: None,
            }
        }
    }

    /// An ONNX heatmap network as a [`KeypointEstimator`].
    #[derive(Debug, Clone)]
    pub struct OnnxHeatmapEstimator {
        plan: Arc<TypedSimplePlan>,
        config: HeatmapModelConfig,
    }

    impl OnnxHeatmapEstimator {
        /// Loads `path` (ONNX, NCHW input) with a fixed input shape `[1, 3, h, w]`.
        pub fn load(path: &Path, config: HeatmapModelConfig) -> Result<Self> {
            let (w, h) = config.input_size;
            let fail = |e: TractError| {
                VisionError::Inference(format!("loading ONNX model {}: {e:#}", path.display()))
            };
            let plan = tract_onnx::onnx()
                .model_for_path(path)
                .and_then(|m| m.with_input_fact(0, f32::fact([1, 3, h, w]).into()))
                .and_then(|m| m.into_optimized())
                .and_then(|m| m.into_runnable())
                .map_err(fail)?;
            Ok(OnnxHeatmapEstimator { plan, config })
        }

        fn mirrored(&self, side: Option<HandSide>) -> bool {
            matches!((self.config.trained_side, side), (Some(t), Some(s)) if t != s)
        }
    }

    impl KeypointEstimator for OnnxHeatmapEstimator {
        fn estimate(
            &self,
            img: &RgbImage,
            region: &HandRegion,
            side_hint: Option<HandSide>,
        ) -> Result<HandKeypoints> {
            let (w, h) = self.config.input_size;
            let mut crop = region.roi.crop_to_image(w, h);
            if self.mirrored(side_hint) {
                crop = crop.compose(&Affine2::mirror_x(w as f64));
            }
            let mut hwc = vec![0f32; w * h * 3];
            warp_into(img, &crop, w, h, self.config.normalization, &mut hwc);
            let mut chw = vec![0f32; w * h * 3];
            for (i, px) in hwc.chunks_exact(3).enumerate() {
                for c in 0..3 {
                    let src = if self.config.bgr { 2 - c } else { c };
                    chw[c * w * h + i] = px[src];
                }
            }
            let input = Tensor::from_shape(&[1, 3, h, w], &chw)?;
            let out = self.plan.run(tvec!(input.into_tvalue()))?;
            let maps = out
                .first()
                .ok_or_else(|| VisionError::ModelOutput("ONNX model has no output".into()))?;
            let shape = maps.shape().to_vec();
            let &[1, c, mh, mw] = shape.as_slice() else {
                return Err(VisionError::ModelOutput(format!(
                    "heatmaps of shape {shape:?}, expected [1, J, H, W]"
                )));
            };
            let maps = maps.cast_to::<f32>()?;
            let peaks = decode_heatmaps(maps.try_as_plain_ram()?.as_slice::<f32>()?, c, mh, mw)
                .ok_or_else(|| {
                    VisionError::ModelOutput(format!("{c} heatmaps, need at least {NUM_LANDMARKS}"))
                })?;
            let (sx, sy) = (w as f64 / mw as f64, h as f64 / mh as f64);
            let mut points = [[0.0; 3]; NUM_LANDMARKS];
            for (p, q) in points.iter_mut().zip(&peaks) {
                let xy = crop.apply([q[0] * sx, q[1] * sy]);
                *p = [xy[0], xy[1], q[2].clamp(0.0, 1.0)];
            }
            let presence = (points.iter().map(|p| p[2]).sum::<f64>() / NUM_LANDMARKS as f64) as f32;
            Ok(HandKeypoints {
                points,
                presence,
                side: side_hint.map(|s| (s, 0.5)),
                cues: None,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_sizes_are_w_x_h_with_positive_integers() {
        assert_eq!(parse_input_size("368x368"), Some((368, 368)));
        assert_eq!(parse_input_size("256X192"), Some((256, 192)));
        for bad in ["368", "0x5", "ax5", "5x", ""] {
            assert_eq!(parse_input_size(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn symmetric_peak_is_at_cell_centre_and_skewed_peak_moves() {
        let (c, h, w) = (21, 5, 5);
        let mut data = vec![0.0f32; c * h * w];
        for j in 0..c {
            let m = &mut data[j * h * w..(j + 1) * h * w];
            m[2 * w + 2] = 1.0;
            m[2 * w + 1] = 0.5;
            m[2 * w + 3] = if j == 0 { 0.5 } else { 0.8 };
        }
        let p = decode_heatmaps(&data, c, h, w).expect("decode");
        assert!((p[0][0] - 2.5).abs() < 1e-9 && (p[0][1] - 2.5).abs() < 1e-9);
        assert_eq!(p[0][2], 1.0);
        assert!(p[1][0] > 2.5 && p[1][0] < 3.0, "{:?}", p[1]);
        assert!(decode_heatmaps(&data, 20, h, w).is_none());
    }
}
