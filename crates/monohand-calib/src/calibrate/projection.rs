//! OpenCV's projection of a board corner through a rig (board pose, camera pose, lens), with
//! its analytic Jacobians.
//!
//! Intrinsics are packed as `[fx, fy, cx, cy, c1, .., c8]`, the eight coefficients those of
//! the lens model ([`LensModel`]): for the pinhole `k1, k2, p1, p2, k3, k4, k5, k6`, for the
//! fisheye `k1, k2, k3, k4` and four slots held at zero. Poses are updated by a local
//! increment `(w, dt)`: `R <- exp(w) R`, `t <- t + dt`.

use monohand_core::camera::{Distortion, LensModel};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Rotation3, SMatrix, Vector2, Vector3};

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

/// Projects a camera-frame point through `lens` with the packed intrinsics `p`, with the
/// Jacobians. `None` for a point that is not in front of the camera (`z <= 1e-9`; a
/// fisheye's too: as `cv::fisheye::calibrate`, a board corner is less than 90 degrees off
/// the axis) or a non-finite result.
pub(crate) fn project(lens: LensModel, p: &Intr, x: &Vector3<f64>) -> Option<Projection> {
    if x.z.is_nan() || x.z <= 1e-9 {
        return None;
    }
    project_through(lens, p, x)
}

/// A lens's distortion from packed intrinsics: the fisheye's four coefficients, the
/// pinhole's eight.
fn distortion(lens: LensModel, p: &Intr) -> Distortion {
    let mut coeffs = [p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11]];
    if lens == LensModel::Fisheye {
        coeffs[4..].fill(0.0);
    }
    Distortion {
        model: lens,
        coeffs,
    }
}

