//! Forward kinematics of the hand and its analytic Jacobian.
//!
//! Each joint angle rotates everything distal to it about its current axis,
//! so the derivative of a joint position `X_j` with respect to angle `k` is
//! `w_k x (X_j - X_k)`, with `w_k` the axis of angle `k` and `X_k` its joint.
//! The root adds the translation (identity) and a rotation perturbation
//! `R <- exp(w) R` whose derivative is `w x (R X)`.

use crate::hand_model::params::{ANGLES_PER_FINGER, NUM_ANGLES};
use crate::hand_model::{Finger, HandPose, HandSkeleton, NUM_JOINTS};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Number of degrees of freedom a joint position can depend on: 6 root + 4 finger angles.
pub const LOCAL_DOF: usize = 10;

// The skeleton's own rest pose is the kinematics' (here, so that the skeleton's module
// does not import the kinematics that take it).
impl HandSkeleton {
    /// Rest-pose joint positions in the hand frame.
    pub fn rest_joints(&self) -> [Vector3<f64>; NUM_JOINTS] {
        forward_kinematics_local(self, &[0.0; 20])
    }
}

/// Joint positions in the hand frame (wrist at the origin) for the given angles.
pub fn forward_kinematics_local(
    sk: &HandSkeleton,
    angles: &[f64; NUM_ANGLES],
) -> [Vector3<f64>; NUM_JOINTS] {
    let mut out = [Vector3::zeros(); NUM_JOINTS];
    for f in Finger::ALL {
        let chain = finger_chain(sk, f, angles);
        let j = f.joints();
        for k in 0..4 {
            out[j[k]] = chain.points[k];
        }
    }
    out
}

/// Joint positions in the camera (reference) frame for a full pose.
///
/// ```
/// use monohand_core::{hand_model::{HandPose, HandSide, HandSkeleton}, kinematics::forward_kinematics};
/// let sk = HandSkeleton::default_for(HandSide::Right);
/// let joints = forward_kinematics(&sk, &HandPose::default());
/// assert_eq!(joints[0], HandPose::default().translation);
/// ```
pub fn forward_kinematics(sk: &HandSkeleton, pose: &HandPose) -> [Vector3<f64>; NUM_JOINTS] {
    let r = pose.rotation.to_rotation_matrix();
    forward_kinematics_local(sk, &pose.angles).map(|p| r * p + pose.translation)
}

/// One finger's joint positions and the axes of its four angles, in the hand frame.
#[derive(Debug, Clone, Copy)]
pub struct FingerChain {
    /// Base, middle, distal joint and tip positions.
    pub points: [Vector3<f64>; 4],
    /// Current flexion axis (the rest axis turned by the abduction).
    pub flexion_axis: Vector3<f64>,
    /// Abduction axis.
    pub abduction_axis: Vector3<f64>,
}

/// Forward kinematics of one finger.
#[inline]
pub fn finger_chain(sk: &HandSkeleton, finger: Finger, angles: &[f64; NUM_ANGLES]) -> FingerChain {
    let g = &sk.fingers[finger.index()];
    let b = finger.index() * ANGLES_PER_FINGER;
    let (flex1, abd, flex2, flex3) = (angles[b], angles[b + 1], angles[b + 2], angles[b + 3]);
    let ra = Rotation3::from_axis_angle(&g.abduction_axis, abd);
    let d = g.rest_direction.into_inner();
    let h = g.flexion_axis;
    let d1 = ra * (Rotation3::from_axis_angle(&h, flex1) * d);
    let d2 = ra * (Rotation3::from_axis_angle(&h, flex1 + flex2) * d);
    let d3 = ra * (Rotation3::from_axis_angle(&h, flex1 + flex2 + flex3) * d);
    let p0 = g.base;
    let p1 = p0 + d1 * g.lengths[0];
    let p2 = p1 + d2 * g.lengths[1];
    let p3 = p2 + d3 * g.lengths[2];
    FingerChain {
        points: [p0, p1, p2, p3],
        flexion_axis: ra * h.into_inner(),
        abduction_axis: g.abduction_axis.into_inner(),
    }
}

