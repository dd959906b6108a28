//! OpenCV's projection of a board corner through a rig (board pose, camera pose, lens), with
//! its analytic Jacobians.
//!
//! Intrinsics are packed as `[fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6]`; poses are
//! updated by a local increment `(w, dt)`: `R <- exp(w) R`, `t <- t + dt`.

use nalgebra::{Matrix2x3, Matrix3, Rotation3, SMatrix, Vector2, Vector3};

/// Intrinsic parameters of one camera: focal lengths, principal point, 8 distortion coefficients.
pub(crate) const N_INTR: usize = 12;

/// One camera's packed intrinsics.
pub(crate) type Intr = [f64; N_INTR];

/// A rigid transform `X' = r X + t` (millimetres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pose {
    /// Rotation.
    pub r: Rotation3<f64>,
    /// Translation, mm.
    pub t: Vector3<f64>,
}

impl Pose {
    /// The identity.
    pub fn identity() -> Pose {
        Pose {
            r: Rotation3::identity(),
            t: Vector3::zeros(),
        }
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            r: self.r * other.r,
            t: self.r * other.t + self.t,
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Pose {
        let ri = self.r.inverse();
        Pose {
            r: ri,
            t: -(ri * self.t),
        }
    }

    /// The pose moved by the local increment `d = (w, dt)`: `R <- exp(w) R`, `t <- t + dt`.
    pub fn retract(&self, d: &[f64]) -> Pose {
        let w = Vector3::new(d[0], d[1], d[2]);
        let mut r = Rotation3::new(w) * self.r;
        r.renormalize();
        Pose {
            r,
            t: self.t + Vector3::new(d[3], d[4], d[5]),
        }
    }
}

/// The cross-product matrix `[v]x`.
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// A projected point and its derivatives with respect to the intrinsics and to the
/// camera-frame point.
pub(crate) struct Projection {
    /// Pixel.
    pub px: Vector2<f64>,
    /// d px / d intrinsics (all 12).
    pub d_intr: SMatrix<f64, 2, N_INTR>,
    /// d px / d camera-frame point.
    pub d_point: Matrix2x3<f64>,
}

/// Projects a camera-frame point with OpenCV's pinhole model (radial-tangential and
/// rational: `monohand_core::camera::LensModel::Pinhole`, as
/// `monohand_core::camera::Distortion::distort`), with the Jacobians. The only model this
/// crate calibrates: its intrinsics (`Intr`) have no lens model to be told another. `None` for a point
/// that is not in front of the camera or a non-finite result.
pub(crate) fn project(p: &Intr, x: &Vector3<f64>) -> Option<Projection> {
    if x.z.is_nan() || x.z <= 1e-9 {
        return None;
    }
    let [fx, fy, _cx, _cy, k1, k2, p1, p2, k3, k4, k5, k6] = *p;
    let iz = 1.0 / x.z;
    let (xn, yn) = (x.x * iz, x.y * iz);
    let r2 = xn * xn + yn * yn;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let a = 1.0 + k1 * r2 + k2 * r4 + k3 * r6;
    let b = 1.0 + k4 * r2 + k5 * r4 + k6 * r6;
    let ib = 1.0 / b;
    let rad = a * ib;
    let xd = xn * rad + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn);
    let yd = yn * rad + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn;
    let px = Vector2::new(fx * xd + p[2], fy * yd + p[3]);
    if !(px.x.is_finite() && px.y.is_finite()) {
        return None;
    }
    // d rad / d r2.
    let da = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r4;
    let db = k4 + 2.0 * k5 * r2 + 3.0 * k6 * r4;
    let drad = (da * b - a * db) * ib * ib;
    // d (xd, yd) / d (xn, yn).
    let dxx = rad + 2.0 * xn * xn * drad + 2.0 * p1 * yn + 6.0 * p2 * xn;
    let dxy = 2.0 * xn * yn * drad + 2.0 * p1 * xn + 2.0 * p2 * yn;
    let dyx = dxy;
    let dyy = rad + 2.0 * yn * yn * drad + 6.0 * p1 * yn + 2.0 * p2 * xn;
    // d (xn, yn) / d X.
    let dn = Matrix2x3::new(iz, 0.0, -xn * iz, 0.0, iz, -yn * iz);
    let dd = nalgebra::Matrix2::new(fx * dxx, fx * dxy, fy * dyx, fy * dyy);
    let d_point = dd * dn;
    // d (xd, yd) / d distortion coefficients.
    let rb = a * ib * ib;
    let ddist: [(f64, f64); 8] = [
        (xn * r2 * ib, yn * r2 * ib),
        (xn * r4 * ib, yn * r4 * ib),
        (2.0 * xn * yn, r2 + 2.0 * yn * yn),
        (r2 + 2.0 * xn * xn, 2.0 * xn * yn),
        (xn * r6 * ib, yn * r6 * ib),
        (-xn * r2 * rb, -yn * r2 * rb),
        (-xn * r4 * rb, -yn * r4 * rb),
        (-xn * r6 * rb, -yn * r6 * rb),
    ];
    let mut d_intr = SMatrix::<f64, 2, N_INTR>::zeros();
    d_intr[(0, 0)] = xd;
    d_intr[(1, 1)] = yd;
    d_intr[(0, 2)] = 1.0;
    d_intr[(1, 3)] = 1.0;
    for (j, (ddx, ddy)) in ddist.iter().enumerate() {
        d_intr[(0, 4 + j)] = fx * ddx;
        d_intr[(1, 4 + j)] = fy * ddy;
    }
    Some(Projection {
        px,
        d_intr,
        d_point,
    })
}

