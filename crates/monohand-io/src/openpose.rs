//! OpenPose `--write_json` keypoint files: reading hands, and writing them back.
//!
//! OpenPose writes one file per frame, `<name>_<000000000012>_keypoints.json`:
//!
//! ```json
//! {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": [...],
//!   "hand_left_keypoints_2d": [x0, y0, c0, x1, y1, c1, ...],
//!   "hand_right_keypoints_2d": [...],
//!   "hand_left_keypoints_3d": [x0, y0, z0, c0, ...], "hand_right_keypoints_3d": [...]}]}
//! ```
//!
//! Each `hand_*_keypoints_2d` holds 21 `[x, y, confidence]` triples (63 numbers)
//! in the OpenPose hand order, which is monohand's order. An empty array, or
//! one whose confidences are all zero (OpenPose writes zeros when it saw no
//! hand), means no hand. Confidences above 1 (a heat-map peak can overshoot)
//! are clamped to 1; negative ones are errors.
//!
//! ```
//! use monohand_io::openpose::parse_openpose;
//! use monohand_core::prelude::HandSide;
//! let mut kp: Vec<f64> = Vec::new();
//! for j in 0..21 { kp.extend([100.0 + j as f64, 200.0, 0.9]); }
//! let json = serde_json::json!({"people": [{"hand_left_keypoints_2d": [],
//!                                          "hand_right_keypoints_2d": kp}]});
//! let frame = parse_openpose(&json.to_string(), "f_keypoints.json").unwrap();
//! assert_eq!(frame.hands.len(), 1);
//! assert_eq!(frame.hands[0].side, HandSide::Right);
//! assert_eq!(frame.hands[0].keypoints.points[3], [103.0, 200.0, 0.9]);
//! ```

use crate::error::{name_of, read_text, IoError, IoResult};
use monohand_core::prelude::*;
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// The hands found in one OpenPose frame file.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenPoseFrame {
    /// The file name (without directory) the frame came from.
    pub source: String,
    /// Every hand with at least one joint of positive confidence, people in
    /// file order, left hand before right for each person.
    pub hands: Vec<HandObservation>,
    /// For each entry of [`OpenPoseFrame::hands`], its index in `people`.
    pub person_of_hand: Vec<usize>,
}

impl OpenPoseFrame {
    /// The first hand of this side, if any.
    pub fn hand(&self, side: HandSide) -> Option<&HandObservation> {
        self.hands.iter().find(|h| h.side == side)
    }
}

/// Splits a name into text and number runs so that `f2` sorts before `f10`.
fn natural_key(name: &str) -> Vec<(bool, u128, String)> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut digits = false;
    let push = |out: &mut Vec<(bool, u128, String)>, s: &mut String, d: bool| {
        if !s.is_empty() {
            let n = if d { s.parse().unwrap_or(u128::MAX) } else { 0 };
            out.push((d, n, std::mem::take(s)));
        }
    };
    for c in name.chars() {
        let d = c.is_ascii_digit();
        if d != digits {
            push(&mut out, &mut cur, digits);
            digits = d;
        }
        cur.push(c);
    }
    push(&mut out, &mut cur, digits);
    out
}

/// The frame files of an OpenPose output: a single file as is, or the
/// `*_keypoints.json` files of a directory (all `*.json` if there are none)
/// sorted by name, numbers compared by value (`f2` before `f10`).
pub fn list_openpose_files(path: impl AsRef<Path>) -> IoResult<Vec<PathBuf>> {
    let path = path.as_ref();
    let meta = std::fs::metadata(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })?;
    if !meta.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let entries = std::fs::read_dir(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        error: source,
    })?;
    let mut all = Vec::new();
    for e in entries {
        let e = e.map_err(|source| IoError::Read {
            path: path.to_path_buf(),
            error: source,
        })?;
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if name.to_ascii_lowercase().ends_with(".json") && p.is_file() {
            all.push((name, p));
        }
    }
    let keypoint_files: Vec<_> = all
        .iter()
        .filter(|(n, _)| n.ends_with("_keypoints.json"))
        .cloned()
        .collect();
    let mut chosen = if keypoint_files.is_empty() {
        all
    } else {
        keypoint_files
    };
    if chosen.is_empty() {
        return Err(IoError::format(
            name_of(path),
            "directory has no *_keypoints.json (or *.json) files",
        ));
    }
    chosen.sort_by(|a, b| {
        natural_key(&a.0)
            .cmp(&natural_key(&b.0))
            .then(a.0.cmp(&b.0))
    });
    Ok(chosen.into_iter().map(|(_, p)| p).collect())
}

