//! The wrist's pose and the joints in the wrist's frame, as robot-hand retargeting reads
//! them: the frame of the MANO convention that dex-retargeting
//! (<https://github.com/dexsuite/dex-retargeting>, MIT) documents, in metres.
//!
//! # The MANO wrist frame
//!
//! dex-retargeting's vector and position retargeting take the 21 joints relative to the
//! wrist, in a wrist frame in "MANO convention". Its MediaPipe example
//! (`example/vector_retargeting/single_hand_detector.py`) builds that frame from landmarks
//! 0 (wrist), 5 (index MCP) and 9 (middle MCP): a first frame `F` whose x runs from the
//! middle MCP to the wrist (laid square to the palm), whose y is the normal of the plane
//! of the three points (an SVD), and z = x × y, the normal's sign chosen so that z points
//! from the middle MCP towards the index MCP; then a fixed matrix per side
//! (`OPERATOR2MANO_RIGHT`, `OPERATOR2MANO_LEFT`), so that the wrist frame's axes are the
//! columns of `F · OPERATOR2MANO`. Worked through, on both hands:
//!
//! - **+z** runs from the wrist towards the fingers (the middle MCP), in the palm's plane;
//! - **+x** points out of the palm (the palmar side), square to the palm;
//! - **+y** = z × x: on a right hand towards the thumb's side, on a left hand towards
//!   the little finger's. The frame is right-handed on both hands; a left hand's frame is
//!   the mirror image of the right's with its y turned back (as OpenXR's X,
//!   [`crate::xr`]).
//!
//! The frame's origin is the wrist joint.
//!
//! # From monohand's model
//!
//! monohand does not estimate that frame from three joints: the fitted model has the
//! hand's own frame, [`HandPose::rotation`] ([`crate::hand_model::skeleton`]: +y from the
//! wrist to the middle knuckle, +z out of the palm, +x to a right hand's thumb side; a
//! left hand is the mirror image in the same frame, `x -> -x`, so its +x points to its
//! little finger). The MANO axes in that frame are therefore the same on both hands:
//! MANO's x is the model's z, its y the model's x, its z the model's y. That is
//! [`MODEL_TO_MANO`], the one matrix of this module, the same for the right hand and its
//! mirror (the mirror is in the skeleton, not in the frame): the wrist frame's rotation
//! is `pose.rotation · MODEL_TO_MANO`.
//!
//! The model's palm is rigid, so its frame and dex-retargeting's construction from the
//! model's joints 0, 5 and 9 differ by a fixed turn: for the default hand 1.8 degrees
//! about the palm's normal (its middle MCP sits 3 mm to the thumb's side of its +y axis).
//! A fit's joints are moved after the fit towards the network's depth and the keypoints'
//! pixels ([`crate::fitting::FitResult::joints_3d`]), which tilts the three joints' plane
//! against the model's palm: on the sample photo and the dev gesture video about 12
//! degrees (docs/robots-and-xr.md). The frame here is the model's, at the given wrist
//! joint.
//!
//! ```
//! use monohand_core::hand_model::{HandPose, HandSide, HandSkeleton};
//! use monohand_core::kinematics::forward_kinematics;
//! use monohand_core::wrist::{joints_in_wrist_frame, wrist_pose, WristConvention};
//! let sk = HandSkeleton::default_for(HandSide::Right);
//! let pose = HandPose::default();
//! let joints = forward_kinematics(&sk, &pose);
//! let w = wrist_pose(&pose, &joints, WristConvention::Mano).unwrap();
//! assert!((w.matrix_m()[(2, 3)] - joints[0].z / 1000.0).abs() < 1e-12);
//! // The middle fingertip lies along +z, in metres.
//! let local = joints_in_wrist_frame(&pose, &joints, WristConvention::Mano).unwrap();
//! assert!(local[12].z > 0.15 && local[12].x.abs() < 0.01);
//! ```

use crate::hand_model::{HandPose, NUM_JOINTS, WRIST};
use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use thiserror::Error;

/// The MANO wrist frame's axes in monohand's hand-model frame, as columns (x: the model's
/// +z, out of the palm; y: the model's +x; z: the model's +y, towards the fingers): the
/// wrist frame's rotation is `pose.rotation * MODEL_TO_MANO`. The same for both hands
/// (the module docs say why).
pub const MODEL_TO_MANO: Matrix3<f64> = Matrix3::new(
    0.0, 1.0, 0.0, //
    0.0, 0.0, 1.0, //
    1.0, 0.0, 0.0,
);

