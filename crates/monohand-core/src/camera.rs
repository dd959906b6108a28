//! Cameras: intrinsics, a lens model ([`LensModel`]: the pinhole with OpenCV's
//! radial-tangential distortion, or OpenCV's fisheye) and their poses.
//!
//! Conventions (OpenCV): x right, y down, z forward, pixel centres at integer
//! coordinates. A [`Camera`]'s extrinsics map a point from the *reference* frame
//! (the first camera of a rig) into this camera's frame: `X_cam = R X_ref + t`.

mod lens;

pub use lens::{Distortion, LensModel};

use crate::error::{CoreError, CoreResult};
use nalgebra::{Matrix2x3, Point2, Rotation3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Horizontal field of view assumed for footage of unknown origin, in degrees.
///
/// 60 degrees is typical of webcams and phone main cameras in video mode
/// (a 26-28 mm-equivalent lens is 65-75 degrees on the 4:3 diagonal, about 60
/// horizontally at 16:9 after stabilisation crop). A wrong guess scales the
/// recovered depth by tan(guess/2)/tan(true/2), e.g. 13% for 60 vs 68 degrees.
pub const GENERIC_HFOV_DEG: f64 = 60.0;

/// Fields of view taken as real, in degrees, across the image's longer side, for cameras
/// that are guessed (a photo's EXIF) and pinhole calibrations: a camera outside them (a 2
/// degree "telephoto" from a resized photo's EXIF, a 170 degree "fisheye" from a typo) is
/// refused unless the user's own calibration gives it ([`Camera::field_of_view_deg`],
/// docs/calibration.md). A fisheye calibration may reach [`MAX_FISHEYE_FOV_DEG`].
pub const PLAUSIBLE_FOV_DEG: std::ops::RangeInclusive<f64> = 5.0..=150.0;

/// The widest field of view across the image's longer side a fisheye camera may have,
/// degrees: cameras past 180 degrees are not supported ([`Camera::validate`]).
pub const MAX_FISHEYE_FOV_DEG: f64 = 180.0;

/// Focal lengths, principal point and image size, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

/// Rigid transform from the reference frame into a camera: `X_cam = rotation * X_ref + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extrinsics {
    /// Rotation from the reference frame to the camera frame.
    pub rotation: Rotation3<f64>,
    /// Translation in millimetres.
    pub translation: Vector3<f64>,
}

impl Default for Extrinsics {
    fn default() -> Self {
        Extrinsics {
            rotation: Rotation3::identity(),
            translation: Vector3::zeros(),
        }
    }
}

impl Extrinsics {
    /// True for the identity transform.
    pub fn is_identity(&self) -> bool {
        self.rotation == Rotation3::identity() && self.translation == Vector3::zeros()
    }

    /// Maps a reference-frame point into this camera's frame.
    pub fn transform(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }

    /// The inverse transform: from this camera's frame back into the reference frame.
    pub fn inverse(&self) -> Extrinsics {
        let rotation = self.rotation.inverse();
        Extrinsics {
            rotation,
            translation: -(rotation * self.translation),
        }
    }

    /// `self` after `first`: maps a point of `first`'s source frame by `first`, then by
    /// `self` (`X ↦ self(first(X))`).
    pub fn after(&self, first: &Extrinsics) -> Extrinsics {
        Extrinsics {
            rotation: self.rotation * first.rotation,
            translation: self.rotation * first.translation + self.translation,
        }
    }
}

/// A calibrated camera: intrinsics, distortion and pose in the reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Focal lengths, principal point, image size.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
    /// Reference frame to this camera.
    pub extrinsics: Extrinsics,
}