/// [`project`] through `monohand_core`'s lens models, the ones the fit uses (OpenCV's
/// pinhole with radial-tangential and rational distortion, its fisheye): the normalised
/// point and its Jacobians from [`Distortion::project_with_jacobians`], then
/// `(fx n.x + cx, fy n.y + cy)` (no skew).
fn project_through(lens: LensModel, p: &Intr, x: &Vector3<f64>) -> Option<Projection> {
    let (n, jn, jk) = distortion(lens, p).project_with_jacobians(x)?;
    let (fx, fy) = (p[0], p[1]);
    let px = Vector2::new(fx * n.x + p[2], fy * n.y + p[3]);
    if !(px.x.is_finite() && px.y.is_finite()) {
        return None;
    }
    let f = Matrix2::new(fx, 0.0, 0.0, fy);
    let mut d_intr = SMatrix::<f64, 2, N_INTR>::zeros();
    d_intr[(0, 0)] = n.x;
    d_intr[(1, 1)] = n.y;
    d_intr[(0, 2)] = 1.0;
    d_intr[(1, 3)] = 1.0;
    // A fisheye's columns past its four coefficients are zero.
    d_intr.fixed_view_mut::<2, 8>(0, 4).copy_from(&(f * jk));
    Some(Projection {
        px,
        d_intr,
        d_point: f * jn,
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
/// frame and the camera at `rel` from the first camera: `X_cam = rel (board x)`, through
/// `lens`.
pub(crate) fn project_corner(
    lens: LensModel,
    p: &Intr,
    rel: &Pose,
    board: &Pose,
    x: &Vector3<f64>,
) -> Option<CornerProjection> {
    let xb = board.r * x;
    let y = xb + board.t;
    let ry = rel.r * y;
    let pr = project(lens, p, &(ry + rel.t))?;
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
    lens: LensModel,
    p: &Intr,
    rel: &Pose,
    board: &Pose,
    x: &Vector3<f64>,
) -> Option<Vector2<f64>> {
    let xc = rel.r * (board.r * x + board.t) + rel.t;
    if xc.z.is_nan() || xc.z <= 1e-9 {
        return None;
    }
    let d = distortion(lens, p).distort(Vector2::new(xc.x / xc.z, xc.y / xc.z));
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
    /// relative pose and of the board pose, through `lens` written out from its definition.
    fn project_generic<D: DualNum<Primitive = f64> + Copy>(
        lens: LensModel,
        p: &[D; N_INTR],
        (rel, board): (&Pose, &Pose),
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
        let (xd, yd) = match lens {
            LensModel::Pinhole => radtan_generic(p, xc),
            LensModel::Fisheye => fisheye_generic(p, xc),
        };
        [p[0] * xd + p[2], p[1] * yd + p[3]]
    }

    /// OpenCV's radial-tangential (rational) distortion of a camera-frame point.
    fn radtan_generic<D: DualNum<Primitive = f64> + Copy>(p: &[D; N_INTR], xc: [D; 3]) -> (D, D) {
        let (xn, yn) = (xc[0] / xc[2], xc[1] / xc[2]);
        let r2 = xn * xn + yn * yn;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let one = D::from(1.0);
        let two = D::from(2.0);
        let rad =
            (one + p[4] * r2 + p[5] * r4 + p[8] * r6) / (one + p[9] * r2 + p[10] * r4 + p[11] * r6);
        (
            xn * rad + two * p[6] * xn * yn + p[7] * (r2 + two * xn * xn),
            yn * rad + p[6] * (r2 + two * yn * yn) + two * p[7] * xn * yn,
        )
    }

    /// Kannala-Brandt: `theta_d = theta (1 + k1 theta^2 + .. + k4 theta^8)` along the ray's
    /// direction, `k` in slots 4-7.
    fn fisheye_generic<D: DualNum<Primitive = f64> + Copy>(p: &[D; N_INTR], xc: [D; 3]) -> (D, D) {
        let r = (xc[0] * xc[0] + xc[1] * xc[1]).sqrt();
        let theta = r.atan2(xc[2]);
        let t2 = theta * theta;
        let one = D::from(1.0);
        let theta_d = theta * (one + t2 * (p[4] + t2 * (p[5] + t2 * (p[6] + t2 * p[7]))));
        (xc[0] * theta_d / r, xc[1] * theta_d / r)
    }

    fn close(a: f64, n: f64, scale: f64) -> bool {
        (a - n).abs() <= 1e-6 * n.abs().max(1e-6 * scale)
    }

    /// The analytic Jacobians of `project_corner` against dual numbers at `x`: the 12
    /// intrinsics, the rotation and translation increments of both poses.
    fn check_against_duals(lens: LensModel, p: &Intr, rel: &Pose, board: &Pose, x: &Vector3<f64>) {
        let a = project_corner(lens, p, rel, board, x).unwrap();
        let b = corner_pixel(lens, p, rel, board, x).unwrap();
        assert!((a.px - b).norm() < 1e-9);
        let (v, j) = jacobian(
            |q: SVector<DualVec64<Const<12>>, 12>| {
                let q: [_; 12] = std::array::from_fn(|i| q[i]);
                let z = [DualVec64::from(0.0); 6];
                SVector::from(project_generic(lens, &q, (rel, board), &z, &z, x))
            },
            &SVector::from(*p),
        );
        assert!((a.px - v).norm() < 1e-9);
        let scale = j.amax();
        for (an, nu) in a.d_intr.iter().zip(j.iter()) {
            assert!(
                close(*an, *nu, scale),
                "{lens} intrinsics: {an} vs {nu}\n{}\n{j}",
                a.d_intr
            );
        }
        let (_, j) = jacobian(
            |d: SVector<DualVec64<Const<12>>, 12>| {
                let q = p.map(DualVec64::from);
                let dr: [_; 6] = std::array::from_fn(|i| d[i]);
                let db: [_; 6] = std::array::from_fn(|i| d[6 + i]);
                SVector::from(project_generic(lens, &q, (rel, board), &dr, &db, x))
            },
            &SVector::<f64, 12>::zeros(),
        );
        let scale = j.amax();
        for c in 0..6 {
            for r in 0..2 {
                assert!(
                    close(a.d_rel[(r, c)], j[(r, c)], scale),
                    "{lens} rel {r},{c}"
                );
                assert!(
                    close(a.d_board[(r, c)], j[(r, 6 + c)], scale),
                    "{lens} board {r},{c}"
                );
            }
        }
    }

    /// The analytic Jacobians against dual numbers, through both lens models: intrinsics,
    /// every distortion coefficient, the rotation and translation increments of both
    /// poses; the fisheye's corners up to 69 degrees off the axis.
    #[test]
    fn jacobians_match_dual_numbers() {
        let pinhole: Intr = [
            900.0, 905.0, 650.0, 350.0, -0.3, 0.12, 1e-3, -5e-4, -0.02, 0.05, -0.01, 0.003,
        ];
        let fisheye: Intr = [
            480.0, 482.0, 641.0, 358.0, 0.02, -0.005, 1e-3, -2e-4, 0.0, 0.0, 0.0, 0.0,
        ];
        let board = Pose {
            r: Rotation3::from_euler_angles(0.4, -0.3, 0.2),
            t: Vector3::new(-60.0, 40.0, 520.0),
        };
        // Far off the axis: the corners 64-69 degrees from it.
        let wide = Pose {
            r: Rotation3::from_euler_angles(0.3, -0.5, -0.1),
            t: Vector3::new(420.0, -180.0, 200.0),
        };
        let rel = Pose {
            r: Rotation3::from_euler_angles(0.02, 0.09, -0.04),
            t: Vector3::new(-60.0, 1.0, 2.0),
        };
        let corners = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(200.0, 125.0, 0.0),
            Vector3::new(75.0, 50.0, 0.0),
        ];
        for x in &corners {
            check_against_duals(LensModel::Pinhole, &pinhole, &rel, &board, x);
            for b in [&board, &wide] {
                check_against_duals(LensModel::Fisheye, &fisheye, &rel, b, x);
            }
        }
        let xc = rel.r * (wide.r * corners[1] + wide.t) + rel.t;
        let deg = xc.xy().norm().atan2(xc.z).to_degrees();
        assert!((63.0..65.0).contains(&deg), "{deg}");
    }

    #[test]
    fn points_behind_are_refused() {
        let p: Intr = [
            500.0, 500.0, 320.0, 240.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ];
        for lens in LensModel::ALL {
            assert!(project(lens, &p, &Vector3::new(0.0, 0.0, -1.0)).is_none());
            assert!(project(lens, &p, &Vector3::new(5.0, 1.0, -1.0)).is_none());
            assert!(project(lens, &p, &Vector3::new(5.0, 1.0, 0.0)).is_none());
            assert!(project(lens, &p, &Vector3::new(f64::NAN, 0.0, 1.0)).is_none());
            let id = Pose::identity();
            let behind = Vector3::new(1.0, 2.0, -3.0);
            assert!(corner_pixel(lens, &p, &id, &id, &behind).is_none());
            assert!(project_corner(lens, &p, &id, &id, &behind).is_none());
        }
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