/// Reads one OpenPose frame file.
pub fn read_openpose_file(path: impl AsRef<Path>) -> IoResult<OpenPoseFrame> {
    let path = path.as_ref();
    let text = read_text(path)?;
    let mut frame = parse_openpose(&text, &name_of(path))?;
    frame.source = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| name_of(path));
    Ok(frame)
}

/// Reads every frame of an OpenPose output (file or directory, see
/// [`list_openpose_files`]); stops at the first bad file.
pub fn read_openpose(path: impl AsRef<Path>) -> IoResult<Vec<OpenPoseFrame>> {
    list_openpose_files(path)?
        .iter()
        .map(read_openpose_file)
        .collect()
}

/// Parses the text of one OpenPose frame file; `file` names it in errors and
/// becomes [`OpenPoseFrame::source`].
pub fn parse_openpose(text: &str, file: &str) -> IoResult<OpenPoseFrame> {
    let v: Value = serde_json::from_str(text).map_err(|e| IoError::json(file, &e))?;
    let people = v
        .get("people")
        .ok_or_else(|| IoError::field(file, "people", "missing"))?
        .as_array()
        .ok_or_else(|| IoError::field(file, "people", "expected an array"))?;
    let mut frame = OpenPoseFrame {
        source: file.to_string(),
        hands: Vec::new(),
        person_of_hand: Vec::new(),
    };
    for (i, person) in people.iter().enumerate() {
        if !person.is_object() {
            return Err(IoError::field(
                file,
                format!("people[{i}]"),
                "expected an object",
            ));
        }
        for side in [HandSide::Left, HandSide::Right] {
            let key = format!("hand_{side}_keypoints_2d");
            let field = format!("people[{i}].{key}");
            let Some(arr) = person.get(&key) else {
                continue;
            };
            if let Some(kp) = parse_hand(arr, file, &field)? {
                frame.hands.push(HandObservation {
                    side,
                    keypoints: kp,
                    cues: None,
                });
                frame.person_of_hand.push(i);
            }
        }
    }
    Ok(frame)
}

/// Parses one `hand_*_keypoints_2d` array: `None` for no hand.
fn parse_hand(arr: &Value, file: &str, field: &str) -> IoResult<Option<Keypoints2d>> {
    let a = match arr {
        Value::Null => return Ok(None),
        Value::Array(a) => a,
        other => {
            return Err(IoError::field(
                file,
                field,
                format!("expected an array of numbers, got {other}"),
            ))
        }
    };
    if a.is_empty() {
        return Ok(None);
    }
    if a.len() != 3 * NUM_JOINTS {
        return Err(IoError::field(
            file,
            field,
            format!(
                "expected {} values (21 x [x, y, confidence]), got {}",
                3 * NUM_JOINTS,
                a.len()
            ),
        ));
    }
    let mut kp = Keypoints2d::default();
    for (i, x) in a.iter().enumerate() {
        let v = x.as_f64().ok_or_else(|| {
            IoError::field(
                file,
                format!("{field}[{i}]"),
                format!("expected a number, got {x}"),
            )
        })?;
        if !v.is_finite() {
            return Err(IoError::field(file, format!("{field}[{i}]"), "not finite"));
        }
        kp.points[i / 3][i % 3] = v;
    }
    for (j, p) in kp.points.iter_mut().enumerate() {
        if p[2] < 0.0 {
            return Err(IoError::field(
                file,
                format!("{field}[{}]", 3 * j + 2),
                format!("confidence {} of joint {j} is negative", p[2]),
            ));
        }
        p[2] = p[2].min(1.0);
    }
    if kp.is_empty() {
        return Ok(None);
    }
    Ok(Some(kp))
}