/// Why a calibration cannot be scaled to images of another size ([`Camera::scaled_to`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScaleError {
    /// The images have no pixels.
    #[error("an image of {width}x{height} pixels")]
    NoPixels {
        /// Their width.
        width: u32,
        /// Their height.
        height: u32,
    },
    /// The images are not the calibrated frame scaled (cropped, or another sensor mode).
    #[error(
        "the calibration is for {}x{} (aspect {:.4}) and the images are {}x{} (aspect {:.4}): \
         not the same frame scaled, so the images were cropped or come from another sensor \
         mode; calibrate at {}x{}",
        calibrated.0, calibrated.1, calibrated.0 as f64 / calibrated.1 as f64,
        images.0, images.1, images.0 as f64 / images.1 as f64, images.0, images.1
    )]
    OtherShape {
        /// The calibration's size.
        calibrated: (u32, u32),
        /// The images' size.
        images: (u32, u32),
    },
    /// The scaled camera is not possible.
    #[error(transparent)]
    Invalid(crate::CoreError),
}

impl Camera {
    /// A camera from its parts, checked ([`Camera::validate`]): the one constructor that
    /// file readers and bindings use, so no camera skips the checks.
    pub fn new(
        intrinsics: Intrinsics,
        distortion: Distortion,
        extrinsics: Extrinsics,
    ) -> CoreResult<Camera> {
        let cam = Camera {
            intrinsics,
            distortion,
            extrinsics,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// A distortion-free camera at the reference pose; checks the numbers.
    ///
    /// ```
    /// use monohand_core::camera::Camera;
    /// let cam = Camera::pinhole(822.79, 822.79, 318.47, 250.31, 640, 480).unwrap();
    /// let px = cam.project(&nalgebra::Vector3::new(0.0, 0.0, 500.0)).unwrap();
    /// assert!((px.x - 318.47).abs() < 1e-9);
    /// ```
    pub fn pinhole(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
    ) -> CoreResult<Camera> {
        Camera::new(
            Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width,
                height,
            },
            Distortion::default(),
            Extrinsics::default(),
        )
    }

    /// OpenCV's fisheye camera (`cv::fisheye`, Kannala-Brandt coefficients `k1 k2 k3 k4`)
    /// at the reference pose; checks the numbers.
    ///
    /// ```
    /// use monohand_core::camera::Camera;
    /// let cam = Camera::fisheye(400.0, 400.0, 639.5, 359.5, 1280, 720, [0.02, -0.005, 0.0, 0.0])
    ///     .unwrap();
    /// assert!((cam.field_of_view_deg() - 180.0).abs() < 0.1);
    /// // Its corners are 104 degrees off the axis: a point 100 degrees off, behind the
    /// // camera's plane, is in the image's bottom right corner.
    /// let px = cam.project(&nalgebra::Vector3::new(858.4, 482.8, -173.6)).unwrap();
    /// assert!(px.x > 1200.0 && px.x < 1280.0 && px.y > 650.0 && px.y < 720.0, "{px}");
    /// // 120 degrees off is past its field.
    /// assert!(cam.project(&nalgebra::Vector3::new(750.0, 420.0, -500.0)).is_none());
    /// ```
    pub fn fisheye(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
        k: [f64; 4],
    ) -> CoreResult<Camera> {
        Camera::new(
            Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width,
                height,
            },
            Distortion::fisheye(k)?,
            Extrinsics::default(),
        )
    }

    /// A camera for footage of unknown origin: principal point at the image centre,
    /// square pixels, horizontal field of view [`GENERIC_HFOV_DEG`].
    pub fn generic(width: u32, height: u32) -> CoreResult<Camera> {
        Camera::with_hfov(width, height, GENERIC_HFOV_DEG)
    }

    /// A camera with square pixels, the principal point at the image centre and this
    /// horizontal field of view (degrees, between 1 and 179).
    pub fn with_hfov(width: u32, height: u32, hfov_deg: f64) -> CoreResult<Camera> {
        if !(hfov_deg.is_finite() && hfov_deg > 1.0 && hfov_deg < 179.0) {
            return Err(CoreError::InvalidCamera(format!(
                "a horizontal field of view of {hfov_deg} degrees (give one between 1 and 179)"
            )));
        }
        let f = 0.5 * width as f64 / (0.5 * hfov_deg.to_radians()).tan();
        Camera::centred(f, width, height)
    }

