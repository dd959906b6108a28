//! The fitted hand as OpenXR's hand joints (`XR_EXT_hand_tracking`): 26 joints, each with a
//! position, an orientation and a radius, in the order and with the names of the spec's
//! `XrHandJointEXT`.
//!
//! # The joints' axes
//!
//! This is the one place they are written down; [`xr_frame`] builds them and everything
//! else calls it. The spec ("Conventions of hand joints") defines, for both hands alike:
//!
//! - **−Z** ([`XR_DISTAL_AXIS`]) runs along the joint's bone, from the joint towards the
//!   finger tip. A finger joint poses the bone that starts at it (the proximal joint at
//!   the knuckle poses the proximal phalanx); a tip takes its distal joint's orientation.
//! - **+Y** ([`XR_DORSAL_AXIS`]) points out of the back of the hand (for a finger bone:
//!   out of the back of the finger, the nail's side), square to the bone.
//! - **+X** = Y × Z: the frame is right-handed on both hands. So on a right hand +X points
//!   to the little finger's side, on a left hand to the thumb's side: a left hand's frames
//!   are the mirror images of the right's with X turned back ([`HandSkeleton::mirrored`]).
//! - The **wrist** joint sits at the wrist, −Z towards the middle finger's metacarpal
//!   joint, +Y out of the back of the hand. The **palm** joint sits at the centre of the
//!   middle finger's metacarpal bone and is oriented like it.
//!
//! The orientation is the rotation from the joint's axes into the frame the joints are
//! given in (the camera's: monohand's 3D is in the first camera's frame, x right, y down,
//! z forward, a right-handed frame, so the axes keep their meaning there).
//!
//! # From monohand's model
//!
//! The model has the wrist, the thumb's CMC, MCP, IP and tip, and each finger's MCP, PIP,
//! DIP and tip ([`crate::hand_model::JOINT_NAMES`]). They are OpenXR's wrist, thumb
//! metacarpal, proximal, distal and tip, and each finger's proximal, intermediate, distal
//! and tip ([`XR_MODEL_JOINT`]). OpenXR's finger metacarpal joints (at the metacarpal's
//! base, by the carpals) and its palm are not in the model's 21: a finger's metacarpal
//! joint is placed on the line from the wrist to its MCP joint, at the fraction
//! [`XR_METACARPAL_FRACTION`] of the way, and the palm halfway between the middle finger's
//! metacarpal and MCP joints.
//!
//! The axes come from the model's own joint axes. A finger's three bones bend about one
//! hinge ([`crate::kinematics::FingerChain::flexion_axis`], turned by the finger's spread),
//! so each bone's +Y is the bone's direction crossed with its hinge: the side the finger
//! does not bend towards. The thumb's hinge is turned about its metacarpal as a real
//! thumb's is ([`crate::hand_model::THUMB_HINGE_ROLL_DEG`]): at the open hand its nail
//! faces 75 degrees from the back of the hand, towards the thumb's side (the mesh's thumb,
//! below: 65-78 degrees). The wrist, the palm and the finger metacarpals take the back of
//! the palm (the hand frame's −z, [`crate::hand_model::skeleton`]) as +Y, laid square to
//! their bone. The bones themselves are those of the joints given, so that −Z runs exactly
//! from each joint to the next one, also when the joints are not the posed model's own
//! (a fit's [`crate::fitting::FitResult::joints_3d`] moved towards the network's depth).
//!
//! # Radii
//!
//! The spec's radius is the distance from the joint to the skin. The model has no skin;
//! the project's hand mesh has one (the WebXR generic hand, Amazon 2019, MIT, in
//! `crates/monohand-io/assets/webxr-generic-hand`: 25 joints, the same as WebXR's and
//! OpenXR's without the palm). [`XR_MESH_RADII_MM`] is, for each joint, the distance from
//! that mesh's joint to the nearest point of its right hand's surface (the palm's: from
//! the centre of its middle metacarpal), in mm at the mesh's size
//! ([`XR_MESH_HAND_LENGTH_MM`]); `monohand-io`'s test `xr_mesh` measures it again from the
//! mesh. A hand's radii are those times its size ([`HandSkeleton::hand_length`] over the
//! mesh's), the same for both hands (the mesh's left hand is within 1 mm of its right's
//! mirror). For the default adult hand (189 mm long, 1.06 times the mesh) they run from
//! 5.2-6.1 mm at the fingertips and 6.3-7.8 mm at the intermediate joints to 16 mm at
//! the palm and the wrist, and 21 mm at the base of the middle metacarpal, deep in the
//! carpus. Monado's hand tracking sets the palm's at 16 mm and the wrist's at 20 mm, half
//! the thicknesses its authors measured with calipers
//! (`src/xrt/auxiliary/util/u_hand_tracking.c`).
//!
//! ```
//! use monohand_core::hand_model::{HandPose, HandSide, HandSkeleton};
//! use monohand_core::xr::{xr_joints_of_pose, XR_JOINT_NAMES, XR_DISTAL_AXIS};
//! let sk = HandSkeleton::default_for(HandSide::Right);
//! let joints = xr_joints_of_pose(&sk, &HandPose::default()).unwrap();
//! // The index finger's proximal joint looks down its phalanx, at the intermediate joint.
//! let (prox, inter) = (&joints[7], &joints[8]);
//! assert_eq!(XR_JOINT_NAMES[7], "index_proximal");
//! let forward = prox.orientation * nalgebra::Vector3::from(XR_DISTAL_AXIS);
//! assert!(forward.angle(&(inter.position - prox.position)) < 1e-9);
//! ```