/// Joint positions in the camera frame and, for each joint, its 3x10 Jacobian with
/// respect to (translation x,y,z; rotation perturbation x,y,z; the four angles of
/// its own finger in parameter order). The wrist's angle columns are zero.
pub fn forward_kinematics_with_jacobian(
    sk: &HandSkeleton,
    pose: &HandPose,
    points: &mut [Vector3<f64>; NUM_JOINTS],
    jacobians: &mut [nalgebra::SMatrix<f64, 3, LOCAL_DOF>; NUM_JOINTS],
) {
    let r = pose.rotation.to_rotation_matrix();
    let rm = r.matrix();
    let t = pose.translation;
    let root_block = |q: &Vector3<f64>, jac: &mut nalgebra::SMatrix<f64, 3, LOCAL_DOF>| {
        jac.fill(0.0);
        jac.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::identity());
        // d(exp(w) q)/dw = -[q]x
        jac.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-q.cross_matrix()));
    };
    points[0] = t;
    root_block(&Vector3::zeros(), &mut jacobians[0]);
    for f in Finger::ALL {
        let c = finger_chain(sk, f, &pose.angles);
        let w = rm * c.flexion_axis;
        let a = rm * c.abduction_axis;
        let cam = c.points.map(|p| rm * p);
        let idx = f.joints();
        for k in 0..4 {
            let j = idx[k];
            points[j] = cam[k] + t;
            let jac = &mut jacobians[j];
            root_block(&cam[k], jac);
            if k >= 1 {
                let lever0 = cam[k] - cam[0];
                jac.fixed_view_mut::<3, 1>(0, 6)
                    .copy_from(&w.cross(&lever0));
                jac.fixed_view_mut::<3, 1>(0, 7)
                    .copy_from(&a.cross(&lever0));
            }
            if k >= 2 {
                jac.fixed_view_mut::<3, 1>(0, 8)
                    .copy_from(&w.cross(&(cam[k] - cam[1])));
            }
            if k >= 3 {
                jac.fixed_view_mut::<3, 1>(0, 9)
                    .copy_from(&w.cross(&(cam[k] - cam[2])));
            }
        }
    }
}

/// Which finger (if any) a joint belongs to: `None` for the wrist.
pub const fn finger_of(joint: usize) -> Option<Finger> {
    if joint == 0 {
        None
    } else {
        Some(Finger::ALL[(joint - 1) / 4])
    }
}

#[cfg(test)]
#[allow(clippy::field_reassign_with_default)]
mod tests {
    use super::*;
    use crate::hand_model::HandSide;
    use nalgebra::UnitQuaternion;
    use num_dual::{jacobian, DualNum, DualVec64};

    /// Generic forward kinematics of one joint for num-dual checks.
    fn fk_generic<D: DualNum<Primitive = f64> + Copy>(
        sk: &HandSkeleton,
        joint: usize,
        x: &[D; 10],
        base: &HandPose,
    ) -> [D; 3] {
        // x = translation offset (3), rotation vector perturbation (3), finger angles (4)
        let Some(f) = finger_of(joint) else {
            // The wrist is the root: only the translation moves it.
            return std::array::from_fn(|i| x[i] + base.translation[i]);
        };
        let g = &sk.fingers[f.index()];
        let k = (joint - 1) % 4;
        let v = |p: Vector3<f64>| [D::from(p.x), D::from(p.y), D::from(p.z)];
        let rot = |axis: [f64; 3], ang: D, p: [D; 3]| -> [D; 3] {
            // Rodrigues
            let (s, c) = (ang.sin(), ang.cos());
            let a = axis.map(D::from);
            let dot = a[0] * p[0] + a[1] * p[1] + a[2] * p[2];
            let cr = [
                a[1] * p[2] - a[2] * p[1],
                a[2] * p[0] - a[0] * p[2],
                a[0] * p[1] - a[1] * p[0],
            ];
            std::array::from_fn(|i| p[i] * c + cr[i] * s + a[i] * dot * (D::from(1.0) - c))
        };
        let h = [g.flexion_axis.x, g.flexion_axis.y, g.flexion_axis.z];
        let aa = [g.abduction_axis.x, g.abduction_axis.y, g.abduction_axis.z];
        let b = f.index() * 4;
        let ang = |i: usize| D::from(base.angles[b + i]) + x[6 + i];
        let mut p = v(g.base);
        let d = v(g.rest_direction.into_inner());
        let mut flex = D::from(0.0);
        for seg in 0..k {
            flex += match seg {
                0 => ang(0),
                1 => ang(2),
                _ => ang(3),
            };
            let dir = rot(aa, ang(1), rot(h, flex, d));
            for i in 0..3 {
                p[i] += dir[i] * g.lengths[seg];
            }
        }
        // root rotation then perturbation
        let r = base.rotation.to_rotation_matrix();
        let m = r.matrix();
        let q: [D; 3] =
            std::array::from_fn(|i| p[0] * m[(i, 0)] + p[1] * m[(i, 1)] + p[2] * m[(i, 2)]);
        // exp of rotation vector (x[3..6]) applied to q
        let wv = [x[3], x[4], x[5]];
        let th2 = wv[0] * wv[0] + wv[1] * wv[1] + wv[2] * wv[2];
        // first-order exact at zero is enough for derivatives at zero
        let cr = [
            wv[1] * q[2] - wv[2] * q[1],
            wv[2] * q[0] - wv[0] * q[2],
            wv[0] * q[1] - wv[1] * q[0],
        ];
        let _ = th2;
        std::array::from_fn(|i| q[i] + cr[i] + x[i] + base.translation[i])
    }

