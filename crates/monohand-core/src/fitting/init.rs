//! Starting poses for a fit from scratch.
//!
//! The palm (wrist, thumb CMC and the four finger MCPs) is rigid in the model,
//! so its pose can be estimated before anything else. We fit a 2D affine map
//! from the palm's model coordinates to the observed normalised image
//! coordinates and decompose it as a scaled orthographic camera (weak
//! perspective): this has a closed-form solution up to a two-fold mirror
//! ambiguity (the palm tilted towards or away from the camera), and both
//! solutions become starts. Each is refined with a root-only
//! Levenberg-Marquardt on the palm joints under full perspective before the
//! full fit. When fewer than three palm joints are seen, a small set of
//! orientations around the camera axis is used instead.

use super::problem::{DofMask, JointMask, PreparedView};
use crate::hand_model::{HandPose, HandSkeleton, NUM_DOF, NUM_JOINTS};
use nalgebra::{Matrix2, Matrix3, Rotation3, UnitQuaternion, Vector2, Vector3};

/// The rigid palm joints: wrist, thumb CMC, index, middle, ring and little MCP.
pub const PALM_JOINTS: [usize; 6] = [0, 1, 5, 9, 13, 17];

/// What the starts need of the fitter: the skeleton and views of the fit in
/// progress, and its Levenberg-Marquardt solver to refine a root pose with.
/// [`HandFitter`](super::HandFitter) implements it; taking it as a trait keeps
/// this module independent of the solver's.
pub(crate) trait StartSolver {
    /// The skeleton the fit in progress poses.
    fn fitted_skeleton(&self) -> &HandSkeleton;
    /// The views of the fit in progress.
    fn views(&self) -> &[PreparedView];
    /// Whether every joint of `pose` is in front of every camera.
    fn in_front(&self, pose: &HandPose) -> bool;
    /// The pose a solve from `start` ends at, over the joints of `mask` and the
    /// degrees of freedom of `free`, after at most `max_iter` iterations.
    fn solve_pose(
        &self,
        start: HandPose,
        mask: &JointMask,
        free: &DofMask,
        max_iter: usize,
    ) -> HandPose;
}

/// Up to 8 starting root poses (translation + rotation, neutral angles).
pub(crate) type Candidates = [Option<HandPose>; 8];

/// Starting poses for a fit: closed-form palm estimates refined on the palm,
/// or an orientation sweep when the palm is not seen.
pub(crate) fn root_candidates(fitter: &impl StartSolver, observed: &JointMask) -> Candidates {
    let sk = fitter.fitted_skeleton();
    let views = fitter.views();
    let mut out: Candidates = [None; 8];
    let neutral = sk.limits.neutral();
    if views.is_empty() {
        return out;
    }
    let vi = best_view(views);
    let view = &views[vi];
    let palm_seen = PALM_JOINTS
        .iter()
        .filter(|&&j| view.start_weights[j] > 0.0)
        .count();
    let rest = sk.rest_joints();
    let mut root_free: DofMask = [false; NUM_DOF];
    root_free[..6].iter_mut().for_each(|f| *f = true);

    if palm_seen >= 3 {
        let mut palm_mask: JointMask = [false; NUM_JOINTS];
        PALM_JOINTS.iter().for_each(|&j| palm_mask[j] = true);
        for (k, cam_pose) in weak_perspective_palm(&rest, view)
            .into_iter()
            .flatten()
            .enumerate()
        {
            let mut p = to_reference(&cam_pose, view);
            p.angles = neutral;
            let mut p = refine(fitter, p, &palm_mask, &root_free);
            init_fingers(sk, &mut p, view);
            out[k] = Some(p);
        }
    }
    if out.iter().all(Option::is_none) {
        // Orientation sweep: palm towards / away from the camera, four in-plane turns.
        let (centroid, spread, n) = image_extent(view);
        if n == 0 {
            return out;
        }
        let k = &view.camera.intrinsics;
        let depth = (k.fx * 0.75 * sk.hand_length() / spread.max(1.0)).clamp(100.0, 5000.0);
        let dir = Vector3::new((centroid.x - k.cx) / k.fx, (centroid.y - k.cy) / k.fy, 1.0);
        for (i, slot) in out.iter_mut().enumerate() {
            let facing = if i % 2 == 0 {
                0.0
            } else {
                std::f64::consts::PI
            };
            let roll = (i / 2) as f64 * std::f64::consts::FRAC_PI_2;
            // Hand y (fingers) up in the image (-y camera), palm normal towards the camera (-z).
            let base = Rotation3::from_matrix_unchecked(Matrix3::new(
                1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0,
            ));
            let r = Rotation3::from_axis_angle(&Vector3::z_axis(), roll)
                * base
                * Rotation3::from_axis_angle(&Vector3::y_axis(), facing);
            let mut p = HandPose {
                translation: dir * depth - r * (0.5 * rest[9]),
                rotation: UnitQuaternion::from_rotation_matrix(&r),
                angles: neutral,
            };
            p = to_reference(&p, view);
            let mut p = refine(fitter, p, observed, &root_free);
            init_fingers(sk, &mut p, view);
            *slot = Some(p);
        }
    }
    out
}

