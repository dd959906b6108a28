//! The animated glTF export, parsed back: GLB container, JSON, accessors and
//! the animated joint positions.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_core::observation::Keypoints2d;
use monohand_io::export::{to_gltf, GltfHand, GltfWriter};
use monohand_io::hand_mesh::{HandMesh, MESH_JOINTS};
use monohand_io::jsonl::HandRecord;
use serde_json::Value;

/// A parsed GLB: its JSON and binary chunk.
struct Glb {
    json: Value,
    bin: Vec<u8>,
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

fn parse_glb(b: &[u8]) -> Glb {
    assert_eq!(&b[0..4], b"glTF");
    assert_eq!(u32_at(b, 4), 2, "version");
    assert_eq!(u32_at(b, 8) as usize, b.len(), "total length");
    let jlen = u32_at(b, 12) as usize;
    assert_eq!(&b[16..20], b"JSON");
    assert_eq!(jlen % 4, 0);
    let json: Value = serde_json::from_slice(&b[20..20 + jlen]).unwrap();
    let o = 20 + jlen;
    let blen = u32_at(b, o) as usize;
    assert_eq!(&b[o + 4..o + 8], b"BIN\0");
    assert_eq!(blen % 4, 0);
    assert_eq!(o + 8 + blen, b.len());
    Glb {
        json,
        bin: b[o + 8..].to_vec(),
    }
}

fn comps(ty: &str) -> usize {
    match ty {
        "SCALAR" => 1,
        "VEC3" => 3,
        "VEC4" => 4,
        t => panic!("unexpected type {t}"),
    }
}

impl Glb {
    /// The float data of an accessor, checked against its buffer view and bounds.
    fn floats(&self, acc: usize) -> Vec<f32> {
        let a = &self.json["accessors"][acc];
        let v = self.floats_unbounded(acc);
        let k = comps(a["type"].as_str().unwrap());
        for (i, x) in v.iter().enumerate() {
            let lo = a["min"][i % k].as_f64().unwrap() as f32;
            let hi = a["max"][i % k].as_f64().unwrap() as f32;
            assert!(
                *x >= lo && *x <= hi,
                "accessor {acc}: {x} outside [{lo}, {hi}]"
            );
        }
        v
    }

