//! Speed of the geometry core: one residual evaluation, one analytic Jacobian,
//! one depth fusion, one monocular fit from scratch, one warm-started tracking
//! fit, one stereo fit.
//! Poses are random inside the joint limits (seeded), seen by the STB camera.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use criterion::{criterion_group, criterion_main, Criterion};
use monohand_core::fitting::fuse_network_depth;
use monohand_core::kinematics::{forward_kinematics_with_jacobian, LOCAL_DOF};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use nalgebra::{Rotation3, SMatrix, UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;

fn random_pose(sk: &HandSkeleton, rng: &mut StdRng) -> HandPose {
    let l = &sk.limits;
    HandPose {
        translation: Vector3::new(
            rng.random_range(-60.0..60.0),
            rng.random_range(-40.0..40.0),
            rng.random_range(350.0..650.0),
        ),
        rotation: UnitQuaternion::from_euler_angles(
            rng.random_range(-3.0..3.0),
            rng.random_range(-1.2..1.2),
            rng.random_range(-3.0..3.0),
        ),
        angles: std::array::from_fn(|i| rng.random_range(l.lower[i]..=l.upper[i])),
    }
}

fn observe(cam: &Camera, joints: &[Vector3<f64>; 21]) -> Keypoints2d {
    let mut kp = Keypoints2d::default();
    for (j, x) in joints.iter().enumerate() {
        if let Some(p) = cam.project(x) {
            kp.points[j] = [p.x, p.y, 1.0];
        }
    }
    kp
}

/// The network's relative 3D as MediaPipe gives it: metric joints about the hand's
/// centre, and the depth of each joint behind the wrist in pixels.
fn network_cues(sk: &HandSkeleton, poses: &[HandPose]) -> Vec<NetworkCues> {
    poses
        .iter()
        .map(|p| {
            let j = forward_kinematics(sk, p);
            let z = 822.79 / j[0].z;
            NetworkCues {
                world_mm: Some(j.map(|x| [x.x - j[9].x, x.y - j[9].y, x.z - j[9].z])),
                depth_px: Some(j.map(|x| (x.z - j[0].z) * z)),
            }
        })
        .collect()
}

/// The kinematics and the depth fusion on their own.
fn bench_kinematics(
    c: &mut Criterion,
    sk: &HandSkeleton,
    pose: &HandPose,
    left: &Camera,
    cues: &NetworkCues,
) {
    c.bench_function("forward_kinematics", |b| {
        b.iter(|| forward_kinematics(sk, black_box(pose)))
    });
    c.bench_function("jacobian_analytic", |b| {
        let mut pts = [Vector3::zeros(); 21];
        let mut jac = [SMatrix::<f64, 3, LOCAL_DOF>::zeros(); 21];
        b.iter(|| forward_kinematics_with_jacobian(sk, black_box(pose), &mut pts, &mut jac))
    });
    c.bench_function("fuse_network_depth", |b| {
        let joints = forward_kinematics(sk, pose);
        let weights = [
            FitOptions::default().fusion.fuse_world,
            FitOptions::default().fusion.fuse_depth,
        ];
        b.iter(|| fuse_network_depth(black_box(&joints), left, cues, weights))
    });
}

fn bench(c: &mut Criterion) {
    let left = Camera::pinhole(822.79, 822.79, 318.47, 250.31, 640, 480).unwrap();
    let right = left.with_extrinsics(Extrinsics {
        rotation: Rotation3::identity(),
        translation: Vector3::new(-120.054, 0.0, 0.0),
    });
    let sk = HandSkeleton::default_for(HandSide::Right);
    let mut rng = StdRng::seed_from_u64(3);
    let poses: Vec<HandPose> = (0..64).map(|_| random_pose(&sk, &mut rng)).collect();
    // Fits that see 2D keypoints only pose the planar thumb (`HandFitter::skeleton`), fits
    // with cues the skeleton as given: each bench's hands are made of the one it fits.
    let observe_with = |sk: &HandSkeleton| -> Vec<(Keypoints2d, Keypoints2d)> {
        poses
            .iter()
            .map(|p| {
                let j = forward_kinematics(sk, p);
                (observe(&left, &j), observe(&right, &j))
            })
            .collect()
    };
    let obs = observe_with(&sk.planar_thumb());
    let obs_cued = observe_with(&sk);

    let cues = network_cues(&sk, &poses);
    bench_kinematics(c, &sk, &poses[0], &left, &cues[0]);
    let mut fitter = HandFitter::new(sk, FitOptions::default()).unwrap();
    let mut i = 0;
    c.bench_function("fit_mono_from_scratch", |b| {
        b.iter(|| {
            i = (i + 1) % obs.len();
            fitter
                .fit(&[View::new(&left, &obs[i].0)])
                .map(|r| r.cost)
                .ok()
        })
    });
    c.bench_function("fit_mono_from_scratch_with_cues", |b| {
        b.iter(|| {
            i = (i + 1) % obs.len();
            fitter
                .fit(&[View::new(&left, &obs_cued[i].0).with_cues(Some(&cues[i]))])
                .map(|r| r.cost)
                .ok()
        })
    });
    c.bench_function("fit_stereo_from_scratch", |b| {
        b.iter(|| {
            i = (i + 1) % obs.len();
            let v = [View::new(&left, &obs[i].0), View::new(&right, &obs[i].1)];
            fitter.fit(&v).map(|r| r.cost).ok()
        })
    });
    // Tracking: start from the true pose of the frame perturbed as by ~1 frame of motion.
    let starts: Vec<HandPose> = poses
        .iter()
        .map(|p| {
            let mut s = *p;
            s.translation += Vector3::new(3.0, -2.0, 5.0);
            s.rotation = UnitQuaternion::from_euler_angles(0.03, -0.02, 0.04) * s.rotation;
            s.angles.iter_mut().for_each(|a| *a += 0.05);
            s
        })
        .collect();
    c.bench_function("fit_mono_tracking_warm_start", |b| {
        b.iter(|| {
            i = (i + 1) % obs.len();
            fitter
                .fit_from(&[View::new(&left, &obs[i].0)], &starts[i])
                .map(|r| r.cost)
                .ok()
        })
    });
    c.bench_function("fit_mono_tracking_warm_start_with_cues", |b| {
        b.iter(|| {
            i = (i + 1) % obs.len();
            fitter
                .fit_from(
                    &[View::new(&left, &obs_cued[i].0).with_cues(Some(&cues[i]))],
                    &starts[i],
                )
                .map(|r| r.cost)
                .ok()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