/// The view that sees most palm joints (then most joints).
pub(crate) fn best_view(views: &[PreparedView]) -> usize {
    (0..views.len())
        .max_by_key(|&i| {
            let palm = PALM_JOINTS
                .iter()
                .filter(|&&j| views[i].start_weights[j] > 0.0)
                .count();
            let all = views[i].start_weights.iter().filter(|&&w| w > 0.0).count();
            (palm, all)
        })
        .unwrap_or(0)
}

/// Centroid and extent (pixels) of the used keypoints of a view.
fn image_extent(view: &PreparedView) -> (Vector2<f64>, f64, usize) {
    let mut c = Vector2::zeros();
    let mut n = 0;
    let (mut lo, mut hi) = (
        Vector2::repeat(f64::INFINITY),
        Vector2::repeat(f64::NEG_INFINITY),
    );
    for j in 0..NUM_JOINTS {
        if view.start_weights[j] > 0.0 {
            let p = Vector2::new(view.ideal[j][0], view.ideal[j][1]);
            c += p;
            n += 1;
            lo = lo.inf(&p);
            hi = hi.sup(&p);
        }
    }
    if n == 0 {
        return (c, 0.0, 0);
    }
    (c / n as f64, (hi - lo).norm(), n)
}

/// Maps a pose expressed in a view's camera frame into the reference frame.
fn to_reference(p: &HandPose, view: &PreparedView) -> HandPose {
    let e = &view.camera.extrinsics;
    if e.is_identity() {
        return *p;
    }
    let rinv = e.rotation.inverse();
    HandPose {
        translation: rinv * (p.translation - e.translation),
        rotation: UnitQuaternion::from_rotation_matrix(&(rinv * p.rotation.to_rotation_matrix())),
        angles: p.angles,
    }
}

/// Closed-form weak-perspective palm pose in the view's camera frame (two mirror solutions).
pub(crate) fn weak_perspective_palm(
    rest: &[Vector3<f64>; NUM_JOINTS],
    view: &PreparedView,
) -> [Option<HandPose>; 2] {
    let k = &view.camera.intrinsics;
    let mut sw = 0.0;
    let mut mp = Vector2::zeros();
    let mut mm = Vector2::zeros();
    for &j in &PALM_JOINTS {
        let w = view.start_weights[j];
        if w > 0.0 {
            let m = Vector2::new(
                (view.ideal[j][0] - k.cx) / k.fx,
                (view.ideal[j][1] - k.cy) / k.fy,
            );
            sw += w;
            mp += w * rest[j].xy();
            mm += w * m;
        }
    }
    if sw <= 0.0 {
        return [None, None];
    }
    mp /= sw;
    mm /= sw;
    let mut spp = Matrix2::zeros();
    let mut smp = Matrix2::zeros();
    for &j in &PALM_JOINTS {
        let w = view.start_weights[j];
        if w > 0.0 {
            let m = Vector2::new(
                (view.ideal[j][0] - k.cx) / k.fx,
                (view.ideal[j][1] - k.cy) / k.fy,
            ) - mm;
            let p = rest[j].xy() - mp;
            spp += w * p * p.transpose();
            smp += w * m * p.transpose();
        }
    }
    let Some(inv) = spp.try_inverse() else {
        return [None, None];
    };
    let a = smp * inv;
    let c = mm - a * mp;
    let (a1, a2) = (a.column(0).into_owned(), a.column(1).into_owned());
    let (a11, a22, a12) = (a1.norm_squared(), a2.norm_squared(), a1.dot(&a2));
    let det = a11 * a22 - a12 * a12;
    let tr = a11 + a22;
    if tr <= 1e-18 {
        return [None, None];
    }
    // k = 1/s^2 solves det k^2 - tr k + 1 = 0; take the smaller root.
    let kk = if det > 1e-12 * tr * tr {
        (tr - (tr * tr - 4.0 * det).max(0.0).sqrt()) / (2.0 * det)
    } else {
        1.0 / tr
    };
    let s = 1.0 / kk.sqrt();
    let b1sq = (1.0 - kk * a11).max(0.0);
    let b2sq = (1.0 - kk * a22).max(0.0);
    let mut out = [None, None];
    for (i, sign) in [1.0, -1.0].into_iter().enumerate() {
        let (b1, b2) = if b1sq.sqrt() > 1e-6 {
            let b1 = sign * b1sq.sqrt();
            (b1, -kk * a12 / b1)
        } else {
            (0.0, sign * b2sq.sqrt())
        };
        let r1 = Vector3::new(a1.x / s, a1.y / s, b1).normalize();
        let r2u = Vector3::new(a2.x / s, a2.y / s, b2);
        let r2 = (r2u - r1 * r1.dot(&r2u)).normalize();
        let r3 = r1.cross(&r2);
        let rot = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[r1, r2, r3]));
        if !r3.iter().all(|v| v.is_finite()) {
            continue;
        }
        let z = 1.0 / s;
        out[i] = Some(HandPose {
            translation: Vector3::new(c.x * z, c.y * z, z),
            rotation: UnitQuaternion::from_rotation_matrix(&rot),
            angles: [0.0; 20],
        });
    }
    out
}

