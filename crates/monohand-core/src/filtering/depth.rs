//! A hand's distance from one camera through a One Euro filter, the hand scaled about the
//! camera's centre to the filtered distance.
//!
//! With one camera the distance is what the 3D fit knows least: it comes from the hand's
//! size in the image, and a 1% error in that size is 4 mm at 400 mm. On the development set
//! two thirds of the output's frame-to-frame shake (second differences of the joints) was
//! in the hand's centroid, most of it along the optical axis, twice the labels' own there
//! (docs/accuracy.md, "The depth filter"). Scaling the joints about the camera's centre
//! changes their distance and nothing else: every joint stays on its viewing ray, so its
//! pixel, the hand's shape and its Procrustes-aligned error are exactly the fit's.
//!
//! ```
//! use monohand_core::camera::Camera;
//! use monohand_core::filtering::{DepthFilter, OneEuroParams};
//! use nalgebra::Vector3;
//!
//! let camera = Camera::pinhole(600.0, 600.0, 319.5, 239.5, 640, 480).expect("camera");
//! let mut filter = DepthFilter::new(OneEuroParams { min_cutoff: 2.0, beta: 0.005, d_cutoff: 1.0 });
//! let mut hand = [Vector3::new(20.0, -10.0, 400.0); 21];
//! filter.apply(0.0, &camera, &mut hand); // the first frame passes unchanged
//! let mut jumped = [Vector3::new(22.0, -11.0, 440.0); 21]; // 10% further, same pixels
//! let before = camera.project(&jumped[0]).expect("in front");
//! filter.apply(1.0 / 30.0, &camera, &mut jumped);
//! assert!(jumped[0].z > 400.0 && jumped[0].z < 440.0); // part of the way
//! let after = camera.project(&jumped[0]).expect("in front");
//! assert!((after - before).norm() < 1e-9); // the same pixel
//! ```

use super::one_euro::{OneEuroFilter, OneEuroParams};
use crate::camera::Camera;
use crate::hand_model::NUM_JOINTS;
use nalgebra::Vector3;

/// Filters a hand's mean distance from a camera over time ([module docs](self)).
#[derive(Debug, Clone)]
pub struct DepthFilter {
    filter: OneEuroFilter<1>,
}

impl DepthFilter {
    /// A filter of the distance (mm) with these One Euro parameters (`beta` in Hz per mm/s).
    pub fn new(params: OneEuroParams) -> DepthFilter {
        DepthFilter {
            filter: OneEuroFilter::new(params),
        }
    }

    /// Forgets the past: the next hand passes unchanged.
    pub fn reset(&mut self) {
        self.filter.reset();
    }

    /// Filters the mean depth of `joints` (reference frame, mm) in `camera` at time `t_s`
    /// (seconds) and scales them about the camera's centre to it. Returns the scale
    /// applied (1 for the first frame, or if a joint is not finite or the hand is not in
    /// front of the camera: then the joints are left as they are and the filter is not fed).
    pub fn apply(
        &mut self,
        t_s: f64,
        camera: &Camera,
        joints: &mut [Vector3<f64>; NUM_JOINTS],
    ) -> f64 {
        let Some(depth) = mean_depth(camera, joints) else {
            return 1.0;
        };
        let filtered = self.filter.filter(t_s, &[[depth, 0.0, 0.0]])[0][0];
        scale_to_depth(camera, joints, depth, filtered)
    }
}

/// The mean depth of `joints` (reference frame, mm) in `camera`: `None` if a joint is not
/// finite or the hand is not in front of the camera.
pub fn mean_depth(camera: &Camera, joints: &[Vector3<f64>; NUM_JOINTS]) -> Option<f64> {
    if joints.iter().any(|x| !x.iter().all(|v| v.is_finite())) {
        return None;
    }
    let depth = joints
        .iter()
        .map(|x| camera.extrinsics.transform(x).z)
        .sum::<f64>()
        / NUM_JOINTS as f64;
    (depth > 0.0).then_some(depth)
}