    /// The float data of an accessor without `min` and `max` (the skinned mesh's weights),
    /// checked against its buffer view.
    fn floats_unbounded(&self, acc: usize) -> Vec<f32> {
        let a = &self.json["accessors"][acc];
        assert_eq!(a["componentType"], 5126);
        let view = &self.json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let off = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        let n = a["count"].as_u64().unwrap() as usize * comps(a["type"].as_str().unwrap());
        assert_eq!(n * 4, len, "accessor {acc} fills its view");
        assert!(off + len <= self.bin.len());
        assert_eq!(off % 4, 0);
        self.bin[off..off + len]
            .chunks(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }
}

fn hand(side: HandSide, id: u64, t: f64) -> HandRecord {
    let mut h = HandRecord::from_keypoints(side, &Keypoints2d::default());
    h.id = Some(id);
    h.joints_3d_mm = Some(std::array::from_fn(|j| {
        [
            20.0 * j as f64 + 100.0 * t,
            10.0 * j as f64,
            500.0 + j as f64,
        ]
    }));
    h
}

/// Meshes: triangle indices stay within their vertex counts.
fn meshes_index_their_vertices(glb: &Glb) {
    let j = &glb.json;
    for m in j["meshes"].as_array().unwrap() {
        let prim = &m["primitives"][0];
        let pos = prim["attributes"]["POSITION"].as_u64().unwrap() as usize;
        let verts = j["accessors"][pos]["count"].as_u64().unwrap();
        let ia = &j["accessors"][prim["indices"].as_u64().unwrap() as usize];
        assert_eq!(ia["componentType"], 5123);
        let view = &j["bufferViews"][ia["bufferView"].as_u64().unwrap() as usize];
        let off = view["byteOffset"].as_u64().unwrap() as usize;
        let n = ia["count"].as_u64().unwrap() as usize;
        assert_eq!(n % 3, 0);
        for i in 0..n {
            let v = u16::from_le_bytes([glb.bin[off + 2 * i], glb.bin[off + 2 * i + 1]]);
            assert!((v as u64) < verts);
        }
    }
}

#[test]
fn animated_glb_parses_back_consistently() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hands.glb");
    let mut w = GltfWriter::new(&path);
    let cam = monohand_core::camera::Camera::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480).unwrap();
    w.set_camera_from(&cam);
    let yfov = 2.0 * (240.0f64 / 500.0).atan();
    // Right hand #1 in every frame; left hand #2 only in frames 1 and 2.
    let times = [0.0, 0.1, 0.2, 0.3];
    for (i, &t) in times.iter().enumerate() {
        let mut hands = vec![hand(HandSide::Right, 1, t)];
        if i == 1 || i == 2 {
            hands.push(hand(HandSide::Left, 2, t));
        }
        w.add_frame(t, &hands).unwrap();
    }
    // Time must increase.
    assert!(w.add_frame(0.3, &[]).is_err());
    assert_eq!(w.frames(), 4);
    w.finish().unwrap();
    assert!(!dir.path().join("hands.glb.tmp").exists());
    let glb = parse_glb(&std::fs::read(&path).unwrap());
    let j = &glb.json;
    assert_eq!(j["asset"]["version"], "2.0");
    assert_eq!(
        j["buffers"][0]["byteLength"].as_u64().unwrap() as usize,
        glb.bin.len()
    );
    // Camera + 2 hands x (21 joints + 20 bones + 1 group).
    let nodes = j["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 1 + 2 * 42);
    assert_eq!(j["cameras"][0]["perspective"]["yfov"].as_f64(), Some(yfov));
    assert_eq!(
        j["cameras"][0]["perspective"]["aspectRatio"].as_f64(),
        Some(640.0 / 480.0)
    );
    let roots = j["scenes"][0]["nodes"].as_array().unwrap();
    assert_eq!(roots.len(), 3);
    // Every accessor is consistent with its view and bounds.
    let n_acc = j["accessors"].as_array().unwrap().len();
    for a in 0..n_acc {
        if j["accessors"][a]["componentType"] == 5126 {
            glb.floats(a);
        }
    }
    let anim = &j["animations"][0];
    let channels = anim["channels"].as_array().unwrap();
    assert_eq!(channels.len(), 2 * (21 * 2 + 20 * 3));
    for c in channels {
        let node = c["target"]["node"].as_u64().unwrap() as usize;
        assert!(node < nodes.len());
        let s = &anim["samplers"][c["sampler"].as_u64().unwrap() as usize];
        let input = s["input"].as_u64().unwrap() as usize;
        let out = s["output"].as_u64().unwrap() as usize;
        assert_eq!(j["accessors"][input]["count"], 4);
        assert_eq!(j["accessors"][out]["count"], 4);
        assert_eq!(glb.floats(input), vec![0.0, 0.1, 0.2, 0.3]);
    }
    // The right hand's index tip (joint 8) at frame 2, converted back to camera mm.
    let find = |name: &str| nodes.iter().position(|n| n["name"] == name).unwrap();
    let tip = find("index_tip_1_right");
    let sampler_of = |node: usize, path: &str| {
        let c = channels
            .iter()
            .find(|c| c["target"]["node"] == node && c["target"]["path"] == path)
            .unwrap();
        &anim["samplers"][c["sampler"].as_u64().unwrap() as usize]
    };
    let tr = glb.floats(sampler_of(tip, "translation")["output"].as_u64().unwrap() as usize);
    let p = &tr[3 * 2..3 * 3];
    let back = [
        p[0] as f64 * 1000.0,
        -p[1] as f64 * 1000.0,
        -p[2] as f64 * 1000.0,
    ];
    let want = [20.0 * 8.0 + 20.0, 80.0, 508.0];
    for k in 0..3 {
        assert!((back[k] - want[k]).abs() < 1e-3, "{back:?} vs {want:?}");
    }
    // The left hand is hidden (scale 0, STEP) outside frames 1 and 2.
    let wrist_l = find("wrist_2_left");
    let s = sampler_of(wrist_l, "scale");
    assert_eq!(s["interpolation"], "STEP");
    let sc = glb.floats(s["output"].as_u64().unwrap() as usize);
    let x: Vec<f32> = sc.chunks(3).map(|c| c[0]).collect();
    assert_eq!(x, vec![0.0, 1.0, 1.0, 0.0]);
    // A bone is scaled along y to its length: wrist -> thumb_cmc is |(20, 10, 1)| mm.
    let bone = find("bone_wrist_thumb_cmc_1_right");
    let sc = glb.floats(sampler_of(bone, "scale")["output"].as_u64().unwrap() as usize);
    let len = (20.0f32 * 20.0 + 10.0 * 10.0 + 1.0).sqrt() / 1000.0;
    assert!((sc[1] - len).abs() < 1e-6, "{} vs {len}", sc[1]);
    meshes_index_their_vertices(&glb);
}

#[test]
fn empty_export_is_still_a_valid_file_and_bad_paths_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.glb");
    let mut w = GltfWriter::new(&path);
    let mut h = HandRecord::from_keypoints(HandSide::Left, &Keypoints2d::default());
    w.add_frame(0.0, std::slice::from_ref(&h)).unwrap(); // 2D only: no track
    h.joints_3d_mm = Some([[f64::NAN; 3]; NUM_JOINTS]);
    w.add_frame(0.5, &[h]).unwrap(); // non-finite: ignored
    w.finish().unwrap();
    let glb = parse_glb(&std::fs::read(&path).unwrap());
    assert!(glb.json.get("animations").is_none());
    assert_eq!(glb.json["nodes"].as_array().unwrap().len(), 1);
    let bad = dir.path().join("no/such/dir/x.glb");
    let e = GltfWriter::new(&bad).finish().unwrap_err().to_string();
    assert!(e.contains("x.glb.tmp"), "{e}");
    assert!(!bad.exists());
}

