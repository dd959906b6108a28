//! Lens models as data: how a direction in the camera's frame becomes a normalised image
//! point (`(u - cx) / fx`, `(v - cy) / fy`), the way back, and the Jacobian of the way
//! there.
//!
//! - [`LensModel::Pinhole`]: perspective projection `(x/z, y/z)` with OpenCV's
//!   radial-tangential distortion (`k1 k2 p1 p2 k3`, rational when `k4 k5 k6` are set);
//!   a point must be in front of the camera (`z > 0`).
//! - [`LensModel::Fisheye`]: OpenCV's fisheye (`cv::fisheye`, Kannala-Brandt): the angle
//!   `theta` between the ray and the optical axis becomes the radius
//!   `theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)`, in the
//!   ray's direction around the axis. `theta = atan2(|(x, y)|, z)`, so a fisheye also
//!   images rays 90 degrees or more off its axis (`z <= 0`).

use crate::error::{CoreError, CoreResult};
use nalgebra::{Matrix2, Matrix2x3, SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// The lens model of a camera ([`Distortion::model`]): which projection its coefficients
/// distort.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LensModel {
    /// Perspective projection with OpenCV's radial-tangential distortion (`k1 k2 p1 p2
    /// [k3 [k4 k5 k6]]`; the rational model when `k4 k5 k6` are set): `cv::projectPoints`.
    #[default]
    Pinhole,
    /// OpenCV's fisheye model (Kannala-Brandt, `cv::fisheye::projectPoints`): `k1 k2 k3
    /// k4` of the angle from the optical axis; the other four coefficients are zero.
    Fisheye,
}

impl LensModel {
    /// Every model, in the order their names are listed in messages.
    pub const ALL: [LensModel; 2] = [LensModel::Pinhole, LensModel::Fisheye];

    /// The model's name in files and messages: `pinhole`, `fisheye`.
    pub fn name(self) -> &'static str {
        match self {
            LensModel::Pinhole => "pinhole",
            LensModel::Fisheye => "fisheye",
        }
    }

    /// The model of a name ([`LensModel::name`]); `None` for any other name.
    pub fn from_name(name: &str) -> Option<LensModel> {
        LensModel::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl std::fmt::Display for LensModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A camera's lens: its model and coefficients, in OpenCV's order. Zero coefficients of
/// the pinhole model are the ideal pinhole; a fisheye with zero coefficients is still a
/// fisheye (the equidistant projection `r = theta`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Distortion {
    /// Which projection the coefficients distort.
    #[serde(default)]
    pub model: LensModel,
    /// [`LensModel::Pinhole`]: `k1, k2, p1, p2, k3, k4, k5, k6`.
    /// [`LensModel::Fisheye`]: `k1, k2, k3, k4`, then four zeros.
    pub coeffs: [f64; 8],
}

impl Distortion {
    /// A pinhole's distortion from an OpenCV coefficient list of length 0, 4, 5 or 8.
    pub fn from_slice(c: &[f64]) -> CoreResult<Distortion> {
        Distortion::new(LensModel::Pinhole, c)
    }

    /// A lens of `model` from its coefficients as OpenCV lists them: 0, 4, 5 or 8 for the
    /// pinhole (`k1 k2 p1 p2 [k3 [k4 k5 k6]]`), 0 or 4 for the fisheye (`k1 k2 k3 k4`).
    pub fn new(model: LensModel, c: &[f64]) -> CoreResult<Distortion> {
        let lengths: &[usize] = match model {
            LensModel::Pinhole => &[0, 4, 5, 8],
            LensModel::Fisheye => &[0, 4],
        };
        if !lengths.contains(&c.len()) {
            let what = match model {
                LensModel::Pinhole => {
                    "the pinhole model needs 0, 4, 5 or 8 distortion \
                                       coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]])"
                }
                LensModel::Fisheye => {
                    "the fisheye model needs 4 distortion coefficients \
                                       (k1 k2 k3 k4)"
                }
            };
            return Err(CoreError::InvalidCamera(format!("{what}, got {}", c.len())));
        }
        if c.iter().any(|v| !v.is_finite()) {
            return Err(CoreError::InvalidCamera(
                "distortion coefficient is not finite".into(),
            ));
        }
        let mut coeffs = [0.0; 8];
        coeffs[..c.len()].copy_from_slice(c);
        Ok(Distortion { model, coeffs })
    }