use crate::hand_model::{Finger, HandPose, HandSkeleton, NUM_JOINTS, WRIST};
use crate::kinematics::{finger_chain, forward_kinematics};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// The number of OpenXR hand joints (`XR_HAND_JOINT_COUNT_EXT`).
pub const XR_JOINT_COUNT: usize = 26;

/// The joint axis that points along the bone towards the finger tip: −Z.
pub const XR_DISTAL_AXIS: [f64; 3] = [0.0, 0.0, -1.0];

/// The joint axis that points out of the back of the hand: +Y.
pub const XR_DORSAL_AXIS: [f64; 3] = [0.0, 1.0, 0.0];

/// The 26 joints' names, in `XrHandJointEXT` order: the enumerant's joint part in lower
/// case (`XR_HAND_JOINT_INDEX_PROXIMAL_EXT` is `index_proximal`), as the spec recommends
/// to name them.
pub const XR_JOINT_NAMES: [&str; XR_JOINT_COUNT] = [
    "palm",
    "wrist",
    "thumb_metacarpal",
    "thumb_proximal",
    "thumb_distal",
    "thumb_tip",
    "index_metacarpal",
    "index_proximal",
    "index_intermediate",
    "index_distal",
    "index_tip",
    "middle_metacarpal",
    "middle_proximal",
    "middle_intermediate",
    "middle_distal",
    "middle_tip",
    "ring_metacarpal",
    "ring_proximal",
    "ring_intermediate",
    "ring_distal",
    "ring_tip",
    "little_metacarpal",
    "little_proximal",
    "little_intermediate",
    "little_distal",
    "little_tip",
];

/// `XR_HAND_JOINT_PALM_EXT`.
pub const XR_PALM: usize = 0;
/// `XR_HAND_JOINT_WRIST_EXT`.
pub const XR_WRIST: usize = 1;

/// The model's joint ([`crate::hand_model::JOINT_NAMES`]) at each OpenXR joint: `None`
/// for the palm and the four finger metacarpals, which the model has not.
pub const XR_MODEL_JOINT: [Option<usize>; XR_JOINT_COUNT] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    None,
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    None,
    Some(9),
    Some(10),
    Some(11),
    Some(12),
    None,
    Some(13),
    Some(14),
    Some(15),
    Some(16),
    None,
    Some(17),
    Some(18),
    Some(19),
    Some(20),
];

