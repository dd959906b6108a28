//! MediaPipe hand-landmark model: a 224x224 rotated crop in `[0, 1]` → 21 landmarks
//! `(x, y, z)` in crop pixels, a hand-presence probability, a handedness probability and 21
//! metric "world" landmarks (metres, origin near the hand centre).
//!
//! ## Per-joint confidence
//! The model has no heatmaps, so a per-joint confidence is built from the network's own
//! self-consistency: its 2D landmarks and its independently regressed 3D world landmarks must
//! describe the same hand. An affine camera (8 parameters: orthographic rotation, scale,
//! shear and shift — ample for a hand-sized crop) is fitted by least squares from the 21 world
//! points to the 21 2D points; a joint whose 2D position disagrees with the projection of its
//! 3D position by a residual `r` (crop pixels) gets
//!
//! `confidence = presence · exp(−½ (r / σ)²)`, σ = [`LandmarkOptions::agreement_sigma`]
//! (default 6 crop pixels ≈ 2.7 % of the crop, ~7 % of the hand's length: on clean, fully
//! visible hands most joints score above 0.7, while a crop where the two heads disagree
//! — a wrong or heavily occluded hand — drops towards 0).
//!
//! So the presence score caps every joint (a doubtful hand makes every joint doubtful), and
//! joints where the two heads disagree — typically occluded or ambiguous fingertips — drop
//! below it. The raw residuals are kept in [`HandLandmarks::agreement_residual`].

use image::RgbImage;

use crate::error::{Result, VisionError};
use crate::geometry::{Affine2, RotatedRect};
use crate::network::{NetOutputs, TfliteNet};
use crate::warp::{warp_into_with_border, Border, Normalization};

/// Number of hand keypoints.
pub const NUM_LANDMARKS: usize = 21;

/// MediaPipe's landmark graph divides the network's `z` by this beside the crop size
/// (`TensorsToLandmarksCalculator`, `normalize_z: 0.4` in `hand_landmark_cpu.pbtxt`, "to
/// account for the Z coordinate distribution in the training data"), so that `z` has
/// about the scale of `x`. Without it the relative depth is 2.5 times too flat.
pub const NORMALIZE_Z: f64 = 0.4;

/// Options of the landmark stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandmarkOptions {
    /// σ of the 2D/3D agreement term, in crop pixels (crop = 224 px).
    pub agreement_sigma: f64,
    /// Also run the network on the left-right mirror of each crop and average the two
    /// readings (turned back into the crop's axes): a test-time ensemble of the two ways
    /// the network sees a hand (as a left and as a right one). On by default: it lowers
    /// every 3D error on the real dev frames (docs/accuracy.md). Twice the network's
    /// time; the two passes run side by side on rayon's threads.
    pub mirror_pass: bool,
}

impl Default for LandmarkOptions {
    fn default() -> Self {
        LandmarkOptions {
            agreement_sigma: 6.0,
            mirror_pass: true,
        }
    }
}

/// Writes into `dst` the left-right mirror of `src`, a `width`-pixel-wide RGB image.
fn mirror_columns(src: &[f32], width: usize, dst: &mut [f32]) {
    let row = 3 * width;
    for (s, d) in src.chunks_exact(row).zip(dst.chunks_exact_mut(row)) {
        for (sp, dp) in s.chunks_exact(3).rev().zip(d.chunks_exact_mut(3)) {
            dp.copy_from_slice(sp);
        }
    }
}

/// Length of the network's landmark outputs (21 joints x 3).
const RAW_LEN: usize = 3 * NUM_LANDMARKS;

/// The network's raw outputs for one crop: `[x, y, z]` per joint in crop pixels, the
/// presence and handedness probabilities, and the world landmarks in the crop's axes.
#[derive(Clone, Copy)]
struct RawOutputs {
    screen: [f32; RAW_LEN],
    presence: f32,
    handed: f32,
    world: [f32; RAW_LEN],
}

impl RawOutputs {
    fn read(out: NetOutputs<'_>) -> Result<Self> {
        let outputs: [&[f32]; 4] = out.first()?;
        match outputs {
            [screen, [presence], [handed], world]
                if screen.len() == RAW_LEN && world.len() == RAW_LEN =>
            {
                let mut raw = RawOutputs {
                    screen: [0.0; RAW_LEN],
                    presence: *presence,
                    handed: *handed,
                    world: [0.0; RAW_LEN],
                };
                raw.screen.copy_from_slice(screen);
                raw.world.copy_from_slice(world);
                Ok(raw)
            }
            _ => Err(not_landmark_outputs()),
        }
    }

