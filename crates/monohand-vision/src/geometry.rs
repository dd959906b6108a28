//! Plane geometry of crops: 2D affine maps and rotated rectangles.
//!
//! Coordinates are *continuous* pixel coordinates: pixel `(i, j)` covers `[i, i+1) x [j, j+1)`
//! and its centre is at `(i + 0.5, j + 0.5)`. Network crops use the same convention in their
//! own pixel grid, so a crop of size `w x h` spans `[0, w] x [0, h]`. Public keypoints are
//! converted once, at the end, to the OpenCV/OpenPose convention (centre of the first pixel
//! at 0) by [`to_pixel_centres`].

use monohand_core::bbox::BBox;

/// `p ↦ A p + t`, stored row-major as `[[a, b, tx], [c, d, ty]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine2(pub [[f64; 3]; 2]);

impl Affine2 {
    /// The identity map.
    pub const IDENTITY: Affine2 = Affine2([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

    /// Applies the map to a point.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let m = &self.0;
        [
            m[0][0] * p[0] + m[0][1] * p[1] + m[0][2],
            m[1][0] * p[0] + m[1][1] * p[1] + m[1][2],
        ]
    }

    /// Applies only the linear part (for vectors).
    pub fn apply_vector(&self, v: [f64; 2]) -> [f64; 2] {
        let m = &self.0;
        [
            m[0][0] * v[0] + m[0][1] * v[1],
            m[1][0] * v[0] + m[1][1] * v[1],
        ]
    }

    /// The left-right mirror of a crop `width` pixels wide, in its own pixel grid:
    /// `(x, y) ↦ (width − x, y)` (its own inverse). Composed after a crop's map,
    /// `crop.compose(&Affine2::mirror_x(w))`, it samples the crop mirrored.
    pub fn mirror_x(width: f64) -> Affine2 {
        Affine2([[-1.0, 0.0, width], [0.0, 1.0, 0.0]])
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Affine2) -> Affine2 {
        let a = &self.0;
        let b = &other.0;
        let mut m = [[0.0; 3]; 2];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = a[r][0] * b[0][c] + a[r][1] * b[1][c] + if c == 2 { a[r][2] } else { 0.0 };
            }
        }
        Affine2(m)
    }

    /// Determinant of the linear part.
    pub fn det(&self) -> f64 {
        self.0[0][0] * self.0[1][1] - self.0[0][1] * self.0[1][0]
    }

    /// The inverse map, `None` if singular.
    pub fn inverse(&self) -> Option<Affine2> {
        let d = self.det();
        if d.abs() < 1e-12 || !d.is_finite() {
            return None;
        }
        let [[a, b, tx], [c, e, ty]] = self.0;
        let (ia, ib, ic, ie) = (e / d, -b / d, -c / d, a / d);
        Some(Affine2([
            [ia, ib, -(ia * tx + ib * ty)],
            [ic, ie, -(ic * tx + ie * ty)],
        ]))
    }

    /// Square root of |det|: how many source units one unit of this map's input covers.
    pub fn scale(&self) -> f64 {
        self.det().abs().sqrt()
    }
}

/// A rectangle of `width x height` pixels centred at `center`, rotated by `rotation` radians
/// (counter-clockwise in the image as displayed, y pointing down, i.e. the rectangle's "up"
/// axis is the image's up axis turned by `rotation`; MediaPipe's `NormalizedRect` convention).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RotatedRect {
    /// Centre in image pixels (continuous coordinates).
    pub center: [f64; 2],
    /// Width in pixels.
    pub width: f64,
    /// Height in pixels.
    pub height: f64,
    /// Rotation in radians.
    pub rotation: f64,
}

impl RotatedRect {
    /// The map from a `out_w x out_h` crop of this rectangle (continuous crop coordinates)
    /// to image coordinates: `p = c + R(θ) · ((x/out_w − ½)·w, (y/out_h − ½)·h)`.
    pub fn crop_to_image(&self, out_w: usize, out_h: usize) -> Affine2 {
        let (s, c) = self.rotation.sin_cos();
        let sx = self.width / out_w as f64;
        let sy = self.height / out_h as f64;
        let [cx, cy] = self.center;
        // p = c + R · (sx x − w/2, sy y − h/2)
        let ox = -self.width / 2.0;
        let oy = -self.height / 2.0;
        Affine2([
            [c * sx, -s * sy, cx + c * ox - s * oy],
            [s * sx, c * sy, cy + s * ox + c * oy],
        ])
    }

