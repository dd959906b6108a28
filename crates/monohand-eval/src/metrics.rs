//! The evaluation metrics, as pure functions on 21-joint arrays.
//!
//! Every function takes joints as `[[f64; 3]; 21]` (mm, in the order of
//! [`monohand_core::hand_model::JOINT_NAMES`]) and, where it averages, a
//! [`JointMask`] of the joints to evaluate. The formulas are in
//! `docs/evaluation.md`; the names here follow it:
//!
//! | metric | function |
//! |---|---|
//! | absolute per-joint error `e_j = ‖p_j − g_j‖` | [`joint_errors`] |
//! | root-relative `‖(p_j − p_r) − (g_j − g_r)‖` | [`root_relative_errors`] |
//! | Zimmermann & Brox "aligned" (root + reference-bone scale) | [`zb_aligned_errors`] |
//! | Procrustes-aligned (similarity: rotation, translation, scale) | [`procrustes_errors`] |
//! | per-axis mean absolute error | [`axis_abs_errors`] |
//! | PCK at a threshold, its curve, and the area under it | [`pck`], [`pck_curve`], [`auc`] |
//! | 2D keypoint error, pixels | [`keypoint_errors_px`] |

use monohand_core::alignment::align;
use monohand_core::hand_model::NUM_JOINTS;
use nalgebra::Vector3;

/// 21 joints, mm.
pub type Joints = [[f64; 3]; NUM_JOINTS];

/// Which joints are evaluated (`true` = evaluated).
pub type JointMask = [bool; NUM_JOINTS];

/// All 21 joints evaluated.
pub const ALL_JOINTS: JointMask = [true; NUM_JOINTS];

/// The reference bone of the Zimmermann & Brox alignment: middle-finger MCP to
/// PIP (keypoints 12 and 11 of their order; see `docs/evaluation.md`).
pub const ZB_REFERENCE_BONE: (usize, usize) = (9, 10);

/// The threshold range of the area under the PCK curve that STB tables quote, mm.
pub const AUC_RANGE_MM: (f64, f64) = (20.0, 50.0);