/// The first OpenXR joint of each finger (thumb to little): the thumb has four joints
/// (metacarpal, proximal, distal, tip), the other fingers five (metacarpal, proximal,
/// intermediate, distal, tip).
pub const fn xr_finger_start(finger: Finger) -> usize {
    match finger {
        Finger::Thumb => 2,
        f => 6 + 5 * (f.index() - 1),
    }
}

/// Where a finger's OpenXR metacarpal joint sits on the line from the wrist to its MCP
/// joint, as a fraction of that line from the wrist (index, middle, ring, little).
///
/// Measured on the project's hand mesh (the module docs): its metacarpal joint projected
/// onto its wrist-to-proximal-joint line (0.341, 0.320, 0.328, 0.502 from the mesh's
/// right hand; it sits 5-7 mm palmar of that line, which is left out). The mesh's little
/// finger metacarpal is the shortest: it starts halfway down the palm.
pub const XR_METACARPAL_FRACTION: [f64; 4] = [0.34, 0.32, 0.33, 0.50];

/// The hand length of the mesh [`XR_MESH_RADII_MM`] was measured on, mm: its wrist to
/// middle MCP, then the middle finger's three bones ([`HandSkeleton::hand_length`]'s
/// measure).
pub const XR_MESH_HAND_LENGTH_MM: f64 = 178.3;

/// Each joint's distance to the skin on the project's hand mesh, mm, at its size
/// [`XR_MESH_HAND_LENGTH_MM`], in `XrHandJointEXT` order (the module docs).
pub const XR_MESH_RADII_MM: [f64; XR_JOINT_COUNT] = [
    15.2, // palm
    15.2, // wrist
    10.9, 10.2, 6.2, 5.2, // thumb
    18.2, 9.5, 6.9, 6.2, 5.5, // index
    20.1, 10.3, 7.4, 6.4, 5.8, // middle
    18.7, 9.8, 6.2, 5.9, 5.7, // ring
    13.0, 7.1, 5.9, 5.3, 4.9, // little
];

/// One OpenXR joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XrJoint {
    /// Position, mm, in the frame the joints were given in.
    pub position: Vector3<f64>,
    /// Rotation from the joint's axes (the module docs) into that frame.
    pub orientation: UnitQuaternion<f64>,
    /// Distance from the joint to the skin, mm.
    pub radius: f64,
}

/// A joint's orientation from the direction of its bone (from the joint towards the tip)
/// and a direction out of the back of the hand: −Z along `distal`, +Y along `dorsal` laid
/// square to it, +X = Y × Z. `None` when `distal` is zero or not finite, or `dorsal` runs
/// along it.
///
/// ```
/// use monohand_core::xr::{xr_frame, XR_DISTAL_AXIS, XR_DORSAL_AXIS};
/// use nalgebra::Vector3;
/// let q = xr_frame(&Vector3::new(0.0, 2.0, 0.0), &Vector3::new(0.3, 0.1, -1.0)).unwrap();
/// assert!((q * Vector3::from(XR_DISTAL_AXIS) - Vector3::y()).norm() < 1e-12);
/// assert!((q * Vector3::from(XR_DORSAL_AXIS)).dot(&Vector3::new(0.3, 0.0, -1.0)) > 0.0);
/// ```
pub fn xr_frame(distal: &Vector3<f64>, dorsal: &Vector3<f64>) -> Option<UnitQuaternion<f64>> {
    let z = -distal.try_normalize(1e-12)?;
    let up = dorsal.try_normalize(1e-12)?;
    let y = (up - z * z.dot(&up)).try_normalize(1e-9)?;
    let x = y.cross(&z);
    if !(x.iter().chain(&y).chain(&z).all(|v| v.is_finite())) {
        return None;
    }
    let m = Matrix3::from_columns(&[x, y, z]);
    Some(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(m),
    ))
}

