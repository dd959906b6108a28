//! The animated glTF export, parsed back: GLB container, JSON, accessors and
//! the animated joint positions.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_core::observation::Keypoints2d;
use monohand_io::export::GltfWriter;
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
        assert_eq!(a["componentType"], 5126);
        let view = &self.json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let off = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        let n = a["count"].as_u64().unwrap() as usize * comps(a["type"].as_str().unwrap());
        assert_eq!(n * 4, len, "accessor {acc} fills its view");
        assert!(off + len <= self.bin.len());
        assert_eq!(off % 4, 0);
        let v: Vec<f32> = self.bin[off..off + len]
            .chunks(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
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
    // Meshes: triangle indices stay within their vertex counts.
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
