//! Zhang's closed-form start: each view's homography (normalised DLT), the focal lengths
//! from the homographies with the principal point at the image centre (as OpenCV's
//! `initIntrinsicParams2D`), and each view's pose from `K^-1 H`. For the fisheye, the same
//! on the corners undistorted by an equidistant lens (`r = f theta`, the fisheye with
//! `k = 0`), whose focal length is the one of a ladder under which the views' boards fit
//! best ([`fisheye_start`]).

use super::projection::Pose;
use monohand_core::camera::Distortion;
use nalgebra::{DMatrix, Matrix2, Matrix3, Point2, Rotation3, Vector2, Vector3};

/// The similarity that moves points' centroid to the origin and their mean distance to √2
/// (Hartley's normalisation), or `None` if they all coincide.
fn normaliser(pts: impl Iterator<Item = Vector2<f64>> + Clone) -> Option<Matrix3<f64>> {
    let n = pts.clone().count() as f64;
    let c = pts.clone().fold(Vector2::zeros(), |a, p| a + p) / n;
    let d = pts.map(|p| (p - c).norm()).sum::<f64>() / n;
    if !(d.is_finite() && d > 1e-12) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    Some(Matrix3::new(
        s,
        0.0,
        -s * c.x,
        0.0,
        s,
        -s * c.y,
        0.0,
        0.0,
        1.0,
    ))
}

/// The homography from the board plane (its x, y in mm) to the image, by the normalised
/// DLT; an error says why the view cannot give one.
pub(crate) fn homography(
    object: &[Vector3<f64>],
    image: &[Point2<f64>],
) -> Result<Matrix3<f64>, String> {
    let tb = normaliser(object.iter().map(|p| p.xy())).ok_or("the board has no extent")?;
    let ti =
        normaliser(image.iter().map(|p| p.coords)).ok_or("the corners all fall on one pixel")?;
    let n = object.len();
    let mut a = DMatrix::<f64>::zeros(2 * n, 9);
    for (i, (o, p)) in object.iter().zip(image).enumerate() {
        let b = tb * Vector3::new(o.x, o.y, 1.0);
        let q = ti * Vector3::new(p.x, p.y, 1.0);
        let (u, v) = (q.x, q.y);
        for k in 0..3 {
            a[(2 * i, k)] = b[k];
            a[(2 * i, 6 + k)] = -u * b[k];
            a[(2 * i + 1, 3 + k)] = b[k];
            a[(2 * i + 1, 6 + k)] = -v * b[k];
        }
    }
    let svd = a.svd(false, true);
    let vt = svd.v_t.ok_or("the homography's SVD failed")?;
    let sv = &svd.singular_values;
    let mut order: Vec<usize> = (0..sv.len()).collect();
    order.sort_by(|&i, &j| sv[i].total_cmp(&sv[j]));
    let (smallest, second, largest) = (order[0], order[1], order[order.len() - 1]);
    if sv[second].is_nan() || sv[second] <= 1e-9 * sv[largest] {
        return Err("the corners are collinear (the board is seen edge-on)".into());
    }
    let h = vt.row(smallest);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    // A singular homography maps the board onto a line.
    let det = hn.determinant().abs();
    if det.is_nan() || det <= 1e-6 * hn.norm().powi(3) {
        return Err("the corners are collinear (the board is seen edge-on)".into());
    }
    let ti_inv = ti
        .try_inverse()
        .ok_or("the corners' normalisation is singular")?;
    let mut hm = ti_inv * hn * tb;
    let scale = hm[(2, 2)];
    if scale.is_nan() || scale.abs() <= 1e-300 {
        return Err("the homography maps the board's origin to infinity".into());
    }
    hm /= scale;
    if hm.iter().any(|v| !v.is_finite()) {
        return Err("the homography is not finite".into());
    }
    // Every corner must be in front: the homogeneous scale keeps one sign.
    let w: Vec<f64> = object
        .iter()
        .map(|o| (hm * Vector3::new(o.x, o.y, 1.0)).z)
        .collect();
    if !(w.iter().all(|&v| v > 0.0) || w.iter().all(|&v| v < 0.0)) {
        return Err("the homography puts the board's horizon inside it".into());
    }
    Ok(hm)
}