    /// OpenCV's fisheye with coefficients `k1 k2 k3 k4`.
    pub fn fisheye(k: [f64; 4]) -> CoreResult<Distortion> {
        Distortion::new(LensModel::Fisheye, &k)
    }

    /// True if all coefficients are zero (for a fisheye this is still a fisheye).
    pub fn is_zero(&self) -> bool {
        self.coeffs.iter().all(|&c| c == 0.0)
    }

    /// True for the ideal pinhole: the pinhole model without distortion, where a pixel is
    /// `f x / z + c`.
    pub fn is_ideal(&self) -> bool {
        self.model == LensModel::Pinhole && self.is_zero()
    }

    /// The coefficients as a file lists them, shortest first: for the pinhole none, 4, 5
    /// or 8 (as many as are needed for the non-zero ones), for the fisheye always 4.
    pub fn listed(&self) -> &[f64] {
        let c = &self.coeffs;
        let n = match self.model {
            LensModel::Fisheye => 4,
            LensModel::Pinhole if c[5..].iter().any(|&v| v != 0.0) => 8,
            LensModel::Pinhole if c[4] != 0.0 => 5,
            LensModel::Pinhole if self.is_zero() => 0,
            LensModel::Pinhole => 4,
        };
        &c[..n]
    }

    /// Why these numbers are no lens, if they are not: a coefficient that is not finite,
    /// or a fisheye with coefficients past its four.
    pub fn check(&self) -> CoreResult<()> {
        if self.coeffs.iter().any(|c| !c.is_finite()) {
            return Err(CoreError::InvalidCamera(
                "distortion coefficient is not finite".into(),
            ));
        }
        if self.model == LensModel::Fisheye && self.coeffs[4..].iter().any(|&c| c != 0.0) {
            return Err(CoreError::InvalidCamera(format!(
                "the fisheye model has 4 coefficients (k1 k2 k3 k4), but coefficients 5-8 are \
                 {:?}",
                &self.coeffs[4..]
            )));
        }
        Ok(())
    }

    /// The fisheye's `k1 k2 k3 k4`.
    #[inline]
    fn k4(&self) -> [f64; 4] {
        [
            self.coeffs[0],
            self.coeffs[1],
            self.coeffs[2],
            self.coeffs[3],
        ]
    }

