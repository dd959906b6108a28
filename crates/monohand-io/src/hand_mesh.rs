//! A real hand mesh driven by the fitted joints, for the skinned glTF export
//! ([`crate::export::GltfWriter`] with [`crate::export::GltfHand::Skinned`]).
//!
//! The mesh is the WebXR generic hand (`assets/webxr-generic-hand/`, MIT licence, Amazon
//! 2019; the licence ships beside it): 1,360 vertices skinned to the 25 joints of the WebXR
//! hand (wrist; per finger a metacarpal, three phalanges and a tip; the thumb without an
//! intermediate phalanx). Its joints are all children of one root, so each joint's pose
//! is set directly from the fitted 21 joints:
//!
//! - the palm (wrist and the four finger bases, and the thumb's CMC) gives the hand's
//!   rotation and size (Kabsch with scale, rest pose to fit);
//! - every joint of the fit that the mesh has is placed where the fit says; the finger
//!   metacarpals, which the fit has not, keep their place on the palm;
//! - each joint turns by the palm's rotation and then the smallest further rotation that
//!   lays its bone (to the next joint of its finger) along the fitted bone.
//!
//! So the mesh's joints pass exactly through the fitted joints; the skin between them
//! follows the WebXR artist's weights.

use crate::error::{IoError, IoResult};
use monohand_core::hand_model::{HandSide, NUM_JOINTS, WRIST};
use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};
use serde_json::Value;

/// The left WebXR generic hand (binary glTF).
const LEFT_GLB: &[u8] = include_bytes!("../assets/webxr-generic-hand/left.glb");
/// The right WebXR generic hand (binary glTF).
const RIGHT_GLB: &[u8] = include_bytes!("../assets/webxr-generic-hand/right.glb");

/// Where the mesh comes from and its licence, for file metadata.
pub const MESH_CREDIT: &str =
    "hand mesh: WebXR generic hand, (c) 2019 Amazon, MIT licence (assets/webxr-generic-hand)";

/// Names of the mesh's 25 joints and the fit's joint each one sits on (`None`: a finger's
/// metacarpal base, which the 21-joint model has not; it stays on the palm).
pub const MESH_JOINTS: [(&str, Option<usize>); 25] = [
    ("wrist", Some(0)),
    ("thumb-metacarpal", Some(1)),
    ("thumb-phalanx-proximal", Some(2)),
    ("thumb-phalanx-distal", Some(3)),
    ("thumb-tip", Some(4)),
    ("index-finger-metacarpal", None),
    ("index-finger-phalanx-proximal", Some(5)),
    ("index-finger-phalanx-intermediate", Some(6)),
    ("index-finger-phalanx-distal", Some(7)),
    ("index-finger-tip", Some(8)),
    ("middle-finger-metacarpal", None),
    ("middle-finger-phalanx-proximal", Some(9)),
    ("middle-finger-phalanx-intermediate", Some(10)),
    ("middle-finger-phalanx-distal", Some(11)),
    ("middle-finger-tip", Some(12)),
    ("ring-finger-metacarpal", None),
    ("ring-finger-phalanx-proximal", Some(13)),
    ("ring-finger-phalanx-intermediate", Some(14)),
    ("ring-finger-phalanx-distal", Some(15)),
    ("ring-finger-tip", Some(16)),
    ("pinky-finger-metacarpal", None),
    ("pinky-finger-phalanx-proximal", Some(17)),
    ("pinky-finger-phalanx-intermediate", Some(18)),
    ("pinky-finger-phalanx-distal", Some(19)),
    ("pinky-finger-tip", Some(20)),
];

/// The mesh joint whose bone a joint follows: the next joint along its finger (tips and
/// the wrist have none).
fn child(k: usize) -> Option<usize> {
    match k {
        0 => None,
        k if k % 5 == 4 => None,
        k => Some(k + 1),
    }
}

/// The fit's palm joints used for the hand's rotation and size, and their mesh joints.
const PALM: [(usize, usize); 6] = [(0, 0), (1, 1), (5, 6), (9, 11), (13, 16), (17, 21)];

