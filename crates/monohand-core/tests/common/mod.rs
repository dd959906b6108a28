//! Helpers shared by the integration tests: random poses and projections.
#![allow(dead_code)]

use monohand_core::prelude::*;
use nalgebra::{UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;

/// A random pose inside the joint limits, hand 300-700 mm in front of the camera,
/// any orientation whose palm is not edge-on to the camera.
pub fn random_pose(sk: &HandSkeleton, rng: &mut StdRng) -> HandPose {
    let l = &sk.limits;
    let angles = std::array::from_fn(|i| rng.random_range(l.lower[i]..=l.upper[i]));
    let rotation = UnitQuaternion::from_euler_angles(
        rng.random_range(-PI..PI),
        rng.random_range(-PI..PI),
        rng.random_range(-PI..PI),
    );
    let z = rng.random_range(300.0..700.0);
    HandPose {
        translation: Vector3::new(
            rng.random_range(-0.2..0.2) * z,
            rng.random_range(-0.15..0.15) * z,
            z,
        ),
        rotation,
        angles,
    }
}

/// Projects the joints of a pose into a camera, with optional Gaussian pixel noise.
pub fn project(
    cam: &Camera,
    joints: &[Vector3<f64>; NUM_JOINTS],
    noise_px: f64,
    rng: &mut StdRng,
) -> Option<Keypoints2d> {
    let n = Normal::new(0.0, noise_px.max(1e-12)).ok()?;
    let mut kp = Keypoints2d::default();
    for (j, x) in joints.iter().enumerate() {
        let px = cam.project(x)?;
        let (du, dv) = if noise_px > 0.0 {
            (n.sample(rng), n.sample(rng))
        } else {
            (0.0, 0.0)
        };
        kp.points[j] = [px.x + du, px.y + dv, 1.0];
    }
    Some(kp)
}

/// Mean per-joint 3D distance.
pub fn mean_error(a: &[Vector3<f64>; NUM_JOINTS], b: &[Vector3<f64>; NUM_JOINTS]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).norm()).sum::<f64>() / NUM_JOINTS as f64
}

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// The STB Bumblebee stereo rig (left camera is the reference).
pub fn stb_rig() -> (Camera, Camera) {
    let left = Camera::pinhole(822.79041, 822.79041, 318.47345, 250.31296, 640, 480).unwrap();
    let right = left.with_extrinsics(Extrinsics {
        rotation: nalgebra::Rotation3::identity(),
        translation: Vector3::new(-120.054, 0.0, 0.0),
    });
    (left, right)
}
