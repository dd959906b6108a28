//! The networks in int8 ([`Precision::Int8`](crate::Precision::Int8)): the calibration
//! tables that code each quantized layer's input, shipped with monohand, and how they are
//! made.
//!
//! A table holds, for every 1x1 convolution and the first convolution (the stem, on the
//! image) of one network (by its node name in the imported graph), the smallest and
//! largest value its input took while the f32 pipeline ran on the calibration frames: what [`monohand_tflite::ActivationQuant::from_min_max`]
//! codes that input from. Tables are plain text (`int8/<network>.txt` in this crate,
//! compiled in), stamped with the SHA-256 of the network they were measured on and ending
//! with the SHA-256 of their own lines, both checked when one is read. A table is only
//! used with the network whose checksum it names.
//!
//! **The calibration frames** ([`calibration_images`]): the shared photos
//! (`../shared/data/images`, every `.jpg` and `.png`, 36 in all) and every 5th frame of
//! the first half of the dev video (`hand_graph_cnn_dev`, frames 0, 5, ..., 145); nothing
//! else, and never the second half (frames 146-291), on which int8 is checked unseen.
//! Each is read by [`crate::HandPipeline::detect`] with the default options (the detector, the
//! landmark network's two passes, the mirror pass) in f32, and the inputs the palm and
//! landmark networks were given are recorded ([`crate::TfliteNet::recording`]); each network's table
//! comes from running its imported f32 graph on those inputs
//! ([`monohand_tflite::int8_input_ranges`]). The same frames give the same table, bit
//! for bit, with any thread count (`tests/int8_calibration.rs` makes them again and
//! compares). `examples/int8_calibrate.rs` writes them.
//!
//! The face detector (heads) always runs in f32.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use tract_core::internal::*;

use crate::error::{Result, VisionError};
use crate::int8_tables::bad;
use crate::models::{sha256_hex, ModelFile};

// The tables and the import with them are below the networks (int8_tables.rs), which
// import with them; how the tables are made (here) runs the pipeline above them.
pub use crate::int8_tables::{import, quantized_networks, Int8Table};

/// How the shipped tables name their frames ([`calibration_images`]).
pub const FRAMES: &str =
    "the shared photos and dev frames 0-145 every 5th, f32 pipeline, default options";

/// The calibration frames (see the module documentation), in a fixed order: the shared
/// photos under `data/images` sorted by path, then the dev video's frames 0, 5, ..., 145
/// under `data/hand_graph_cnn_dev/images`. `data` is `../shared/data`.
pub fn calibration_images(data: &Path) -> Result<Vec<PathBuf>> {
    let mut photos = Vec::new();
    let mut dirs = vec![data.join("images")];
    while let Some(dir) = dirs.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|source| VisionError::Io {
            path: dir.clone(),
            source,
        })?;
        for e in entries {
            let path = e
                .map_err(|source| VisionError::Io {
                    path: dir.clone(),
                    source,
                })?
                .path();
            if path.is_dir() {
                dirs.push(path);
            } else if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("jpg" | "png")
            ) {
                photos.push(path);
            }
        }
    }
    photos.sort();
    let dev = data.join("hand_graph_cnn_dev/images");
    photos.extend((0..146).step_by(5).map(|i| dev.join(format!("{i:05}.jpg"))));
    Ok(photos)
}

/// The tables of the palm and landmark networks of `models`, measured on `images` with
/// the f32 pipeline (see the module documentation); `frames` describes the images in the
/// tables.
pub fn calibrate(
    models: &crate::ModelOptions,
    images: &[PathBuf],
    frames: &str,
) -> Result<Vec<(ModelFile, Int8Table)>> {
    let store = crate::ModelStore::new(models.model_dir.clone())?;
    let files = [models.palm.palm_file(), models.landmark.landmark_file()];
    let mut loaded = Vec::new();
    for file in files {
        let bytes = store.load(file)?;
        let recorder = Arc::new(Mutex::new(Vec::new()));
        let net = crate::TfliteNet::from_bytes(&bytes, &store.path_of(file))?
            .recording(Arc::clone(&recorder));
        loaded.push((file, bytes, net, recorder));
    }
    let [(_, _, palm, _), (_, _, landmark, _)] = &loaded[..] else {
        return Err(bad("two networks to calibrate"));
    };
    // The f32 pipeline with the default options, without heads.
    let pipeline = crate::HandPipeline::from_networks(
        palm.clone(),
        landmark.clone(),
        None,
        crate::PipelineOptions::default(),
    )?;
    for path in images {
        pipeline.detect_file(path)?;
    }
    let mut tables = Vec::new();
    for (file, bytes, _, recorder) in &loaded {
        let recorded = std::mem::take(
            &mut *recorder
                .lock()
                .map_err(|_| bad("the input recorder was poisoned"))?,
        );
        if recorded.is_empty() {
            return Err(bad(format!(
                "{} never ran on the calibration frames",
                file.file_name()
            )));
        }
        let model = monohand_tflite::import(bytes).map_err(|source| VisionError::Import {
            path: store.path_of(*file),
            source,
        })?;
        let runs: Vec<TVec<Tensor>> = recorded.into_iter().map(|t| tvec!(t)).collect();
        let ranges = monohand_tflite::int8_input_ranges(&model, &runs)?;
        tables.push((
            *file,
            Int8Table {
                network_sha256: sha256_hex(bytes),
                frames: format!("{frames}; {} network runs", runs.len()),
                ranges: ranges.into_iter().collect(),
            },
        ));
    }
    Ok(tables)
}