    /// A camera with square pixels of focal length `f` (pixels) and the principal point
    /// at the image centre (pixel-centre convention), for example from a photo's EXIF.
    pub fn centred(f: f64, width: u32, height: u32) -> CoreResult<Camera> {
        Camera::pinhole(
            f,
            f,
            (width as f64 - 1.0) / 2.0,
            (height as f64 - 1.0) / 2.0,
            width,
            height,
        )
    }

    /// The field of view across the image's longer side, degrees (the one
    /// [`PLAUSIBLE_FOV_DEG`] bounds): twice the angle from the axis at the image's edge
    /// along that side, half the side from the centre. For the pinhole model from the
    /// focal length (the distortion left out); for a fisheye through its model, so that it
    /// may reach 180 degrees and more (NaN if the model folds back before the edge, which
    /// [`Camera::validate`] refuses).
    pub fn field_of_view_deg(&self) -> f64 {
        let k = &self.intrinsics;
        let (side, f) = if k.width >= k.height {
            (k.width, k.fx)
        } else {
            (k.height, k.fy)
        };
        let r = 0.5 * side as f64 / f;
        let half = match self.distortion.model {
            LensModel::Pinhole => r.atan(),
            LensModel::Fisheye => self.distortion.fisheye_angle(r).unwrap_or(f64::NAN),
        };
        2.0 * half.to_degrees()
    }

    /// Why this camera's field of view cannot be a real one, if it is outside
    /// [`PLAUSIBLE_FOV_DEG`] (a fisheye: outside 5 to [`MAX_FISHEYE_FOV_DEG`] degrees).
    pub fn implausible_field_of_view(&self) -> Option<String> {
        let fov = self.field_of_view_deg();
        let (lo, hi) = match self.distortion.model {
            LensModel::Pinhole => (*PLAUSIBLE_FOV_DEG.start(), *PLAUSIBLE_FOV_DEG.end()),
            LensModel::Fisheye => (*PLAUSIBLE_FOV_DEG.start(), MAX_FISHEYE_FOV_DEG),
        };
        let lens = match self.distortion.model {
            LensModel::Pinhole => "",
            LensModel::Fisheye => "fisheye ",
        };
        (!(lo..=hi).contains(&fov)).then(|| {
            format!(
                "a {fov:.1} degree field of view across the longer side, outside the \
                 {lo:.0}-{hi:.0} degrees of real {lens}cameras"
            )
        })
    }

    /// Why a fisheye's lens cannot be this camera's: its model folds back before the
    /// image's edge, or its field of view is past [`MAX_FISHEYE_FOV_DEG`].
    fn check_fisheye_field(&self) -> CoreResult<()> {
        let fold = self
            .distortion
            .fisheye_fold_angle()
            .unwrap_or(std::f64::consts::PI);
        let fov = self.field_of_view_deg();
        if fov.is_nan() {
            return Err(CoreError::InvalidCamera(format!(
                "the fisheye's k1..k4 {:?} make its image radius stop growing {:.1} degrees \
                 from the axis, before the image's edge: not a lens",
                self.distortion.listed(),
                fold.to_degrees()
            )));
        }
        if fov > MAX_FISHEYE_FOV_DEG {
            return Err(CoreError::InvalidCamera(format!(
                "a fisheye of {fov:.1} degrees across the image's longer side: cameras past \
                 {MAX_FISHEYE_FOV_DEG:.0} degrees are not supported"
            )));
        }
        Ok(())
    }

    /// A fisheye's field: the angle from the axis (radians) of the image's farthest
    /// corner, or of its fold if that comes first. Points past 90 degrees are seen up to
    /// it.
    fn fisheye_field_angle(&self) -> f64 {
        let k = &self.intrinsics;
        let dx = (k.cx + 0.5).max(k.width as f64 - 0.5 - k.cx) / k.fx;
        let dy = (k.cy + 0.5).max(k.height as f64 - 0.5 - k.cy) / k.fy;
        let fold = self
            .distortion
            .fisheye_fold_angle()
            .unwrap_or(std::f64::consts::PI);
        self.distortion
            .fisheye_angle(dx.hypot(dy))
            .map_or(fold, |t| t.min(fold))
    }

