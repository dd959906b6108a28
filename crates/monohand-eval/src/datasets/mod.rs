//! Datasets read natively (without converting them to a manifest first), and
//! [`Dataset::load`], which tells the kind of a dataset from its path and reads it
//! (a manifest, or one of these).

pub mod hand_graph_cnn;
pub mod stb;
pub mod table_rig;

use crate::dataset::Dataset;
use crate::error::{EvalError, EvalResult};
use std::path::Path;

impl Dataset {
    /// Reads a dataset, telling the kind from the path: a `.jsonl` file (or a
    /// folder holding `manifest.jsonl`) is a manifest ([`crate::manifest`]); a
    /// folder with `labels/*_BB.mat` is STB ([`crate::datasets::stb`]); a folder
    /// with hand-graph-cnn's `labels.json` is read by
    /// [`crate::datasets::hand_graph_cnn`]; a rig folder (`reference_3d_mm.json`, `cameras/`,
    /// `images/`, `labels_2d/`) by [`crate::datasets::table_rig`].
    pub fn load(path: impl AsRef<Path>) -> EvalResult<Dataset> {
        let path = path.as_ref();
        if path.is_file() {
            return crate::manifest::read_manifest(path);
        }
        if !path.is_dir() {
            return Err(EvalError::dataset(path, "no such file or folder"));
        }
        let m = path.join("manifest.jsonl");
        if m.is_file() {
            return crate::manifest::read_manifest(&m);
        }
        if crate::datasets::stb::is_stb_folder(path) {
            return crate::datasets::stb::load_stb(path);
        }
        if crate::datasets::hand_graph_cnn::is_hand_graph_cnn_folder(path) {
            return crate::datasets::hand_graph_cnn::load_hand_graph_cnn(path);
        }
        if crate::datasets::table_rig::is_table_rig_folder(path) {
            return crate::datasets::table_rig::load_table_rig(path);
        }
        Err(EvalError::dataset(
            path,
            "not a dataset: expected a manifest (.jsonl file, or a folder with manifest.jsonl), \
             an STB folder (labels/*_BB.mat), a hand-graph-cnn folder (labels.json with crop boxes) \
             or a rig folder (reference_3d_mm.json, cameras/, images/, labels_2d/)",
        ))
    }
}

/// A dataset's name: its folder's, else `fallback`.
fn folder_name(dir: &Path, fallback: &str) -> String {
    dir.file_name()
        .map_or_else(|| fallback.to_string(), |n| n.to_string_lossy().to_string())
}