/// A board corner seen by a camera of a rig, with its Jacobians.
pub(crate) struct CornerProjection {
    /// Pixel.
    pub px: Vector2<f64>,
    /// d px / d the camera's intrinsics.
    pub d_intr: SMatrix<f64, 2, N_INTR>,
    /// d px / d the increment of the camera's pose relative to the first camera.
    pub d_rel: SMatrix<f64, 2, 6>,
    /// d px / d the increment of the board's pose in the first camera.
    pub d_board: SMatrix<f64, 2, 6>,
}

/// Projects board point `x` (board frame) with the board at `board` in the first camera's
/// frame and the camera at `rel` from the first camera: `X_cam = rel (board x)`.
pub(crate) fn project_corner(
    p: &Intr,
    rel: &Pose,
    board: &Pose,
    x: &Vector3<f64>,
) -> Option<CornerProjection> {
    let xb = board.r * x;
    let y = xb + board.t;
    let ry = rel.r * y;
    let pr = project(p, &(ry + rel.t))?;
    let rm = rel.r.matrix();
    let jp = pr.d_point;
    let mut d_rel = SMatrix::<f64, 2, 6>::zeros();
    d_rel
        .fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(jp * -skew(&ry)));
    d_rel.fixed_view_mut::<2, 3>(0, 3).copy_from(&jp);
    let jpr = jp * rm;
    let mut d_board = SMatrix::<f64, 2, 6>::zeros();
    d_board
        .fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(jpr * -skew(&xb)));
    d_board.fixed_view_mut::<2, 3>(0, 3).copy_from(&jpr);
    Some(CornerProjection {
        px: pr.px,
        d_intr: pr.d_intr,
        d_rel,
        d_board,
    })
}