/// The focal lengths from the homographies with the principal point fixed at `(cx, cy)`:
/// for each view, orthogonal columns of `K^-1 H` and of its diagonals (OpenCV's
/// `initIntrinsicParams2D`), solved by least squares for `1/fx^2` and `1/fy^2`. `None`
/// when the views do not determine them (all face-on).
pub(crate) fn focal_from_homographies(hs: &[Matrix3<f64>], cx: f64, cy: f64) -> Option<(f64, f64)> {
    let mut ata = Matrix2::<f64>::zeros();
    let mut atb = Vector2::<f64>::zeros();
    for h in hs {
        let mut m = *h;
        for j in 0..3 {
            m[(0, j)] -= m[(2, j)] * cx;
            m[(1, j)] -= m[(2, j)] * cy;
        }
        let c0 = m.column(0).into_owned();
        let c1 = m.column(1).into_owned();
        let d1 = (c0 + c1) * 0.5;
        let d2 = (c0 - c1) * 0.5;
        let (c0, c1, d1, d2) = (
            c0.try_normalize(1e-300)?,
            c1.try_normalize(1e-300)?,
            d1.try_normalize(1e-300)?,
            d2.try_normalize(1e-300)?,
        );
        for (a, b) in [(c0, c1), (d1, d2)] {
            let row = Vector2::new(a.x * b.x, a.y * b.y);
            ata += row * row.transpose();
            atb += row * (-a.z * b.z);
        }
    }
    let f = ata.try_inverse()? * atb;
    let (fx, fy) = ((1.0 / f.x).abs().sqrt(), (1.0 / f.y).abs().sqrt());
    (fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0).then_some((fx, fy))
}

/// A view's board pose from its homography and the intrinsics `k`: `K^-1 H = s [r1 r2 t]`,
/// the rotation re-orthonormalised by SVD, the board in front of the camera.
pub(crate) fn pose_from_homography(k: &Matrix3<f64>, h: &Matrix3<f64>) -> Option<Pose> {
    let m = k.try_inverse()? * h;
    let n1 = m.column(0).norm();
    let n2 = m.column(1).norm();
    if !(n1 > 0.0 && n2 > 0.0) {
        return None;
    }
    let mut s = 2.0 / (n1 + n2);
    if m[(2, 2)] < 0.0 {
        s = -s;
    }
    let r1 = m.column(0) * s;
    let r2 = m.column(1) * s;
    let r3 = r1.cross(&r2);
    let t = m.column(2) * s;
    let r = nearest_rotation(&Matrix3::from_columns(&[r1, r2, r3]))?;
    let pose = Pose {
        r: Rotation3::from_matrix_unchecked(r),
        t: t.into_owned(),
    };
    (pose.t.iter().all(|v| v.is_finite()) && pose.t.z > 0.0).then_some(pose)
}

/// The rotation matrix nearest to `m` (Frobenius norm): `U V^T` of its SVD, with the last
/// column of `U` flipped if that would be a reflection.
pub(crate) fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut r = u * vt;
    if r.determinant() < 0.0 {
        let mut u2 = u;
        u2.column_mut(2).neg_mut();
        r = u2 * vt;
    }
    Some(r)
}

