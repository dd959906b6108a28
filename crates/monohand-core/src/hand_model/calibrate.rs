//! Fitting a skeleton to a recorded sequence of 3D hands (motion capture,
//! dataset labels): palm layout, bone lengths, joint axes and limits.
//!
//! The palm is taken as rigid. Each frame's palm frame is built from the wrist
//! (joint 0), the index and little MCPs and the middle MCP. Base positions and
//! bone lengths are averages over frames. A finger's flexion hinge is the normal
//! of the plane of its first two bones; as the finger abducts, that normal
//! sweeps a cone around the abduction axis, so the abduction axis is the normal
//! of the best plane through the hinge normals (smallest principal direction).
//! Rest directions and the zero of flexion follow the template skeleton, and
//! the template's limits are widened to contain every observed angle (plus a
//! 3 degree margin).

use crate::error::{CoreError, CoreResult};
use crate::hand_model::{Finger, FingerGeometry, HandSide, HandSkeleton, NUM_JOINTS};
use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Unit, Vector3};

/// A skeleton fitted to 3D data, with how well it explains the data.
#[derive(Debug, Clone, Copy)]
pub struct SkeletonFit {
    /// The fitted skeleton.
    pub skeleton: HandSkeleton,
    /// Mean distance (mm) between the data and the skeleton posed by inverse
    /// kinematics on each frame.
    pub residual_mm: f64,
}

/// The palm frame of one 3D hand: rotation (columns = hand axes in the data
/// frame) and origin (joint 0).
pub fn palm_frame(
    joints: &[Vector3<f64>; NUM_JOINTS],
    side: HandSide,
) -> Option<(Rotation3<f64>, Vector3<f64>)> {
    let o = joints[0];
    let y = (joints[9] - o).try_normalize(1e-9)?;
    let across = match side {
        HandSide::Right => joints[5] - joints[17],
        HandSide::Left => joints[17] - joints[5],
    };
    let x = (across - y * y.dot(&across)).try_normalize(1e-9)?;
    let z = x.cross(&y);
    Some((
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
        o,
    ))
}

/// Fits a skeleton of the given side to 3D frames (mm), starting from `template`.
pub fn fit_skeleton(
    frames: &[[Vector3<f64>; NUM_JOINTS]],
    template: &HandSkeleton,
) -> CoreResult<SkeletonFit> {
    let side = template.side;
    let local: Vec<[Vector3<f64>; NUM_JOINTS]> = frames
        .iter()
        .filter_map(|f| {
            if f.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
                return None;
            }
            let (r, o) = palm_frame(f, side)?;
            Some(f.map(|p| r.inverse() * (p - o)))
        })
        .collect();
    if local.is_empty() {
        return Err(CoreError::InvalidSkeleton(
            "no usable 3D frame to fit a skeleton to".into(),
        ));
    }
    let n = local.len() as f64;
    let mut sk = *template;
    for f in Finger::ALL {
        let j = f.joints();
        let g = &mut sk.fingers[f.index()];
        g.base = local.iter().map(|p| p[j[0]]).sum::<Vector3<f64>>() / n;
        for k in 0..3 {
            g.lengths[k] = local
                .iter()
                .map(|p| (p[j[k + 1]] - p[j[k]]).norm())
                .sum::<f64>()
                / n;
        }
        // Hinge normals from frames where the first two bones are visibly bent.
        // Their signs follow the bend (flexion or hyperextension) and are oriented
        // by a reference hinge: the template's, except that the thumb's is taken
        // before the default roll (`THUMB_HINGE_ROLL_DEG`). Orienting by the rolled
        // hinge splits the thumb's bends differently (STB residual 0.74 mm against
        // 0.39), and a search over references that minimised the 3D residual (0.26
        // mm) gave skeletons that lift worse from 2D (docs/accuracy.md, "The floor").
        let raw: Vec<Vector3<f64>> = local
            .iter()
            .filter_map(|p| {
                let c = (p[j[1]] - p[j[0]])
                    .normalize()
                    .cross(&(p[j[2]] - p[j[1]]).normalize());
                (c.norm() >= 0.2).then(|| c.normalize())
            })
            .collect();
        if raw.len() >= 10 {
            let reference = match f {
                Finger::Thumb => template.planar_thumb().fingers[0].flexion_axis.into_inner(),
                _ => g.flexion_axis.into_inner(),
            };
            if let Some(fitted) = hinge_from_normals(&raw, reference, g) {
                *g = fitted;
                if f == Finger::Thumb {
                    sk.thumb_hinge_roll_deg = 0.0;
                }
            }
        }
    }
    // Widen the limits to the observed angles and measure the residual.
    let mut lower = sk.limits.lower;
    let mut upper = sk.limits.upper;
    let margin = 3f64.to_radians();
    let mut residual = 0.0;
    let mut count = 0usize;
    for p in &local {
        let mut angles = sk.limits.neutral();
        for f in Finger::ALL {
            let j = f.joints();
            let pts = [p[j[0]], p[j[1]], p[j[2]], p[j[3]]];
            let b = f.index() * 4;
            let best = finger_ik(&sk, f, &pts);
            angles[b..b + 4].copy_from_slice(&best.1);
        }
        for i in 0..angles.len() {
            lower[i] = lower[i].min(angles[i] - margin);
            upper[i] = upper[i].max(angles[i] + margin);
        }
        let fk = crate::kinematics::forward_kinematics_local(&sk, &angles);
        for j in 0..NUM_JOINTS {
            residual += (fk[j] - p[j]).norm();
            count += 1;
        }
    }
    sk.limits.lower = lower;
    sk.limits.upper = upper;
    sk.validate()?;
    Ok(SkeletonFit {
        skeleton: sk,
        residual_mm: residual / count as f64,
    })
}

