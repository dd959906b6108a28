//! Rectified crops: a hand's region seen by a virtual pinhole camera aimed at it, as UmeTrack
//! and HOT3D crop their fisheye frames. The landmark network then sees an undistorted,
//! perspective-correct hand wherever it is in a wide or fisheye frame; its keypoints map
//! back through the same camera model into the image.
//!
//! The virtual camera shares the real camera's centre. Its axis is the ray through the
//! region's centre, its x axis the image's x direction there, and its focal length the
//! image's own resolution there (pixels per radian), so that near the hand a pixel of the
//! view is about a pixel of the image. The view is drawn by projecting every view pixel's
//! ray through the camera model ([`Camera::project_cam`]) and sampling the image
//! bilinearly; the projections are computed on a grid every [`GRID`] pixels and interpolated
//! between (under 0.01 px from the exact map for the lenses tested).
//!
//! Coordinates here are pixel centres (the camera's convention, [`crate::geometry`]).

use crate::geometry::{from_pixel_centres, to_pixel_centres, RotatedRect};
use crate::keypoints::HandKeypoints;
use crate::RgbImage;
use monohand_core::camera::Camera;
use nalgebra::{Matrix3, Point2, Vector3};

/// Spacing of the exact projections the view's pixel map interpolates between, pixels.
pub const GRID: usize = 8;

/// The largest view drawn, pixels a side: a region larger than this (a hand filling a large
/// frame) is drawn at a lower resolution.
pub const MAX_SIDE: usize = 1024;

/// A virtual pinhole camera aimed at one region of a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RectifiedView {
    /// Camera frame to the view's frame (rows: the view's x, y and z axes).
    rotation: Matrix3<f64>,
    /// Focal length, view pixels.
    focal: f64,
    /// The view's side, pixels.
    side: usize,
}

impl RectifiedView {
    /// The view of `roi` (pixel-centre coordinates) through `camera`: `None` when the
    /// region's centre has no ray (outside a fisheye's field) or the camera's map is
    /// degenerate there.
    pub fn aimed_at(camera: &Camera, roi: &RotatedRect) -> Option<RectifiedView> {
        let c = Point2::new(roi.center[0], roi.center[1]);
        let axis = camera.ray(c)?;
        let step = 2.0;
        let along_x = camera.ray(Point2::new(c.x + step, c.y))?;
        let along_y = camera.ray(Point2::new(c.x, c.y + step))?;
        let x = along_x - axis * axis.dot(&along_x);
        if !(axis.iter().all(|v| v.is_finite()) && x.norm() > 1e-12) {
            return None;
        }
        let x = x.normalize();
        let y = axis.cross(&x);
        // Pixels per radian at the centre, across and down.
        let angle = |r: &Vector3<f64>| axis.angle(r);
        let per_radian = 2.0 * step / (angle(&along_x) + angle(&along_y));
        // The square around the region, at most MAX_SIDE pixels.
        let [bw, bh] = bounds_size(roi);
        let extent = bw.max(bh) + 2.0;
        let side = (extent.ceil() as usize).clamp(16, MAX_SIDE);
        let focal = per_radian * side as f64 / extent.max(side as f64);
        if !(focal.is_finite() && focal > 0.0) {
            return None;
        }
        Some(RectifiedView {
            rotation: Matrix3::from_rows(&[x.transpose(), y.transpose(), axis.transpose()]),
            focal,
            side,
        })
    }

    /// The view's side, pixels.
    pub fn side(&self) -> usize {
        self.side
    }

    /// The view's centre, pixel-centre coordinates.
    fn centre(&self) -> f64 {
        (self.side as f64 - 1.0) / 2.0
    }

    /// The ray (camera frame) of a view pixel.
    fn ray(&self, p: [f64; 2]) -> Vector3<f64> {
        let c = self.centre();
        let v = Vector3::new((p[0] - c) / self.focal, (p[1] - c) / self.focal, 1.0);
        self.rotation.transpose() * v
    }

    /// A view pixel's place in the image (pixel centres); `None` where the camera does not
    /// see its ray.
    pub fn to_image(&self, camera: &Camera, p: [f64; 2]) -> Option<[f64; 2]> {
        let q = camera.project_cam(&self.ray(p))?;
        (q.x.is_finite() && q.y.is_finite()).then_some([q.x, q.y])
    }

    /// An image pixel's place in the view (pixel centres); `None` behind the view.
    pub fn from_image(&self, camera: &Camera, p: [f64; 2]) -> Option<[f64; 2]> {
        let v = self.rotation * camera.ray(Point2::new(p[0], p[1]))?;
        if v.z.is_nan() || v.z <= 1e-9 {
            return None;
        }
        let c = self.centre();
        Some([c + self.focal * v.x / v.z, c + self.focal * v.y / v.z])
    }