    /// Applies the lens to normalised pinhole coordinates `(x/z, y/z)` of a point in front
    /// of the camera.
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        match self.model {
            LensModel::Pinhole => self.radtan(p),
            LensModel::Fisheye => {
                let r = p.norm();
                if r == 0.0 {
                    return p;
                }
                p * (fisheye_theta_d(&self.k4(), r.atan()) / r)
            }
        }
    }

    /// OpenCV's radial-tangential distortion of normalised coordinates.
    fn radtan(&self, p: Vector2<f64>) -> Vector2<f64> {
        let [k1, k2, p1, p2, k3, k4, k5, k6] = self.coeffs;
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (1.0 + k4 * r2 + k5 * r4 + k6 * r6);
        Vector2::new(
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// Inverts [`Distortion::distort`]: the normalised pinhole coordinates of a distorted
    /// normalised point. The pinhole model by fixed-point iteration (as
    /// `cv::undistortPoints`), the fisheye by Newton on the angle (as
    /// `cv::fisheye::undistortPoints`). `None` where a fisheye's point has no pinhole
    /// point: 90 degrees or more off the axis, or past the largest radius the lens
    /// reaches.
    pub fn undistort(&self, d: Vector2<f64>) -> Option<Vector2<f64>> {
        match self.model {
            LensModel::Pinhole => Some(self.undistort_radtan(d)),
            LensModel::Fisheye => {
                let theta_d = d.norm();
                if theta_d == 0.0 {
                    return Some(d);
                }
                let theta = fisheye_angle(&self.k4(), theta_d)?;
                (theta < FRAC_PI_2 - 1e-9).then(|| d * (theta.tan() / theta_d))
            }
        }
    }

    fn undistort_radtan(&self, d: Vector2<f64>) -> Vector2<f64> {
        if self.is_zero() {
            return d;
        }
        let mut p = d;
        for _ in 0..20 {
            let err = self.radtan(p) - d;
            p -= err;
            if err.norm_squared() < 1e-24 {
                break;
            }
        }
        p
    }

    /// The unit ray in the camera's frame of a distorted normalised point; `None` where a
    /// fisheye's lens does not reach.
    pub fn ray(&self, d: Vector2<f64>) -> Option<Vector3<f64>> {
        match self.model {
            LensModel::Pinhole => {
                let n = self.undistort_radtan(d);
                Some(Vector3::new(n.x, n.y, 1.0).normalize())
            }
            LensModel::Fisheye => {
                let theta_d = d.norm();
                if theta_d == 0.0 {
                    return Some(Vector3::z());
                }
                let theta = fisheye_angle(&self.k4(), theta_d)?;
                let s = theta.sin() / theta_d;
                Some(Vector3::new(d.x * s, d.y * s, theta.cos()))
            }
        }
    }

    /// A fisheye's angle from the axis (radians) of the rays at distorted normalised
    /// radius `theta_d`: `None` for the pinhole model, or past the largest radius the
    /// lens reaches.
    pub fn fisheye_angle(&self, theta_d: f64) -> Option<f64> {
        match self.model {
            LensModel::Pinhole => None,
            LensModel::Fisheye => fisheye_angle(&self.k4(), theta_d),
        }
    }

    /// A fisheye's largest angle from the axis (radians) up to which its radius grows
    /// with the angle (at most pi); past it the model folds back. `None` for the pinhole.
    pub fn fisheye_fold_angle(&self) -> Option<f64> {
        (self.model == LensModel::Fisheye).then(|| fisheye_fold_angle(&self.k4()))
    }

    /// The normalised image point of a camera-frame point and its 2x3 Jacobian. `None`
    /// for a pinhole's point not in front of the camera (`z <= 1e-9`), a point on a
    /// fisheye's axis behind it, or a non-finite result. A fisheye's points 90 degrees or
    /// more off its axis are projected: whether the camera sees them is the camera's
    /// question (its field, `Camera::project_with_jacobian`).
    pub fn project_with_jacobian(
        &self,
        x: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let out = match self.model {
            LensModel::Pinhole => self.radtan_with_jacobian(x)?,
            LensModel::Fisheye => fisheye_with_jacobian(&self.k4(), x)?,
        };
        (out.0.iter().chain(out.1.iter()).all(|v| v.is_finite())).then_some(out)
    }

    /// [`Distortion::project_with_jacobian`] with, third, the Jacobian of the normalised
    /// point with respect to the eight coefficients ([`Distortion::coeffs`]' order): what
    /// a calibration linearises. A fisheye's columns 5-8 are zero (its model has no such
    /// coefficients). `None` where [`Distortion::project_with_jacobian`] is.
    pub fn project_with_jacobians(
        &self,
        x: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>, SMatrix<f64, 2, 8>)> {
        let (n, j) = self.project_with_jacobian(x)?;
        let mut dk = SMatrix::<f64, 2, 8>::zeros();
        match self.model {
            LensModel::Pinhole => {
                // n = (x rad + tangential, y rad + tangential), rad = a / b.
                let [k1, k2, _, _, k3, k4, k5, k6] = self.coeffs;
                let (xn, yn) = (x.x / x.z, x.y / x.z);
                let r2 = xn * xn + yn * yn;
                let (r4, r6) = (r2 * r2, r2 * r2 * r2);
                let a = 1.0 + k1 * r2 + k2 * r4 + k3 * r6;
                let ib = 1.0 / (1.0 + k4 * r2 + k5 * r4 + k6 * r6);
                let rb = a * ib * ib;
                let cols = [
                    (xn * r2 * ib, yn * r2 * ib),
                    (xn * r4 * ib, yn * r4 * ib),
                    (2.0 * xn * yn, r2 + 2.0 * yn * yn),
                    (r2 + 2.0 * xn * xn, 2.0 * xn * yn),
                    (xn * r6 * ib, yn * r6 * ib),
                    (-xn * r2 * rb, -yn * r2 * rb),
                    (-xn * r4 * rb, -yn * r4 * rb),
                    (-xn * r6 * rb, -yn * r6 * rb),
                ];
                for (c, (dx, dy)) in cols.into_iter().enumerate() {
                    dk[(0, c)] = dx;
                    dk[(1, c)] = dy;
                }
            }
            LensModel::Fisheye => {
                // n = (x, y) theta_d / r, d theta_d / d k_i = theta^(2i + 3): the column is
                // (x, y) h theta^(2i + 2) with h = theta / r (1 / z on the axis).
                let r = x.x.hypot(x.y);
                let theta = r.atan2(x.z);
                let h = if r > 0.0 { theta / r } else { 1.0 / x.z };
                let t2 = theta * theta;
                let mut p = h * t2;
                for c in 0..4 {
                    dk[(0, c)] = x.x * p;
                    dk[(1, c)] = x.y * p;
                    p *= t2;
                }
            }
        }
        dk.iter().all(|v| v.is_finite()).then_some((n, j, dk))
    }

    /// The pinhole projection through the radial-tangential distortion, with its Jacobian.
    fn radtan_with_jacobian(&self, x: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        if x.z.is_nan() || x.z <= 1e-9 {
            return None;
        }
        let [k1, k2, p1, p2, k3, k4, k5, k6] = self.coeffs;
        let iz = 1.0 / x.z;
        let (xn, yn) = (x.x * iz, x.y * iz);
        let r2 = xn * xn + yn * yn;
        let r4 = r2 * r2;
        let a = 1.0 + k1 * r2 + k2 * r4 + k3 * r4 * r2;
        let b = 1.0 + k4 * r2 + k5 * r4 + k6 * r4 * r2;
        let rad = a / b;
        // d rad / d r2.
        let da = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r4;
        let db = k4 + 2.0 * k5 * r2 + 3.0 * k6 * r4;
        let drad = (da * b - a * db) / (b * b);
        let d = Vector2::new(
            xn * rad + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn),
            yn * rad + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn,
        );
        let dxy = 2.0 * xn * yn * drad + 2.0 * p1 * xn + 2.0 * p2 * yn;
        let dd = Matrix2::new(
            rad + 2.0 * xn * xn * drad + 2.0 * p1 * yn + 6.0 * p2 * xn,
            dxy,
            dxy,
            rad + 2.0 * yn * yn * drad + 6.0 * p1 * yn + 2.0 * p2 * xn,
        );
        let dn = Matrix2x3::new(iz, 0.0, -xn * iz, 0.0, iz, -yn * iz);
        Some((d, dd * dn))
    }
}

