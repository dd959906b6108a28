//! A point from the rays of the cameras that see it, in the least-squares sense.
//!
//! ```
//! use monohand_core::triangulation::triangulate;
//! use nalgebra::Vector3;
//!
//! let x = Vector3::new(10.0, -20.0, 500.0);
//! let (a, b) = (Vector3::zeros(), Vector3::new(-100.0, 0.0, 0.0));
//! let rays = [(a, (x - a).normalize(), 1.0), (b, (x - b).normalize(), 1.0)];
//! assert!((triangulate(&rays).expect("two rays") - x).norm() < 1e-9);
//! ```

use nalgebra::{Matrix3, Vector3};

/// The point nearest to the rays `(origin, unit direction, weight)`: it minimises
/// `Σ w |(I − d dᵀ)(X − o)|²`. `None` with fewer than two rays of positive weight, or rays
/// so nearly parallel that the point along them is not determined (the normal matrix's
/// smallest eigenvalue below 1e-6 of its largest: rays less than about 0.1 degree apart).
pub fn triangulate(rays: &[(Vector3<f64>, Vector3<f64>, f64)]) -> Option<Vector3<f64>> {
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    let mut n = 0;
    for (origin, dir, w) in rays {
        if !(*w > 0.0 && w.is_finite()) {
            continue;
        }
        let p = (Matrix3::identity() - dir * dir.transpose()) * *w;
        a += p;
        b += p * origin;
        n += 1;
    }
    if n < 2 {
        return None;
    }
    let eig = a.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if !(hi > 0.0 && lo > 1e-6 * hi) {
        return None;
    }
    a.try_inverse().map(|inv| inv * b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_rays_with_noise_meet_near_the_point_and_parallel_rays_do_not() {
        let x = Vector3::new(40.0, 15.0, 600.0);
        let origins = [
            Vector3::zeros(),
            Vector3::new(-300.0, 0.0, 50.0),
            Vector3::new(0.0, 250.0, 100.0),
        ];
        // Each ray aimed 1 mm off the point, in different directions.
        let offsets = [Vector3::x(), Vector3::y(), -Vector3::x()];
        let rays: Vec<_> = origins
            .iter()
            .zip(&offsets)
            .map(|(o, e)| (*o, (x + e - o).normalize(), 1.0))
            .collect();
        let p = triangulate(&rays).expect("three rays");
        assert!((p - x).norm() < 1.0, "{p}");
        // One ray, or two of the same direction, or weights of 0: no point.
        assert!(triangulate(&rays[..1]).is_none());
        let parallel = [rays[0], (Vector3::new(1.0, 0.0, 0.0), rays[0].1, 1.0)];
        assert!(triangulate(&parallel).is_none());
        let unweighted = [rays[0], (rays[1].0, rays[1].1, 0.0)];
        assert!(triangulate(&unweighted).is_none());
    }
}