/// The conventions of the wrist frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WristConvention {
    /// MANO's, as dex-retargeting documents it ([`MODEL_TO_MANO`]).
    Mano,
}

impl WristConvention {
    /// Every convention.
    pub const ALL: [WristConvention; 1] = [WristConvention::Mano];

    /// Its name in the records and in Python: `"mano"`.
    pub const fn name(self) -> &'static str {
        match self {
            WristConvention::Mano => "mano",
        }
    }

    /// The convention's axes in monohand's hand-model frame, as columns.
    pub const fn from_model(self) -> Matrix3<f64> {
        match self {
            WristConvention::Mano => MODEL_TO_MANO,
        }
    }
}

impl std::fmt::Display for WristConvention {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A convention's name that is none of [`WristConvention::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("unknown wrist frame convention {name:?} (known: \"mano\")")]
pub struct UnknownConvention {
    /// The name given.
    pub name: String,
}

impl std::str::FromStr for WristConvention {
    type Err = UnknownConvention;
    fn from_str(s: &str) -> Result<WristConvention, UnknownConvention> {
        WristConvention::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| UnknownConvention { name: s.into() })
    }
}

/// The wrist's pose: where the wrist frame is and how it is turned, in the frame of the
/// joints it was made from (the first camera's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WristPose {
    /// The rotation from the wrist frame's axes into the joints' frame (its columns are
    /// the wrist frame's x, y and z).
    pub rotation: Rotation3<f64>,
    /// The wrist joint, mm.
    pub position_mm: Vector3<f64>,
    /// The convention of the axes.
    pub convention: WristConvention,
}

impl WristPose {
    /// The homogeneous 4x4 transform from the wrist frame to the joints' frame, in metres
    /// (`[R t; 0 0 0 1]`, `t` the wrist in metres).
    pub fn matrix_m(&self) -> Matrix4<f64> {
        let mut m = self.rotation.matrix().to_homogeneous();
        m.fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&(self.position_mm / 1000.0));
        m
    }

    /// A point of the joints' frame (mm) in the wrist frame, metres.
    pub fn to_wrist_frame_m(&self, point_mm: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (point_mm - self.position_mm) / 1000.0
    }
}

/// The wrist pose of a fitted hand: at its wrist joint `joints[0]` (mm; usually the fit's
/// [`crate::fitting::FitResult::joints_3d`]), turned as the model's hand frame `pose`
/// ([`HandPose::rotation`]) in `convention`. `None` if a number is not finite.
pub fn wrist_pose(
    pose: &HandPose,
    joints: &[Vector3<f64>; NUM_JOINTS],
    convention: WristConvention,
) -> Option<WristPose> {
    let position_mm = joints[WRIST];
    if !pose.is_finite() || !position_mm.iter().all(|v| v.is_finite()) {
        return None;
    }
    let m = pose.rotation.to_rotation_matrix().matrix() * convention.from_model();
    Some(WristPose {
        rotation: Rotation3::from_matrix_unchecked(m),
        position_mm,
        convention,
    })
}