/// The 26 OpenXR joints of a hand with joints at `joints` (mm, the frame of `pose`), the
/// model's axes from `skeleton` posed by `pose`, and radii for the skeleton's size (the
/// module docs say how). `joints` are usually the fit's
/// [`crate::fitting::FitResult::joints_3d`]; [`xr_joints_of_pose`] takes the posed
/// model's own.
///
/// `None` if a bone has no length, a joint is not finite, or a bone runs along its
/// finger's hinge (joints far from the model's: the hinge is square to every bone the
/// model poses).
pub fn xr_joints(
    skeleton: &HandSkeleton,
    pose: &HandPose,
    joints: &[Vector3<f64>; NUM_JOINTS],
) -> Option<[XrJoint; XR_JOINT_COUNT]> {
    if !joints.iter().all(|p| p.iter().all(|v| v.is_finite())) || !pose.is_finite() {
        return None;
    }
    let r = pose.rotation;
    // The back of the palm: the hand frame's -z (its +z is palmar on both sides).
    let back = r * Vector3::new(0.0, 0.0, -1.0);
    let wrist = joints[WRIST];
    let size = skeleton.hand_length() / XR_MESH_HAND_LENGTH_MM;
    if !(size.is_finite() && size > 0.0) {
        return None;
    }
    let mut position = [Vector3::zeros(); XR_JOINT_COUNT];
    let mut orientation = [UnitQuaternion::identity(); XR_JOINT_COUNT];
    for f in Finger::ALL {
        let model = f.joints();
        let hinge = r * finger_chain(skeleton, f, &pose.angles).flexion_axis;
        let start = xr_finger_start(f);
        let mut first = start;
        if f != Finger::Thumb {
            let base = joints[model[0]];
            let at = wrist + (base - wrist) * XR_METACARPAL_FRACTION[f.index() - 1];
            position[start] = at;
            orientation[start] = xr_frame(&(base - at), &back)?;
            first += 1;
        }
        // The model's joints of the finger: its base (thumb CMC, finger MCP), two middle
        // joints and its tip; each poses the bone to the next.
        for k in 0..3 {
            let bone = joints[model[k + 1]] - joints[model[k]];
            position[first + k] = joints[model[k]];
            orientation[first + k] = xr_frame(&bone, &bone.cross(&hinge))?;
        }
        position[first + 3] = joints[model[3]];
        orientation[first + 3] = orientation[first + 2];
    }
    let middle = xr_finger_start(Finger::Middle);
    position[XR_WRIST] = wrist;
    orientation[XR_WRIST] = xr_frame(&(position[middle] - wrist), &back)?;
    position[XR_PALM] = (position[middle] + position[middle + 1]) / 2.0;
    orientation[XR_PALM] = orientation[middle];
    Some(std::array::from_fn(|i| XrJoint {
        position: position[i],
        orientation: orientation[i],
        radius: XR_MESH_RADII_MM[i] * size,
    }))
}