    /// The readings of a crop sampled through [`Affine2::mirror_x`]`(size)`, turned back
    /// into the unmirrored crop's axes: x mirrored, the world's x negated, the handedness
    /// swapped (the network saw the other hand).
    fn unmirrored(mut self, size: f64) -> Self {
        for j in 0..NUM_LANDMARKS {
            self.screen[3 * j] = (size - self.screen[3 * j] as f64) as f32;
            self.world[3 * j] = -self.world[3 * j];
        }
        self.handed = 1.0 - self.handed;
        self
    }

    /// The mean of two readings of the same crop.
    fn mean(&self, other: &Self) -> Self {
        let mut m = *self;
        for (a, b) in m.screen.iter_mut().zip(&other.screen) {
            *a = 0.5 * (*a + b);
        }
        for (a, b) in m.world.iter_mut().zip(&other.world) {
            *a = 0.5 * (*a + b);
        }
        m.presence = 0.5 * (self.presence + other.presence);
        m.handed = 0.5 * (self.handed + other.handed);
        m
    }
}

fn not_landmark_outputs() -> VisionError {
    VisionError::ModelOutput("hand landmark outputs are not [63, 1, 1, 63]".into())
}

/// The landmark model's outputs for one crop, mapped back to the image.
#[derive(Clone, Debug, PartialEq)]
pub struct HandLandmarks {
    /// `[x, y, z]` per joint: x, y in image pixels (continuous coordinates, see
    /// [`crate::geometry`]); z relative depth in the same pixel scale (wrist ≈ 0, negative is
    /// closer to the camera), MediaPipe's own ([`NORMALIZE_Z`]).
    pub image: [[f64; 3]; NUM_LANDMARKS],
    /// Per-joint confidence (see the module docs).
    pub confidence: [f64; NUM_LANDMARKS],
    /// 2D/3D agreement residual per joint, in crop pixels.
    pub agreement_residual: [f64; NUM_LANDMARKS],
    /// Hand presence probability.
    pub presence: f32,
    /// The network's raw handedness output: probability of MediaPipe's label "Left", defined
    /// for *mirrored* (selfie) images, i.e. of a physical right hand in an unmirrored image;
    /// see [`crate::pipeline`].
    pub handedness_raw: f32,
    /// Metric 3D landmarks in metres (the network's "world" output, origin near the hand's
    /// centre), turned from the crop's axes to the image's (x right, y down, z away from the
    /// camera), as MediaPipe's `WorldLandmarkProjectionCalculator` does.
    pub world: [[f64; 3]; NUM_LANDMARKS],
    /// The crop the landmarks were read from.
    pub roi: RotatedRect,
}

/// The hand-landmark network.
#[derive(Debug, Clone)]
pub struct LandmarkModel {
    net: TfliteNet,
    size: usize,
    /// Options.
    pub options: LandmarkOptions,
}

impl LandmarkModel {
    /// Wraps an imported `hand_landmark_{full,lite}.tflite`.
    pub fn new(net: TfliteNet, options: LandmarkOptions) -> Result<Self> {
        let [_, h, w, c] = net.input_shape();
        if h != w || c != 3 {
            return Err(VisionError::ModelOutput(format!(
                "landmark input {h}x{w}x{c}, expected square RGB"
            )));
        }
        Ok(LandmarkModel {
            net,
            size: h,
            options,
        })
    }

    /// Crop side in pixels (224).
    pub fn input_size(&self) -> usize {
        self.size
    }

    /// The network input for `roi` of `img` (one affine warp).
    pub fn preprocess(
        &self,
        img: &RgbImage,
        roi: &RotatedRect,
    ) -> Result<tract_core::prelude::Tensor> {
        self.net
            .input_with(|buf| self.crop_into(img, roi, false, buf))
    }

    /// Warps the crop of `roi` into `buf`, a `size x size x 3` network input, mirrored
    /// left-right when `mirrored`.
    fn crop_into(&self, img: &RgbImage, roi: &RotatedRect, mirrored: bool, buf: &mut [f32]) {
        let mut m = roi.crop_to_image(self.size, self.size);
        if mirrored {
            m = m.compose(&Affine2::mirror_x(self.size as f64));
        }
        warp_into_with_border(
            img,
            &m,
            self.size,
            self.size,
            Normalization::UNIT,
            Border::Replicate,
            buf,
        )
    }

    /// Runs the model on `roi` of `img`: with [`LandmarkOptions::mirror_pass`], the mean of
    /// the two passes of [`estimate_pass`](Self::estimate_pass) (run side by side), else
    /// the plain pass alone.
    pub fn estimate(&self, img: &RgbImage, roi: &RotatedRect) -> Result<HandLandmarks> {
        let raw = if self.options.mirror_pass {
            // The crop is warped once; the mirrored input is its columns in reverse order,
            // the same samples as a warp through `Affine2::mirror_x` up to rounding in the
            // composed map (every pixel centre maps onto its mirror's).
            let (plain, mirrored) = self.net.run_pooled_pair(
                |plain, mirrored| {
                    self.crop_into(img, roi, false, plain);
                    mirror_columns(plain, self.size, mirrored);
                },
                RawOutputs::read,
            )?;
            plain.mean(&mirrored.unmirrored(self.size as f64))
        } else {
            self.read(img, roi, false)?
        };
        self.landmarks_of(&raw, roi)
    }