    /// `roi` (pixel centres in the image) in the view: its centre at the view's centre,
    /// its sides and rotation measured through the view.
    pub fn roi(&self, camera: &Camera, roi: &RotatedRect) -> Option<RotatedRect> {
        let (s, c) = roi.rotation.sin_cos();
        let centre = self.from_image(camera, roi.center)?;
        let at = |dx: f64, dy: f64| {
            self.from_image(
                camera,
                [
                    roi.center[0] + c * dx - s * dy,
                    roi.center[1] + s * dx + c * dy,
                ],
            )
        };
        let (hw, hh) = (roi.width / 2.0, roi.height / 2.0);
        let (r, l) = (at(hw, 0.0)?, at(-hw, 0.0)?);
        let (d, u) = (at(0.0, hh)?, at(0.0, -hh)?);
        let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        Some(RotatedRect {
            center: centre,
            width: dist(r, l),
            height: dist(d, u),
            rotation: (r[1] - l[1]).atan2(r[0] - l[0]),
        })
    }

    /// Keypoints read in this view (continuous coordinates, as the estimators give them)
    /// mapped into the image; a keypoint the camera does not see gets confidence 0. The
    /// network's metric 3D is turned from the view's axes into the camera's.
    pub fn map_back(&self, camera: &Camera, kp: &mut HandKeypoints) {
        for p in &mut kp.points {
            match self.to_image(camera, to_pixel_centres([p[0], p[1]])) {
                Some(q) => [p[0], p[1]] = from_pixel_centres(q),
                None => p[2] = 0.0,
            }
        }
        if let Some(world) = kp.cues.as_mut().and_then(|c| c.world_mm.as_mut()) {
            let back = self.rotation.transpose();
            for w in world.iter_mut() {
                *w = (back * Vector3::from(*w)).into();
            }
        }
    }

    /// Draws the view of `image` into `out` (resized to the view's side); pixels the camera
    /// does not see are black. `map` is the caller's buffer for the view's grid of image
    /// points (every 8 pixels), reused from hand to hand.
    pub fn draw(
        &self,
        camera: &Camera,
        image: &RgbImage,
        out: &mut RgbImage,
        map: &mut Vec<Option<[f64; 2]>>,
    ) {
        let n = self.side;
        if out.dimensions() != (n as u32, n as u32) {
            *out = RgbImage::new(n as u32, n as u32);
        }
        let cells = n.div_ceil(GRID);
        let nodes = cells + 1;
        map.clear();
        map.reserve(nodes * nodes);
        for gy in 0..nodes {
            for gx in 0..nodes {
                map.push(self.to_image(camera, [(gx * GRID) as f64, (gy * GRID) as f64]));
            }
        }
        let (w, h) = (image.width() as usize, image.height() as usize);
        let src = image.as_raw();
        let dst: &mut [u8] = out;
        for y in 0..n {
            let (gy, fy) = (y / GRID, (y % GRID) as f64 / GRID as f64);
            for x in 0..n {
                let (gx, fx) = (x / GRID, (x % GRID) as f64 / GRID as f64);
                let corner = |dx: usize, dy: usize| map[(gy + dy) * nodes + gx + dx];
                let px = match (corner(0, 0), corner(1, 0), corner(0, 1), corner(1, 1)) {
                    (Some(a), Some(b), Some(c), Some(d)) => {
                        let top = [a[0] + (b[0] - a[0]) * fx, a[1] + (b[1] - a[1]) * fx];
                        let bot = [c[0] + (d[0] - c[0]) * fx, c[1] + (d[1] - c[1]) * fx];
                        sample(
                            src,
                            w,
                            h,
                            top[0] + (bot[0] - top[0]) * fy,
                            top[1] + (bot[1] - top[1]) * fy,
                        )
                    }
                    _ => [0; 3],
                };
                dst[3 * (y * n + x)..3 * (y * n + x) + 3].copy_from_slice(&px);
            }
        }
    }
}

/// Width and height of a rotated rectangle's axis-aligned bounds.
fn bounds_size(r: &RotatedRect) -> [f64; 2] {
    let (s, c) = r.rotation.sin_cos();
    [
        r.width * c.abs() + r.height * s.abs(),
        r.width * s.abs() + r.height * c.abs(),
    ]
}

