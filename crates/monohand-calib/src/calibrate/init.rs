//! Zhang's closed-form start: each view's homography (normalised DLT), the focal lengths
//! from the homographies with the principal point at the image centre (as OpenCV's
//! `initIntrinsicParams2D`), and each view's pose from `K^-1 H`.

use super::projection::Pose;
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