    /// This camera for the same lens on images of `width` x `height`: the frame scaled as a
    /// whole (focal lengths and principal point times the scale, pixel centres kept at
    /// integers: `c' = (c + 0.5) s - 0.5`; distortion, which is in normalised coordinates,
    /// and the pose unchanged). The aspect ratio must be the same up to one pixel of
    /// rounding on either side; otherwise the error says why the camera cannot describe
    /// these images (cropped, or another sensor mode).
    pub fn scaled_to(&self, width: u32, height: u32) -> Result<Camera, ScaleError> {
        let k = &self.intrinsics;
        if width == 0 || height == 0 {
            return Err(ScaleError::NoPixels { width, height });
        }
        let sx = width as f64 / k.width as f64;
        let sy = height as f64 / k.height as f64;
        // One pixel of rounding on either side of the scaled frame.
        let off_x = (k.width as f64 * sy - width as f64).abs();
        let off_y = (k.height as f64 * sx - height as f64).abs();
        if off_x > 1.0 && off_y > 1.0 {
            return Err(ScaleError::OtherShape {
                calibrated: (k.width, k.height),
                images: (width, height),
            });
        }
        let mut cam = *self;
        cam.intrinsics = Intrinsics {
            fx: k.fx * sx,
            fy: k.fy * sy,
            cx: (k.cx + 0.5) * sx - 0.5,
            cy: (k.cy + 0.5) * sy - 0.5,
            width,
            height,
        };
        cam.validate().map_err(ScaleError::Invalid)?;
        Ok(cam)
    }