/// A finger's hinge from its bend normals oriented by `reference`: the abduction
/// axis is the normal of the best plane through them (smallest principal direction),
/// the flexion axis their mean direction; rest direction and flexion sense follow
/// the template.
fn hinge_from_normals(
    raw: &[Vector3<f64>],
    reference: Vector3<f64>,
    template: &FingerGeometry,
) -> Option<FingerGeometry> {
    let t_h = template.flexion_axis.into_inner();
    let normals: Vec<Vector3<f64>> = raw
        .iter()
        .map(|&c| if c.dot(&reference) < 0.0 { -c } else { c })
        .collect();
    let mean = normals.iter().sum::<Vector3<f64>>() / normals.len() as f64;
    // Keep the template's sense of flexion.
    let (normals, mean) = if mean.dot(&t_h) < 0.0 {
        (normals.iter().map(|c| -c).collect::<Vec<_>>(), -mean)
    } else {
        (normals, mean)
    };
    let cov = normals
        .iter()
        .map(|v| (v - mean) * (v - mean).transpose())
        .sum::<Matrix3<f64>>();
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let spread = eig.eigenvalues[order[1]].max(0.0) / normals.len() as f64;
    let t_a = template.abduction_axis.into_inner();
    let a = if spread > 1e-4 {
        let e = eig.eigenvectors.column(order[0]).into_owned();
        if e.dot(&t_a) < 0.0 {
            -e
        } else {
            e
        }
    } else {
        t_a
    };
    let c = mean.dot(&a).clamp(-1.0, 1.0);
    let perp = (mean - a * mean.dot(&a)).try_normalize(1e-9)?;
    let h = (a * c + perp * (1.0 - c * c).sqrt()).normalize();
    let d0 = template.rest_direction.into_inner();
    let d = (d0 - h * h.dot(&d0)).try_normalize(1e-9).unwrap_or(d0);
    Some(FingerGeometry {
        abduction_axis: Unit::new_normalize(a),
        flexion_axis: Unit::new_normalize(h),
        rest_direction: Unit::new_normalize(d),
        ..*template
    })
}

/// Best inverse-kinematics angles of one finger for its four points (hand frame),
/// over both base branches, and their summed point error (mm).
fn finger_ik(sk: &HandSkeleton, f: Finger, pts: &[Vector3<f64>; 4]) -> (f64, [f64; 4]) {
    let b = f.index() * 4;
    let mut best = (f64::INFINITY, [0.0; 4]);
    for branch in 0..2 {
        let mut a = [0.0; 4];
        crate::fitting::init::finger_angles_from_points(sk, f, pts, branch, &mut a);
        let mut trial = sk.limits.neutral();
        trial[b..b + 4].copy_from_slice(&a);
        let chain = crate::kinematics::finger_chain(sk, f, &trial);
        let e: f64 = (0..4).map(|k| (chain.points[k] - pts[k]).norm()).sum();
        if e < best.0 {
            best = (e, a);
        }
    }
    best
}

#[cfg(test)]
#[allow(clippy::field_reassign_with_default)]
mod tests {
    use super::*;
    use crate::hand_model::HandPose;
    use crate::kinematics::forward_kinematics;
    use nalgebra::UnitQuaternion;

    #[test]
    fn recovers_a_known_skeleton() {
        // A distorted hand: longer bones, moved knuckles; poses with varied spread.
        for side in [HandSide::Right, HandSide::Left] {
            let template = HandSkeleton::default_for(side);
            let mut truth = template.scaled(1.1).unwrap();
            truth.fingers[2].lengths[0] += 4.0;
            let frames: Vec<_> = (0..200)
                .map(|i| {
                    let t = i as f64 * 0.1;
                    let mut pose = HandPose::default();
                    pose.rotation = UnitQuaternion::from_euler_angles(t.sin(), 0.3 * t.cos(), t);
                    for (k, a) in pose.angles.iter_mut().enumerate() {
                        let lo = truth.limits.lower[k].max(-0.2);
                        let hi = truth.limits.upper[k].min(1.2);
                        *a = lo + (hi - lo) * (0.5 + 0.5 * (t * (1.0 + 0.3 * k as f64)).sin());
                    }
                    forward_kinematics(&truth, &pose)
                })
                .collect();
            let fit = fit_skeleton(&frames, &template).unwrap();
            assert!(
                fit.residual_mm < 0.5,
                "{side}: residual {}",
                fit.residual_mm
            );
            let (a, b) = (fit.skeleton.bone_lengths(), truth.bone_lengths());
            for i in 0..20 {
                assert!((a[i] - b[i]).abs() < 0.01, "bone {i}: {} vs {}", a[i], b[i]);
            }
        }
    }
}