    /// One network pass on the crop of `roi` (`mirrored`: on its left-right mirror image,
    /// with the readings turned back into the crop's axes, so that both passes describe
    /// the hand as it is in `img`).
    pub fn estimate_pass(
        &self,
        img: &RgbImage,
        roi: &RotatedRect,
        mirrored: bool,
    ) -> Result<HandLandmarks> {
        self.landmarks_of(&self.read(img, roi, mirrored)?, roi)
    }

    /// One network pass: the crop is warped straight into the network's reused input
    /// buffer, the outputs are copied out of it (and unmirrored for a mirrored crop).
    fn read(&self, img: &RgbImage, roi: &RotatedRect, mirrored: bool) -> Result<RawOutputs> {
        let raw = self.net.run_pooled(
            |buf| self.crop_into(img, roi, mirrored, buf),
            RawOutputs::read,
        )?;
        Ok(if mirrored {
            raw.unmirrored(self.size as f64)
        } else {
            raw
        })
    }

    fn landmarks_of(&self, raw: &RawOutputs, roi: &RotatedRect) -> Result<HandLandmarks> {
        self.postprocess(
            &[
                &raw.screen[..],
                &[raw.presence],
                &[raw.handed],
                &raw.world[..],
            ],
            roi,
        )
    }

    /// Maps raw outputs (`[63], [1], [1], [63]`) back to the image.
    pub fn postprocess<S: AsRef<[f32]>>(
        &self,
        out: &[S],
        roi: &RotatedRect,
    ) -> Result<HandLandmarks> {
        let (screen, presence, handed, world) = match out {
            [a, b, c, d] => (a.as_ref(), b.as_ref(), c.as_ref(), d.as_ref()),
            _ => return Err(not_landmark_outputs()),
        };
        let (presence, handed) = match (presence, handed) {
            ([p], [h]) if screen.len() == RAW_LEN && world.len() == RAW_LEN => (*p, *h),
            _ => return Err(not_landmark_outputs()),
        };
        let to_image = roi.crop_to_image(self.size, self.size);
        let z_scale = roi.width / self.size as f64 / NORMALIZE_Z;
        let (sin, cos) = roi.rotation.sin_cos();
        let mut image = [[0.0; 3]; NUM_LANDMARKS];
        let mut crop = [[0.0; 2]; NUM_LANDMARKS];
        let mut w3 = [[0.0; 3]; NUM_LANDMARKS];
        for j in 0..NUM_LANDMARKS {
            let (x, y, z) = (
                screen[3 * j] as f64,
                screen[3 * j + 1] as f64,
                screen[3 * j + 2] as f64,
            );
            let p = to_image.apply([x, y]);
            image[j] = [p[0], p[1], z * z_scale];
            crop[j] = [x, y];
            let (wx, wy) = (world[3 * j] as f64, world[3 * j + 1] as f64);
            w3[j] = [
                cos * wx - sin * wy,
                sin * wx + cos * wy,
                world[3 * j + 2] as f64,
            ];
        }
        let residual = affine_residuals(&w3, &crop);
        let sigma = self.options.agreement_sigma;
        let presence_f = presence.clamp(0.0, 1.0) as f64;
        let mut confidence = [0.0; NUM_LANDMARKS];
        for (c, r) in confidence.iter_mut().zip(&residual) {
            *c = presence_f * (-0.5 * (r / sigma).powi(2)).exp();
        }
        Ok(HandLandmarks {
            image,
            confidence,
            agreement_residual: residual,
            presence,
            handedness_raw: handed,
            world: w3,
            roi: *roi,
        })
    }
}