/// Refines a root pose with the fitter's own views, first pushing it in front
/// of every camera.
fn refine(
    fitter: &impl StartSolver,
    mut p: HandPose,
    mask: &JointMask,
    free: &DofMask,
) -> HandPose {
    if !fitter.in_front(&p) {
        p.translation.z = p.translation.z.abs().max(200.0);
        if !fitter.in_front(&p) {
            return p;
        }
    }
    fitter.solve_pose(p, mask, free, 30)
}

/// Sets each finger's angles from the rays of its observed keypoints, given the
/// root pose: every bone's far joint lies on its keypoint's viewing ray at the
/// bone's length from the near joint (a ray-sphere intersection with a near and
/// a far root). All 2^3 root choices are turned into angles (clamped to the
/// limits) and the one with the lowest reprojection cost in the view is kept.
pub(crate) fn init_fingers(sk: &HandSkeleton, pose: &mut HandPose, view: &PreparedView) {
    let k = &view.camera.intrinsics;
    let e = &view.camera.extrinsics;
    let r_root = pose.rotation.to_rotation_matrix();
    // hand frame -> view camera frame
    let to_cam = |p: &Vector3<f64>| e.rotation * (r_root * p + pose.translation) + e.translation;
    let to_hand = |x: &Vector3<f64>| {
        r_root.inverse() * (e.rotation.inverse() * (x - e.translation) - pose.translation)
    };
    let ray = |j: usize| {
        Vector3::new(
            (view.ideal[j][0] - k.cx) / k.fx,
            (view.ideal[j][1] - k.cy) / k.fy,
            1.0,
        )
        .normalize()
    };
    for f in crate::hand_model::Finger::ALL {
        let g = &sk.fingers[f.index()];
        let joints = f.joints();
        // Number of leading bones whose far joint is observed.
        let seen = (1..4)
            .take_while(|&s| view.start_weights[joints[s]] > 0.0)
            .count();
        if seen == 0 {
            continue;
        }
        let base_cam = to_cam(&g.base);
        let b = f.index() * crate::hand_model::params::ANGLES_PER_FINGER;
        let mut best_cost = finger_cost(sk, pose, view, f);
        let mut best = [
            pose.angles[b],
            pose.angles[b + 1],
            pose.angles[b + 2],
            pose.angles[b + 3],
        ];
        for combo in 0..(1usize << seen) {
            let mut pts = [base_cam; 4];
            for s in 1..=seen {
                let c = pts[s - 1];
                let r = ray(joints[s]);
                let len = g.lengths[s - 1];
                let rc = r.dot(&c);
                let disc = rc * rc - c.norm_squared() + len * len;
                let t = if disc >= 0.0 {
                    if combo >> (s - 1) & 1 == 0 {
                        rc - disc.sqrt()
                    } else {
                        rc + disc.sqrt()
                    }
                } else {
                    rc
                };
                let dir = (r * t.max(1.0) - c).try_normalize(1e-12).unwrap_or(r);
                pts[s] = c + dir * len;
            }
            let local = pts.map(|x| to_hand(&x));
            for branch in 0..2 {
                let mut angles = best;
                finger_angles_from_points(sk, f, &local[..=seen], branch, &mut angles);
                let mut trial = *pose;
                trial.angles[b..b + 4].copy_from_slice(&angles);
                sk.limits.clamp(&mut trial.angles);
                let cost = finger_cost(sk, &trial, view, f);
                if cost < best_cost {
                    best_cost = cost;
                    best.copy_from_slice(&trial.angles[b..b + 4]);
                }
            }
        }
        pose.angles[b..b + 4].copy_from_slice(&best);
    }
}

