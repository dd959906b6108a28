//! OpenPose-style JSON: one file per frame with the 2D and 3D hand keypoints
//! (built on [`crate::openpose`]).

use crate::error::IoResult;
use crate::jsonl::{FrameRecord, HandRecord};
use crate::openpose::{write_openpose_file, OpenPoseHandOut, OpenPosePerson};
use monohand_core::hand_model::HandSide;
use monohand_core::observation::Keypoints2d;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// The OpenPose people of a frame. OpenPose groups hands by person; monohand
/// does not know persons, so a frame with at most one left and one right hand
/// gives one person holding both, and any other frame one person per hand
/// (in the frame's order).
pub fn openpose_people(frame: &FrameRecord) -> Vec<OpenPosePerson> {
    let out = |h: &HandRecord| OpenPoseHandOut {
        keypoints_2d: Keypoints2d {
            points: h.keypoints_2d,
        },
        joints_3d: h.joints_3d_mm.map(|j| j.map(Vector3::from)),
    };
    let count = |s: HandSide| frame.hands.iter().filter(|h| h.side == s).count();
    if count(HandSide::Left) <= 1 && count(HandSide::Right) <= 1 {
        if frame.hands.is_empty() {
            return Vec::new();
        }
        let pick = |s: HandSide| frame.hands.iter().find(|h| h.side == s).map(out);
        return vec![OpenPosePerson {
            left: pick(HandSide::Left),
            right: pick(HandSide::Right),
        }];
    }
    frame
        .hands
        .iter()
        .map(|h| match h.side {
            HandSide::Left => OpenPosePerson {
                left: Some(out(h)),
                right: None,
            },
            HandSide::Right => OpenPosePerson {
                left: None,
                right: Some(out(h)),
            },
        })
        .collect()
}

/// The file name OpenPose uses for a frame: `{stem}_{frame:012}_keypoints.json`.
pub fn openpose_file_name(stem: &str, frame: u64) -> String {
    format!("{stem}_{frame:012}_keypoints.json")
}

/// Writes one frame as `dir/{stem}_{frame:012}_keypoints.json` and returns the path.
/// The directory must exist. [`crate::openpose::read_openpose`] reads the
/// directory back (2D keypoints).
pub fn write_openpose_frame(dir: &Path, stem: &str, frame: &FrameRecord) -> IoResult<PathBuf> {
    let path = dir.join(openpose_file_name(stem, frame.frame));
    write_openpose_file(&path, &openpose_people(frame))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::test_support::hand;
    use monohand_core::hand_model::NUM_JOINTS;
    use serde_json::Value;

    #[test]
    fn openpose_export_pairs_hands_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let frame = FrameRecord {
            frame: 12,
            hands: vec![
                hand(HandSide::Right, Some(1), 500.0),
                hand(HandSide::Left, Some(2), 450.0),
            ],
            ..Default::default()
        };
        let people = openpose_people(&frame);
        assert_eq!(people.len(), 1);
        assert!(people[0].left.is_some() && people[0].right.is_some());
        let path = write_openpose_frame(dir.path(), "clip", &frame).unwrap();
        assert!(path.ends_with("clip_000000000012_keypoints.json"));
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let l3 = v["people"][0]["hand_left_keypoints_3d"].as_array().unwrap();
        assert_eq!(l3.len(), 4 * NUM_JOINTS);
        assert_eq!(l3[4 * 2 + 2].as_f64(), Some(452.0));
        assert_eq!(l3[3].as_f64(), Some(0.75));
        let back = crate::openpose::read_openpose(dir.path()).unwrap();
        assert_eq!(back[0].hands.len(), 2);
        assert_eq!(
            back[0].hand(HandSide::Right).unwrap().keypoints.points[3],
            [103.0, 50.5, 0.75]
        );
        // Two right hands: one person each.
        let two = FrameRecord {
            hands: vec![
                hand(HandSide::Right, Some(1), 1.0),
                hand(HandSide::Right, Some(2), 2.0),
            ],
            ..Default::default()
        };
        assert_eq!(openpose_people(&two).len(), 2);
        assert!(openpose_people(&FrameRecord::default()).is_empty());
    }
}