#[test]
fn each_hand_is_keyed_over_its_own_life_only() {
    // 1,000 frames; hand #1 in all of them, then a new id every 100 frames for 10 frames
    // (hands lost and found again, as in a long video). Each short-lived track is keyed
    // over its 10 frames and one hidden frame either side: its cost does not grow with
    // the video's length.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.glb");
    let mut w = GltfWriter::new(&path);
    for i in 0..1000u64 {
        let t = i as f64 / 30.0;
        let mut hands = vec![hand(HandSide::Right, 1, t)];
        if i % 100 >= 50 && i % 100 < 60 {
            hands.push(hand(HandSide::Left, 100 + i / 100, t));
        }
        w.add_frame(t, &hands).unwrap();
    }
    w.finish().unwrap();
    let glb = parse_glb(&std::fs::read(&path).unwrap());
    let j = &glb.json;
    let nodes = j["nodes"].as_array().unwrap();
    let anim = &j["animations"][0];
    let input_of = |name: &str| {
        let node = nodes.iter().position(|n| n["name"] == name).unwrap();
        let c = anim["channels"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["target"]["node"] == node && c["target"]["path"] == "scale")
            .unwrap();
        let s = &anim["samplers"][c["sampler"].as_u64().unwrap() as usize];
        (
            glb.floats(s["input"].as_u64().unwrap() as usize),
            glb.floats(s["output"].as_u64().unwrap() as usize),
        )
    };
    let (t1, _) = input_of("wrist_1_right");
    assert_eq!(t1.len(), 1000);
    // Hand #104 lives in frames 450-459: keys at frames 449..=460, hidden at both ends.
    let (t, sc) = input_of("wrist_104_left");
    assert_eq!(t.len(), 12);
    assert_eq!(t[0], (449.0f64 / 30.0) as f32);
    assert_eq!(t[11], (460.0f64 / 30.0) as f32);
    let shown: Vec<f32> = sc.chunks(3).map(|c| c[0]).collect();
    assert_eq!(shown[0], 0.0);
    assert!(shown[1..11].iter().all(|&s| s == 1.0));
    assert_eq!(shown[11], 0.0);
    // 11 tracks: the file is about the long track plus 10 short ones, not 11 long ones.
    let size = std::fs::metadata(&path).unwrap().len();
    let per_key = 4 * (1 + 3) * (21 * 2 + 20 * 3); // bytes per frame of one track, about
    assert!(
        (size as usize) < per_key * (1000 + 10 * 12) + 200_000,
        "{size} bytes"
    );
}