/// The 21 joints (mm, in the order of [`crate::hand_model::JOINT_NAMES`]) in the wrist
/// frame of [`wrist_pose`], metres: what dex-retargeting's retargeters read as the hand's
/// joint positions. `None` if a number is not finite.
pub fn joints_in_wrist_frame(
    pose: &HandPose,
    joints: &[Vector3<f64>; NUM_JOINTS],
    convention: WristConvention,
) -> Option<[Vector3<f64>; NUM_JOINTS]> {
    if !joints.iter().all(|p| p.iter().all(|v| v.is_finite())) {
        return None;
    }
    let w = wrist_pose(pose, joints, convention)?;
    Some(joints.map(|p| w.to_wrist_frame_m(&p)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hand_model::{HandSide, HandSkeleton, NUM_ANGLES};
    use crate::kinematics::forward_kinematics;
    use nalgebra::{UnitQuaternion, SVD};

    /// dex-retargeting's `OPERATOR2MANO_RIGHT` and `OPERATOR2MANO_LEFT`, rows as there.
    fn operator2mano(side: HandSide) -> Matrix3<f64> {
        match side {
            HandSide::Right => Matrix3::new(0.0, 0.0, -1.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0),
            HandSide::Left => Matrix3::new(0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        }
    }

    /// The reference: dex-retargeting's wrist frame from joints 0, 5 and 9 (re-derived from
    /// `estimate_frame_from_hand_points`): x from the middle MCP to the wrist laid square to
    /// the points' plane, y that plane's normal by an SVD, z = x × y turned towards the
    /// index MCP; then `OPERATOR2MANO` (the retargeter's joints are `p · F · O`, so the
    /// frame's axes are the columns of `F · O`).
    fn dex_frame(j: &[Vector3<f64>; NUM_JOINTS], side: HandSide) -> Matrix3<f64> {
        let p = [j[0], j[5], j[9]];
        let x_vector = p[0] - p[2];
        let mean = (p[0] + p[1] + p[2]) / 3.0;
        let centred = Matrix3::from_rows(&[
            (p[0] - mean).transpose(),
            (p[1] - mean).transpose(),
            (p[2] - mean).transpose(),
        ]);
        let svd = SVD::new(centred, false, true);
        let v_t = svd.v_t.unwrap();
        let smallest = (0..3)
            .min_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]))
            .unwrap();
        let mut normal: Vector3<f64> = v_t.row(smallest).transpose();
        let x = (x_vector - normal * x_vector.dot(&normal)).normalize();
        let mut z = x.cross(&normal);
        if z.dot(&(p[1] - p[2])) < 0.0 {
            normal = -normal;
            z = -z;
        }
        Matrix3::from_columns(&[x, normal, z]) * operator2mano(side)
    }

    /// Every finger bent and spread by known angles, turned and moved before the camera.
    fn posed() -> HandPose {
        let mut angles = [0.0; NUM_ANGLES];
        angles[..4].copy_from_slice(&[0.3, -0.2, 0.25, 0.2]);
        for f in 1..5 {
            let b = 4 * f;
            angles[b] = 0.4 + 0.1 * f as f64;
            angles[b + 1] = 0.1 - 0.05 * f as f64;
            angles[b + 2] = 0.6 + 0.05 * f as f64;
            angles[b + 3] = 0.3;
        }
        HandPose {
            translation: Vector3::new(-60.0, 35.0, 480.0),
            rotation: UnitQuaternion::from_euler_angles(-0.9, 0.5, 2.6),
            angles,
        }
    }

    /// The angle of the rotation between two frames, degrees.
    fn degrees_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        let r = a.transpose() * b;
        ((r.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }

    #[test]
    fn the_models_frame_is_dex_retargetings_from_joints_0_5_9() {
        for side in [HandSide::Right, HandSide::Left] {
            let sk = HandSkeleton::default_for(side);
            for pose in [posed(), HandPose::default()] {
                let joints = forward_kinematics(&sk, &pose);
                let w = wrist_pose(&pose, &joints, WristConvention::Mano).unwrap();
                let reference = dex_frame(&joints, side);
                let deg = degrees_between(w.rotation.matrix(), &reference);
                // The default palm's middle MCP is 3 mm off the model's +y at 95 mm: 1.8 degrees.
                assert!((1.7..1.9).contains(&deg), "{side}: {deg} degrees");
                // The joints in the frame: dex-retargeting's `(p - p0) · F · O`, within that turn
                // (the middle fingertip is 190 mm from the wrist: sin 1.9 degrees of it, 6.3 mm).
                let ours = joints_in_wrist_frame(&pose, &joints, WristConvention::Mano).unwrap();
                for (i, p) in joints.iter().enumerate() {
                    let theirs = reference.transpose() * (p - joints[0]) / 1000.0;
                    let off = (ours[i] - theirs).norm();
                    assert!(off < 0.0064, "{side} joint {i}: {off} m");
                }
            }
        }
    }

    #[test]
    fn the_axes_mean_what_the_convention_says() {
        let pose = posed();
        for side in [HandSide::Right, HandSide::Left] {
            let j = forward_kinematics(&HandSkeleton::default_for(side), &pose);
            let r = *wrist_pose(&pose, &j, WristConvention::Mano)
                .unwrap()
                .rotation
                .matrix();
            let (x, y, z) = (r.column(0), r.column(1), r.column(2));
            let unit = |v: Vector3<f64>| v.normalize();
            // +z towards the middle MCP, +x out of the palm, +y to the thumb on a right hand
            // and to the little finger on a left one.
            assert!(z.dot(&unit(j[9] - j[0])) > 0.999, "{side}");
            let palm_normal = unit((j[5] - j[0]).cross(&(j[9] - j[0])));
            let palmar = match side {
                HandSide::Right => palm_normal,
                HandSide::Left => -palm_normal,
            };
            assert!(x.dot(&palmar) > 0.999, "{side}: {}", x.dot(&palmar));
            let to_thumb = unit(j[5] - j[17]);
            match side {
                HandSide::Right => assert!(y.dot(&to_thumb) > 0.9, "{side}"),
                HandSide::Left => assert!(y.dot(&to_thumb) < -0.9, "{side}"),
            }
        }
    }

    #[test]
    fn the_frame_is_orthonormal_and_right_handed_and_the_pose_a_rigid_transform() {
        let pose = posed();
        let j = forward_kinematics(&HandSkeleton::default_for(HandSide::Left), &pose);
        let w = wrist_pose(&pose, &j, WristConvention::Mano).unwrap();
        let r = w.rotation.matrix();
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((MODEL_TO_MANO.determinant() - 1.0).abs() < 1e-15);
        let m = w.matrix_m();
        assert_eq!(
            m.row(3).iter().copied().collect::<Vec<_>>(),
            [0.0, 0.0, 0.0, 1.0]
        );
        assert!((m.fixed_view::<3, 1>(0, 3) - j[0] / 1000.0).norm() < 1e-15);
        // The 4x4 takes the joints in the wrist frame back to the camera's, in metres.
        let local = joints_in_wrist_frame(&pose, &j, WristConvention::Mano).unwrap();
        assert_eq!(local[0], Vector3::zeros());
        for (p, l) in j.iter().zip(&local) {
            let back = m * l.push(1.0);
            assert!((back.xyz() - p / 1000.0).norm() < 1e-12);
        }
    }

    #[test]
    fn a_left_hand_in_its_wrist_frame_is_the_right_one_with_y_turned() {
        // The same pose on a right hand and on its mirror: in the wrist frame the left's
        // joints are the right's with y -> -y (y is the one axis the mirror turns back).
        let pose = posed();
        let joints = |side| forward_kinematics(&HandSkeleton::default_for(side), &pose);
        let (jr, jl) = (joints(HandSide::Right), joints(HandSide::Left));
        let r = joints_in_wrist_frame(&pose, &jr, WristConvention::Mano).unwrap();
        let l = joints_in_wrist_frame(&pose, &jl, WristConvention::Mano).unwrap();
        for (a, b) in r.iter().zip(&l) {
            assert!((Vector3::new(a.x, -a.y, a.z) - b).norm() < 1e-12, "{a} {b}");
        }
        // And the thumb tip is on +y on the right, on -y on the left, by most of a palm.
        assert!(r[4].y > 0.03 && l[4].y < -0.03, "{} {}", r[4].y, l[4].y);
    }

    #[test]
    fn bad_numbers_and_names_are_refused() {
        let pose = posed();
        let mut j = forward_kinematics(&HandSkeleton::default_for(HandSide::Right), &pose);
        j[7].x = f64::NAN;
        assert!(wrist_pose(&pose, &j, WristConvention::Mano).is_some());
        assert!(joints_in_wrist_frame(&pose, &j, WristConvention::Mano).is_none());
        j[0].z = f64::INFINITY;
        assert!(wrist_pose(&pose, &j, WristConvention::Mano).is_none());
        let mut bad = pose;
        bad.angles[3] = f64::NAN;
        let good = forward_kinematics(&HandSkeleton::default_for(HandSide::Right), &pose);
        assert!(wrist_pose(&bad, &good, WristConvention::Mano).is_none());
        assert_eq!("mano".parse::<WristConvention>(), Ok(WristConvention::Mano));
        let e = "MANO".parse::<WristConvention>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown wrist frame convention \"MANO\" (known: \"mano\")"
        );
    }
}
