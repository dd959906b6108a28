//! Helpers shared by the integration tests: model fetching with an explicit SKIP, shared data
//! lookup and a minimal `.npy` reader for the reference fixtures.
#![allow(dead_code)]

use std::path::PathBuf;

use monohand_vision::{HandPipeline, ModelOptions, ModelStore, PipelineOptions, VisionError};

/// The model store, fetched if needed. `None` (after printing why) only when pip or the
/// network is unavailable and `MONOHAND_REQUIRE_MODELS` is unset (CI sets it, so there a
/// missing network fails the test instead of skipping it); any other failure (e.g. a
/// checksum mismatch) panics.
pub fn models() -> Option<ModelStore> {
    let store = ModelStore::new(None).expect("model cache directory");
    match store.fetch() {
        Ok(()) => Some(store),
        Err(VisionError::ModelFetch(msg))
            if std::env::var_os("MONOHAND_REQUIRE_MODELS").is_none() =>
        {
            eprintln!("SKIP: MediaPipe weights unavailable (pip/network missing): {msg}");
            None
        }
        Err(e) => panic!("model fetch failed: {e}"),
    }
}

/// The model store and a [`HandPipeline`] with the default options built from it (with the
/// face detector if `detect_heads`); `None` as [`models`].
pub fn pipeline(detect_heads: bool) -> Option<(ModelStore, HandPipeline)> {
    let store = models()?;
    let options = ModelOptions {
        model_dir: Some(store.dir().to_path_buf()),
        detect_heads,
        ..Default::default()
    };
    let pipeline = HandPipeline::new(&options, PipelineOptions::default()).expect("pipeline");
    Some((store, pipeline))
}

/// `../shared/data/<rel>` from the repository root; a missing file fails the test.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let p = root.join(rel);
    if p.exists() {
        Some(p)
    } else {
        panic!(
            "shared test data {} not found (../shared beside the repository)",
            p.display()
        )
    }
}

/// Path of a committed fixture.
pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// A `.npy` array: shape and values as f32 (from `<f4` or `|u1`).
pub struct Npy {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// Reads a little-endian `.npy` file of dtype `<f4` or `|u1`, C order.
pub fn read_npy(name: &str) -> Npy {
    let bytes = std::fs::read(fixture(name)).expect("fixture");
    assert_eq!(&bytes[..6], b"\x93NUMPY", "not a npy file");
    let (header_len, start) = if bytes[6] == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        )
    };
    let header = std::str::from_utf8(&bytes[start..start + header_len]).expect("header");
    assert!(header.contains("'fortran_order': False"));
    let shape_str = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .expect("shape");
    let shape: Vec<usize> = shape_str
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().expect("dim"))
        .collect();
    let body = &bytes[start + header_len..];
    let data: Vec<f32> = if header.contains("'<f4'") {
        body.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    } else if header.contains("'|u1'") {
        body.iter().map(|&b| b as f32).collect()
    } else {
        panic!("unsupported dtype in {header}")
    };
    assert_eq!(data.len(), shape.iter().product::<usize>());
    Npy { shape, data }
}