/// One hand to write: 2D keypoints and, optionally, 3D joints (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpenPoseHandOut {
    /// The 2D keypoints `[u, v, confidence]`.
    pub keypoints_2d: Keypoints2d,
    /// 3D joints in mm; written as `[x, y, z, c]` with `c` the 2D confidence
    /// (1 where the 2D confidence is 0, since the model places every joint).
    pub joints_3d: Option<[Vector3<f64>; NUM_JOINTS]>,
}

/// One person to write: up to two hands.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OpenPosePerson {
    /// The left hand, if any.
    pub left: Option<OpenPoseHandOut>,
    /// The right hand, if any.
    pub right: Option<OpenPoseHandOut>,
}

/// The OpenPose JSON (format version 1.3) for these people. Body and face
/// arrays are written empty; a missing hand is an empty array.
pub fn to_openpose_json(people: &[OpenPosePerson]) -> Value {
    let hand2d = |h: &Option<OpenPoseHandOut>| -> Value {
        match h {
            Some(h) => json!(h.keypoints_2d.points.iter().flatten().collect::<Vec<_>>()),
            None => json!([]),
        }
    };
    let hand3d = |h: &Option<OpenPoseHandOut>| -> Value {
        match h.and_then(|h| h.joints_3d.map(|j| (h.keypoints_2d, j))) {
            Some((kp, joints)) => {
                let mut v = Vec::with_capacity(4 * NUM_JOINTS);
                for (j, x) in joints.iter().enumerate() {
                    let c = kp.points[j][2];
                    v.extend([x.x, x.y, x.z, if c > 0.0 { c } else { 1.0 }]);
                }
                json!(v)
            }
            None => json!([]),
        }
    };
    let people: Vec<Value> = people
        .iter()
        .map(|p| {
            json!({
                "person_id": [-1],
                "pose_keypoints_2d": [],
                "face_keypoints_2d": [],
                "hand_left_keypoints_2d": hand2d(&p.left),
                "hand_right_keypoints_2d": hand2d(&p.right),
                "pose_keypoints_3d": [],
                "face_keypoints_3d": [],
                "hand_left_keypoints_3d": hand3d(&p.left),
                "hand_right_keypoints_3d": hand3d(&p.right),
            })
        })
        .collect();
    json!({"version": 1.3, "people": people})
}

