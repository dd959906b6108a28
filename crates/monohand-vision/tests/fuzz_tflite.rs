//! Fuzzing of the `.tflite` importer (monohand-tflite, see docs/fuzzing.md) with the real
//! MediaPipe networks as seeds: a damaged or hostile model must give an error, never a
//! panic, an out-of-bounds read or a huge allocation from a forged size.
//!
//! Mutations are aimed at the flatbuffer's structure (tables, vectors, shapes, indices,
//! options), not at the weights: positions are drawn outside the weight buffers.
//! `MONOHAND_FUZZ_CASES` sets the number of mutated models (default below, sized for
//! `.ci/run`), `MONOHAND_FUZZ_SEED` the RNG seed. Needs the models (fetched like the other
//! tests; a missing model fails the test).
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "../../monohand-io/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{cases, mutate_binary, run, Regions, TrackingAlloc};
use monohand_vision::tflite_import::{import, import_with, list_operators, ImportOptions};
use monohand_vision::{ModelFile, ModelStore};

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated models in a default `cargo test`.
const CI_CASES: usize = 1000;

fn store() -> ModelStore {
    let store = ModelStore::new(None).expect("model cache directory");
    if let Err(e) = store.fetch() {
        panic!("the tflite fuzz test needs the MediaPipe models as seeds: {e}");
    }
    store
}

/// The byte ranges of a model that are not weight data (the flatbuffer's tables, vectors and
/// strings), where mutations are drawn.
fn structure(bytes: &[u8]) -> Regions {
    let model = tract_tflite::tflite::root_as_model(bytes).expect("seed model parses");
    let base = bytes.as_ptr() as usize;
    let mut data: Vec<(usize, usize)> = model
        .buffers()
        .into_iter()
        .flatten()
        .filter_map(|b| b.data())
        .map(|d| {
            let s = d.bytes().as_ptr() as usize - base;
            (s, s + d.bytes().len())
        })
        .filter(|(s, e)| e - s >= 64)
        .collect();
    data.sort_unstable();
    let mut out = Vec::new();
    let mut at = 0;
    for (s, e) in data {
        if s > at {
            out.push((at, s));
        }
        at = at.max(e);
    }
    out.push((at, bytes.len()));
    Regions(out)
}

#[test]
fn fuzz_tflite_import() {
    let store = store();
    let files = [
        ModelFile::FaceDetectionShortRange,
        ModelFile::PalmDetectionLite,
        ModelFile::HandLandmarkLite,
    ];
    let seeds: Vec<Vec<u8>> = files.iter().map(|&f| store.load(f).unwrap()).collect();
    for (seed, file) in seeds.iter().zip(files) {
        import(seed).unwrap_or_else(|e| panic!("seed {file:?} does not import: {e}"));
    }
    let regions: Vec<Regions> = seeds.iter().map(|s| structure(s)).collect();
    // Most cases on the small face detector, whose import is the fastest.
    let weights = [6usize, 2, 2];
    run(
        "tflite",
        &seeds,
        cases(CI_CASES),
        |rng, seeds| {
            let mut k = rng.below(weights.iter().sum());
            let mut i = 0;
            while k >= weights[i] {
                k -= weights[i];
                i += 1;
            }
            mutate_binary(rng, std::slice::from_ref(&seeds[i]), &regions[i..=i])
        },
        |input| {
            let _ = list_operators(input);
            let options = ImportOptions {
                fast_depthwise: input.len() % 2 == 0,
                fused_prelu: input.len() % 3 != 0,
                fast_pointwise: input.len() % 5 != 0,
                fused_pointwise_epilogue: input.len() % 7 != 0,
                fused_depthwise_activation: input.len() % 11 != 0,
                register_blocked_depthwise: input.len() % 13 != 0,
                fast_conv: input.len() % 17 != 0,
                split_rows: input.len() % 19 != 0,
                fast_resize: input.len() % 23 != 0,
                fast_pool: input.len() % 29 != 0,
            };
            import(input)?;
            import_with(input, options).map(|m| m.nodes().len())
        },
    );
}
