//! The 27 pose parameters: translation, unit quaternion and 20 joint angles.
//!
//! Layout of the flat parameter vector (defined here once):
//!
//! | index  | meaning                                                        |
//! |--------|----------------------------------------------------------------|
//! | 0..3   | wrist translation in the (first) camera frame, millimetres     |
//! | 3..7   | hand orientation as a unit quaternion, `x, y, z, w`           |
//! | 7..27  | joint angles in radians, 4 per finger, thumb to little         |
//!
//! The four angles of a finger are, in order: base flexion, base abduction
//! (the MCP joint, or the CMC joint for the thumb), middle flexion (PIP; thumb
//! MCP) and distal flexion (DIP; thumb IP).

use crate::hand_model::joints::{Finger, NUM_FINGERS};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Number of pose parameters (3 translation + 4 quaternion + 20 angles).
pub const NUM_PARAMS: usize = 27;
/// Number of joint angles.
pub const NUM_ANGLES: usize = 20;
/// Angles per finger.
pub const ANGLES_PER_FINGER: usize = 4;
/// Degrees of freedom (the quaternion has 3).
pub const NUM_DOF: usize = 26;

/// Offset of the translation in the flat parameter vector.
pub const TRANSLATION: usize = 0;
/// Offset of the quaternion (`x, y, z, w`) in the flat parameter vector.
pub const QUATERNION: usize = 3;
/// Offset of the joint angles in the flat parameter vector.
pub const ANGLES: usize = 7;

/// Which angle of a finger.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FingerAngle {
    /// Flexion at the finger base (MCP; thumb CMC).
    BaseFlexion = 0,
    /// Abduction (spread) at the finger base (MCP; thumb CMC).
    BaseAbduction = 1,
    /// Flexion of the middle joint (PIP; thumb MCP).
    MiddleFlexion = 2,
    /// Flexion of the distal joint (DIP; thumb IP).
    DistalFlexion = 3,
}

/// Index of one angle in the 20-angle array.
pub const fn angle_index(finger: Finger, angle: FingerAngle) -> usize {
    finger.index() * ANGLES_PER_FINGER + angle as usize
}

/// Names of the 20 angles, in order (e.g. `index_mcp_flexion`).
pub fn angle_names() -> [String; NUM_ANGLES] {
    std::array::from_fn(|i| {
        let f = Finger::ALL[i / ANGLES_PER_FINGER];
        let (base, mid, dist) = match f {
            Finger::Thumb => ("cmc", "mcp", "ip"),
            _ => ("mcp", "pip", "dip"),
        };
        match i % ANGLES_PER_FINGER {
            0 => format!("{}_{base}_flexion", f.name()),
            1 => format!("{}_{base}_abduction", f.name()),
            2 => format!("{}_{mid}_flexion", f.name()),
            _ => format!("{}_{dist}_flexion", f.name()),
        }
    })
}

/// A full hand pose: where the wrist is, how the hand is turned, how it is bent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPose {
    /// Wrist position in the camera frame, millimetres.
    pub translation: Vector3<f64>,
    /// Rotation from the hand frame to the camera frame.
    pub rotation: UnitQuaternion<f64>,
    /// Joint angles in radians (see the module docs for the order).
    pub angles: [f64; NUM_ANGLES],
}

impl Default for HandPose {
    fn default() -> Self {
        HandPose {
            translation: Vector3::new(0.0, 0.0, 500.0),
            rotation: UnitQuaternion::identity(),
            angles: [0.0; NUM_ANGLES],
        }
    }
}

impl HandPose {
    /// The flat 27-parameter vector (quaternion as `x, y, z, w`).
    pub fn to_params(&self) -> [f64; NUM_PARAMS] {
        let mut p = [0.0; NUM_PARAMS];
        p[TRANSLATION..TRANSLATION + 3].copy_from_slice(self.translation.as_slice());
        let q = self.rotation.quaternion();
        p[QUATERNION..QUATERNION + 4].copy_from_slice(&[q.i, q.j, q.k, q.w]);
        p[ANGLES..].copy_from_slice(&self.angles);
        p
    }

    /// Builds a pose from the flat 27-parameter vector; the quaternion is normalised.
    ///
    /// Returns `None` if a value is not finite or the quaternion is zero.
    pub fn from_params(p: &[f64; NUM_PARAMS]) -> Option<HandPose> {
        if p.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let q = Quaternion::new(
            p[QUATERNION + 3],
            p[QUATERNION],
            p[QUATERNION + 1],
            p[QUATERNION + 2],
        );
        if q.norm() < 1e-12 {
            return None;
        }
        let mut angles = [0.0; NUM_ANGLES];
        angles.copy_from_slice(&p[ANGLES..]);
        Some(HandPose {
            translation: Vector3::new(p[0], p[1], p[2]),
            rotation: UnitQuaternion::from_quaternion(q),
            angles,
        })
    }

    /// The four angles of one finger.
    pub fn finger_angles(&self, finger: Finger) -> [f64; ANGLES_PER_FINGER] {
        let b = finger.index() * ANGLES_PER_FINGER;
        [
            self.angles[b],
            self.angles[b + 1],
            self.angles[b + 2],
            self.angles[b + 3],
        ]
    }

    /// True if every number in the pose is finite.
    pub fn is_finite(&self) -> bool {
        self.to_params().iter().all(|v| v.is_finite())
    }
}

const _: () = assert!(NUM_FINGERS * ANGLES_PER_FINGER == NUM_ANGLES);
const _: () = assert!(ANGLES + NUM_ANGLES == NUM_PARAMS);

#[cfg(test)]
#[allow(clippy::field_reassign_with_default)]
mod tests {
    use super::*;

    #[test]
    fn params_round_trip() {
        let mut pose = HandPose::default();
        pose.translation = Vector3::new(1.0, -2.0, 300.0);
        pose.rotation = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
        pose.angles[5] = 0.4;
        let back = HandPose::from_params(&pose.to_params()).unwrap();
        assert!((back.translation - pose.translation).norm() < 1e-12);
        assert!(back.rotation.angle_to(&pose.rotation) < 1e-12);
        assert_eq!(back.angles, pose.angles);
        assert_eq!(angle_index(Finger::Index, FingerAngle::BaseAbduction), 5);
        assert_eq!(angle_names()[5], "index_mcp_abduction");
    }

    #[test]
    fn nan_params_rejected() {
        let mut p = HandPose::default().to_params();
        p[10] = f64::NAN;
        assert!(HandPose::from_params(&p).is_none());
    }
}