/// One mesh accessor's raw bytes and its glTF description (without `bufferView`).
#[derive(Debug, Clone)]
pub struct RawAccessor {
    /// The data, tightly packed, little-endian.
    pub bytes: Vec<u8>,
    /// The accessor object (`componentType`, `count`, `type`, `min`/`max` if given).
    pub accessor: Value,
    /// The buffer view target (34962 vertices, 34963 indices), if any.
    pub target: Option<u32>,
}

/// A pose of one mesh joint: translation, rotation (`[x, y, z, w]`) and uniform scale, in
/// glTF's frame (metres, y up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointPose {
    /// Position, metres.
    pub translation: [f32; 3],
    /// Rotation quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// Uniform scale (the fitted hand's size over the mesh's).
    pub scale: f32,
}

/// A skinned hand mesh: its vertex data and its joints' bind pose.
#[derive(Debug, Clone)]
pub struct HandMesh {
    /// Which hand.
    pub side: HandSide,
    /// `POSITION`, `NORMAL`, `JOINTS_0`, `WEIGHTS_0` (vertex attributes), in that order.
    pub attributes: Vec<(&'static str, RawAccessor)>,
    /// Triangle indices.
    pub indices: RawAccessor,
    /// The 25 inverse bind matrices (column-major `MAT4`), in [`MESH_JOINTS`] order.
    pub inverse_bind: RawAccessor,
    /// Bind position of each joint ([`MESH_JOINTS`] order), metres.
    rest_position: [Vector3<f64>; 25],
    /// Bind rotation of each joint.
    rest_rotation: [UnitQuaternion<f64>; 25],
}

fn bad(what: impl Into<String>) -> IoError {
    IoError::field("webxr-generic-hand", "glb", what.into())
}

/// The JSON and binary chunks of a GLB file.
fn glb_chunks(glb: &[u8]) -> IoResult<(Value, &[u8])> {
    let u32_at = |o: usize| -> IoResult<usize> {
        glb.get(o..o + 4)
            .and_then(|b| b.try_into().ok())
            .map(|b: [u8; 4]| u32::from_le_bytes(b) as usize)
            .ok_or_else(|| bad("truncated"))
    };
    if glb.get(0..4) != Some(b"glTF") {
        return Err(bad("not a GLB file"));
    }
    let json_len = u32_at(12)?;
    let json = glb
        .get(20..20 + json_len)
        .ok_or_else(|| bad("truncated JSON"))?;
    let doc: Value = serde_json::from_slice(json).map_err(|e| bad(e.to_string()))?;
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at)?;
    let bin = glb
        .get(bin_at + 8..bin_at + 8 + bin_len)
        .ok_or_else(|| bad("truncated BIN"))?;
    Ok((doc, bin))
}

