//! Exports of the per-frame results for other tools (see `docs/output-format.md`):
//!
//! - [`CsvWriter`]: one CSV row per hand per frame, flushed per frame, for
//!   spreadsheets and pandas.
//! - [`openpose_people`] / [`write_openpose_frame`]: one OpenPose-style JSON
//!   file per frame with `hand_{left,right}_keypoints_2d` and
//!   `hand_{left,right}_keypoints_3d` (built on [`crate::openpose`]).
//! - [`GltfWriter`]: an animated glTF 2.0 binary (`.glb`) of the 3D joints and
//!   bones, for viewing without code (Blender: File > Import > glTF 2.0; or a
//!   browser glTF viewer such as <https://gltf-viewer.donmccurdy.com>, which
//!   loads the file locally).

mod csv;
mod gltf;
mod openpose;

pub use csv::{csv_header, csv_rows, CsvWriter};
pub use gltf::{to_gltf, GltfHand, GltfWriter};
pub use openpose::{openpose_file_name, openpose_people, write_openpose_frame};

/// What the tests of the formats share.
#[cfg(test)]
mod test_support {
    use crate::jsonl::HandRecord;
    use monohand_core::hand_model::HandSide;
    use monohand_core::observation::Keypoints2d;

    /// A hand with 2D keypoints, 3D joints around depth `z` mm, `id` and a score.
    pub(super) fn hand(side: HandSide, id: Option<u64>, z: f64) -> HandRecord {
        let mut kp = Keypoints2d::default();
        for (j, p) in kp.points.iter_mut().enumerate() {
            *p = [100.0 + j as f64, 50.5, 0.75];
        }
        let mut h = HandRecord::from_keypoints(side, &kp);
        h.joints_3d_mm = Some(std::array::from_fn(|j| {
            [10.0 * j as f64, -5.0 * j as f64, z + j as f64]
        }));
        h.id = id;
        h.score = Some(0.97);
        h
    }
}
