//! The skinned hand of `monohand run --gltf` for the page's 3D view: the WebXR generic hand
//! mesh ([`monohand_io::hand_mesh`]) laid on a record's fitted joints by the same code as
//! the glTF export. The page loads the mesh once as a binary glTF ([`HandMeshes::glb`],
//! written by [`GltfWriter`]) and then moves its 25 joints every frame
//! ([`HandMeshes::pose`]).

use crate::WebError;
use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_io::export::{to_gltf, GltfHand, GltfWriter};
use monohand_io::hand_mesh::{HandMesh, MESH_JOINTS};
use monohand_io::jsonl::FrameRecord;

/// Numbers per mesh joint in [`HandMeshes::pose`]: translation (3), rotation (4), scale.
pub const POSE_STRIDE: usize = 8;

/// The left and right WebXR hand meshes.
#[derive(Debug, Clone)]
pub struct HandMeshes {
    left: HandMesh,
    right: HandMesh,
}

impl HandMeshes {
    /// Parses the two meshes built into the library.
    pub fn new() -> Result<HandMeshes, WebError> {
        Ok(HandMeshes {
            left: HandMesh::webxr(HandSide::Left)?,
            right: HandMesh::webxr(HandSide::Right)?,
        })
    }

    /// A binary glTF of `frame`'s fitted hands as skinned meshes, exactly as `run --gltf`
    /// writes one frame: a node per mesh joint, named `<joint>_<id>_<side>`
    /// ([`MESH_JOINTS`]' names), under a node per hand.
    pub fn glb(frame: &FrameRecord) -> Result<Vec<u8>, WebError> {
        let mut writer = GltfWriter::new("monohand-web.glb");
        writer.set_hand(GltfHand::Skinned)?;
        writer.add_record(frame.time_s.unwrap_or(0.0), frame)?;
        Ok(writer.to_glb())
    }

    /// The pose of each of the 25 mesh joints ([`MESH_JOINTS`] order) that lays the `side`
    /// mesh on `joints_mm` (a record's `joints_3d_mm`, camera frame, mm): for each joint its
    /// glTF translation (m), rotation `[x, y, z, w]` and uniform scale, [`POSE_STRIDE`]
    /// numbers one joint after the other. `None` if the palm is degenerate.
    pub fn pose(&self, side: HandSide, joints_mm: &[[f64; 3]; NUM_JOINTS]) -> Option<Vec<f32>> {
        let mesh = match side {
            HandSide::Left => &self.left,
            HandSide::Right => &self.right,
        };
        let poses = mesh.pose(&joints_mm.map(to_gltf))?;
        let mut out = Vec::with_capacity(MESH_JOINTS.len() * POSE_STRIDE);
        for p in poses {
            out.extend(p.translation);
            out.extend(p.rotation);
            out.push(p.scale);
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use monohand_io::jsonl::HandRecord;

    /// The mesh's own rest joints, in the camera frame (mm), moved 400 mm in front of it.
    fn rest_joints_mm(meshes: &HandMeshes, side: HandSide) -> [[f64; 3]; NUM_JOINTS] {
        let mesh = match side {
            HandSide::Left => &meshes.left,
            HandSide::Right => &meshes.right,
        };
        mesh.rest_joints().map(|p| {
            let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
            [1000.0 * x, -1000.0 * y, -1000.0 * z + 400.0]
        })
    }

    #[test]
    fn posed_mesh_joints_pass_through_the_fitted_joints() {
        let meshes = HandMeshes::new().unwrap();
        for side in [HandSide::Left, HandSide::Right] {
            let joints = rest_joints_mm(&meshes, side);
            let pose = meshes.pose(side, &joints).unwrap();
            assert_eq!(pose.len(), MESH_JOINTS.len() * POSE_STRIDE);
            for (k, (_, fit)) in MESH_JOINTS.iter().enumerate() {
                let p = &pose[k * POSE_STRIDE..(k + 1) * POSE_STRIDE];
                // The rest pose moved: the hand's own size, unit rotations.
                assert!((p[7] - 1.0).abs() < 1e-3, "scale {}", p[7]);
                let q_norm = p[3..7].iter().map(|v| v * v).sum::<f32>().sqrt();
                assert!((q_norm - 1.0).abs() < 1e-4);
                if let Some(j) = fit {
                    let want = to_gltf(joints[*j]);
                    for d in 0..3 {
                        assert!((p[d] - want[d]).abs() < 1e-5, "{side:?} joint {k}");
                    }
                }
            }
        }
        // A palm squeezed to a point cannot be posed.
        assert!(meshes
            .pose(HandSide::Left, &[[0.0, 0.0, 400.0]; NUM_JOINTS])
            .is_none());
    }

    #[test]
    fn glb_holds_each_hand_as_named_joints() {
        let meshes = HandMeshes::new().unwrap();
        let joints = rest_joints_mm(&meshes, HandSide::Right);
        let keypoints = monohand_core::observation::Keypoints2d {
            points: [[0.0, 0.0, 1.0]; NUM_JOINTS],
        };
        let mut hand = HandRecord::from_keypoints(HandSide::Right, &keypoints);
        hand.joints_3d_mm = Some(joints);
        hand.id = Some(7);
        let frame = FrameRecord {
            hands: vec![hand],
            ..FrameRecord::default()
        };
        let glb = HandMeshes::glb(&frame).unwrap();
        assert_eq!(&glb[0..4], b"glTF");
        let text = String::from_utf8_lossy(&glb);
        for (name, _) in MESH_JOINTS {
            assert!(text.contains(&format!("\"{name}_7_right\"")), "{name}");
        }
        assert!(!text.contains("_left\""));
    }
}