fn v(p: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

/// Converts nalgebra points into a [`Joints`] array.
pub fn to_joints(points: &[Vector3<f64>; NUM_JOINTS]) -> Joints {
    points.map(|p| [p.x, p.y, p.z])
}

/// Absolute 3D error of each joint, `‖p_j − g_j‖` (mm, camera frame).
pub fn joint_errors(pred: &Joints, gt: &Joints) -> [f64; NUM_JOINTS] {
    std::array::from_fn(|j| (v(&pred[j]) - v(&gt[j])).norm())
}

/// The joints of `mask` that `gt` has: a dataset marks a joint it lacks with NaN
/// coordinates (a rig's reference where too few views labelled it), and every metric
/// leaves such joints out.
pub fn labelled(gt: &Joints, mask: &JointMask) -> JointMask {
    std::array::from_fn(|j| mask[j] && gt[j].iter().all(|x| x.is_finite()))
}

/// Mean of the masked entries that are numbers (a joint without ground truth has a NaN
/// error); NaN if there is none.
pub fn masked_mean(values: &[f64; NUM_JOINTS], mask: &JointMask) -> f64 {
    let (s, n) = values
        .iter()
        .zip(mask)
        .filter(|(x, &m)| m && !x.is_nan())
        .fold((0.0, 0usize), |(s, n), (x, _)| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// The joints moved so that joint `root` is at the origin.
pub fn root_relative(joints: &Joints, root: usize) -> Joints {
    let r = joints[root];
    joints.map(|p| [p[0] - r[0], p[1] - r[1], p[2] - r[2]])
}

/// Root-relative error of each joint: `‖(p_j − p_r) − (g_j − g_r)‖`.
pub fn root_relative_errors(pred: &Joints, gt: &Joints, root: usize) -> [f64; NUM_JOINTS] {
    joint_errors(&root_relative(pred, root), &root_relative(gt, root))
}

/// The prediction aligned as Zimmermann & Brox (ICCV 2017) evaluate: moved to
/// the ground truth's root and scaled so that its reference bone `bone` has
/// the ground truth's length: `a_j = g_r + (p_j − p_r) · ‖g_b − g_a‖ / ‖p_b − p_a‖`.
/// A degenerate predicted bone (shorter than 1e-9 mm) leaves the scale at 1.
pub fn zb_align(pred: &Joints, gt: &Joints, root: usize, bone: (usize, usize)) -> Joints {
    let lp = (v(&pred[bone.1]) - v(&pred[bone.0])).norm();
    let lg = (v(&gt[bone.1]) - v(&gt[bone.0])).norm();
    let s = if lp > 1e-9 { lg / lp } else { 1.0 };
    let (pr, gr) = (v(&pred[root]), v(&gt[root]));
    pred.map(|p| {
        let a = gr + (v(&p) - pr) * s;
        [a.x, a.y, a.z]
    })
}

/// Per-joint error after [`zb_align`].
pub fn zb_aligned_errors(
    pred: &Joints,
    gt: &Joints,
    root: usize,
    bone: (usize, usize),
) -> [f64; NUM_JOINTS] {
    joint_errors(&zb_align(pred, gt, root, bone), gt)
}

/// The similarity transform `x ↦ s R x + t` that best maps the masked
/// predicted joints onto the ground truth in the least-squares sense
/// (Umeyama 1991), applied to all 21 predicted joints. `None` if fewer than 3
/// joints are masked in or the prediction is degenerate (all points equal).
pub fn procrustes_align(pred: &Joints, gt: &Joints, mask: &JointMask) -> Option<Joints> {
    let mut from = [Vector3::zeros(); NUM_JOINTS];
    let mut to = [Vector3::zeros(); NUM_JOINTS];
    let mut n = 0;
    for j in (0..NUM_JOINTS).filter(|&j| mask[j]) {
        (from[n], to[n]) = (v(&pred[j]), v(&gt[j]));
        n += 1;
    }
    let s = align(&from[..n], &to[..n], true)?;
    Some(pred.map(|p| {
        let a = s.apply(&v(&p));
        [a.x, a.y, a.z]
    }))
}

/// Per-joint error after [`procrustes_align`] on the masked joints (PA-MPJPE
/// is its masked mean). Falls back to the absolute error if the alignment is
/// undefined.
pub fn procrustes_errors(pred: &Joints, gt: &Joints, mask: &JointMask) -> [f64; NUM_JOINTS] {
    match procrustes_align(pred, gt, mask) {
        Some(a) => joint_errors(&a, gt),
        None => joint_errors(pred, gt),
    }
}

/// Mean absolute error along x, y and z (camera axes) over the masked joints.
pub fn axis_abs_errors(pred: &Joints, gt: &Joints, mask: &JointMask) -> [f64; 3] {
    let mut s = [0.0; 3];
    let mut n = 0usize;
    for j in (0..NUM_JOINTS).filter(|&j| mask[j]) {
        for (a, sa) in s.iter_mut().enumerate() {
            *sa += (pred[j][a] - gt[j][a]).abs();
        }
        n += 1;
    }
    if n == 0 {
        return [f64::NAN; 3];
    }
    s.map(|x| x / n as f64)
}

/// 2D error of each joint in pixels, `‖k_j − k*_j‖`, `None` where either side
/// has no point (confidence 0).
pub fn keypoint_errors_px(
    pred: &[[f64; 3]; NUM_JOINTS],
    gt: &[[f64; 3]; NUM_JOINTS],
) -> [Option<f64>; NUM_JOINTS] {
    std::array::from_fn(|j| {
        let (p, g) = (pred[j], gt[j]);
        if p[2] > 0.0 && g[2] > 0.0 {
            Some(((p[0] - g[0]).powi(2) + (p[1] - g[1]).powi(2)).sqrt())
        } else {
            None
        }
    })
}

/// Fraction of `errors` at or below `threshold` (0 for an empty list).
pub fn pck(errors: &[f64], threshold: f64) -> f64 {
    if errors.is_empty() {
        return 0.0;
    }
    errors.iter().filter(|&&e| e <= threshold).count() as f64 / errors.len() as f64
}

/// [`pck`] at each threshold.
pub fn pck_curve(errors: &[f64], thresholds: &[f64]) -> Vec<f64> {
    thresholds.iter().map(|&t| pck(errors, t)).collect()
}

/// `n` evenly spaced thresholds from `lo` to `hi` inclusive (`n >= 2`).
pub fn thresholds(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// Normalised area under the PCK curve between `lo` and `hi` mm, computed
/// exactly (the curve is a step function):
/// `AUC = 1/(hi−lo) ∫_lo^hi PCK(t) dt = mean_i (hi − clamp(e_i, lo, hi)) / (hi − lo)`.
/// A trapezoid rule on a fine threshold grid converges to this value.
pub fn auc(errors: &[f64], lo: f64, hi: f64) -> f64 {
    if errors.is_empty() || hi <= lo {
        return 0.0;
    }
    errors
        .iter()
        .map(|&e| (hi - e.clamp(lo, hi)) / (hi - lo))
        .sum::<f64>()
        / errors.len() as f64
}

/// Mean of a list (NaN if empty).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        f64::NAN
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// The `q`-quantile (0..=1) of a list by linear interpolation (NaN if empty).
pub fn quantile(x: &[f64], q: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos.fract());
    if i + 1 < s.len() {
        s[i] * (1.0 - f) + s[i + 1] * f
    } else {
        s[i]
    }
}

/// The mean of the masked joints.
pub fn centroid(joints: &Joints, mask: &JointMask) -> [f64; 3] {
    let mask = labelled(joints, mask);
    let n = mask.iter().filter(|&&m| m).count().max(1) as f64;
    let mut c = [0.0; 3];
    for (p, _) in joints.iter().zip(mask).filter(|(_, m)| *m) {
        for k in 0..3 {
            c[k] += p[k] / n;
        }
    }
    c
}

/// Per-joint errors after shifting both hands to their centroids (over `mask`, of the
/// joints each has).
pub fn centroid_errors(pred: &Joints, gt: &Joints, mask: &JointMask) -> [f64; NUM_JOINTS] {
    let (cp, cg) = (centroid(pred, mask), centroid(gt, mask));
    let shift = |j: &Joints, c: [f64; 3]| j.map(|p| [p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
    joint_errors(&shift(pred, cp), &shift(gt, cg))
}

/// The ratio of the predicted hand's distance to the true one's: the depths of the
/// centroids of the masked joints `gt` has, in `camera`'s frame (joints in its reference
/// frame). Above 1: the hand was placed too far. `None` if a centroid is not in front.
pub fn depth_ratio(
    pred: &Joints,
    gt: &Joints,
    mask: &JointMask,
    camera: &monohand_core::camera::Camera,
) -> Option<f64> {
    let mask = labelled(gt, mask);
    let depth = |j: &Joints| camera.extrinsics.transform(&v(&centroid(j, &mask))).z;
    let (p, g) = (depth(pred), depth(gt));
    (p > 0.0 && g > 0.0).then(|| p / g)
}

/// Mean over joints of the second difference `|x(t+1) - 2 x(t) + x(t-1)|` (mm per
/// frame squared): the jitter of a joint trajectory, for three consecutive frames.
pub fn acceleration(prev: &Joints, now: &Joints, next: &Joints, mask: &JointMask) -> f64 {
    let a: [f64; NUM_JOINTS] = std::array::from_fn(|j| {
        let d: [f64; 3] = std::array::from_fn(|k| next[j][k] - 2.0 * now[j][k] + prev[j][k]);
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    });
    masked_mean(&a, mask)
}

/// All per-joint errors of one evaluated hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandErrors {
    /// Absolute error per joint, camera frame (mm).
    pub absolute: [f64; NUM_JOINTS],
    /// Root-relative error per joint (mm).
    pub root_relative: [f64; NUM_JOINTS],
    /// Zimmermann & Brox aligned error per joint (mm).
    pub aligned: [f64; NUM_JOINTS],
    /// Procrustes-aligned error per joint (mm).
    pub procrustes: [f64; NUM_JOINTS],
    /// Centroid-aligned error per joint: both hands shifted to their mean over
    /// the evaluated joints, no rotation or scale (mm).
    pub centroid: [f64; NUM_JOINTS],
    /// Mean absolute error along x, y, z over the evaluated joints (mm).
    pub axis: [f64; 3],
}

impl HandErrors {
    /// Every metric of one prediction against its ground truth; `root` is the
    /// root joint (wrist, or the palm centre for STB).
    /// Joints `gt` lacks (NaN) are left out of the masked metrics and have NaN errors.
    pub fn compute(pred: &Joints, gt: &Joints, mask: &JointMask, root: usize) -> HandErrors {
        let mask = &labelled(gt, mask);
        HandErrors {
            absolute: joint_errors(pred, gt),
            root_relative: root_relative_errors(pred, gt, root),
            aligned: zb_aligned_errors(pred, gt, root, ZB_REFERENCE_BONE),
            procrustes: procrustes_errors(pred, gt, mask),
            centroid: centroid_errors(pred, gt, mask),
            axis: axis_abs_errors(pred, gt, mask),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    fn hand() -> Joints {
        // A non-degenerate, non-planar set of 21 points (a spiral).
        std::array::from_fn(|j| {
            let a = j as f64 * 0.7;
            [30.0 * a.cos(), 30.0 * a.sin(), 500.0 + 4.0 * j as f64]
        })
    }

    #[test]
    fn pure_shift_is_absolute_but_not_relative() {
        let g = hand();
        let p = g.map(|q| [q[0] + 6.0, q[1] - 8.0, q[2]]); // |(6, -8, 0)| = 10
        let e = HandErrors::compute(&p, &g, &ALL_JOINTS, 0);
        for j in 0..NUM_JOINTS {
            assert!((e.absolute[j] - 10.0).abs() < 1e-12);
            assert!(e.root_relative[j].abs() < 1e-12);
            assert!(e.aligned[j].abs() < 1e-12);
            assert!(e.procrustes[j] < 1e-9);
        }
        assert!((masked_mean(&e.absolute, &ALL_JOINTS) - 10.0).abs() < 1e-12);
        assert!((e.axis[0] - 6.0).abs() < 1e-12);
        assert!((e.axis[1] - 8.0).abs() < 1e-12);
        assert!(e.axis[2].abs() < 1e-12);
    }

    #[test]
    fn rigid_and_similarity_transforms_give_zero_pa_error() {
        let g = hand();
        let r = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let t = Vector3::new(-40.0, 25.0, 90.0);
        for s in [1.0, 1.37] {
            let p = g.map(|q| {
                let x = r * Vector3::new(q[0], q[1], q[2]) * s + t;
                [x.x, x.y, x.z]
            });
            let e = procrustes_errors(&p, &g, &ALL_JOINTS);
            assert!(e.iter().all(|&x| x < 1e-9), "scale {s}: {e:?}");
            // But not zero absolute error.
            assert!(masked_mean(&joint_errors(&p, &g), &ALL_JOINTS) > 10.0);
        }
    }

    #[test]
    fn centroid_alignment_removes_shift_not_rotation_and_acceleration_sees_jitter() {
        let g = hand();
        let shifted = g.map(|q| [q[0] + 30.0, q[1], q[2] - 12.0]);
        let e = centroid_errors(&shifted, &g, &ALL_JOINTS);
        assert!(e.iter().all(|&x| x < 1e-9), "{e:?}");
        let r = Rotation3::from_euler_angles(0.0, 0.0, 0.5);
        let turned = g.map(|q| {
            let x = r * Vector3::new(q[0], q[1], q[2] - 540.0);
            [x.x, x.y, x.z + 540.0]
        });
        assert!(masked_mean(&centroid_errors(&turned, &g, &ALL_JOINTS), &ALL_JOINTS) > 5.0);
        // Uniform motion has no acceleration; a 2 mm kick on every joint has 2 * 2 mm.
        let step = |d: f64| g.map(|q| [q[0] + d, q[1], q[2]]);
        assert!(acceleration(&step(0.0), &step(1.0), &step(2.0), &ALL_JOINTS) < 1e-12);
        let a = acceleration(&step(0.0), &step(2.0), &step(0.0), &ALL_JOINTS);
        assert!((a - 4.0).abs() < 1e-12, "{a}");
    }

    #[test]
    fn procrustes_does_not_reflect() {
        let g = hand();
        let p = g.map(|q| [-q[0], q[1], q[2]]); // a mirror image
        let e = procrustes_errors(&p, &g, &ALL_JOINTS);
        assert!(masked_mean(&e, &ALL_JOINTS) > 1.0);
    }

    #[test]
    fn zb_alignment_removes_root_and_scale_only() {
        let g = hand();
        // Scaled about the root by 1.2 and shifted: aligned error 0.
        let root = g[0];
        let p = g.map(|q| {
            [
                root[0] + 1.2 * (q[0] - root[0]) + 5.0,
                root[1] + 1.2 * (q[1] - root[1]),
                root[2] + 1.2 * (q[2] - root[2]) - 30.0,
            ]
        });
        let e = zb_aligned_errors(&p, &g, 0, ZB_REFERENCE_BONE);
        assert!(e.iter().all(|&x| x < 1e-9), "{e:?}");
        // Root-relative still sees the 20% scale.
        assert!(masked_mean(&root_relative_errors(&p, &g, 0), &ALL_JOINTS) > 1.0);
    }

    #[test]
    fn masked_mean_ignores_masked_out_joints() {
        let mut e = [1.0; NUM_JOINTS];
        e[0] = 100.0;
        let mut m = ALL_JOINTS;
        m[0] = false;
        assert_eq!(masked_mean(&e, &m), 1.0);
        assert!(masked_mean(&e, &[false; NUM_JOINTS]).is_nan());
    }

    #[test]
    fn pck_and_auc_of_a_known_list() {
        let e = [5.0, 15.0, 25.0, 35.0, 45.0, 55.0];
        assert_eq!(pck(&e, 20.0), 2.0 / 6.0);
        assert_eq!(pck(&e, 25.0), 3.0 / 6.0); // at the threshold counts
        assert_eq!(pck(&e, 0.0), 0.0);
        assert_eq!(
            pck_curve(&e, &[10.0, 50.0, 60.0]),
            vec![1.0 / 6.0, 5.0 / 6.0, 1.0]
        );
        // By hand: over [20, 50] each error contributes (50 - clamp(e)) / 30:
        // 5, 15 -> 1; 25 -> 25/30; 35 -> 15/30; 45 -> 5/30; 55 -> 0.
        let want = (1.0 + 1.0 + 25.0 / 30.0 + 15.0 / 30.0 + 5.0 / 30.0) / 6.0;
        assert!((auc(&e, 20.0, 50.0) - want).abs() < 1e-12);
        // The trapezoid rule on a fine grid agrees.
        let t = thresholds(20.0, 50.0, 30001);
        let c = pck_curve(&e, &t);
        let trap: f64 = c.windows(2).map(|w| 0.5 * (w[0] + w[1])).sum::<f64>() / 30000.0;
        assert!((trap - want).abs() < 1e-3, "{trap} vs {want}");
        assert_eq!(auc(&[0.0; 4], 20.0, 50.0), 1.0);
        assert_eq!(auc(&[80.0], 20.0, 50.0), 0.0);
        assert_eq!(auc(&[], 20.0, 50.0), 0.0);
    }

    #[test]
    fn keypoint_errors_skip_missing_points() {
        let mut a = [[0.0, 0.0, 1.0]; NUM_JOINTS];
        let b = [[3.0, 4.0, 1.0]; NUM_JOINTS];
        a[2][2] = 0.0;
        let e = keypoint_errors_px(&a, &b);
        assert_eq!(e[0], Some(5.0));
        assert_eq!(e[2], None);
    }

    #[test]
    fn quantiles() {
        assert_eq!(quantile(&[3.0, 1.0, 2.0], 0.5), 2.0);
        assert_eq!(quantile(&[1.0, 2.0], 0.5), 1.5);
        assert!(quantile(&[], 0.5).is_nan());
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
    }
}