/// The fisheye's start: the focal length `f` of an equidistant lens (`r = f theta`, the
/// fisheye with `k = 0`) centred at `c`, and each view's board pose under it (or why none).
///
/// As `cv::fisheye::calibrate`, the principal point starts at the centre and each view's
/// pose comes from the homography of its corners undistorted by the current guess. The
/// guess is the best of a ladder of focal lengths (eighth-octave steps from a 360 degree to
/// a 3 degree field across the image's longer side, and `pinhole_focal`, Zhang's on the
/// raw corners, if given): best is the lowest median over the views of their RMS
/// reprojection error under it (infinite for a view without a pose; views posed under no
/// focal length of the ladder are left out). A view whose corners are 90 degrees or more
/// off the axis under the guess has no pose (its undistorted corners are at infinity).
pub(crate) fn fisheye_start(
    object: &[Vector3<f64>],
    views: &[&[Point2<f64>]],
    size: (u32, u32),
    c: (f64, f64),
    pinhole_focal: Option<f64>,
) -> (f64, Vec<Result<Pose, String>>) {
    let side = f64::from(size.0.max(size.1));
    let ladder = (-8..=48).map(|i| side / std::f64::consts::PI * 2f64.powf(i as f64 / 8.0));
    let focals: Vec<f64> = ladder
        .chain(pinhole_focal.filter(|f| f.is_finite() && *f > 0.0))
        .collect();
    // Per focal length, each view's RMS under it (infinite without a pose).
    let rms: Vec<Vec<f64>> = focals
        .iter()
        .map(|&f| {
            views
                .iter()
                .map(|v| match equidistant_pose(object, v, f, c) {
                    Ok(p) => equidistant_rms(object, v, &p, f, c),
                    Err(_) => f64::INFINITY,
                })
                .collect()
        })
        .collect();
    // Views posed under no focal length do not take part in the choice.
    let hopeful: Vec<usize> = (0..views.len())
        .filter(|&i| rms.iter().any(|r| r[i].is_finite()))
        .collect();
    let score = |r: &[f64]| {
        let mut s: Vec<f64> = hopeful.iter().map(|&i| r[i]).collect();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(f64::INFINITY)
    };
    let f = focals
        .iter()
        .zip(&rms)
        .map(|(&f, r)| (f, score(r)))
        .filter(|(_, s)| s.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(side / std::f64::consts::PI, |(f, _)| f);
    let poses = views
        .iter()
        .map(|v| equidistant_pose(object, v, f, c))
        .collect();
    (f, poses)
}

/// A view's board pose under an equidistant lens of focal length `f` centred at `c`: the
/// pose from the homography of its corners undistorted to the pinhole's normalised plane.
fn equidistant_pose(
    object: &[Vector3<f64>],
    corners: &[Point2<f64>],
    f: f64,
    c: (f64, f64),
) -> Result<Pose, String> {
    let lens = Distortion::fisheye([0.0; 4]).map_err(|e| e.to_string())?;
    let pinhole = corners
        .iter()
        .map(|p| {
            let d = Vector2::new((p.x - c.0) / f, (p.y - c.1) / f);
            lens.undistort(d).map(Point2::from)
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            format!(
                "a corner 90 degrees or more off the axis under the start's focal length {f:.1} px"
            )
        })?;
    let h = homography(object, &pinhole).map_err(|e| format!("no homography: {e}"))?;
    pose_from_homography(&Matrix3::identity(), &h)
        .ok_or_else(|| "no pose from the homography (the board behind the camera?)".into())
}

/// RMS pixel error of a view's corners against the board at `pose` seen through the
/// equidistant lens of focal length `f` centred at `c`; infinite if a corner is behind.
fn equidistant_rms(
    object: &[Vector3<f64>],
    corners: &[Point2<f64>],
    pose: &Pose,
    f: f64,
    c: (f64, f64),
) -> f64 {
    let Ok(lens) = Distortion::fisheye([0.0; 4]) else {
        return f64::INFINITY;
    };
    let mut sse = 0.0;
    for (x, p) in object.iter().zip(corners) {
        let xc = pose.r * x + pose.t;
        if xc.z.is_nan() || xc.z <= 1e-9 {
            return f64::INFINITY;
        }
        let n = lens.distort(Vector2::new(xc.x / xc.z, xc.y / xc.z));
        sse += (Vector2::new(f * n.x + c.0, f * n.y + c.1) - p.coords).norm_squared();
    }
    let rms = (sse / object.len().max(1) as f64).sqrt();
    if rms.is_nan() {
        f64::INFINITY
    } else {
        rms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_and_pose_of_an_exact_view() {
        let k = Matrix3::new(800.0, 0.0, 320.0, 0.0, 810.0, 240.0, 0.0, 0.0, 1.0);
        let pose = Pose {
            r: Rotation3::from_euler_angles(0.4, -0.2, 0.1),
            t: Vector3::new(-100.0, -60.0, 600.0),
        };
        let obj: Vec<_> = (0..6)
            .flat_map(|r| (0..9).map(move |c| Vector3::new(c as f64 * 25.0, r as f64 * 25.0, 0.0)))
            .collect();
        let img: Vec<_> = obj
            .iter()
            .map(|x| {
                let p = k * (pose.r * x + pose.t);
                Point2::new(p.x / p.z, p.y / p.z)
            })
            .collect();
        let h = homography(&obj, &img).unwrap();
        let back = pose_from_homography(&k, &h).unwrap();
        assert!((back.r.matrix() - pose.r.matrix()).amax() < 1e-9);
        assert!((back.t - pose.t).norm() < 1e-6);
        // Collinear corners: refused with a reason.
        let line: Vec<_> = obj.iter().map(|x| Point2::new(x.x, 2.0 * x.x)).collect();
        assert!(homography(&obj, &line).unwrap_err().contains("collinear"));
    }
}
