//! Fuzzing of monohand-eval's parsers of outside input (see docs/fuzzing.md): MATLAB v5
//! `.mat` files (then the STB labels read from them), the evaluation manifest, STB's
//! camera_params.json and hand-graph-cnn's labels.json. Every mutated input must give `Ok`
//! or `Err`: no panic, no allocation over the harness limit, no hang.
//!
//! `MONOHAND_FUZZ_CASES` sets the number of mutated inputs per parser (default below, sized
//! for `.ci/run`), `MONOHAND_FUZZ_SEED` the RNG seed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "../../monohand-io/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use std::io::{Read, Write};
use std::path::Path;

use fuzz_support::{cases, mutate_binary, mutate_text, run, shared, text, Regions, TrackingAlloc};
use monohand_eval::datasets::hand_graph_cnn::load_hand_graph_cnn;
use monohand_eval::manifest::parse_manifest;
use monohand_eval::mat::{to_bytes, MatArray, MatFile};
use monohand_eval::stb::{stb_cameras_from_str, StbSequence};

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated inputs per parser in a default `cargo test`.
const CI_CASES: usize = 3000;
/// The .mat seeds are larger (the real STB file inflates to 0.75 MB).
const CI_MAT_CASES: usize = 2000;

const DIR: &str = env!("CARGO_MANIFEST_DIR");

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// The same file with its data elements in one `miCOMPRESSED` element.
fn compressed(file: &[u8]) -> Vec<u8> {
    let body = zlib(&file[128..]);
    let mut out = file[..128].to_vec();
    let big = &file[126..128] == b"MI";
    for word in [15u32, body.len() as u32] {
        out.extend(if big {
            word.to_be_bytes()
        } else {
            word.to_le_bytes()
        });
    }
    out.extend(body);
    out
}

/// A compressed file's elements, inflated (uncompressed files are valid v5 too).
fn inflated(file: &[u8]) -> Vec<u8> {
    let mut out = file[..128].to_vec();
    let mut pos = 128;
    while pos + 8 <= file.len() {
        let ty = u32::from_le_bytes(file[pos..pos + 4].try_into().unwrap());
        let n = u32::from_le_bytes(file[pos + 4..pos + 8].try_into().unwrap()) as usize;
        let data = &file[pos + 8..pos + 8 + n];
        if ty == 15 {
            flate2::read::ZlibDecoder::new(data)
                .read_to_end(&mut out)
                .unwrap();
        } else {
            out.extend_from_slice(&file[pos..pos + 8 + n]);
        }
        pos += 8 + n;
    }
    out
}

/// A big-endian file with an int16 array stored with the small-element name format and a
/// complex single array: the paths `to_bytes` does not write.
fn big_endian_seed() -> Vec<u8> {
    fn tag(out: &mut Vec<u8>, ty: u32, data: &[u8]) {
        out.extend(ty.to_be_bytes());
        out.extend((data.len() as u32).to_be_bytes());
        out.extend_from_slice(data);
        while !out.len().is_multiple_of(8) {
            out.push(0);
        }
    }
    let mut header = b"MATLAB 5.0 MAT-file, big-endian fuzz seed".to_vec();
    header.resize(116, b' ');
    header.extend([0u8; 8]);
    header.extend(0x0100u16.to_be_bytes());
    header.extend(b"MI");
    let mut out = header;
    // int16 [2, 3], name "ab" in a small data element.
    let mut m = Vec::new();
    tag(&mut m, 6, &[0, 0, 0, 10, 0, 0, 0, 0]);
    tag(&mut m, 5, &[0, 0, 0, 2, 0, 0, 0, 3]);
    m.extend(((2u32 << 16) | 1).to_be_bytes());
    m.extend(b"ab\0\0");
    let vals: Vec<u8> = [1i16, -2, 3, -4, 5, -6]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    tag(&mut m, 3, &vals);
    tag(&mut out, 14, &m);
    // complex single [1, 2], logical flag set.
    let mut m = Vec::new();
    tag(&mut m, 6, &[0, 0, 0x0a, 7, 0, 0, 0, 0]);
    tag(&mut m, 5, &[0, 0, 0, 1, 0, 0, 0, 2]);
    tag(&mut m, 1, b"cplx");
    let re: Vec<u8> = [1.5f32, 2.5].iter().flat_map(|v| v.to_be_bytes()).collect();
    tag(&mut m, 7, &re);
    tag(&mut m, 7, &re);
    tag(&mut out, 14, &m);
    // a cell array (skipped as unsupported).
    let mut m = Vec::new();
    tag(&mut m, 6, &[0, 0, 0, 1, 0, 0, 0, 0]);
    tag(&mut m, 5, &[0, 0, 0, 1, 0, 0, 0, 1]);
    tag(&mut m, 1, b"cell");
    tag(&mut out, 14, &m);
    out
}

