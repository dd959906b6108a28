//! Least-squares alignment of two point sets: the rotation, translation and
//! optionally scale that best map one onto the other (Kabsch 1976, Umeyama 1991).
//!
//! ```
//! use monohand_core::alignment::align;
//! use nalgebra::{Rotation3, Vector3};
//!
//! let from = [Vector3::x(), Vector3::y(), Vector3::z(), Vector3::zeros()];
//! let turn = Rotation3::from_euler_angles(0.1, 0.2, 0.3);
//! let to = from.map(|p| turn * p * 2.0 + Vector3::new(5.0, 0.0, 0.0));
//! let s = align(&from, &to, true).expect("well-posed");
//! assert!((s.scale - 2.0).abs() < 1e-9);
//! assert!((s.apply(&from[1]) - to[1]).norm() < 1e-9);
//! ```

use nalgebra::{Matrix3, Rotation3, Vector3};

/// `x ↦ scale · rotation · x + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    /// A proper rotation (no reflection).
    pub rotation: Rotation3<f64>,
    /// 1 for a rigid alignment.
    pub scale: f64,
    /// Applied after the rotation and scale.
    pub translation: Vector3<f64>,
}

impl Similarity {
    /// Maps one point.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x * self.scale + self.translation
    }
}

/// The similarity (`with_scale`) or rigid transform that maps `from` onto `to`
/// with the least sum of squared distances, pairing the points by index.
/// `None` if the slices differ in length, hold fewer than 3 points, or `from`
/// has all its points in one place.
pub fn align(from: &[Vector3<f64>], to: &[Vector3<f64>], with_scale: bool) -> Option<Similarity> {
    if from.len() != to.len() || from.len() < 3 {
        return None;
    }
    let n = from.len() as f64;
    let mf = from.iter().sum::<Vector3<f64>>() / n;
    let mt = to.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    let mut var_from = 0.0;
    for (f, t) in from.iter().zip(to) {
        let (a, b) = (f - mf, t - mt);
        cov += b * a.transpose();
        var_from += a.norm_squared();
    }
    if !(var_from > 1e-18 && var_from.is_finite()) {
        return None;
    }
    let svd = cov.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u * v_t).determinant().signum();
    let rotation = Rotation3::from_matrix_unchecked(
        u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t,
    );
    let sv = svd.singular_values;
    let scale = if with_scale {
        (sv[0] + sv[1] + d * sv[2]) / var_from
    } else {
        1.0
    };
    Some(Similarity {
        rotation,
        scale,
        translation: mt - rotation * mf * scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> [Vector3<f64>; 5] {
        [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(10.0, 1.0, -2.0),
            Vector3::new(-3.0, 7.0, 4.0),
            Vector3::new(2.0, -5.0, 9.0),
            Vector3::new(6.0, 6.0, 6.0),
        ]
    }

    #[test]
    fn recovers_a_known_transform_rigid_and_with_scale() {
        let r = Rotation3::from_euler_angles(0.7, -0.4, 2.1);
        let t = Vector3::new(-20.0, 3.0, 400.0);
        let to = cloud().map(|p| r * p * 1.5 + t);
        let s = align(&cloud(), &to, true).expect("aligned");
        assert!((s.scale - 1.5).abs() < 1e-9);
        assert!((s.rotation.matrix() - r.matrix()).norm() < 1e-9);
        assert!((s.translation - t).norm() < 1e-9);
        // Rigid: the scale stays 1 and the centroids still meet.
        let rigid = align(&cloud(), &to, false).expect("aligned");
        assert_eq!(rigid.scale, 1.0);
        let centroid = |p: &[Vector3<f64>]| p.iter().sum::<Vector3<f64>>() / p.len() as f64;
        let moved = cloud().map(|p| rigid.apply(&p));
        assert!((centroid(&moved) - centroid(&to)).norm() < 1e-9);
    }

    #[test]
    fn never_reflects() {
        let mirrored = cloud().map(|p| Vector3::new(-p.x, p.y, p.z));
        let s = align(&cloud(), &mirrored, true).expect("aligned");
        assert!((s.rotation.matrix().determinant() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let p = [Vector3::new(1.0, 2.0, 3.0); 4];
        assert!(align(&p, &cloud()[..4], true).is_none());
        assert!(align(&cloud()[..2], &cloud()[..2], false).is_none());
        assert!(align(&cloud(), &cloud()[..4], false).is_none());
    }
}
