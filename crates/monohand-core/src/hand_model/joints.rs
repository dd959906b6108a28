//! The 21 hand keypoints and the five fingers, in the OpenPose / MediaPipe order.
//!
//! This module is the single source of truth for the joint order: every other
//! module, file format and test indexes joints through the constants here.

use serde::{Deserialize, Serialize};

/// Number of hand keypoints (wrist + 4 per finger).
pub const NUM_JOINTS: usize = 21;

/// Number of fingers (thumb, index, middle, ring, little).
pub const NUM_FINGERS: usize = 5;

/// Index of the wrist keypoint.
pub const WRIST: usize = 0;

/// Human-readable names of the 21 keypoints, in order.
pub const JOINT_NAMES: [&str; NUM_JOINTS] = [
    "wrist",
    "thumb_cmc",
    "thumb_mcp",
    "thumb_ip",
    "thumb_tip",
    "index_mcp",
    "index_pip",
    "index_dip",
    "index_tip",
    "middle_mcp",
    "middle_pip",
    "middle_dip",
    "middle_tip",
    "ring_mcp",
    "ring_pip",
    "ring_dip",
    "ring_tip",
    "little_mcp",
    "little_pip",
    "little_dip",
    "little_tip",
];

/// The parent of each keypoint in the kinematic tree (`None` for the wrist).
pub const PARENT: [Option<usize>; NUM_JOINTS] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(0),
    Some(5),
    Some(6),
    Some(7),
    Some(0),
    Some(9),
    Some(10),
    Some(11),
    Some(0),
    Some(13),
    Some(14),
    Some(15),
    Some(0),
    Some(17),
    Some(18),
    Some(19),
];

/// The 20 bones as (parent, child) keypoint pairs, finger by finger, base to tip.
pub const BONES: [(usize, usize); 20] = [
    (0, 1),
    (1, 2),
    (2, 3),
    (3, 4),
    (0, 5),
    (5, 6),
    (6, 7),
    (7, 8),
    (0, 9),
    (9, 10),
    (10, 11),
    (11, 12),
    (0, 13),
    (13, 14),
    (14, 15),
    (15, 16),
    (0, 17),
    (17, 18),
    (18, 19),
    (19, 20),
];

/// A finger of the hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Finger {
    /// The thumb; its base joint is the carpometacarpal (CMC) joint.
    Thumb,
    /// The index finger.
    Index,
    /// The middle finger.
    Middle,
    /// The ring finger.
    Ring,
    /// The little finger.
    Little,
}

impl Finger {
    /// All fingers in keypoint order.
    pub const ALL: [Finger; NUM_FINGERS] = [
        Finger::Thumb,
        Finger::Index,
        Finger::Middle,
        Finger::Ring,
        Finger::Little,
    ];

    /// Position of this finger in [`Finger::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The four keypoints of this finger, base to tip (e.g. MCP, PIP, DIP, tip).
    pub const fn joints(self) -> [usize; 4] {
        let b = 1 + 4 * (self as usize);
        [b, b + 1, b + 2, b + 3]
    }

    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Finger::Thumb => "thumb",
            Finger::Index => "index",
            Finger::Middle => "middle",
            Finger::Ring => "ring",
            Finger::Little => "little",
        }
    }
}

/// Which hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HandSide {
    /// The left hand.
    Left,
    /// The right hand.
    Right,
}

impl HandSide {
    /// `"left"` or `"right"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            HandSide::Left => "left",
            HandSide::Right => "right",
        }
    }

    /// The other hand.
    pub const fn opposite(self) -> HandSide {
        match self {
            HandSide::Left => HandSide::Right,
            HandSide::Right => HandSide::Left,
        }
    }
}

impl std::fmt::Display for HandSide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for HandSide {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "left" | "l" => Ok(HandSide::Left),
            "right" | "r" => Ok(HandSide::Right),
            other => Err(format!(
                "unknown hand side {other:?} (expected left or right)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parents_and_bones_agree() {
        for (p, c) in BONES {
            assert_eq!(PARENT[c], Some(p));
        }
        for f in Finger::ALL {
            let j = f.joints();
            assert_eq!(PARENT[j[0]], Some(WRIST));
            assert_eq!(JOINT_NAMES[j[3]], format!("{}_tip", f.name()));
        }
    }
}