    /// The four corners in image coordinates: top-left, top-right, bottom-right, bottom-left
    /// of the rectangle's own frame.
    pub fn corners(&self) -> [[f64; 2]; 4] {
        let m = self.crop_to_image(1, 1);
        [
            m.apply([0.0, 0.0]),
            m.apply([1.0, 0.0]),
            m.apply([1.0, 1.0]),
            m.apply([0.0, 1.0]),
        ]
    }

    /// Axis-aligned bounds of the rotated rectangle.
    pub fn bounds(&self) -> BBox {
        BBox::around(self.corners())
    }
}

/// The map from a `size x size` network input to the image for aspect-preserving letterboxing:
/// the image is scaled to fit and centred, the rest is padding.
pub fn letterbox_to_image(image_w: u32, image_h: u32, size: usize) -> Affine2 {
    let long = image_w.max(image_h) as f64;
    let s = long / size as f64;
    let pad_x = (long - image_w as f64) / 2.0;
    let pad_y = (long - image_h as f64) / 2.0;
    Affine2([[s, 0.0, -pad_x], [0.0, s, -pad_y]])
}

/// Wraps an angle to `[-π, π)`.
pub fn normalize_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    a - 2.0 * PI * ((a + PI) / (2.0 * PI)).floor()
}

/// Continuous coordinates → OpenCV/OpenPose pixel coordinates (first pixel centre at 0).
///
/// The networks' pre- and post-processing work in continuous coordinates (the first
/// pixel spans `[0, 1)`); everything the pipeline returns is in pixel-centre coordinates,
/// as the keypoint files and the cameras are. This pair is the only place the half pixel
/// is added or taken away.
pub fn to_pixel_centres(p: [f64; 2]) -> [f64; 2] {
    [p[0] - 0.5, p[1] - 0.5]
}

/// Pixel-centre coordinates → continuous coordinates (the inverse of [`to_pixel_centres`]).
pub fn from_pixel_centres(p: [f64; 2]) -> [f64; 2] {
    [p[0] + 0.5, p[1] + 0.5]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: [f64; 2], b: [f64; 2]) -> bool {
        (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9
    }

    #[test]
    fn inverse_roundtrips() {
        let r = RotatedRect {
            center: [100.0, 50.0],
            width: 80.0,
            height: 80.0,
            rotation: 0.7,
        };
        let m = r.crop_to_image(224, 224);
        let inv = m.inverse().expect("invertible");
        let p = [13.0, 201.0];
        assert!(close(inv.apply(m.apply(p)), p));
        assert!(close(m.compose(&inv).apply([5.0, 6.0]), [5.0, 6.0]));
    }

    #[test]
    fn crop_centre_maps_to_rect_centre_and_rotation_turns_up_axis() {
        let r = RotatedRect {
            center: [100.0, 50.0],
            width: 40.0,
            height: 40.0,
            rotation: FRAC_PI_2,
        };
        let m = r.crop_to_image(224, 224);
        assert!(close(m.apply([112.0, 112.0]), [100.0, 50.0]));
        // The crop's top edge centre lies to the right of the centre in the image.
        assert!(close(m.apply([112.0, 0.0]), [120.0, 50.0]));
    }

    #[test]
    fn letterbox_centres_the_short_side() {
        let m = letterbox_to_image(640, 480, 192);
        assert!(close(m.apply([0.0, 24.0]), [0.0, 0.0]));
        assert!(close(m.apply([192.0, 168.0]), [640.0, 480.0]));
    }

    #[test]
    fn angles_wrap() {
        assert!((normalize_angle(3.0 * std::f64::consts::PI) + std::f64::consts::PI).abs() < 1e-12);
        assert!((normalize_angle(0.5) - 0.5).abs() < 1e-12);
    }
}