/// Every mesh, material and accessor of `j` is used (by a node, a mesh, a skin or an
/// animation), and every node is reachable from the scene: the Khronos validator's
/// `UNUSED_OBJECT` (scripts/web-test.sh runs the validator itself).
fn assert_nothing_unused(j: &Value) {
    let arr = |k: &str| j[k].as_array().cloned().unwrap_or_default();
    let idx = |v: &Value| v.as_u64().unwrap() as usize;
    let mut accessors = std::collections::BTreeSet::new();
    let mut meshes = std::collections::BTreeSet::new();
    let mut materials = std::collections::BTreeSet::new();
    let mut reached = std::collections::BTreeSet::new();
    let mut stack: Vec<usize> = j["scenes"][0]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(idx)
        .collect();
    while let Some(n) = stack.pop() {
        assert!(reached.insert(n), "node {n} reached twice");
        let node = &j["nodes"][n];
        if let Some(c) = node["children"].as_array() {
            stack.extend(c.iter().map(idx));
        }
        if let Some(m) = node.get("mesh") {
            meshes.insert(idx(m));
        }
    }
    assert_eq!(
        reached.len(),
        arr("nodes").len(),
        "every node is in the scene"
    );
    for m in &meshes {
        for p in j["meshes"][*m]["primitives"].as_array().unwrap() {
            accessors.extend(p["attributes"].as_object().unwrap().values().map(idx));
            accessors.insert(idx(&p["indices"]));
            materials.insert(idx(&p["material"]));
        }
    }
    for s in arr("skins") {
        accessors.insert(idx(&s["inverseBindMatrices"]));
    }
    for a in arr("animations") {
        for s in a["samplers"].as_array().unwrap() {
            accessors.insert(idx(&s["input"]));
            accessors.insert(idx(&s["output"]));
        }
    }
    assert_eq!(meshes, (0..arr("meshes").len()).collect(), "meshes used");
    assert_eq!(
        materials,
        (0..arr("materials").len()).collect(),
        "materials used"
    );
    assert_eq!(
        accessors,
        (0..arr("accessors").len()).collect(),
        "accessors used"
    );
}

#[test]
fn a_right_hand_alone_as_joints_adds_no_left_hand_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("right.glb");
    let mut w = GltfWriter::new(&path);
    for i in 0..3 {
        let t = i as f64 * 0.1;
        w.add_frame(t, &[hand(HandSide::Right, 1, t)]).unwrap();
    }
    w.finish().unwrap();
    let glb = parse_glb(&std::fs::read(&path).unwrap());
    assert_nothing_unused(&glb.json);
    let names: Vec<&str> = glb.json["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    // The right joint and the five fingers' bones; no left joint.
    assert_eq!(names.len(), 6, "{names:?}");
    assert!(names.contains(&"right_joint") && !names.contains(&"left_joint"));
}

