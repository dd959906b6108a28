//! monohand's own resize and max pool operators give the networks' outputs of tract's, bit
//! for bit, in f32 and in int8.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use monohand_vision::tflite_import::ImportOptions;
use monohand_vision::{ModelFile, NetOutputs, Precision, TfliteNet, VisionError};

/// The bits of every output of a run.
fn all_bits(out: NetOutputs<'_>) -> Result<Vec<Vec<u32>>, VisionError> {
    (0..out.len())
        .map(|i| out.get(i).map(|v| v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

#[test]
fn own_resize_and_pool_give_tracts_bits() {
    let Some(store) = common::models() else {
        return;
    };
    let tracts = ImportOptions {
        fast_resize: false,
        fast_pool: false,
        ..Default::default()
    };
    // The palm detectors' input photo (MediaPipe's letterboxed frame of a real hand).
    let photo: Vec<f32> = common::read_npy("palm_input_u8.npy")
        .data
        .iter()
        .map(|v| v / 255.0)
        .collect();
    // The palm detectors have both (two upsamplings, four pools, three of them padded);
    // the lite landmark network one pool.
    for file in [
        ModelFile::PalmDetectionFull,
        ModelFile::PalmDetectionLite,
        ModelFile::HandLandmarkLite,
    ] {
        let bytes = store.load(file).expect("load model");
        let path = store.path_of(file);
        for precision in [Precision::F32, Precision::Int8] {
            let ours = TfliteNet::from_bytes_in(&bytes, &path, ImportOptions::default(), precision)
                .expect("import");
            let theirs =
                TfliteNet::from_bytes_in(&bytes, &path, tracts, precision).expect("import");
            let len: usize = ours.input_shape().iter().product();
            let input: Vec<f32> = if len == photo.len() {
                photo.clone()
            } else {
                (0..len)
                    .map(|i| ((i * 7919) % 1009) as f32 / 1009.0)
                    .collect()
            };
            let run = |net: &TfliteNet| {
                net.run_pooled(|buf| buf.copy_from_slice(&input), all_bits)
                    .expect("run")
            };
            assert_eq!(run(&ours), run(&theirs), "{file:?} {precision:?}");
        }
    }
}