/// Bytes per component of a glTF component type.
fn component_size(t: u64) -> Option<usize> {
    match t {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

/// Components of a glTF accessor type.
fn type_components(t: &str) -> Option<usize> {
    match t {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" | "MAT2" => Some(4),
        "MAT3" => Some(9),
        "MAT4" => Some(16),
        _ => None,
    }
}

/// Copies accessor `i` out of a GLB (tightly packed views only).
fn raw_accessor(doc: &Value, bin: &[u8], i: u64) -> IoResult<RawAccessor> {
    let a = &doc["accessors"][i as usize];
    let view = &doc["bufferViews"][a["bufferView"]
        .as_u64()
        .ok_or_else(|| bad("accessor view"))? as usize];
    let comp = a["componentType"]
        .as_u64()
        .and_then(component_size)
        .ok_or_else(|| bad("component type"))?;
    let n = a["type"]
        .as_str()
        .and_then(type_components)
        .ok_or_else(|| bad("accessor type"))?;
    let count = a["count"].as_u64().ok_or_else(|| bad("count"))? as usize;
    let elem = comp * n;
    if view["byteStride"]
        .as_u64()
        .is_some_and(|s| s as usize != elem)
    {
        return Err(bad("interleaved buffer views are not read"));
    }
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let bytes = bin
        .get(start..start + count * elem)
        .ok_or_else(|| bad("accessor out of the buffer"))?
        .to_vec();
    let mut accessor = a.clone();
    if let Some(o) = accessor.as_object_mut() {
        o.remove("bufferView");
        o.remove("byteOffset");
        o.remove("name");
    }
    Ok(RawAccessor {
        bytes,
        accessor,
        target: view["target"].as_u64().map(|t| t as u32),
    })
}

/// Sets to 0 every joint index whose weight is 0 (`joints`: `JOINTS_0`, u8 `VEC4`;
/// `weights`: `WEIGHTS_0`, f32 `VEC4`). Such a joint moves nothing, so the skin is the same;
/// glTF asks for it (the Khronos validator's `ACCESSOR_JOINTS_USED_ZERO_WEIGHT`), and
/// the WebXR asset does not (1,978 of its joint indices over the two hands).
fn zero_unweighted_joints(joints: &mut RawAccessor, weights: &RawAccessor) -> IoResult<()> {
    if weights.accessor["componentType"] != 5126 || weights.accessor["type"] != "VEC4" {
        return Err(bad("WEIGHTS_0 is not f32 VEC4"));
    }
    if joints.accessor["type"] != "VEC4" || weights.bytes.len() != 4 * joints.bytes.len() {
        return Err(bad("JOINTS_0 and WEIGHTS_0 differ in size"));
    }
    for (j, w) in joints.bytes.iter_mut().zip(weights.bytes.chunks_exact(4)) {
        if f32::from_le_bytes([w[0], w[1], w[2], w[3]]) == 0.0 {
            *j = 0;
        }
    }
    Ok(())
}

impl HandMesh {
    /// The WebXR generic hand of this side (parsed from the copy built into the library).
    pub fn webxr(side: HandSide) -> IoResult<HandMesh> {
        let glb = match side {
            HandSide::Left => LEFT_GLB,
            HandSide::Right => RIGHT_GLB,
        };
        let (doc, bin) = glb_chunks(glb)?;
        let skin = &doc["skins"][0];
        let prim = &doc["meshes"][0]["primitives"][0];
        let attr = |name: &str| -> IoResult<RawAccessor> {
            let i = prim["attributes"][name]
                .as_u64()
                .ok_or_else(|| bad(format!("no {name}")))?;
            raw_accessor(&doc, bin, i)
        };
        // The skin's joint slots, by name, in MESH_JOINTS order.
        let slots: Vec<&str> = skin["joints"]
            .as_array()
            .ok_or_else(|| bad("no skin joints"))?
            .iter()
            .map(|n| {
                n.as_u64()
                    .and_then(|n| doc["nodes"][n as usize]["name"].as_str())
                    .unwrap_or("")
            })
            .collect();
        let order: Vec<usize> = MESH_JOINTS
            .iter()
            .map(|(name, _)| {
                slots
                    .iter()
                    .position(|s| s == name)
                    .ok_or_else(|| bad(format!("no joint {name}")))
            })
            .collect::<IoResult<_>>()?;
        if slots.len() != MESH_JOINTS.len() {
            return Err(bad("the skin does not have 25 joints"));
        }
        // JOINTS_0 refers to skin slots: renumber to MESH_JOINTS order.
        let mut joints = attr("JOINTS_0")?;
        if joints.accessor["componentType"] != 5121 {
            return Err(bad("JOINTS_0 is not u8"));
        }
        let to_ours: Vec<u8> = (0..slots.len())
            .map(|s| order.iter().position(|&o| o == s).unwrap_or(0) as u8)
            .collect();
        for b in &mut joints.bytes {
            *b = to_ours.get(*b as usize).copied().unwrap_or(0);
        }
        let weights = attr("WEIGHTS_0")?;
        zero_unweighted_joints(&mut joints, &weights)?;
        let ibm_raw = raw_accessor(
            &doc,
            bin,
            skin["inverseBindMatrices"]
                .as_u64()
                .ok_or_else(|| bad("no inverse bind matrices"))?,
        )?;
        let floats: Vec<f32> = ibm_raw
            .bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let mut ibm_bytes = Vec::with_capacity(ibm_raw.bytes.len());
        let mut rest_position = [Vector3::zeros(); 25];
        let mut rest_rotation = [UnitQuaternion::identity(); 25];
        for (k, &slot) in order.iter().enumerate() {
            let m = floats
                .get(slot * 16..slot * 16 + 16)
                .ok_or_else(|| bad("short inverse bind matrices"))?;
            ibm_bytes.extend(m.iter().flat_map(|v| v.to_le_bytes()));
            let ibm = Matrix4::from_column_slice(&m.iter().map(|&v| v as f64).collect::<Vec<_>>());
            let bind = ibm
                .try_inverse()
                .ok_or_else(|| bad("singular bind matrix"))?;
            rest_position[k] = Vector3::new(bind[(0, 3)], bind[(1, 3)], bind[(2, 3)]);
            let r: Matrix3<f64> = bind.fixed_view::<3, 3>(0, 0).into_owned();
            rest_rotation[k] = UnitQuaternion::from_matrix(&r);
        }
        Ok(HandMesh {
            side,
            attributes: vec![
                ("POSITION", attr("POSITION")?),
                ("NORMAL", attr("NORMAL")?),
                ("JOINTS_0", joints),
                ("WEIGHTS_0", weights),
            ],
            indices: raw_accessor(
                &doc,
                bin,
                prim["indices"].as_u64().ok_or_else(|| bad("no indices"))?,
            )?,
            inverse_bind: RawAccessor {
                bytes: ibm_bytes,
                ..ibm_raw
            },
            rest_position,
            rest_rotation,
        })
    }

    /// Bind position of the mesh joint `k` ([`MESH_JOINTS`] order), metres, glTF frame.
    pub fn rest_position(&self, k: usize) -> Option<[f64; 3]> {
        self.rest_position.get(k).map(|p| [p.x, p.y, p.z])
    }

    /// The pose of every mesh joint ([`MESH_JOINTS`] order) that lays the mesh on the
    /// fitted joints `joints` (glTF frame, metres). `None` if the palm is degenerate.
    pub fn pose(&self, joints: &[[f32; 3]; NUM_JOINTS]) -> Option<[JointPose; 25]> {
        let fit: Vec<Vector3<f64>> = joints
            .iter()
            .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        // Palm: similarity transform rest -> fit (Kabsch with scale, Umeyama).
        let n = PALM.len() as f64;
        let cf = PALM.iter().map(|&(j, _)| fit[j]).sum::<Vector3<f64>>() / n;
        let cr = PALM
            .iter()
            .map(|&(_, k)| self.rest_position[k])
            .sum::<Vector3<f64>>()
            / n;
        let mut h = Matrix3::zeros();
        let (mut var_r, mut var_f) = (0.0, 0.0);
        for &(j, k) in &PALM {
            let (a, b) = (self.rest_position[k] - cr, fit[j] - cf);
            h += b * a.transpose();
            var_r += a.norm_squared();
            var_f += b.norm_squared();
        }
        if !(var_r > 1e-12 && var_f > 1e-12 && var_f.is_finite()) {
            return None;
        }
        let svd = h.svd(true, true);
        let (u, v_t) = (svd.u?, svd.v_t?);
        let d = (u * v_t).determinant().signum();
        let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
        let palm = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
        let scale = (var_f / var_r).sqrt();
        // Target positions of all 25 mesh joints.
        let target: [Vector3<f64>; 25] = std::array::from_fn(|k| match MESH_JOINTS[k].1 {
            Some(j) => fit[j],
            None => fit[WRIST] + palm * ((self.rest_position[k] - self.rest_position[0]) * scale),
        });
        let mut out = [JointPose {
            translation: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            scale: 0.0,
        }; 25];
        let mut turn = [palm; 25];
        for k in 0..25 {
            if let Some(c) = child(k) {
                let rest_dir = palm * (self.rest_position[c] - self.rest_position[k]);
                let dir = target[c] - target[k];
                if let Some(swing) = UnitQuaternion::rotation_between(&rest_dir, &dir) {
                    turn[k] = swing * palm;
                }
            } else if k != 0 {
                turn[k] = turn[k - 1];
            }
        }
        for k in 0..25 {
            let q = turn[k] * self.rest_rotation[k];
            let t = target[k];
            if !(t.iter().all(|v| v.is_finite()) && q.coords.iter().all(|v| v.is_finite())) {
                return None;
            }
            out[k] = JointPose {
                translation: [t.x as f32, t.y as f32, t.z as f32],
                rotation: [q.i as f32, q.j as f32, q.k as f32, q.w as f32],
                scale: scale as f32,
            };
        }
        Some(out)
    }

    /// The rest pose's fit-joint positions (glTF frame, metres): the 21 joints of the fit
    /// that would leave the mesh as modelled. For tests and checks.
    pub fn rest_joints(&self) -> [[f32; 3]; NUM_JOINTS] {
        let mut j = [[0.0f32; 3]; NUM_JOINTS];
        for (k, (_, fit)) in MESH_JOINTS.iter().enumerate() {
            if let Some(i) = fit {
                let p = self.rest_position[k];
                j[*i] = [p.x as f32, p.y as f32, p.z as f32];
            }
        }
        j
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < tol)
    }

    #[test]
    fn both_meshes_load_with_25_joints_and_1360_vertices() {
        for side in [HandSide::Left, HandSide::Right] {
            let m = HandMesh::webxr(side).unwrap();
            assert_eq!(m.attributes[0].0, "POSITION");
            assert_eq!(m.attributes[0].1.bytes.len(), 1360 * 12);
            assert_eq!(m.inverse_bind.bytes.len(), 25 * 64);
            // Joint indices are renumbered into MESH_JOINTS order (0..25).
            assert!(m.attributes[2].1.bytes.iter().all(|&j| j < 25));
            // A joint of zero weight is joint 0 (glTF's rule), and every vertex is
            // weighted to some joint.
            let weights: Vec<f32> = m.attributes[3]
                .1
                .bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let joints = &m.attributes[2].1.bytes;
            assert_eq!(weights.len(), joints.len());
            assert!(joints
                .iter()
                .zip(&weights)
                .all(|(&j, &w)| w != 0.0 || j == 0));
            assert!(weights.chunks(4).all(|w| w.iter().sum::<f32>() > 0.99));
            // A hand is about 18 cm from the wrist to the middle fingertip.
            let d = (m.rest_position[14] - m.rest_position[0]).norm();
            assert!((0.15..0.22).contains(&d), "{d}");
        }
    }

    #[test]
    fn the_rest_pose_gives_the_bind_pose_back() {
        let m = HandMesh::webxr(HandSide::Right).unwrap();
        let pose = m.pose(&m.rest_joints()).unwrap();
        for (k, p) in pose.iter().enumerate() {
            assert!((p.scale - 1.0).abs() < 1e-4, "{k}: {}", p.scale);
            assert!(close(
                p.translation,
                m.rest_position(k).unwrap().map(|v| v as f32),
                1e-5
            ));
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                p.rotation[3] as f64,
                p.rotation[0] as f64,
                p.rotation[1] as f64,
                p.rotation[2] as f64,
            ));
            assert!(q.angle_to(&m.rest_rotation[k]) < 1e-3, "{k}");
        }
    }

    #[test]
    fn a_moved_and_larger_hand_moves_every_joint_with_it() {
        let m = HandMesh::webxr(HandSide::Left).unwrap();
        let rot = UnitQuaternion::from_euler_angles(0.4, -1.1, 2.0);
        let shift = Vector3::new(0.1, -0.05, -0.45);
        let moved = m.rest_joints().map(|p| {
            let v = rot * (Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) * 1.2) + shift;
            [v.x as f32, v.y as f32, v.z as f32]
        });
        let pose = m.pose(&moved).unwrap();
        for (k, p) in pose.iter().enumerate() {
            let want = rot * (m.rest_position[k] * 1.2) + shift;
            assert!(
                close(
                    p.translation,
                    [want.x as f32, want.y as f32, want.z as f32],
                    1e-4
                ),
                "{k}"
            );
            assert!((p.scale - 1.2).abs() < 1e-3);
        }
        // Degenerate palm: no pose.
        assert!(m.pose(&[[0.0; 3]; NUM_JOINTS]).is_none());
        let mut nan = moved;
        nan[5][0] = f32::NAN;
        assert!(m.pose(&nan).is_none());
    }
}