#[test]
fn the_skinned_hand_is_a_root_node_and_follows_the_joints() {
    let mesh = HandMesh::webxr(HandSide::Left).unwrap();
    // The mesh's own rest pose, in the camera's frame (mm) half a metre away, moved 10 mm
    // to the right each frame.
    let rest = mesh.rest_joints();
    let at = |k: usize| -> [[f64; 3]; NUM_JOINTS] {
        rest.map(|p| {
            [
                p[0] as f64 * 1000.0 + 10.0 * k as f64,
                -p[1] as f64 * 1000.0,
                -p[2] as f64 * 1000.0 + 500.0,
            ]
        })
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("skinned.glb");
    let mut w = GltfWriter::new(&path);
    w.set_hand(GltfHand::Skinned).unwrap();
    for k in 0..4 {
        let mut h = HandRecord::from_keypoints(HandSide::Left, &Keypoints2d::default());
        h.id = Some(7);
        h.joints_3d_mm = Some(at(k));
        w.add_frame(k as f64 / 30.0, &[h]).unwrap();
    }
    w.finish().unwrap();
    let glb = parse_glb(&std::fs::read(&path).unwrap());
    let j = &glb.json;
    assert_nothing_unused(j);
    assert_eq!(j["skins"].as_array().unwrap().len(), 1);
    assert_eq!(
        j["meshes"].as_array().unwrap().len(),
        1,
        "the skinned hand only"
    );
    // The skinned mesh's node is a root of the scene; the hand's node holds its joints.
    let nodes = j["nodes"].as_array().unwrap();
    let roots: Vec<u64> = j["scenes"][0]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_u64().unwrap())
        .collect();
    let skinned: Vec<u64> = (0..nodes.len() as u64)
        .filter(|&n| nodes[n as usize].get("skin").is_some())
        .collect();
    assert_eq!(skinned.len(), 1);
    assert!(roots.contains(&skinned[0]), "{roots:?}");
    assert_eq!(nodes[skinned[0] as usize]["name"], "mesh_7_left");
    let hand = nodes.iter().find(|n| n["name"] == "hand_7_left").unwrap();
    assert_eq!(
        hand["children"].as_array().unwrap().len(),
        MESH_JOINTS.len()
    );
    // Joint indices of zero weight are 0 (the validator's ACCESSOR_JOINTS_USED_ZERO_WEIGHT).
    let prim = &j["meshes"][0]["primitives"][0];
    let weights = glb.floats_unbounded(prim["attributes"]["WEIGHTS_0"].as_u64().unwrap() as usize);
    let ja = &j["accessors"][prim["attributes"]["JOINTS_0"].as_u64().unwrap() as usize];
    assert_eq!(ja["componentType"], 5121);
    let view = &j["bufferViews"][ja["bufferView"].as_u64().unwrap() as usize];
    let off = view["byteOffset"].as_u64().unwrap() as usize;
    let joints = &glb.bin[off..off + weights.len()];
    let unweighted = weights.iter().filter(|&&w| w == 0.0).count();
    assert!(unweighted > 1000, "{unweighted} joint slots of zero weight");
    for (i, (&jt, &wt)) in joints.iter().zip(&weights).enumerate() {
        assert!(
            wt != 0.0 || jt == 0,
            "slot {i}: joint {jt} with zero weight"
        );
    }
    // Each fitted joint's node is keyed where the fit put it (glTF frame, metres).
    let anim = &j["animations"][0];
    for (k, (name, fit)) in MESH_JOINTS.iter().enumerate() {
        let Some(fit) = fit else { continue };
        let node = nodes
            .iter()
            .position(|n| n["name"] == format!("{name}_7_left"))
            .unwrap();
        let c = anim["channels"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["target"]["node"] == node && c["target"]["path"] == "translation")
            .unwrap();
        let s = &anim["samplers"][c["sampler"].as_u64().unwrap() as usize];
        let tr = glb.floats(s["output"].as_u64().unwrap() as usize);
        for f in 0..4 {
            let want = to_gltf(at(f)[*fit]);
            for a in 0..3 {
                assert!(
                    (tr[3 * f + a] - want[a]).abs() < 1e-5,
                    "joint {k} frame {f}"
                );
            }
        }
    }
}
