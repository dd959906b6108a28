//! Reused run states give exactly the outputs of fresh runs.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_vision::{ModelFile, TfliteNet};
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
                .run_in(
                    &mut state,
                    |buf| buf.copy_from_slice(&data),
                    |out| {
                        (0..out.len())
                            .map(|i| out.get(i).map(bits))
                            .collect::<Result<Vec<_>, _>>()
                    },
                )
                .expect("reused run");
            let pooled = net
                .run_pooled(
                    |buf| buf.copy_from_slice(&data),
                    |out| {
                        (0..out.len())
                            .map(|i| out.get(i).map(bits))
                            .collect::<Result<Vec<_>, _>>()
                    },
                )
                .expect("pooled run");
            let fresh: Vec<Vec<u32>> = fresh.iter().map(|o| bits(o)).collect();
            assert_eq!(reused, fresh, "{file:?}, input {seed}: reused state");
            assert_eq!(pooled, fresh, "{file:?}, input {seed}: pooled state");
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