    /// Checks that the camera is physically possible.
    pub fn validate(&self) -> CoreResult<()> {
        let k = &self.intrinsics;
        let bad = |m: String| Err(CoreError::InvalidCamera(m));
        if !(k.fx.is_finite() && k.fy.is_finite() && k.fx > 0.0 && k.fy > 0.0) {
            return bad(format!(
                "focal lengths must be positive and finite (fx={}, fy={})",
                k.fx, k.fy
            ));
        }
        if !(k.cx.is_finite() && k.cy.is_finite()) {
            return bad(format!(
                "principal point must be finite (cx={}, cy={})",
                k.cx, k.cy
            ));
        }
        if k.width == 0 || k.height == 0 {
            return bad(format!(
                "image size must be positive ({}x{})",
                k.width, k.height
            ));
        }
        self.distortion.check()?;
        if self.distortion.model == LensModel::Fisheye {
            self.check_fisheye_field()?;
        }
        let r = self.extrinsics.rotation.matrix();
        if r.iter().any(|v| !v.is_finite())
            || self.extrinsics.translation.iter().any(|v| !v.is_finite())
        {
            return bad("extrinsics are not finite".into());
        }
        let ortho = (r.transpose() * r - nalgebra::Matrix3::identity()).norm();
        if ortho > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
            return bad("rotation matrix is not a proper rotation".into());
        }
        Ok(())
    }

    /// Returns this camera with the given extrinsics.
    pub fn with_extrinsics(mut self, extrinsics: Extrinsics) -> Camera {
        self.extrinsics = extrinsics;
        self
    }

    /// Projects a point given in this camera's own frame through its lens. `None` where
    /// the camera does not see it: for the pinhole model behind the camera (`z <= 1e-9`);
    /// for a fisheye on its axis behind it, or 90 degrees or more off its axis and past its
    /// field (the angle of the image's farthest corner).
    pub fn project_cam(&self, x: &Vector3<f64>) -> Option<Point2<f64>> {
        let n = match self.distortion.model {
            LensModel::Pinhole => {
                if x.z <= 1e-9 {
                    return None;
                }
                self.distortion.distort(Vector2::new(x.x / x.z, x.y / x.z))
            }
            LensModel::Fisheye => self.fisheye_normalised(x)?.0,
        };
        let k = &self.intrinsics;
        Some(Point2::new(k.fx * n.x + k.cx, k.fy * n.y + k.cy))
    }

    /// A fisheye's normalised point of a camera-frame point with its Jacobian, `None`
    /// past its field.
    #[inline]
    fn fisheye_normalised(&self, x: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        if x.z <= 0.0 && x.x.hypot(x.y).atan2(x.z) > self.fisheye_field_angle() {
            return None;
        }
        self.distortion.project_with_jacobian(x)
    }

    /// Projects a camera-frame point through the lens, with the 2x3 Jacobian of the pixel
    /// with respect to the point: what the fit linearises. `None` where
    /// [`Camera::project_cam`] is `None`. The ideal pinhole (no distortion) is
    /// [`Camera::pinhole_project_with_jacobian`] exactly.
    #[inline]
    pub fn project_with_jacobian(
        &self,
        x: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        if self.distortion.is_ideal() {
            return (x.z > 1e-9).then(|| self.pinhole_project_with_jacobian(x));
        }
        let (n, j) = match self.distortion.model {
            LensModel::Pinhole => self.distortion.project_with_jacobian(x)?,
            LensModel::Fisheye => self.fisheye_normalised(x)?,
        };
        let k = &self.intrinsics;
        let f = nalgebra::Matrix2::new(k.fx, 0.0, 0.0, k.fy);
        Some((Vector2::new(k.fx * n.x + k.cx, k.fy * n.y + k.cy), f * j))
    }

    /// Projects a reference-frame point into this camera's image (distortion applied).
    pub fn project(&self, x_ref: &Vector3<f64>) -> Option<Point2<f64>> {
        self.project_cam(&self.extrinsics.transform(x_ref))
    }

    /// Maps an observed (distorted) pixel to the pixel an ideal pinhole camera with
    /// the same intrinsics would have seen. `None` for a fisheye's pixel that no pinhole
    /// sees (90 degrees or more off the axis, or past the lens's reach): use
    /// [`Camera::ray`] for those.
    pub fn undistort_pixel(&self, px: Point2<f64>) -> Option<Point2<f64>> {
        if self.distortion.is_ideal() {
            return Some(px);
        }
        let k = &self.intrinsics;
        let d = Vector2::new((px.x - k.cx) / k.fx, (px.y - k.cy) / k.fy);
        let n = self.distortion.undistort(d)?;
        Some(Point2::new(k.fx * n.x + k.cx, k.fy * n.y + k.cy))
    }

    /// Ideal pinhole projection of a camera-frame point and its 2x3 Jacobian.
    #[inline]
    pub fn pinhole_project_with_jacobian(
        &self,
        x: &Vector3<f64>,
    ) -> (Vector2<f64>, Matrix2x3<f64>) {
        let k = &self.intrinsics;
        let iz = 1.0 / x.z;
        let u = k.fx * x.x * iz + k.cx;
        let v = k.fy * x.y * iz + k.cy;
        let j = Matrix2x3::new(
            k.fx * iz,
            0.0,
            -k.fx * x.x * iz * iz,
            0.0,
            k.fy * iz,
            -k.fy * x.y * iz * iz,
        );
        (Vector2::new(u, v), j)
    }

    /// Back-projects a pixel (distorted) to a unit ray in this camera's frame, through the
    /// lens: a fisheye's rays may point 90 degrees or more off its axis (`z <= 0`). `None`
    /// for a fisheye's pixel past the largest radius its lens reaches.
    pub fn ray(&self, px: Point2<f64>) -> Option<Vector3<f64>> {
        let k = &self.intrinsics;
        if self.distortion.is_ideal() {
            let d = Vector3::new((px.x - k.cx) / k.fx, (px.y - k.cy) / k.fy, 1.0);
            return Some(d.normalize());
        }
        self.distortion
            .ray(Vector2::new((px.x - k.cx) / k.fx, (px.y - k.cy) / k.fy))
    }

    /// Position of this camera's centre in the reference frame.
    pub fn centre(&self) -> Vector3<f64> {
        -(self.extrinsics.rotation.inverse() * self.extrinsics.translation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn distortion_round_trip() {
        let d = Distortion::from_slice(&[0.1868, -1.3734, 0.001, -0.002, 2.668]).unwrap();
        for &(x, y) in &[(0.0, 0.0), (0.2, -0.1), (-0.3, 0.25)] {
            let p = Vector2::new(x, y);
            let back = d.undistort(d.distort(p)).unwrap();
            assert!((back - p).norm() < 1e-9, "{p:?} -> {back:?}");
        }
        assert!(Distortion::from_slice(&[1.0, 2.0, 3.0]).is_err());
    }

    #[test]
    fn generic_camera_field_of_view() {
        let cam = Camera::generic(640, 480).unwrap();
        let hfov = 2.0 * (320.0 / cam.intrinsics.fx).atan();
        assert!((hfov.to_degrees() - GENERIC_HFOV_DEG).abs() < 1e-9);
    }

    #[test]
    fn field_of_view_is_across_the_longer_side() {
        // The generic camera: 60 degrees across a landscape image; a portrait one is wider
        // along its height.
        let land = Camera::generic(640, 480).unwrap();
        assert!((land.field_of_view_deg() - 60.0).abs() < 1e-9);
        assert!(land.implausible_field_of_view().is_none());
        let portrait = Camera::generic(480, 640).unwrap();
        let want = 2.0 * (320.0 / portrait.intrinsics.fy).atan().to_degrees();
        assert!((portrait.field_of_view_deg() - want).abs() < 1e-9);
        // A resized photo's focal plane resolution read against the small image: 2.3 degrees.
        let tele = Camera::centred(21237.3, 848, 565).unwrap();
        let why = tele.implausible_field_of_view().unwrap();
        assert!(why.contains("2.3 degree") && why.contains("5-150"), "{why}");
        let fisheye = Camera::centred(50.0, 848, 565).unwrap();
        assert!(fisheye.implausible_field_of_view().is_some());
    }

    #[test]
    fn scaling_keeps_the_frame_and_refuses_another_aspect() {
        let cal = Camera::pinhole(1400.0, 1390.0, 959.5, 539.5, 1920, 1080)
            .unwrap()
            .with_extrinsics(Extrinsics {
                rotation: Rotation3::from_euler_angles(0.1, 0.0, 0.0),
                translation: Vector3::new(-120.0, 0.0, 0.0),
            });
        // 1920x1080 -> 848x477: 477 is 1080 x 0.4417 rounded (477.0), the same frame.
        let s = cal.scaled_to(848, 477).unwrap();
        let k = s.intrinsics;
        let sx = 848.0 / 1920.0;
        assert!((k.fx - 1400.0 * sx).abs() < 1e-9);
        assert!((k.fy - 1390.0 * 477.0 / 1080.0).abs() < 1e-9);
        // The centred principal point stays centred: (w - 1) / 2.
        assert!((k.cx - 423.5).abs() < 1e-9 && (k.cy - 238.0).abs() < 1e-9);
        assert_eq!((k.width, k.height), (848, 477));
        assert_eq!(s.extrinsics, cal.extrinsics);
        assert_eq!(s.distortion, cal.distortion);
        // The same size is the same camera.
        assert_eq!(cal.scaled_to(1920, 1080).unwrap(), cal);
        // 4:3 frames from a 16:9 calibration: cropped or another mode, refused with why.
        let e = cal.scaled_to(640, 480).unwrap_err().to_string();
        assert!(e.contains("1920x1080") && e.contains("640x480"), "{e}");
        assert!(cal.scaled_to(0, 480).is_err());
    }

    #[test]
    fn extrinsics_invert_and_compose() {
        let a = Extrinsics {
            rotation: Rotation3::from_euler_angles(0.3, -1.2, 2.0),
            translation: Vector3::new(-400.0, 20.0, 310.0),
        };
        let b = Extrinsics {
            rotation: Rotation3::from_euler_angles(-0.7, 0.1, 0.4),
            translation: Vector3::new(5.0, -60.0, 80.0),
        };
        let x = Vector3::new(12.0, -30.0, 650.0);
        assert!((a.inverse().transform(&a.transform(&x)) - x).norm() < 1e-9);
        assert!((b.after(&a).transform(&x) - b.transform(&a.transform(&x))).norm() < 1e-9);
        let id = a.after(&a.inverse());
        assert!((id.rotation.matrix() - Matrix3::identity()).norm() < 1e-12);
        assert!(id.translation.norm() < 1e-9);
    }

    /// The issue's fisheye: 150 degrees across 1280x720, k = (0.02, -0.005, 0, 0).
    fn wide_fisheye() -> Camera {
        // theta_d at 75 degrees: the focal length that puts it at the image's edge.
        let t = 75f64.to_radians();
        let f = 640.0 / (t * (1.0 + 0.02 * t * t - 0.005 * t.powi(4)));
        Camera::fisheye(f, f, 639.5, 359.5, 1280, 720, [0.02, -0.005, 0.0, 0.0]).unwrap()
    }

    #[test]
    fn a_fisheyes_field_of_view_comes_from_its_model() {
        let cam = wide_fisheye();
        assert!(
            (cam.field_of_view_deg() - 150.0).abs() < 1e-9,
            "{}",
            cam.field_of_view_deg()
        );
        // Past 150 degrees, but a fisheye's own calibration: no warning up to 180.
        assert!(cam.implausible_field_of_view().is_none());
        let k = cam.intrinsics;
        // A pinhole of the same focal length would be 106 degrees.
        let pinhole = Camera::pinhole(k.fx, k.fy, k.cx, k.cy, 1280, 720).unwrap();
        assert!((pinhole.field_of_view_deg() - 106.314).abs() < 1e-3);
        // Scaling keeps the model and the field of view.
        let half = cam.scaled_to(640, 360).unwrap();
        assert_eq!(half.distortion, cam.distortion);
        assert!((half.field_of_view_deg() - 150.0).abs() < 0.2);
        // Past 180 degrees: refused, with the reason.
        let e = Camera::fisheye(
            300.0,
            300.0,
            639.5,
            359.5,
            1280,
            720,
            [0.02, -0.005, 0.0, 0.0],
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("cameras past 180 degrees are not supported"),
            "{e}"
        );
        assert!(e.contains("a fisheye of 24"), "{e}");
        // A model that folds back before the image's edge is no lens.
        let e = Camera::fisheye(300.0, 300.0, 639.5, 359.5, 1280, 720, [-0.3, 0.0, 0.0, 0.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("stop growing 60.4 degrees"), "{e}");
        // Coefficients past the fisheye's four.
        let mut bad = cam;
        bad.distortion.coeffs[4] = 0.1;
        assert!(bad.validate().is_err());
    }

    #[test]
    fn a_fisheye_projects_past_90_degrees_within_its_field() {
        let cam = wide_fisheye();
        let k = cam.intrinsics;
        // Every pixel's ray projects back onto it, the corners (86 degrees) included.
        for (u, v) in [(639.5, 359.5), (0.0, 0.0), (1279.0, 719.0), (100.0, 650.0)] {
            let ray = cam.ray(Point2::new(u, v)).unwrap();
            let back = cam.project_cam(&(ray * 500.0)).unwrap();
            assert!(
                (back - Point2::new(u, v)).norm() < 1e-9,
                "({u}, {v}): {back}"
            );
        }
        // A wider fisheye: 178 degrees across, its corners 102 degrees off the axis.
        let t = 89f64.to_radians();
        let f = 640.0 / (t * (1.0 + 0.02 * t * t - 0.005 * t.powi(4)));
        let wide =
            Camera::fisheye(f, f, 639.5, 359.5, 1280, 720, [0.02, -0.005, 0.0, 0.0]).unwrap();
        let corner = wide.ray(Point2::new(-0.5, -0.5)).unwrap();
        assert!(corner.z < 0.0, "{corner}");
        let behind = Vector3::new(-400.0, -225.0, -50.0);
        let px = wide.project_cam(&behind).unwrap();
        assert!(px.x > 0.0 && px.y > 0.0 && px.x < 100.0, "{px}");
        assert!((wide.ray(px).unwrap() - behind.normalize()).norm() < 1e-12);
        // It has no pinhole pixel.
        assert!(wide.undistort_pixel(px).is_none());
        // Beyond the corners' angle it is not seen; straight behind, never.
        assert!(wide
            .project_cam(&Vector3::new(-400.0, -225.0, -400.0))
            .is_none());
        assert!(cam.project_cam(&behind).is_none());
        assert!(wide.project_cam(&Vector3::new(0.0, 0.0, -10.0)).is_none());
        // The ideal pinhole pixel of a pixel under 90 degrees.
        let ideal = cam.undistort_pixel(Point2::new(1000.0, 500.0)).unwrap();
        let ray = cam.ray(Point2::new(1000.0, 500.0)).unwrap();
        assert!((ideal.x - (k.fx * ray.x / ray.z + k.cx)).abs() < 1e-9);
    }

    #[test]
    fn projection_jacobians_are_the_lens_models_through_the_intrinsics() {
        let fisheye = wide_fisheye();
        let mut radtan = Camera::pinhole(800.0, 790.0, 320.0, 240.0, 640, 480).unwrap();
        radtan.distortion = Distortion::from_slice(&[-0.28, 0.07, 1e-3, -5e-4, 0.02]).unwrap();
        let ideal = Camera::pinhole(800.0, 790.0, 320.0, 240.0, 640, 480).unwrap();
        let x = Vector3::new(120.0, -80.0, 450.0);
        for cam in [fisheye, radtan, ideal] {
            let (uv, j) = cam.project_with_jacobian(&x).unwrap();
            assert_eq!(uv, cam.project_cam(&x).unwrap().coords);
            // Central differences (the lens models' own are checked against num-dual).
            for c in 0..3 {
                let mut dx = Vector3::zeros();
                dx[c] = 1e-4;
                let num = (cam.project_cam(&(x + dx)).unwrap()
                    - cam.project_cam(&(x - dx)).unwrap())
                    / 2e-4;
                assert!(
                    (num - j.column(c)).norm() < 1e-6 * j.amax(),
                    "{c}: {num} {j}"
                );
            }
        }
        // The ideal pinhole's is the pinhole's, to the bit.
        assert_eq!(
            ideal.project_with_jacobian(&x).unwrap(),
            ideal.pinhole_project_with_jacobian(&x)
        );
        assert!(ideal
            .project_with_jacobian(&Vector3::new(1.0, 1.0, -1.0))
            .is_none());
    }

    #[test]
    fn impossible_cameras_rejected() {
        assert!(Camera::pinhole(-1.0, 1.0, 0.0, 0.0, 10, 10).is_err());
        assert!(Camera::pinhole(f64::NAN, 1.0, 0.0, 0.0, 10, 10).is_err());
        assert!(Camera::pinhole(1.0, 1.0, 0.0, 0.0, 0, 10).is_err());
        let mut cam = Camera::pinhole(1.0, 1.0, 0.0, 0.0, 10, 10).unwrap();
        cam.extrinsics.rotation =
            Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_diagonal_element(2.0));
        assert!(cam.validate().is_err());
    }

    #[test]
    fn stereo_baseline_projection() {
        // STB convention: right camera = left translated by +120 mm along x.
        let left = Camera::pinhole(822.79, 822.79, 318.47, 250.31, 640, 480).unwrap();
        let right = left.with_extrinsics(Extrinsics {
            rotation: Rotation3::identity(),
            translation: Vector3::new(-120.054, 0.0, 0.0),
        });
        let x = Vector3::new(100.0, 20.0, 650.0);
        let disparity = left.project(&x).unwrap().x - right.project(&x).unwrap().x;
        assert!((disparity - 822.79 * 120.054 / 650.0).abs() < 1e-9);
        assert!((right.centre() - Vector3::new(120.054, 0.0, 0.0)).norm() < 1e-12);
    }
}