/// Bilinear sample at `(x, y)` (pixel centres); black outside the image.
fn sample(src: &[u8], w: usize, h: usize, x: f64, y: f64) -> [u8; 3] {
    if !(x > -1.0 && y > -1.0 && x < w as f64 && y < h as f64) {
        return [0; 3];
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (ax, ay) = (x - x0, y - y0);
    let (x0, y0) = (x0 as isize, y0 as isize);
    let at = |xi: isize, yi: isize, k: usize| -> f64 {
        if xi < 0 || yi < 0 || xi >= w as isize || yi >= h as isize {
            0.0
        } else {
            f64::from(src[3 * (yi as usize * w + xi as usize) + k])
        }
    };
    let mut out = [0u8; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let v = at(x0, y0, k) * (1.0 - ax) * (1.0 - ay)
            + at(x0 + 1, y0, k) * ax * (1.0 - ay)
            + at(x0, y0 + 1, k) * (1.0 - ax) * ay
            + at(x0 + 1, y0 + 1, k) * ax * ay;
        *o = v.round().clamp(0.0, 255.0) as u8;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roi(cx: f64, cy: f64, size: f64, rotation: f64) -> RotatedRect {
        RotatedRect {
            center: [cx, cy],
            width: size,
            height: size,
            rotation,
        }
    }

    #[test]
    fn at_the_centre_of_a_pinhole_the_view_is_the_image() {
        let cam = Camera::centred(500.0, 641, 481).unwrap();
        let view = RectifiedView::aimed_at(&cam, &roi(320.0, 240.0, 100.0, 0.0)).unwrap();
        // The view's pixels are the image's pixels, shifted (to the 5e-6 by which the
        // pixels per radian measured over 2 px differ from the focal length).
        let c = view.centre();
        let p = view.to_image(&cam, [c + 10.0, c - 20.0]).unwrap();
        assert!(
            (p[0] - 330.0).abs() < 1e-3 && (p[1] - 220.0).abs() < 1e-3,
            "{p:?}"
        );
        let back = view.from_image(&cam, p).unwrap();
        assert!((back[0] - c - 10.0).abs() < 1e-9 && (back[1] - c + 20.0).abs() < 1e-9);
        let r = view.roi(&cam, &roi(320.0, 240.0, 100.0, 0.3)).unwrap();
        assert!(
            (r.width - 100.0).abs() < 1e-3 && (r.rotation - 0.3).abs() < 1e-9,
            "{r:?}"
        );
    }

    #[test]
    fn off_centre_the_view_undoes_the_perspective_stretch() {
        // A region 30 degrees off the axis of a pinhole: the image stretches it along the
        // radius by 1/cos^2 and across by 1/cos; the view sees it square.
        let f = 500.0;
        let cam = Camera::centred(f, 2001, 1001).unwrap();
        let x = 1000.0 + f * 30f64.to_radians().tan();
        let view = RectifiedView::aimed_at(&cam, &roi(x, 500.0, 60.0, 0.0)).unwrap();
        let r = view.roi(&cam, &roi(x, 500.0, 60.0, 0.0)).unwrap();
        let c30 = 30f64.to_radians().cos();
        // Widths in the view relative to heights: (1/cos^2 in the image) / (1/cos) undone.
        let ratio = r.width / r.height;
        assert!((ratio - c30).abs() < 0.01, "{ratio} vs {c30}");
        // Round trip of any pixel near the hand.
        for p in [[x + 17.0, 489.0], [x - 25.0, 520.0]] {
            let v = view.from_image(&cam, p).unwrap();
            let q = view.to_image(&cam, v).unwrap();
            assert!((q[0] - p[0]).hypot(q[1] - p[1]) < 1e-6, "{p:?} -> {q:?}");
        }
    }

    #[test]
    fn the_drawn_view_samples_the_image_where_the_map_says() {
        // A horizontal ramp image: each pixel's red is its column / 4.
        let cam = Camera::centred(400.0, 800, 600).unwrap();
        let image = RgbImage::from_fn(800, 600, |x, _| image::Rgb([(x / 4) as u8, 0, 0]));
        let r = roi(600.0, 200.0, 120.0, 0.2);
        let view = RectifiedView::aimed_at(&cam, &r).unwrap();
        let mut out = RgbImage::new(1, 1);
        view.draw(&cam, &image, &mut out, &mut Vec::new());
        assert_eq!(out.width() as usize, view.side());
        let n = view.side();
        let mut worst = 0.0f64;
        for (x, y) in [(0, 0), (n / 2, n / 3), (n - 1, n - 1), (5, n - 3)] {
            let p = view.to_image(&cam, [x as f64, y as f64]).unwrap();
            let want = p[0] / 4.0;
            let got = f64::from(out.get_pixel(x as u32, y as u32).0[0]);
            worst = worst.max((got - want).abs());
        }
        // The ramp's steps (1/4 per pixel, rounded) and the interpolated map.
        assert!(worst <= 1.0, "{worst}");
    }
}
