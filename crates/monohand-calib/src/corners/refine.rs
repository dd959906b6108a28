//! Subpixel refinement of saddle points (as `cv::cornerSubPix`), and the sharpness of a
//! board's edges.

use super::plane::sample_gray;
use crate::image::GrayImage;
use nalgebra::{Point2, Vector2};

/// Iterations at most, and the step (pixels) under which the iteration stops.
const MAX_ITERATIONS: usize = 30;
const EPSILON: f64 = 0.001;

/// Moves `p` to the point whose lines to the pixels of the `(2 hw + 1)^2` window around
/// it are orthogonal to their gradients (least squares, Gaussian-weighted, iterated). A
/// corner that would leave its window, or the image, keeps its first position.
pub(crate) fn refine_one(image: &GrayImage<'_>, p: Point2<f64>, hw: usize) -> Point2<f64> {
    let hw = hw.max(1);
    let win = 2 * hw + 1;
    let side = win + 2;
    // Gaussian weights exp(-(x^2 + y^2)) with x, y in [-1, 1] across the window.
    let weight: Vec<f64> = (0..win)
        .map(|i| {
            let t = (i as f64 - hw as f64) / hw as f64;
            (-t * t).exp()
        })
        .collect();
    let mut patch = vec![0.0f64; side * side];
    let start = p;
    let mut cur = p;
    let (w, h) = (image.width as f64, image.height as f64);
    for _ in 0..MAX_ITERATIONS {
        let ox = cur.x - (hw + 1) as f64;
        let oy = cur.y - (hw + 1) as f64;
        for i in 0..side {
            for j in 0..side {
                patch[i * side + j] = sample_gray(image, ox + j as f64, oy + i as f64);
            }
        }
        let (mut a, mut b, mut c, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..win {
            let py = i as f64 - hw as f64;
            for j in 0..win {
                let px = j as f64 - hw as f64;
                let m = weight[i] * weight[j];
                let at = |y: usize, x: usize| patch[y * side + x];
                let gx = at(i + 1, j + 2) - at(i + 1, j);
                let gy = at(i + 2, j + 1) - at(i, j + 1);
                let (gxx, gxy, gyy) = (gx * gx * m, gx * gy * m, gy * gy * m);
                a += gxx;
                b += gxy;
                c += gyy;
                bb1 += gxx * px + gxy * py;
                bb2 += gxy * px + gyy * py;
            }
        }
        let det = a * c - b * b;
        if det.abs() <= f64::EPSILON * f64::EPSILON || !det.is_finite() {
            break;
        }
        let step = Vector2::new(c * bb1 - b * bb2, -b * bb1 + a * bb2) / det;
        cur += step;
        if !(cur.x >= 0.0 && cur.y >= 0.0 && cur.x < w && cur.y < h) {
            break;
        }
        if step.norm_squared() <= EPSILON * EPSILON {
            break;
        }
    }
    let moved = cur - start;
    let inside = cur.x >= 0.0 && cur.y >= 0.0 && cur.x < w && cur.y < h;
    if !(moved.x.abs() <= hw as f64 && moved.y.abs() <= hw as f64 && inside) {
        return start;
    }
    cur
}

/// The sharpness of the edges between adjacent corners of a `rows` x `cols` grid: for
/// each edge, the steepest grey-level slope across its middle divided by the difference
/// between the squares on its two sides (1/pixel; about 0.4 / sigma for an edge blurred
/// by a Gaussian of sigma pixels, near 1 for a perfectly sharp one), the mean over the
/// edges with some contrast. Zero if none has.
pub(crate) fn sharpness(
    image: &GrayImage<'_>,
    corners: &[Point2<f64>],
    rows: usize,
    cols: usize,
) -> f64 {
    let mut total = 0.0;
    let mut count = 0usize;
    let mut edge = |p: Point2<f64>, q: Point2<f64>| {
        let d = q - p;
        let len = d.norm();
        if len < 4.0 {
            return;
        }
        let along = d / len;
        let normal = Vector2::new(-along.y, along.x);
        let reach = 0.3 * len;
        let steps = (2.0 * reach).ceil() as i32; // half-pixel steps across
        let mid = p + d * 0.5;
        // Three profiles across the edge, averaged: at its middle and a tenth of a side
        // either way along it.
        let profile = |t: f64| {
            [-0.1, 0.0, 0.1]
                .iter()
                .map(|&s| {
                    let x = mid + along * (s * len) + normal * t;
                    sample_gray(image, x.x, x.y)
                })
                .sum::<f64>()
                / 3.0
        };
        let values: Vec<f64> = (-steps..=steps).map(|k| profile(k as f64 * 0.5)).collect();
        let n = values.len();
        if n < 8 {
            return;
        }
        let plateau = n / 5;
        let lo = values[..plateau].iter().sum::<f64>() / plateau as f64;
        let hi = values[n - plateau..].iter().sum::<f64>() / plateau as f64;
        let contrast = (hi - lo).abs();
        if contrast < 8.0 {
            return;
        }
        let slope = values
            .windows(3)
            .map(|v| (v[2] - v[0]).abs())
            .fold(0.0, f64::max);
        total += slope / contrast;
        count += 1;
    };
    for r in 0..rows {
        for c in 0..cols {
            let p = corners[r * cols + c];
            if c + 1 < cols {
                edge(p, corners[r * cols + c + 1]);
            }
            if r + 1 < rows {
                edge(p, corners[(r + 1) * cols + c]);
            }
        }
    }
    if count == 0 {
        0.0
    } else {
        total / count as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An X corner at (cx, cy) blurred over about a pixel (a product of smooth steps),
    /// its axes turned by `angle`.
    fn x_corner(w: usize, h: usize, cx: f64, cy: f64, angle: f64) -> Vec<u8> {
        let (sn, cs) = angle.sin_cos();
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                let (u, v) = (cs * dx + sn * dy, -sn * dx + cs * dy);
                out.push((125.0 + 100.0 * (u / 2.0).tanh() * (v / 2.0).tanh()).round() as u8);
            }
        }
        out
    }

    #[test]
    fn refinement_finds_the_saddle() {
        let data = x_corner(40, 40, 20.3, 18.7, 0.4);
        let img = GrayImage::new(40, 40, &data).unwrap();
        let p = refine_one(&img, Point2::new(19.0, 20.0), 5);
        assert!((p - Point2::new(20.3, 18.7)).norm() < 0.02, "{p}");
    }

    #[test]
    fn a_flat_window_leaves_the_corner() {
        let data = vec![128u8; 400];
        let img = GrayImage::new(20, 20, &data).unwrap();
        let p = refine_one(&img, Point2::new(10.0, 10.0), 5);
        assert_eq!(p, Point2::new(10.0, 10.0));
    }
}
