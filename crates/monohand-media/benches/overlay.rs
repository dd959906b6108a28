//! Cost of drawing the depth overlay (`scene::SceneRenderer`) on a 640x480 frame with two
//! fitted hands: the default layers (shaded bones, top view, labels) and all layers.
//! Target: under 3 ms per frame. `cargo bench -p monohand-media --bench overlay`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed bench is a panic

use criterion::{criterion_group, criterion_main, Criterion};
use monohand_core::camera::Camera;
use monohand_core::hand_model::{HandPose, HandSide, HandSkeleton, NUM_ANGLES};
use monohand_core::kinematics::forward_kinematics;
use monohand_io::jsonl::HandRecord;
use monohand_media::scene::{Layer, Layers, SceneRenderer};
use monohand_media::video::RgbImage;
use nalgebra::{UnitQuaternion, Vector3};
use std::hint::black_box;

/// A hand of the default skeleton, fingers half bent, palm towards the camera, wrist at
/// `at` (mm): as large in the image as a hand at arm's length.
fn hand(side: HandSide, at: [f64; 3], id: u64) -> HandRecord {
    let sk = HandSkeleton::default_for(side);
    let mut angles = [0.0; NUM_ANGLES];
    for (i, a) in angles.iter_mut().enumerate() {
        *a = if i % 4 == 1 { 0.05 } else { 0.5 };
    }
    let pose = HandPose {
        translation: Vector3::from(at),
        rotation: UnitQuaternion::from_euler_angles(0.3, 0.4, 3.0),
        angles,
    };
    let joints = forward_kinematics(&sk, &pose).map(|p| [p.x, p.y, p.z]);
    HandRecord {
        joints_3d_mm: Some(joints),
        id: Some(id),
        score: Some(0.97),
        ..HandRecord::from_keypoints(side, &Default::default())
    }
}

fn bench(c: &mut Criterion) {
    let camera = Camera::generic(640, 480).expect("generic camera");
    let hands = [
        hand(HandSide::Left, [-90.0, 60.0, 380.0], 1),
        hand(HandSide::Right, [100.0, 80.0, 520.0], 2),
    ];
    let background = RgbImage::from_fn(640, 480, |x, y| {
        image::Rgb([(x % 256) as u8, (y % 256) as u8, ((x + y) % 256) as u8])
    });
    let mut renderer = SceneRenderer::default();
    let mut frame = background.clone();
    let mut cases = vec![
        ("default layers".to_string(), Layers::default()),
        ("all layers".to_string(), Layers::only(&Layer::ALL)),
    ];
    // Each layer alone, to say where the time goes.
    for layer in Layer::ALL {
        cases.push((format!("{} alone", layer.name()), Layers::only(&[layer])));
    }
    for (name, layers) in cases {
        c.bench_function(&format!("overlay 640x480, 2 hands, {name}"), |b| {
            b.iter(|| {
                frame.copy_from_slice(&background);
                renderer.draw(&mut frame, black_box(&hands), &[camera], &layers);
            })
        });
    }
    // The copy of the background alone, to subtract.
    c.bench_function("copy of a 640x480 frame (baseline)", |b| {
        b.iter(|| frame.copy_from_slice(black_box(&background)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