    /// The bone vectors the fitter's cue residuals use, `X_child - X_parent`, and their
    /// Jacobian `J_child - J_parent` in the child's local columns.
    #[test]
    fn bone_vector_jacobian_matches_dual_numbers() {
        let sk = HandSkeleton::default_for(HandSide::Left);
        let mut pose = HandPose::default();
        pose.translation = Vector3::new(-40.0, 10.0, 380.0);
        pose.rotation = UnitQuaternion::from_euler_angles(-0.3, 0.9, 0.4);
        for (i, a) in pose.angles.iter_mut().enumerate() {
            *a = 0.25 - 0.02 * i as f64;
        }
        let mut pts = [Vector3::zeros(); NUM_JOINTS];
        let mut jac = [nalgebra::SMatrix::<f64, 3, LOCAL_DOF>::zeros(); NUM_JOINTS];
        forward_kinematics_with_jacobian(&sk, &pose, &mut pts, &mut jac);
        for &(p, c) in crate::hand_model::BONES.iter() {
            let (val, jd) = jacobian(
                |x: nalgebra::SVector<DualVec64<nalgebra::Const<10>>, 10>| {
                    let arr: [DualVec64<nalgebra::Const<10>>; 10] = std::array::from_fn(|i| x[i]);
                    let a = fk_generic(&sk, c, &arr, &pose);
                    let b = fk_generic(&sk, p, &arr, &pose);
                    nalgebra::SVector::from([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
                },
                &nalgebra::SVector::<f64, 10>::zeros(),
            );
            let bone = pts[c] - pts[p];
            assert!((Vector3::new(val[0], val[1], val[2]) - bone).norm() < 1e-9);
            let err = (jd - (jac[c] - jac[p])).abs().max();
            assert!(err < 1e-8, "bone ({p}, {c}): jacobian mismatch {err}");
        }
    }

    #[test]
    fn analytic_jacobian_matches_dual_numbers() {
        for side in [HandSide::Right, HandSide::Left] {
            let sk = HandSkeleton::default_for(side);
            let mut pose = HandPose::default();
            pose.translation = Vector3::new(30.0, -20.0, 450.0);
            pose.rotation = UnitQuaternion::from_euler_angles(0.4, -0.7, 1.1);
            for (i, a) in pose.angles.iter_mut().enumerate() {
                *a = 0.03 * i as f64 - 0.1;
            }
            let mut pts = [Vector3::zeros(); NUM_JOINTS];
            let mut jac = [nalgebra::SMatrix::<f64, 3, LOCAL_DOF>::zeros(); NUM_JOINTS];
            forward_kinematics_with_jacobian(&sk, &pose, &mut pts, &mut jac);
            let fk = forward_kinematics(&sk, &pose);
            for j in 1..NUM_JOINTS {
                assert!((fk[j] - pts[j]).norm() < 1e-9);
                let (val, jd) = jacobian(
                    |x: nalgebra::SVector<DualVec64<nalgebra::Const<10>>, 10>| {
                        let arr: [DualVec64<nalgebra::Const<10>>; 10] =
                            std::array::from_fn(|i| x[i]);
                        let r = fk_generic(&sk, j, &arr, &pose);
                        nalgebra::SVector::from([r[0], r[1], r[2]])
                    },
                    &nalgebra::SVector::<f64, 10>::zeros(),
                );
                assert!((Vector3::new(val[0], val[1], val[2]) - pts[j]).norm() < 1e-9);
                let err = (jd - jac[j]).abs().max();
                assert!(
                    err < 1e-8,
                    "joint {j}: jacobian mismatch {err}\n{jd}\n{}",
                    jac[j]
                );
            }
        }
    }
}