/// `theta_d(theta) = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)`.
#[inline]
fn fisheye_theta_d(k: &[f64; 4], t: f64) -> f64 {
    let t2 = t * t;
    t * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
}

/// `d theta_d / d theta = 1 + 3 k1 theta^2 + 5 k2 theta^4 + 7 k3 theta^6 + 9 k4 theta^8`.
#[inline]
fn fisheye_slope(k: &[f64; 4], t: f64) -> f64 {
    let t2 = t * t;
    1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
}

/// The first angle in (0, pi] where the fisheye's radius stops growing, or pi.
fn fisheye_fold_angle(k: &[f64; 4]) -> f64 {
    const STEPS: usize = 512;
    let at = |i: usize| PI * i as f64 / STEPS as f64;
    let Some(i) = (1..=STEPS).find(|&i| fisheye_slope(k, at(i)) <= 0.0) else {
        return PI;
    };
    // The slope is positive at at(i - 1) and not at at(i): bisect.
    let (mut lo, mut hi) = (at(i - 1), at(i));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if fisheye_slope(k, mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The angle whose radius is `theta_d` on the rising part of the fisheye's curve:
/// Newton from `theta_d` (as `cv::fisheye::undistortPoints`), kept inside a bracket that
/// bisection shrinks whenever a Newton step would leave it. `None` for a negative or
/// non-finite radius, or one past the largest radius the lens reaches.
fn fisheye_angle(k: &[f64; 4], theta_d: f64) -> Option<f64> {
    if !(theta_d.is_finite() && theta_d >= 0.0) {
        return None;
    }
    let (mut lo, mut hi) = (0.0, fisheye_fold_angle(k));
    if fisheye_theta_d(k, hi) < theta_d {
        return None;
    }
    let mut t = theta_d.clamp(lo, hi);
    for _ in 0..100 {
        let f = fisheye_theta_d(k, t) - theta_d;
        if f == 0.0 {
            return Some(t);
        }
        if f > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let step = f / fisheye_slope(k, t);
        let next = t - step;
        t = if next > lo && next < hi && step.is_finite() {
            next
        } else {
            0.5 * (lo + hi)
        };
        if step.abs() <= 1e-15 * t.max(1.0) || hi - lo <= 1e-15 * hi.max(1.0) {
            return Some(t);
        }
    }
    Some(t)
}

/// The fisheye's normalised image point of a camera-frame point, with its Jacobian
/// (`n = s (x, y)`, `s = theta_d(theta) / r`, `r = |(x, y)|`, `theta = atan2(r, z)`).
fn fisheye_with_jacobian(k: &[f64; 4], x: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
    let (px, py, z) = (x.x, x.y, x.z);
    let r2 = px * px + py * py;
    let r = r2.sqrt();
    let rho2 = r2 + z * z;
    if rho2.is_nan() || rho2 == 0.0 || (r == 0.0 && z <= 0.0) {
        return None;
    }
    let theta = r.atan2(z);
    let t2 = theta * theta;
    // g = theta_d / theta and g' / theta, polynomials in theta^2.
    let g = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
    let g1 = 2.0 * k[0] + t2 * (4.0 * k[1] + t2 * (6.0 * k[2] + t2 * 8.0 * k[3]));
    // h = theta / r, and (d h / d r) / r = (z / rho^2 - h) / r^2.
    let (h, dh) = if z > 0.0 && r < 1e-2 * z {
        // Near the axis the difference cancels: its series in t = r / z.
        let t = r / z;
        let tt = t * t;
        let q = -2.0 / 3.0 + tt * (4.0 / 5.0 + tt * (-6.0 / 7.0 + tt * (8.0 / 9.0)));
        let h = if r > 0.0 { theta / r } else { 1.0 / z };
        (h, q / (z * z * z))
    } else {
        let h = theta / r;
        (h, (z / rho2 - h) / r2)
    };
    let s = g * h;
    // (d s / d r) / r and d s / d z.
    let a = g1 * h * h * z / rho2 + g * dh;
    let sz = -(g + t2 * g1) / rho2;
    let n = Vector2::new(s * px, s * py);
    let j = Matrix2x3::new(
        s + px * px * a,
        px * py * a,
        px * sz,
        px * py * a,
        s + py * py * a,
        py * sz,
    );
    Some((n, j))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Const, SVector};
    use num_dual::{jacobian, DualNum, DualVec64};

    type D3 = DualVec64<Const<3>>;

    /// The fisheye over dual numbers, straight from its definition.
    fn fisheye_generic<D: DualNum<Primitive = f64> + Copy>(k: &[f64; 4], x: [D; 3]) -> [D; 2] {
        let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let theta = r.atan2(x[2]);
        let t2 = theta * theta;
        let theta_d = theta
            * (D::one()
                + t2 * (D::from(k[0])
                    + t2 * (D::from(k[1]) + t2 * (D::from(k[2]) + t2 * D::from(k[3])))));
        [x[0] * theta_d / r, x[1] * theta_d / r]
    }

    /// OpenCV's radial-tangential projection over dual numbers.
    fn radtan_generic<D: DualNum<Primitive = f64> + Copy>(c: &[f64; 8], x: [D; 3]) -> [D; 2] {
        let [k1, k2, p1, p2, k3, k4, k5, k6] = c.map(D::from);
        let (u, v) = (x[0] / x[2], x[1] / x[2]);
        let r2 = u * u + v * v;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let two = D::from(2.0);
        let rad =
            (D::one() + k1 * r2 + k2 * r4 + k3 * r6) / (D::one() + k4 * r2 + k5 * r4 + k6 * r6);
        [
            u * rad + two * p1 * u * v + p2 * (r2 + two * u * u),
            v * rad + p1 * (r2 + two * v * v) + two * p2 * u * v,
        ]
    }

    type D8 = DualVec64<Const<8>>;

    /// The fisheye over dual numbers with dual coefficients, from its definition.
    fn fisheye_dual_coeffs(k: &[D8; 4], x: [D8; 3]) -> [D8; 2] {
        let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let theta = r.atan2(x[2]);
        let t2 = theta * theta;
        let theta_d = theta * (D8::from(1.0) + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
        [x[0] * theta_d / r, x[1] * theta_d / r]
    }

    /// OpenCV's radial-tangential projection with dual coefficients.
    fn radtan_dual_coeffs(c: &[D8; 8], x: [D8; 3]) -> [D8; 2] {
        let [k1, k2, p1, p2, k3, k4, k5, k6] = *c;
        let (u, v) = (x[0] / x[2], x[1] / x[2]);
        let r2 = u * u + v * v;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let two = D8::from(2.0);
        let rad = (D8::from(1.0) + k1 * r2 + k2 * r4 + k3 * r6)
            / (D8::from(1.0) + k4 * r2 + k5 * r4 + k6 * r6);
        [
            u * rad + two * p1 * u * v + p2 * (r2 + two * u * u),
            v * rad + p1 * (r2 + two * v * v) + two * p2 * u * v,
        ]
    }

    /// The largest difference between the analytic Jacobian and num-dual's, over points.
    fn worst_jacobian_error(
        d: &Distortion,
        points: &[Vector3<f64>],
        generic: impl Fn([D3; 3]) -> [D3; 2],
    ) -> f64 {
        let mut worst: f64 = 0.0;
        for p in points {
            let (n, j) = d.project_with_jacobian(p).unwrap();
            let (val, jd) = jacobian(
                |v: SVector<D3, 3>| SVector::from(generic([v[0], v[1], v[2]])),
                &SVector::<f64, 3>::from([p.x, p.y, p.z]),
            );
            assert!((Vector2::new(val[0], val[1]) - n).norm() < 1e-12, "{p:?}");
            // Relative to the Jacobian's size, which falls as 1/|x|.
            let err = (jd - j).amax() / jd.amax();
            worst = worst.max(err);
        }
        worst
    }

    #[test]
    fn the_fisheye_jacobian_matches_dual_numbers_at_every_angle() {
        let d = Distortion::fisheye([0.02, -0.005, 0.001, -0.0002]).unwrap();
        let points = [
            Vector3::new(100.0, -50.0, 400.0),
            Vector3::new(300.0, 200.0, 100.0),
            Vector3::new(400.0, 10.0, 0.0),
            Vector3::new(400.0, -80.0, -50.0),
            Vector3::new(-250.0, 90.0, -300.0),
            // Near the axis, where the series takes over (r / z under 1e-2) and just past.
            Vector3::new(1e-7, -2e-7, 300.0),
            Vector3::new(2.0, 1.0, 300.0),
            Vector3::new(3.0, 1.5, 300.0),
        ];
        let err = worst_jacobian_error(&d, &points, |x| fisheye_generic(&d.k4(), x));
        println!("fisheye: Jacobian within {err:.1e} of num-dual's (relative)");
        assert!(err < 1e-12, "fisheye: {err:e}");
        // On the axis itself: the limit, d n / d (x, y) = 1 / z, d n / d z = 0.
        let (n, j) = d
            .project_with_jacobian(&Vector3::new(0.0, 0.0, 250.0))
            .unwrap();
        assert_eq!(n, Vector2::zeros());
        let want = Matrix2x3::new(1.0 / 250.0, 0.0, 0.0, 0.0, 1.0 / 250.0, 0.0);
        assert!((j - want).amax() < 1e-18, "{j}");
        assert!(d
            .project_with_jacobian(&Vector3::new(0.0, 0.0, -5.0))
            .is_none());
    }

    /// The coefficient Jacobian of [`Distortion::project_with_jacobians`] against num-dual,
    /// differentiating `generic(coeffs, x)` with respect to the eight coefficients.
    fn worst_coefficient_error(
        d: &Distortion,
        points: &[Vector3<f64>],
        generic: impl Fn([D8; 8], [D8; 3]) -> [D8; 2],
    ) -> f64 {
        let mut worst: f64 = 0.0;
        for p in points {
            let (n, j, dk) = d.project_with_jacobians(p).unwrap();
            let (n1, j1) = d.project_with_jacobian(p).unwrap();
            assert!(n == n1 && j == j1);
            let xs = [p.x, p.y, p.z].map(D8::from);
            let (val, jd) = jacobian(
                |c: SVector<D8, 8>| SVector::from(generic(std::array::from_fn(|i| c[i]), xs)),
                &SVector::<f64, 8>::from(d.coeffs),
            );
            assert!((Vector2::new(val[0], val[1]) - n).norm() < 1e-12, "{p:?}");
            worst = worst.max((jd - dk).amax() / jd.amax().max(1e-300));
        }
        worst
    }

    #[test]
    fn the_coefficient_jacobians_match_dual_numbers() {
        let points = [
            Vector3::new(100.0, -50.0, 400.0),
            Vector3::new(300.0, 200.0, 100.0),
            Vector3::new(-250.0, 90.0, 60.0),
            Vector3::new(1e-7, -2e-7, 300.0),
        ];
        let fisheye = Distortion::fisheye([0.02, -0.005, 0.001, -0.0002]).unwrap();
        let k = fisheye.coeffs;
        let err = worst_coefficient_error(&fisheye, &points, |c, x| {
            let k4 = [c[0], c[1], c[2], c[3]];
            fisheye_dual_coeffs(&k4, x)
        });
        println!("fisheye: coefficient Jacobian within {err:.1e} of num-dual's (relative)");
        assert!(err < 1e-12, "fisheye: {err:e} at {k:?}");
        // On the axis the point does not move with the coefficients.
        let (_, _, dk) = fisheye
            .project_with_jacobians(&Vector3::new(0.0, 0.0, 5.0))
            .unwrap();
        assert_eq!(dk, SMatrix::<f64, 2, 8>::zeros());
        let c = [0.18, -1.37, 2e-3, 1e-3, 2.67, 0.1, -0.2, 0.3];
        let pinhole = Distortion::new(LensModel::Pinhole, &c).unwrap();
        let err = worst_coefficient_error(&pinhole, &points, |c, x| radtan_dual_coeffs(&c, x));
        println!("pinhole: coefficient Jacobian within {err:.1e} of num-dual's (relative)");
        assert!(err < 1e-12, "pinhole: {err:e}");
        assert!(fisheye
            .project_with_jacobians(&Vector3::new(0.0, 0.0, -5.0))
            .is_none());
    }

    #[test]
    fn the_pinhole_jacobians_match_dual_numbers() {
        let points = [
            Vector3::new(100.0, -50.0, 400.0),
            Vector3::new(-150.0, 120.0, 300.0),
            Vector3::new(0.0, 0.0, 500.0),
        ];
        for c in [
            [0.0; 8],
            [-0.28, 0.07, 1e-3, -5e-4, 0.02, 0.0, 0.0, 0.0],
            [0.18, -1.37, 2e-3, 1e-3, 2.67, 0.1, -0.2, 0.3],
        ] {
            let d = Distortion::new(LensModel::Pinhole, &c).unwrap();
            let err = worst_jacobian_error(&d, &points, |x| radtan_generic(&c, x));
            println!("pinhole {c:?}: Jacobian within {err:.1e} of num-dual's (relative)");
            assert!(err < 1e-12, "{c:?}: {err:e}");
        }
        let d = Distortion::default();
        assert!(d
            .project_with_jacobian(&Vector3::new(1.0, 2.0, 0.0))
            .is_none());
    }

    #[test]
    fn the_fisheye_inverts_to_its_rays() {
        let d = Distortion::fisheye([0.02, -0.005, 0.001, -0.0002]).unwrap();
        for p in [
            Vector3::new(100.0, -50.0, 400.0),
            Vector3::new(400.0, -80.0, -50.0),
            Vector3::new(1e-9, 0.0, 1.0),
        ] {
            let (n, _) = d.project_with_jacobian(&p).unwrap();
            let ray = d.ray(n).unwrap();
            assert!((ray - p.normalize()).norm() < 1e-13, "{p:?}: {ray:?}");
        }
        // Under 90 degrees a ray has a pinhole point, and the fisheye's distortion of that
        // point is the projection.
        let p = Vector3::new(300.0, 200.0, 100.0);
        let (n, _) = d.project_with_jacobian(&p).unwrap();
        let u = d.undistort(n).unwrap();
        assert!((u - Vector2::new(3.0, 2.0)).norm() < 1e-11, "{u:?}");
        assert!((d.distort(u) - n).norm() < 1e-14);
        // At 90 degrees and past it, none.
        let (n, _) = d
            .project_with_jacobian(&Vector3::new(1.0, 0.0, -0.2))
            .unwrap();
        assert!(d.undistort(n).is_none());
        assert!(d.ray(n).is_some());
    }

    #[test]
    fn a_folding_fisheye_has_no_ray_past_its_fold() {
        // theta_d = theta - 0.3 theta^3 stops growing at theta = 1 / sqrt(0.9).
        let d = Distortion::fisheye([-0.3, 0.0, 0.0, 0.0]).unwrap();
        let fold = d.fisheye_fold_angle().unwrap();
        assert!((fold - (1.0f64 / 0.9).sqrt()).abs() < 1e-12, "{fold}");
        let top = fold - 0.3 * fold.powi(3);
        assert!((d.fisheye_angle(top * 0.999).unwrap() - fold).abs() < 0.1);
        assert!(d.fisheye_angle(top * 1.001).is_none());
        assert!(d.ray(Vector2::new(top * 1.001, 0.0)).is_none());
        assert_eq!(Distortion::default().fisheye_fold_angle(), None);
    }

    #[test]
    fn coefficient_counts_follow_the_model() {
        assert!(Distortion::new(LensModel::Fisheye, &[0.1, 0.0, 0.0, 0.0, 0.0]).is_err());
        assert!(Distortion::new(LensModel::Pinhole, &[0.1, 0.0, 0.0]).is_err());
        let f = Distortion::fisheye([0.1, 0.2, 0.3, 0.4]).unwrap();
        assert_eq!(f.listed(), &[0.1, 0.2, 0.3, 0.4]);
        assert!(!f.is_ideal());
        let zero = Distortion::fisheye([0.0; 4]).unwrap();
        assert!(zero.is_zero() && !zero.is_ideal());
        assert_eq!(zero.listed().len(), 4);
        let p = Distortion::from_slice(&[0.1, 0.0, 0.0, 0.0, 0.2]).unwrap();
        assert_eq!(p.listed().len(), 5);
        assert!(Distortion::default().is_ideal() && Distortion::default().listed().is_empty());
        let mut bad = f;
        bad.coeffs[6] = 0.1;
        assert!(bad
            .check()
            .unwrap_err()
            .to_string()
            .contains("4 coefficients"));
        assert_eq!(LensModel::from_name("fisheye"), Some(LensModel::Fisheye));
        assert_eq!(LensModel::from_name("omni"), None);
    }
}