/// Residuals of the least-squares affine camera `u = A [X Y Z 1]ᵀ` from 3D points to 2D
/// points, per point. Returns zeros if the fit is degenerate.
pub fn affine_residuals(
    world: &[[f64; 3]; NUM_LANDMARKS],
    uv: &[[f64; 2]; NUM_LANDMARKS],
) -> [f64; NUM_LANDMARKS] {
    // Normal equations (XᵀX) a = Xᵀu for each image axis, X rows = [X, Y, Z, 1].
    let mut xtx = [[0.0; 4]; 4];
    let mut xtu = [[0.0; 2]; 4];
    for (w, p) in world.iter().zip(uv) {
        let row = [w[0], w[1], w[2], 1.0];
        for i in 0..4 {
            for j in 0..4 {
                xtx[i][j] += row[i] * row[j];
            }
            xtu[i][0] += row[i] * p[0];
            xtu[i][1] += row[i] * p[1];
        }
    }
    let Some(a) = solve4(xtx, xtu) else {
        return [0.0; NUM_LANDMARKS];
    };
    let mut out = [0.0; NUM_LANDMARKS];
    for ((o, w), p) in out.iter_mut().zip(world).zip(uv) {
        let row = [w[0], w[1], w[2], 1.0];
        let u: f64 = (0..4).map(|i| row[i] * a[i][0]).sum();
        let v: f64 = (0..4).map(|i| row[i] * a[i][1]).sum();
        *o = ((u - p[0]).powi(2) + (v - p[1]).powi(2)).sqrt();
    }
    out
}

/// Solves `M x = b` (4x4, two right-hand sides) by Gaussian elimination with partial pivoting.
// Row operations read two rows of the same array: index loops are the clear form here.
#[allow(clippy::needless_range_loop)]
fn solve4(mut m: [[f64; 4]; 4], mut b: [[f64; 2]; 4]) -> Option<[[f64; 2]; 4]> {
    for col in 0..4 {
        let pivot = (col..4).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[pivot][col].abs() < 1e-12 {
            return None;
        }
        m.swap(col, pivot);
        b.swap(col, pivot);
        for r in 0..4 {
            if r != col {
                let f = m[r][col] / m[col][col];
                for c in 0..4 {
                    m[r][c] -= f * m[col][c];
                }
                for k in 0..2 {
                    b[r][k] -= f * b[col][k];
                }
            }
        }
    }
    let mut x = [[0.0; 2]; 4];
    for i in 0..4 {
        for k in 0..2 {
            x[i][k] = b[i][k] / m[i][i];
        }
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mirrored_crop_is_the_crops_columns_reversed() {
        // A textured image, and crops of it turned, scaled (supersampled when shrunk) and
        // across its edge, as the landmark stage takes them.
        let img = RgbImage::from_fn(320, 240, |x, y| {
            image::Rgb([
                ((x * 7 + y * 3) % 256) as u8,
                ((x * x / 5 + y) % 256) as u8,
                ((x ^ y) % 256) as u8,
            ])
        });
        let size = 32;
        for (center, side, rotation) in [
            ([160.0, 120.0], 90.0, 0.0),
            ([100.3, 80.7], 150.0, 0.6),
            ([300.0, 20.0], 70.0, -2.2),
            ([160.0, 120.0], 20.0, 1.0),
        ] {
            let roi = RotatedRect {
                center,
                width: side,
                height: side,
                rotation,
            };
            let warp = |m: &Affine2| {
                let mut buf = vec![0f32; size * size * 3];
                warp_into_with_border(
                    &img,
                    m,
                    size,
                    size,
                    Normalization::UNIT,
                    Border::Replicate,
                    &mut buf,
                );
                buf
            };
            let m = roi.crop_to_image(size, size);
            let plain = warp(&m);
            let warped_mirror = warp(&m.compose(&Affine2::mirror_x(size as f64)));
            let mut flipped = vec![f32::NAN; plain.len()];
            mirror_columns(&plain, size, &mut flipped);
            let worst = flipped
                .iter()
                .zip(&warped_mirror)
                .map(|(a, b)| (a - b).abs())
                .fold(0f32, f32::max);
            // The same samples; only the rounding of the composed map differs.
            assert!(worst < 1e-4, "{roi:?}: {worst}");
            // And it is a mirror: a column and its partner hold the same pixel.
            assert_eq!(flipped[..3], plain[3 * (size - 1)..3 * size]);
        }
    }

    #[test]
    fn exact_affine_projection_has_zero_residual_and_outlier_stands_out() {
        let mut world = [[0.0; 3]; NUM_LANDMARKS];
        let mut uv = [[0.0; 2]; NUM_LANDMARKS];
        for j in 0..NUM_LANDMARKS {
            let t = j as f64;
            world[j] = [0.01 * t.sin(), 0.02 * (t * 0.7).cos(), 0.005 * t];
            uv[j] = [
                100.0 + 2000.0 * world[j][0] + 300.0 * world[j][2],
                50.0 - 2000.0 * world[j][1],
            ];
        }
        let r = affine_residuals(&world, &uv);
        assert!(r.iter().all(|&v| v < 1e-6), "{r:?}");
        uv[8][0] += 20.0;
        let r = affine_residuals(&world, &uv);
        let worst = (0..NUM_LANDMARKS)
            .max_by(|&a, &b| r[a].total_cmp(&r[b]))
            .expect("max");
        assert_eq!(worst, 8);
    }
}