/// Weighted reprojection cost of one finger's joints in one view.
fn finger_cost(
    sk: &HandSkeleton,
    pose: &HandPose,
    view: &PreparedView,
    f: crate::hand_model::Finger,
) -> f64 {
    let chain = crate::kinematics::finger_chain(sk, f, &pose.angles);
    let r = pose.rotation.to_rotation_matrix();
    let k = &view.camera.intrinsics;
    let mut cost = 0.0;
    for (s, &j) in f.joints().iter().enumerate() {
        let w = view.start_weights[j];
        if w <= 0.0 {
            continue;
        }
        let x = view
            .camera
            .extrinsics
            .transform(&(r * chain.points[s] + pose.translation));
        if x.z <= 1.0 {
            return f64::INFINITY;
        }
        let du = k.fx * x.x / x.z + k.cx - view.ideal[j][0];
        let dv = k.fy * x.y / x.z + k.cy - view.ideal[j][1];
        cost += w * w * (du * du + dv * dv);
    }
    cost
}

/// Inverse kinematics of one finger from its joint positions in the hand frame
/// (base first; 2 to 4 points). Writes the angles it can determine. The base
/// flexion has two solutions; `branch` (0 or 1) picks one.
pub(crate) fn finger_angles_from_points(
    sk: &HandSkeleton,
    f: crate::hand_model::Finger,
    pts: &[Vector3<f64>],
    branch: usize,
    angles: &mut [f64; 4],
) {
    let g = &sk.fingers[f.index()];
    let lim = &sk.limits;
    let b = f.index() * 4;
    if pts.len() < 2 {
        return;
    }
    let Some(u1) = (pts[1] - pts[0]).try_normalize(1e-9) else {
        return;
    };
    let a = g.abduction_axis.into_inner();
    let d = g.rest_direction.into_inner();
    let h = g.flexion_axis;
    let e = h.cross(&d);
    // a . (cos p d + sin p e) = a . u1
    let (ca, cb, c) = (a.dot(&d), a.dot(&e), a.dot(&u1));
    let rr = (ca * ca + cb * cb).sqrt();
    let phi0 = cb.atan2(ca);
    let delta = if rr > 1e-12 {
        (c / rr).clamp(-1.0, 1.0).acos()
    } else {
        0.0
    };
    let centre = 0.5 * (lim.lower[b] + lim.upper[b]);
    let wrap = |x: f64| {
        (x + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
    };
    let cands = [wrap(phi0 + delta), wrap(phi0 - delta)];
    let dist = |p: f64| {
        if p < lim.lower[b] {
            lim.lower[b] - p
        } else if p > lim.upper[b] {
            p - lim.upper[b]
        } else {
            0.0
        }
    };
    // Both roots are tried by the caller; branch 0 is the one nearer the limits' range.
    let key = |p: f64| (dist(p), (p - centre).abs());
    let preferred = if key(cands[0]) <= key(cands[1]) { 0 } else { 1 };
    let flex1 = cands[if branch == 0 {
        preferred
    } else {
        1 - preferred
    }];
    let v = d * flex1.cos() + e * flex1.sin();
    let vp = v - a * a.dot(&v);
    let up = u1 - a * a.dot(&u1);
    let abd = a.dot(&vp.cross(&up)).atan2(vp.dot(&up));
    angles[0] = flex1;
    angles[1] = abd;
    let w = Rotation3::from_axis_angle(&g.abduction_axis, abd) * h.into_inner();
    let signed = |x: Vector3<f64>, y: Vector3<f64>| w.dot(&x.cross(&y)).atan2(x.dot(&y));
    if pts.len() >= 3 {
        if let Some(u2) = (pts[2] - pts[1]).try_normalize(1e-9) {
            angles[2] = signed(u1, u2);
            if pts.len() >= 4 {
                if let Some(u3) = (pts[3] - pts[2]).try_normalize(1e-9) {
                    angles[3] = signed(u2, u3);
                }
            }
        }
    }
}