/// Just the pixel of [`project_corner`], without the Jacobians.
pub(crate) fn corner_pixel(
    p: &Intr,
    rel: &Pose,
    board: &Pose,
    x: &Vector3<f64>,
) -> Option<Vector2<f64>> {
    let xc = rel.r * (board.r * x + board.t) + rel.t;
    if xc.z.is_nan() || xc.z <= 1e-9 {
        return None;
    }
    let d = monohand_core::camera::Distortion {
        model: monohand_core::camera::LensModel::Pinhole,
        coeffs: [p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11]],
    }
    .distort(Vector2::new(xc.x / xc.z, xc.y / xc.z));
    let px = Vector2::new(p[0] * d.x + p[2], p[1] * d.y + p[3]);
    (px.x.is_finite() && px.y.is_finite()).then_some(px)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Const, SVector};
    use num_dual::{jacobian, DualNum, DualVec64};

    /// OpenCV's projection over dual numbers: intrinsics, then a rotation-vector increment
    /// (first order, exact for derivatives at zero) and a translation increment of the
    /// relative pose and of the board pose.
    fn project_generic<D: DualNum<Primitive = f64> + Copy>(
        p: &[D; N_INTR],
        rel: &Pose,
        board: &Pose,
        d_rel: &[D; 6],
        d_board: &[D; 6],
        x: &Vector3<f64>,
    ) -> [D; 2] {
        let mat = |r: &Rotation3<f64>, v: [D; 3]| -> [D; 3] {
            let m = r.matrix();
            std::array::from_fn(|i| v[0] * m[(i, 0)] + v[1] * m[(i, 1)] + v[2] * m[(i, 2)])
        };
        let inc = |w: &[D; 6], q: [D; 3]| -> [D; 3] {
            let cr = [
                w[1] * q[2] - w[2] * q[1],
                w[2] * q[0] - w[0] * q[2],
                w[0] * q[1] - w[1] * q[0],
            ];
            std::array::from_fn(|i| q[i] + cr[i])
        };
        let xv = [D::from(x.x), D::from(x.y), D::from(x.z)];
        let xb = inc(d_board, mat(&board.r, xv));
        let y: [D; 3] = std::array::from_fn(|i| xb[i] + D::from(board.t[i]) + d_board[3 + i]);
        let ry = inc(d_rel, mat(&rel.r, y));
        let xc: [D; 3] = std::array::from_fn(|i| ry[i] + D::from(rel.t[i]) + d_rel[3 + i]);
        let (xn, yn) = (xc[0] / xc[2], xc[1] / xc[2]);
        let r2 = xn * xn + yn * yn;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let one = D::from(1.0);
        let two = D::from(2.0);
        let rad =
            (one + p[4] * r2 + p[5] * r4 + p[8] * r6) / (one + p[9] * r2 + p[10] * r4 + p[11] * r6);
        let xd = xn * rad + two * p[6] * xn * yn + p[7] * (r2 + two * xn * xn);
        let yd = yn * rad + p[6] * (r2 + two * yn * yn) + two * p[7] * xn * yn;
        [p[0] * xd + p[2], p[1] * yd + p[3]]
    }

    fn close(a: f64, n: f64, scale: f64) -> bool {
        (a - n).abs() <= 1e-6 * n.abs().max(1e-6 * scale)
    }

    /// The analytic Jacobians against dual numbers: intrinsics, all 8 distortion
    /// coefficients, the rotation and translation increments of both poses.
    #[test]
    fn jacobians_match_dual_numbers() {
        let p: Intr = [
            900.0, 905.0, 650.0, 350.0, -0.3, 0.12, 1e-3, -5e-4, -0.02, 0.05, -0.01, 0.003,
        ];
        let board = Pose {
            r: Rotation3::from_euler_angles(0.4, -0.3, 0.2),
            t: Vector3::new(-60.0, 40.0, 520.0),
        };
        let rel = Pose {
            r: Rotation3::from_euler_angles(0.02, 0.09, -0.04),
            t: Vector3::new(-60.0, 1.0, 2.0),
        };
        for x in [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(200.0, 125.0, 0.0),
            Vector3::new(75.0, 50.0, 0.0),
        ] {
            let a = project_corner(&p, &rel, &board, &x).unwrap();
            let b = corner_pixel(&p, &rel, &board, &x).unwrap();
            assert!((a.px - b).norm() < 1e-9);
            // Intrinsics.
            let (v, j) = jacobian(
                |q: SVector<DualVec64<Const<12>>, 12>| {
                    let q: [_; 12] = std::array::from_fn(|i| q[i]);
                    let z = [DualVec64::from(0.0); 6];
                    SVector::from(project_generic(&q, &rel, &board, &z, &z, &x))
                },
                &SVector::from(p),
            );
            assert!((a.px - v).norm() < 1e-9);
            let scale = j.amax();
            for (an, nu) in a.d_intr.iter().zip(j.iter()) {
                assert!(
                    close(*an, *nu, scale),
                    "intrinsics: {an} vs {nu}\n{}\n{j}",
                    a.d_intr
                );
            }
            // The two poses' increments.
            let (_, j) = jacobian(
                |d: SVector<DualVec64<Const<12>>, 12>| {
                    let q = p.map(DualVec64::from);
                    let dr: [_; 6] = std::array::from_fn(|i| d[i]);
                    let db: [_; 6] = std::array::from_fn(|i| d[6 + i]);
                    SVector::from(project_generic(&q, &rel, &board, &dr, &db, &x))
                },
                &SVector::<f64, 12>::zeros(),
            );
            let scale = j.amax();
            for c in 0..6 {
                for r in 0..2 {
                    assert!(close(a.d_rel[(r, c)], j[(r, c)], scale), "rel {r},{c}");
                    assert!(
                        close(a.d_board[(r, c)], j[(r, 6 + c)], scale),
                        "board {r},{c}"
                    );
                }
            }
        }
    }

    #[test]
    fn points_behind_are_refused() {
        let p: Intr = [
            500.0, 500.0, 320.0, 240.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ];
        assert!(project(&p, &Vector3::new(0.0, 0.0, -1.0)).is_none());
        assert!(project(&p, &Vector3::new(f64::NAN, 0.0, 1.0)).is_none());
    }

    #[test]
    fn retract_composes() {
        let a = Pose {
            r: Rotation3::from_euler_angles(0.1, 0.2, 0.3),
            t: Vector3::new(1.0, 2.0, 3.0),
        };
        let id = a.compose(&a.inverse());
        assert!((id.r.matrix() - Matrix3::identity()).amax() < 1e-12 && id.t.norm() < 1e-12);
        let b = a.retract(&[0.0; 6]);
        assert!((b.r.matrix() - a.r.matrix()).amax() < 1e-12);
    }
}