/// Scales `joints`, whose mean depth in `camera` is `depth` ([`mean_depth`]), about the
/// camera's centre so that it becomes `target`: every joint stays on its viewing ray.
/// Returns the scale applied (1, and the joints left as they are, unless it is finite and
/// positive).
pub fn scale_to_depth(
    camera: &Camera,
    joints: &mut [Vector3<f64>; NUM_JOINTS],
    depth: f64,
    target: f64,
) -> f64 {
    let scale = target / depth;
    if !(scale.is_finite() && scale > 0.0) {
        return 1.0;
    }
    let centre = camera.centre();
    for x in joints.iter_mut() {
        *x = centre + (*x - centre) * scale;
    }
    scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Extrinsics;
    use nalgebra::Rotation3;

    fn hand(depth: f64) -> [Vector3<f64>; NUM_JOINTS] {
        std::array::from_fn(|j| {
            Vector3::new(
                j as f64 * 4.0 - 40.0,
                30.0 - j as f64 * 2.0,
                depth + j as f64,
            )
        })
    }

    const PARAMS: OneEuroParams = OneEuroParams {
        min_cutoff: 2.0,
        beta: 0.005,
        d_cutoff: 1.0,
    };

    #[test]
    fn pixels_stay_and_depth_noise_shrinks_for_a_moved_camera() {
        // A camera turned and moved away from the reference frame: the scaling is about its
        // centre, so every joint keeps its pixel.
        let camera = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480)
            .expect("camera")
            .with_extrinsics(Extrinsics {
                rotation: Rotation3::from_euler_angles(0.1, -0.3, 0.05),
                translation: Vector3::new(-60.0, 15.0, 30.0),
            });
        let mut filter = DepthFilter::new(PARAMS);
        let (mut raw_shake, mut out_shake, mut last): (f64, f64, Vec<f64>) = (0.0, 0.0, Vec::new());
        for k in 0..60 {
            // A still hand whose distance from the camera jumps by ±6 mm from frame to frame.
            let noise = if k % 2 == 0 { 6.0 } else { -6.0 };
            let truth = hand(420.0);
            let centre = camera.centre();
            let mut joints = truth.map(|x| centre + (x - centre) * (1.0 + noise / 420.0));
            let pixels = joints.map(|x| camera.project(&x).expect("in front"));
            filter.apply(k as f64 / 30.0, &camera, &mut joints);
            for (x, p) in joints.iter().zip(&pixels) {
                assert!((camera.project(x).expect("in front") - p).norm() < 1e-9);
            }
            let depth = joints
                .iter()
                .map(|x| camera.extrinsics.transform(x).z)
                .sum::<f64>()
                / 21.0;
            last.push(depth);
            if k >= 10 {
                raw_shake += 12.0;
                out_shake += (last[k] - last[k - 1]).abs();
            }
        }
        // The filtered distance moves a fraction of the raw 12 mm per frame.
        assert!(out_shake < 0.5 * raw_shake, "{out_shake} of {raw_shake}");
    }

    #[test]
    fn a_steady_approach_is_followed_and_bad_hands_are_left_alone() {
        let camera = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).expect("camera");
        let mut filter = DepthFilter::new(PARAMS);
        let mut lag: f64 = 0.0;
        for k in 0..90 {
            // 150 mm/s towards the camera, from 600 mm.
            let depth = 600.0 - 150.0 * k as f64 / 30.0;
            let mut joints = hand(depth);
            filter.apply(k as f64 / 30.0, &camera, &mut joints);
            let out = joints.iter().map(|x| x.z).sum::<f64>() / 21.0;
            lag = lag.max(out - (depth + 10.0));
        }
        // The One Euro filter lags a steady motion; at this speed by about a centimetre.
        assert!((0.0..15.0).contains(&lag), "lag {lag} mm");
        let mut bad = hand(400.0);
        bad[3].x = f64::NAN;
        assert_eq!(filter.apply(4.0, &camera, &mut bad), 1.0);
        let mut behind = hand(-400.0);
        let kept = behind;
        assert_eq!(filter.apply(4.1, &camera, &mut behind), 1.0);
        assert_eq!(behind, kept);
    }
}