/// Writes one OpenPose frame file (see [`to_openpose_json`]).
pub fn write_openpose_file(path: impl AsRef<Path>, people: &[OpenPosePerson]) -> IoResult<()> {
    crate::sink::write_file_atomically(
        path.as_ref(),
        to_openpose_json(people).to_string().as_bytes(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kp_values(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| match i % 3 {
                2 => 0.5,
                k => 10.0 * i as f64 + k as f64,
            })
            .collect()
    }

    fn frame_json(left: Value, right: Value) -> String {
        json!({"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": [],
            "hand_left_keypoints_2d": left, "hand_right_keypoints_2d": right}]})
        .to_string()
    }

    #[test]
    fn parses_hands_and_skips_empty_ones() {
        let f = parse_openpose(
            &frame_json(json!(kp_values(63)), json!(vec![0.0; 63])),
            "a.json",
        )
        .unwrap();
        assert_eq!(f.hands.len(), 1);
        assert_eq!(f.hands[0].side, HandSide::Left);
        assert_eq!(f.hands[0].keypoints.points[20], [600.0, 611.0, 0.5]);
        assert_eq!(f.person_of_hand, vec![0]);
        let f = parse_openpose(&frame_json(json!([]), json!(kp_values(63))), "a.json").unwrap();
        assert_eq!(f.hand(HandSide::Right).unwrap().side, HandSide::Right);
        assert!(f.hand(HandSide::Left).is_none());
        let f = parse_openpose(r#"{"version": 1.3, "people": []}"#, "a.json").unwrap();
        assert!(f.hands.is_empty());
        // Overshooting confidence is clamped.
        let mut v = kp_values(63);
        v[2] = 1.03;
        let f = parse_openpose(&frame_json(json!(v), json!([])), "a.json").unwrap();
        assert_eq!(f.hands[0].keypoints.points[0][2], 1.0);
    }

    #[test]
    fn bad_frames_name_file_and_field() {
        let e = parse_openpose(
            &frame_json(json!(kp_values(60)), json!([])),
            "f_keypoints.json",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("f_keypoints.json")
                && e.contains("people[0].hand_left_keypoints_2d")
                && e.contains("got 60"),
            "{e}"
        );
        let mut v: Vec<Value> = kp_values(63).into_iter().map(|x| json!(x)).collect();
        v[7] = json!("NaN");
        let e = parse_openpose(&frame_json(json!([]), json!(v)), "g.json")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("g.json") && e.contains("hand_right_keypoints_2d[7]"),
            "{e}"
        );
        let text = frame_json(json!(kp_values(63)), json!([])).replace("600.0", "NaN");
        let e = parse_openpose(&text, "n.json").unwrap_err().to_string();
        assert!(e.contains("n.json") && e.contains("invalid JSON"), "{e}");
        let e = parse_openpose("{\"people\": [", "t.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.json"), "{e}");
        let e = parse_openpose("{}", "p.json").unwrap_err().to_string();
        assert!(e.contains("p.json: field people: missing"), "{e}");
        let mut v = kp_values(63);
        v[5] = -0.5;
        let e = parse_openpose(&frame_json(json!(v), json!([])), "c.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("[5]") && e.contains("negative"), "{e}");
    }

    #[test]
    fn directory_order_and_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut kp = Keypoints2d::default();
        for (j, p) in kp.points.iter_mut().enumerate() {
            *p = [j as f64 * 3.0, 50.0 - j as f64, 0.25 + j as f64 / 40.0];
        }
        let joints: [Vector3<f64>; NUM_JOINTS] =
            std::array::from_fn(|j| Vector3::new(j as f64, 2.0, 500.0));
        // Files named so that plain string order is wrong: 10 < 2 < 9.
        for i in [2usize, 10, 9] {
            let mut k = kp;
            k.points[0][0] = i as f64;
            let person = OpenPosePerson {
                left: None,
                right: Some(OpenPoseHandOut {
                    keypoints_2d: k,
                    joints_3d: Some(joints),
                }),
            };
            write_openpose_file(dir.path().join(format!("v_{i}_keypoints.json")), &[person])
                .unwrap();
        }
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        std::fs::write(dir.path().join("other.json"), "{}").unwrap();
        let frames = read_openpose(dir.path()).unwrap();
        let order: Vec<f64> = frames
            .iter()
            .map(|f| f.hands[0].keypoints.points[0][0])
            .collect();
        assert_eq!(order, vec![2.0, 9.0, 10.0]);
        assert_eq!(frames[0].source, "v_2_keypoints.json");
        assert_eq!(frames[1].hands[0].keypoints.points[5], kp.points[5]);
        // The 3D array is written as [x, y, z, c] x 21.
        let text = std::fs::read_to_string(dir.path().join("v_9_keypoints.json")).unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        let a = v["people"][0]["hand_right_keypoints_3d"]
            .as_array()
            .unwrap();
        assert_eq!(a.len(), 84);
        assert_eq!(a[4 * 3].as_f64(), Some(3.0));
        assert_eq!(
            v["people"][0]["hand_left_keypoints_3d"]
                .as_array()
                .unwrap()
                .len(),
            0
        );
        // A single file works too; a missing path is an error naming it.
        assert_eq!(
            list_openpose_files(dir.path().join("v_9_keypoints.json"))
                .unwrap()
                .len(),
            1
        );
        let e = read_openpose(dir.path().join("nope"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope"), "{e}");
        let empty = tempfile::tempdir().unwrap();
        assert!(list_openpose_files(empty.path()).is_err());
    }
}
