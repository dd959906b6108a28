//! Reused run states give exactly the outputs of fresh runs, and running the independent
//! network passes of a frame side by side gives exactly the sequential result.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_vision::image_io::load_rgb;
use monohand_vision::{ModelFile, NetOutputs, TfliteNet, VisionError};
use tract_core::prelude::Tensor;

/// A deterministic input in `[0, 1]`, different for each `seed`.
fn pseudo_random(len: usize, seed: u64) -> Vec<f32> {
    let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The bits of every output of a run.
fn all_bits(out: NetOutputs<'_>) -> Result<Vec<Vec<u32>>, VisionError> {
    (0..out.len()).map(|i| out.get(i).map(bits)).collect()
}

#[test]
fn reused_state_matches_fresh_runs_across_calls() {
    let Some(store) = common::models() else {
        return;
    };
    for file in [
        ModelFile::HandLandmarkFull,
        ModelFile::PalmDetectionFull,
        ModelFile::FaceDetectionShortRange,
    ] {
        let bytes = store.load(file).expect("load model");
        let net = TfliteNet::from_bytes(&bytes, &store.path_of(file)).expect("import");
        let shape = net.input_shape();
        let len: usize = shape.iter().product();
        let mut state = net.new_state().expect("state");
        let mut buffer = None;
        // Different inputs one after the other (and one repeated), so a stale value anywhere
        // in the reused state would show.
        for seed in [1, 2, 3, 1, 4] {
            let data = pseudo_random(len, seed);
            let fresh = net
                .run(Tensor::from_shape(&shape, &data).expect("tensor"))
                .expect("fresh run");
            let reused = net
                .run_in(&mut state, |buf| buf.copy_from_slice(&data), all_bits)
                .expect("reused run");
            let pooled = net
                .run_pooled(|buf| buf.copy_from_slice(&data), all_bits)
                .expect("pooled run");
            // Two runs side by side, the second on another input made from the first's.
            let other = pseudo_random(len, seed + 10);
            let (first, second) = net
                .run_pooled_pair(
                    |a, b| {
                        a.copy_from_slice(&data);
                        b.copy_from_slice(&other);
                    },
                    all_bits,
                )
                .expect("pair of runs");
            let fresh_other = net
                .run(Tensor::from_shape(&shape, &other).expect("tensor"))
                .expect("fresh run");
            let fresh: Vec<Vec<u32>> = fresh.iter().map(|o| bits(o)).collect();
            let fresh_other: Vec<Vec<u32>> = fresh_other.iter().map(|o| bits(o)).collect();
            assert_eq!(reused, fresh, "{file:?}, input {seed}: reused state");
            assert_eq!(pooled, fresh, "{file:?}, input {seed}: pooled state");
            assert_eq!(first, fresh, "{file:?}, input {seed}: first of a pair");
            assert_eq!(
                second, fresh_other,
                "{file:?}, input {seed}: second of a pair"
            );
            assert_ne!(first, second, "{file:?}: the pair's inputs differ");
            // The input is written in place: one buffer for every call.
            let ptr = state.input().as_ptr::<f32>().expect("f32 input") as usize;
            assert_eq!(
                *buffer.get_or_insert(ptr),
                ptr,
                "{file:?}: input reallocated"
            );
        }
    }
}

#[test]
fn parallel_two_hand_tracking_matches_sequential() {
    let Some((_, mut pipeline)) = common::pipeline(true) else {
        return;
    };
    // Two-hand photos, tracked as if they were video frames: each frame is tracked from the
    // previous frame's hands, with and without the detectors.
    let frames: Vec<_> = ["images/hamer/test5.jpg", "images/interwild/image.jpg"]
        .iter()
        .filter_map(|rel| common::shared(rel))
        .map(|p| load_rgb(&p).expect("image"))
        .collect();
    let mut runs = Vec::new();
    for parallel in [false, true] {
        pipeline.set_parallel(parallel);
        let mut out = Vec::new();
        for img in &frames {
            let first = pipeline.detect(img).expect("detect");
            assert!(first.hands.len() >= 2, "{} hands", first.hands.len());
            let mut previous = first.hands.clone();
            out.push((first, Vec::new()));
            for detect_new in [false, true, false] {
                let (d, origin) = pipeline.track(img, &previous, detect_new).expect("track");
                assert!(d.hands.len() >= 2, "{} hands tracked", d.hands.len());
                previous = d.hands.clone();
                out.push((d, origin));
            }
        }
        runs.push(out);
    }
    assert!(!runs[0].is_empty());
    assert_eq!(runs[0], runs[1]);
}