/// [`xr_joints`] at the posed model's own joints ([`forward_kinematics`]).
pub fn xr_joints_of_pose(
    skeleton: &HandSkeleton,
    pose: &HandPose,
) -> Option<[XrJoint; XR_JOINT_COUNT]> {
    xr_joints(skeleton, pose, &forward_kinematics(skeleton, pose))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hand_model::{HandSide, NUM_ANGLES};

    /// A pose with every finger bent and spread by known angles, turned and moved in front
    /// of the camera. Each finger's bends add up to less than 90 degrees, so that every
    /// phalanx's back still faces the back of the hand; the thumb bends a little (bent
    /// across the palm, its nail turns away from the back of the hand, as a thumb's does).
    fn known_pose() -> HandPose {
        let mut angles = [0.0; NUM_ANGLES];
        angles[..4].copy_from_slice(&[0.1, -0.2, 0.15, 0.1]);
        for f in 1..5 {
            let b = 4 * f;
            angles[b] = 0.35 - 0.05 * f as f64; // base flexion
            angles[b + 1] = 0.12 - 0.06 * f as f64; // spread
            angles[b + 2] = 0.5 + 0.04 * f as f64; // middle flexion
            angles[b + 3] = 0.25 + 0.03 * f as f64; // distal flexion
        }
        HandPose {
            translation: Vector3::new(35.0, -20.0, 420.0),
            rotation: UnitQuaternion::from_euler_angles(0.7, -0.4, 2.1),
            angles,
        }
    }

    fn axis(q: &UnitQuaternion<f64>, a: [f64; 3]) -> Vector3<f64> {
        q * Vector3::from(a)
    }

    /// The angle between two vectors, radians, accurate near 0 (unlike `acos`).
    fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        a.cross(b).norm().atan2(a.dot(b))
    }

    /// The joint whose position a joint's -Z looks at (`None`: a tip, which keeps its
    /// distal joint's orientation).
    fn next(i: usize) -> Option<usize> {
        match i {
            XR_PALM => Some(12),
            XR_WRIST => Some(11),
            5 | 10 | 15 | 20 | 25 => None,
            i => Some(i + 1),
        }
    }

    /// The back of the palm from the joints alone: square to the wrist and the index and
    /// middle MCP joints, on the side the handedness says is the back.
    fn palm_back(j: &[Vector3<f64>; NUM_JOINTS], side: HandSide) -> Vector3<f64> {
        let n = (j[9] - j[0]).cross(&(j[5] - j[0])).normalize();
        match side {
            HandSide::Right => n,
            HandSide::Left => -n,
        }
    }

    #[test]
    fn minus_z_runs_along_each_bone_and_plus_y_out_of_the_back_of_the_hand() {
        let pose = known_pose();
        for side in [HandSide::Right, HandSide::Left] {
            let sk = HandSkeleton::default_for(side);
            let model = forward_kinematics(&sk, &pose);
            let xr = xr_joints_of_pose(&sk, &pose).unwrap();
            let back = palm_back(&model, side);
            // The palm's back as the hand frame has it: the joints agree.
            assert!((back - pose.rotation * Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-9);
            let mut worst = 0.0f64;
            for i in 0..XR_JOINT_COUNT {
                let q = &xr[i].orientation;
                match next(i) {
                    Some(n) => {
                        let bone = xr[n].position - xr[i].position;
                        worst = worst.max(angle(&axis(q, XR_DISTAL_AXIS), &bone));
                    }
                    None => assert_eq!(*q, xr[i - 1].orientation, "{}", XR_JOINT_NAMES[i]),
                }
                let up = axis(q, XR_DORSAL_AXIS);
                assert!(
                    up.dot(&back) > 0.0,
                    "{side} {}: {}",
                    XR_JOINT_NAMES[i],
                    up.dot(&back)
                );
                // Right-handed: X = Y x Z.
                let x = axis(q, [1.0, 0.0, 0.0]);
                assert!((x - up.cross(&axis(q, [0.0, 0.0, 1.0]))).norm() < 1e-12);
            }
            assert!(worst < 1e-6, "{side}: -Z off its bone by {worst} rad");
            // A finger's phalanges turn their backs away from the palm's by exactly the
            // finger's bends so far (its spread turns about the palm's normal).
            for f in &Finger::ALL[1..] {
                let a = pose.finger_angles(*f);
                let bends = [a[0], a[0] + a[2], a[0] + a[2] + a[3], a[0] + a[2] + a[3]];
                let first = xr_finger_start(*f) + 1;
                for (k, bend) in bends.iter().enumerate() {
                    let up = axis(&xr[first + k].orientation, XR_DORSAL_AXIS);
                    assert!(
                        (up.dot(&back) - bend.cos()).abs() < 1e-9,
                        "{side} {f:?} {k}"
                    );
                }
                // The metacarpals lie in the palm, nearly.
                let up = axis(&xr[first - 1].orientation, XR_DORSAL_AXIS);
                assert!(up.dot(&back) > 0.998, "{side} {f:?}: {}", up.dot(&back));
            }
            for i in [XR_PALM, XR_WRIST] {
                assert!(axis(&xr[i].orientation, XR_DORSAL_AXIS).dot(&back) > 0.999);
            }
            // The thumb's phalanges turn about its hinge by its bends: each one's +Y is its
            // metacarpal's turned by the bends after it.
            let a = pose.finger_angles(Finger::Thumb);
            let t = xr_finger_start(Finger::Thumb);
            let up = |k: usize| axis(&xr[t + k].orientation, XR_DORSAL_AXIS);
            for (k, bend) in [(1, a[2]), (2, a[2] + a[3]), (3, a[2] + a[3])] {
                assert!(
                    (angle(&up(0), &up(k)) - bend).abs() < 1e-9,
                    "{side} thumb {k}"
                );
            }
        }
    }

    #[test]
    fn an_open_thumb_turns_its_nail_partly_sideways() {
        // At the open hand the thumb's nail faces 75 degrees from the back of the hand
        // (the mesh's thumb: 65-78), towards the thumb's side of the hand.
        for side in [HandSide::Right, HandSide::Left] {
            let sk = HandSkeleton::default_for(side);
            let pose = HandPose::default();
            let model = forward_kinematics(&sk, &pose);
            let xr = xr_joints_of_pose(&sk, &pose).unwrap();
            let back = palm_back(&model, side);
            let thumbwards = model[5] - model[17];
            for i in 2..6 {
                let up = axis(&xr[i].orientation, XR_DORSAL_AXIS);
                let deg = angle(&up, &back).to_degrees();
                assert!(
                    (70.0..80.0).contains(&deg),
                    "{side} {}: {deg}",
                    XR_JOINT_NAMES[i]
                );
                assert!(up.dot(&thumbwards) > 0.0);
            }
        }
    }

    #[test]
    fn the_joints_sit_on_the_model_and_the_metacarpals_on_the_palm() {
        let pose = known_pose();
        let sk = HandSkeleton::default_for(HandSide::Right);
        let model = forward_kinematics(&sk, &pose);
        let xr = xr_joints_of_pose(&sk, &pose).unwrap();
        for (i, m) in XR_MODEL_JOINT.iter().enumerate() {
            match m {
                Some(j) => assert_eq!(xr[i].position, model[*j], "{}", XR_JOINT_NAMES[i]),
                None if i == XR_PALM => {
                    let mid = (xr[11].position + model[9]) / 2.0;
                    assert!((xr[i].position - mid).norm() < 1e-12);
                }
                None => {
                    let f = Finger::ALL[(i - 6) / 5 + 1];
                    assert_eq!(i, xr_finger_start(f));
                    let base = model[f.joints()[0]];
                    let t = XR_METACARPAL_FRACTION[f.index() - 1];
                    assert!((xr[i].position - (model[0] + (base - model[0]) * t)).norm() < 1e-12);
                }
            }
        }
        assert_eq!(
            XR_JOINT_NAMES[xr_finger_start(Finger::Little) + 4],
            "little_tip"
        );
        assert_eq!(
            XR_JOINT_NAMES[xr_finger_start(Finger::Thumb)],
            "thumb_metacarpal"
        );
    }

    #[test]
    fn given_joints_are_followed_and_the_axes_stay_square() {
        // Joints moved off the posed model (as the fusion with the network's depth moves
        // them): the joints are where they were given, -Z still along each given bone.
        let pose = known_pose();
        let sk = HandSkeleton::default_for(HandSide::Left);
        let mut joints = forward_kinematics(&sk, &pose);
        for (j, p) in joints.iter_mut().enumerate() {
            *p += Vector3::new(1.5, -2.0, 3.0) * ((j as f64 * 0.7).sin());
        }
        let xr = xr_joints(&sk, &pose, &joints).unwrap();
        for i in 0..XR_JOINT_COUNT {
            if let Some(j) = XR_MODEL_JOINT[i] {
                assert_eq!(xr[i].position, joints[j]);
            }
            if let Some(n) = next(i) {
                let bone = xr[n].position - xr[i].position;
                let e = angle(&axis(&xr[i].orientation, XR_DISTAL_AXIS), &bone);
                assert!(e < 1e-9, "{} {e}", XR_JOINT_NAMES[i]);
            }
        }
        // Nothing to orient: a bone of no length, a joint not finite.
        let mut flat = joints;
        flat[6] = flat[5];
        assert!(xr_joints(&sk, &pose, &flat).is_none());
        let mut nan = joints;
        nan[3].y = f64::NAN;
        assert!(xr_joints(&sk, &pose, &nan).is_none());
        assert!(xr_frame(&Vector3::zeros(), &Vector3::y()).is_none());
        assert!(xr_frame(&Vector3::y(), &Vector3::y()).is_none());
    }

    #[test]
    fn the_left_hand_is_the_mirror_of_the_right() {
        let pose = known_pose();
        let r = xr_joints_of_pose(&HandSkeleton::default_for(HandSide::Right), &pose).unwrap();
        let l = xr_joints_of_pose(&HandSkeleton::default_for(HandSide::Left), &pose).unwrap();
        // In the hand frame, the left hand is the right one with x -> -x.
        let local = |v: Vector3<f64>| pose.rotation.inverse() * v;
        let mirror = |v: Vector3<f64>| Vector3::new(-v.x, v.y, v.z);
        for i in 0..XR_JOINT_COUNT {
            let (a, b) = (&r[i], &l[i]);
            let (pa, pb) = (
                local(a.position - pose.translation),
                local(b.position - pose.translation),
            );
            assert!((pb - mirror(pa)).norm() < 1e-9, "{}", XR_JOINT_NAMES[i]);
            // -Z and +Y mirror (they mean the same on both hands); X turns back to keep
            // the frame right-handed.
            for (ax, sign) in [
                ([0.0, 0.0, -1.0], 1.0),
                ([0.0, 1.0, 0.0], 1.0),
                ([1.0, 0.0, 0.0], -1.0),
            ] {
                let (ua, ub) = (
                    local(axis(&a.orientation, ax)),
                    local(axis(&b.orientation, ax)),
                );
                assert!(
                    (ub - mirror(ua) * sign).norm() < 1e-9,
                    "{} {ax:?}",
                    XR_JOINT_NAMES[i]
                );
            }
            assert_eq!(a.radius, b.radius);
        }
        // +X: towards the little finger on the right hand, towards the thumb on the left.
        let thumb_side = |xr: &[XrJoint; XR_JOINT_COUNT], i: usize| {
            let towards = xr[7].position - xr[22].position; // index MCP - little MCP
            axis(&xr[i].orientation, [1.0, 0.0, 0.0]).dot(&towards)
        };
        assert!(thumb_side(&r, 12) < 0.0 && thumb_side(&l, 12) > 0.0);
    }

    #[test]
    fn radii_are_an_adult_hands() {
        // Plausible distances from the joint to the skin of an adult hand, mm: fingertips
        // 4-8, the finger joints 4.5-13 (a finger 9-26 mm thick), the palm, wrist and
        // metacarpal bases 10-25 (the palm 20-50 mm thick; Monado's calipers: palm 32,
        // wrist 40).
        let range = |i: usize| match i {
            XR_PALM | XR_WRIST | 6 | 11 | 16 | 21 => (10.0, 25.0),
            5 | 10 | 15 | 20 | 25 => (4.0, 8.0),
            _ => (4.5, 13.0),
        };
        for scale in [0.9, 1.0, 1.1] {
            let sk = HandSkeleton::default_for(HandSide::Right)
                .scaled(scale)
                .unwrap();
            let xr = xr_joints_of_pose(&sk, &known_pose()).unwrap();
            for (i, j) in xr.iter().enumerate() {
                let (lo, hi) = range(i);
                assert!(
                    (lo..=hi).contains(&j.radius),
                    "{scale} {}: {}",
                    XR_JOINT_NAMES[i],
                    j.radius
                );
            }
            // They grow with the hand.
            assert!(
                (xr[10].radius - XR_MESH_RADII_MM[10] * sk.hand_length() / XR_MESH_HAND_LENGTH_MM)
                    .abs()
                    < 1e-12
            );
        }
    }
}