#[test]
fn fuzz_mat() {
    let real = shared(DIR, "stb_b1counting/labels/B1Counting_BB.mat");
    let hand: Vec<f64> = (0..3 * 21 * 2).map(|i| i as f64 * 1.5 - 20.0).collect();
    let small = to_bytes(&[
        MatArray::new("handPara", vec![3, 21, 2], hand).unwrap(),
        MatArray::new("x", vec![1, 1], vec![7.0]).unwrap(),
        MatArray::new("empty", vec![0, 3], vec![]).unwrap(),
    ]);
    let seeds = vec![
        small.clone(),
        compressed(&small),
        big_endian_seed(),
        compressed(&big_endian_seed()),
        inflated(&real),
        real,
    ];
    // Structure: the header and the element tags sit in the first bytes of the large seeds;
    // the rest is numbers. Small seeds are all structure.
    let head = |n: usize| Regions(vec![(0, n), (116, 128)]);
    let regions = [
        Regions(vec![]),
        Regions(vec![]),
        Regions(vec![]),
        Regions(vec![]),
        head(256),
        head(256),
    ];
    run(
        "mat",
        &seeds,
        cases(CI_MAT_CASES),
        |rng, seeds| {
            let mut b = mutate_binary(rng, seeds, &regions);
            // Mutations inside compressed elements: recompress a mutated body.
            if b.len() > 128 && rng.chance(25) {
                b = compressed(&b);
            }
            b
        },
        |input| {
            let mat = MatFile::from_bytes(input, "fuzz.mat")?;
            for a in &mat.arrays {
                let _ = a.get(&[1, 2, 3]);
                let _ = a.get(&[0]);
            }
            if mat.require("handPara").is_ok() {
                let seq = StbSequence::from_mat(&mat, "fuzz.mat")?;
                let _ = seq.frames.first().map(|f| f.bone_lengths());
            }
            Ok::<_, monohand_io::IoError>(())
        },
    );
}

const CAM: &str = r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480}"#;

fn manifest_seed() -> Vec<u8> {
    let joints: Vec<String> = (0..21)
        .map(|j| format!("[{}, {}, 500]", j, 2 * j))
        .collect();
    let joints = format!("[{}]", joints.join(", "));
    let kp2: Vec<String> = (0..21)
        .map(|j| format!("[{}, {}]", 10 + j, 20 + j))
        .collect();
    let kp3: Vec<String> = (0..21)
        .map(|j| format!("[{}, {}, 0.9]", 10 + j, 20 + j))
        .collect();
    let cam2 = r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480, "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [-120, 0, 0]}"#;
    let mut s = String::new();
    s.push_str(&format!(
        r#"{{"sequence": "s", "frame": 0, "images": ["a_l.png", "a_r.png"], "cameras": [{CAM}, {cam2}], "root": "palm_centre", "hands": [{{"side": "left", "joints_3d": {joints}, "keypoints_2d": [[{}], [{}]]}}]}}"#,
        kp2.join(", "),
        kp3.join(", ")
    ));
    s.push('\n');
    s.push('\n');
    s.push_str(&format!(
        r#"{{"sequence": "s", "cameras": [{CAM}], "root": "palm_centre", "hands": [{{"side": "right", "joints_3d": {joints}}}, {{"side": "left", "joints_3d": {joints}}}]}}"#
    ));
    s.push('\n');
    s.push_str(&format!(
        r#"{{"sequence": "t", "frame": 9, "cameras": [{CAM}], "root": "palm_centre", "hands": [{{"side": "right", "joints_3d": {joints}}}]}}"#
    ));
    s.push('\n');
    s.into_bytes()
}

#[test]
fn fuzz_manifest() {
    let seeds = vec![manifest_seed()];
    run("manifest", &seeds, cases(CI_CASES), mutate_text, |input| {
        let ds = parse_manifest(input, "fuzz.jsonl", Path::new("/data"))?;
        // What the evaluation does next with each frame.
        for f in &ds.frames {
            for h in 0..f.hands.len() {
                for v in 0..f.cameras.len() {
                    let _ = f.gt_keypoints(h, v);
                }
            }
        }
        let _ = ds.sequences();
        let _ = ds.num_hands();
        Ok::<_, monohand_eval::EvalError>(())
    });
}

#[test]
fn fuzz_stb_cameras() {
    let seeds = vec![shared(DIR, "stb_b1counting/camera_params.json")];
    run(
        "stb_cameras",
        &seeds,
        cases(CI_CASES),
        mutate_text,
        |input| stb_cameras_from_str(&text(input), "camera_params.json"),
    );
}

#[test]
fn fuzz_hand_graph_cnn_labels() {
    // The real labels, cut to their first three frames (the 292 frames only slow the run).
    let real = shared(DIR, "hand_graph_cnn_dev/labels.json");
    let mut v: serde_json::Value = serde_json::from_slice(&real).unwrap();
    v["frames"].as_array_mut().unwrap().truncate(3);
    let seeds = vec![serde_json::to_vec_pretty(&v).unwrap()];
    let dir = tempfile::tempdir().unwrap();
    let labels = dir.path().join("labels.json");
    run(
        "hand_graph_cnn_labels",
        &seeds,
        cases(CI_CASES / 3),
        mutate_text,
        |input| {
            std::fs::write(&labels, input).unwrap();
            load_hand_graph_cnn(dir.path()).map(|ds| ds.frames.len())
        },
    );
}
