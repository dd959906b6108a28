//! A camera's intrinsics, distortion and view poses from chessboard corners (Zhang's
//! closed form, then Levenberg-Marquardt), and the poses between the cameras of a rig.
//!
//! As OpenCV's `calibrateCamera` computes it: per view a normalised-DLT homography; the
//! focal lengths from the homographies with the principal point at the image centre
//! (`initIntrinsicParams2D`); each view's pose from `K^-1 H`; then a Levenberg-Marquardt
//! refinement of the intrinsics, the distortion (5 or 8 coefficients) and every view's pose
//! together, with analytic Jacobians and the board poses eliminated by a Schur complement.
//! Views far worse than the median are dropped and the solve redone. The standard deviations
//! are OpenCV's `stdDeviationsIntrinsics` (`s^2 (J^T J)^-1`). On OpenCV's stereo sample the
//! results equal OpenCV's (`tests/calibrate.rs`).
//!
//! [`DistortionModel::Fisheye`] is OpenCV's `cv::fisheye::calibrate` (with
//! `CALIB_RECOMPUTE_EXTRINSIC | CALIB_FIX_SKEW`): the Kannala-Brandt model of
//! `monohand_core::camera::LensModel::Fisheye` with k1..k4. Its start is the principal point
//! at the centre and an equidistant lens (`k = 0`) whose focal length fits the views best,
//! each view's pose from the homography of its corners undistorted by that lens; then the
//! same refinement. On OpenCV's stereo sample it equals `cv2.fisheye.calibrate` and
//! `cv2.fisheye.stereoCalibrate` on the same corners (`tests/fisheye.rs`).
//!
//! A rig ([`calibrate_rig`]) is each camera calibrated alone, the cameras placed from the
//! instants they share (chordal mean of the rotations, median of the translations), then one
//! joint refinement as `cv::stereoCalibrate` (with or without its intrinsics, see
//! [`CalibrateOptions::refine_rig_intrinsics`]).

use crate::board::Board;
use crate::error::CalibResult;
use monohand_core::camera::{Camera, Extrinsics, LensModel};
use nalgebra::Point2;

/// The lens distortion estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DistortionModel {
    /// OpenCV's default five coefficients: k1 k2 p1 p2 k3.
    #[default]
    Standard,
    /// OpenCV's rational model, eight coefficients: k1 k2 p1 p2 k3 k4 k5 k6.
    Rational,
    /// OpenCV's fisheye model (`cv::fisheye`, Kannala-Brandt), four coefficients of the
    /// angle from the axis: k1 k2 k3 k4 (no tangential terms, no skew). For lenses wider
    /// than about 120 degrees, where the pinhole's polynomial in `tan(theta)` cannot follow.
    Fisheye,
}

impl std::str::FromStr for DistortionModel {
    type Err = String;

    /// `standard`, `rational` or `fisheye`, as the command line and Python name them.
    fn from_str(s: &str) -> Result<DistortionModel, String> {
        match s {
            "standard" => Ok(DistortionModel::Standard),
            "rational" => Ok(DistortionModel::Rational),
            "fisheye" => Ok(DistortionModel::Fisheye),
            other => Err(format!("{other:?} is not standard, rational or fisheye")),
        }
    }
}

impl DistortionModel {
    /// The lens model the calibration's camera has: [`LensModel::Fisheye`] for
    /// [`DistortionModel::Fisheye`], [`LensModel::Pinhole`] for the others.
    pub fn lens(self) -> LensModel {
        match self {
            DistortionModel::Standard | DistortionModel::Rational => LensModel::Pinhole,
            DistortionModel::Fisheye => LensModel::Fisheye,
        }
    }
}

/// Options of a calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrateOptions {
    /// The distortion estimated.
    pub model: DistortionModel,
    /// A view whose RMS reprojection error exceeds this many times the median view's
    /// (and 1 px) is dropped and the calibration redone without it; `f64::INFINITY` keeps
    /// every view (as OpenCV's `calibrateCamera`).
    pub outlier_factor: f64,
    /// Levenberg-Marquardt iterations at most.
    pub max_iterations: usize,
    /// In [`calibrate_rig`], whether the joint refinement also refines each camera's
    /// intrinsics and distortion (as `cv::stereoCalibrate` without `CALIB_FIX_INTRINSIC`),
    /// or keeps each camera's own calibration and refines only the poses (with it).
    pub refine_rig_intrinsics: bool,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions {
            model: DistortionModel::Standard,
            outlier_factor: 3.0,
            max_iterations: 100,
            refine_rig_intrinsics: true,
        }
    }
}

/// One view of the board: its corners in board order, pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardView {
    /// What the view is called in reports (a file name, `frame 120`, ...).
    pub name: String,
    /// The board's corners in [`Board::object_points`] order, pixels.
    pub corners: Vec<Point2<f64>>,
}

/// What became of one view.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResult {
    /// The view's name.
    pub name: String,
    /// The board's pose in the camera: `X_cam = R X_board + t`, millimetres (the identity
    /// for a view that never entered a solve).
    pub board_pose: Extrinsics,
    /// RMS reprojection error of its corners, pixels (per corner, Euclidean, as OpenCV's);
    /// NaN for a view that never entered a solve (no homography).
    pub rms_px: f64,
    /// `None` if the view was used; otherwise why it was dropped.
    pub dropped: Option<String>,
}

/// One standard deviation of each estimated number, from the solver's covariance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IntrinsicsStd {
    /// Focal length x, pixels.
    pub fx: f64,
    /// Focal length y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Distortion coefficients in [`monohand_core::camera::Distortion::coeffs`]' order (the
    /// pinhole's k1 k2 p1 p2 k3 k4 k5 k6, the fisheye's k1 k2 k3 k4; zero where fixed).
    pub distortion: [f64; 8],
}

/// A warning about a calibration that is computed but may not be trusted.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibWarning {
    /// Fewer views than a trustworthy focal length needs.
    TooFewViews {
        /// Views used.
        used: usize,
        /// Views recommended.
        recommended: usize,
    },
    /// The board was seen nearly face-on in every view: the focal length is poorly
    /// determined. `max_tilt_deg` is the largest tilt seen.
    TooFlat {
        /// The largest angle between the board's normal and the optical axis, degrees.
        max_tilt_deg: f64,
    },
    /// The corners covered only the middle of the image: the distortion is guessed at the
    /// edges. `coverage` is the fraction of the image's cells that saw a corner.
    TooCentral {
        /// Fraction (0-1) of a grid of the image's cells that saw at least one corner.
        coverage: f64,
    },
    /// The focal length's standard deviation is large: `relative` of its value.
    UncertainFocal {
        /// sigma(f) / f.
        relative: f64,
    },
}

impl std::fmt::Display for CalibWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CalibWarning::TooFewViews { used, recommended } => write!(
                f,
                "only {used} views were used; {recommended} or more give a focal length to trust"
            ),
            CalibWarning::TooFlat { max_tilt_deg } => write!(
                f,
                "the board was never tilted more than {max_tilt_deg:.0} degrees: tilt it 20-45 degrees in some views, or the focal length cannot be told from the distance"
            ),
            CalibWarning::TooCentral { coverage } => write!(
                f,
                "the corners covered {:.0}% of the image: show the board near the edges and corners too, or the distortion there is guessed",
                coverage * 100.0
            ),
            CalibWarning::UncertainFocal { relative } => write!(
                f,
                "the focal length is uncertain by {:.1}% (one standard deviation): a hand's depth is as uncertain",
                relative * 100.0
            ),
        }
    }
}

/// One camera's calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraCalibration {
    /// The camera: intrinsics, distortion; extrinsics identity (or, in a rig, from the
    /// first camera to this one).
    pub camera: Camera,
    /// RMS reprojection error over the used views' corners, pixels: OpenCV's
    /// `sqrt(sum |e|^2 / N_corners)` (per corner, Euclidean; noise of sigma per coordinate
    /// gives about sigma sqrt 2).
    pub rms_px: f64,
    /// Every view given, in order, with its pose and error or why it was dropped.
    pub views: Vec<ViewResult>,
    /// One standard deviation of the intrinsics and distortion.
    pub std: IntrinsicsStd,
    /// Reasons not to trust the result fully.
    pub warnings: Vec<CalibWarning>,
}

impl CameraCalibration {
    /// Number of views used.
    pub fn used_views(&self) -> usize {
        self.views.iter().filter(|v| v.dropped.is_none()).count()
    }

    /// One standard deviation of a hand's depth at `z_mm` from the focal length's
    /// uncertainty alone, millimetres: a depth from a known size scales with the focal
    /// length, `sigma_z = z sigma_f / f`, with `sigma_f / f` the mean of fx's and fy's.
    pub fn depth_std_mm(&self, z_mm: f64) -> f64 {
        let k = &self.camera.intrinsics;
        z_mm * 0.5 * (self.std.fx / k.fx + self.std.fy / k.fy)
    }
}

/// Calibrates one camera from views of `board` in images `width` x `height`.
pub fn calibrate_camera(
    board: &Board,
    views: &[BoardView],
    width: u32,
    height: u32,
    options: &CalibrateOptions,
) -> CalibResult<CameraCalibration> {
    single::calibrate(board, views, (width, height), options)
}

/// A rig's calibration: each camera's, with extrinsics from the first camera's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCalibration {
    /// One calibration per camera, in the order given; `cameras[0]` has the identity
    /// extrinsics and each other camera `X_k = R X_0 + t` (mm).
    pub cameras: Vec<CameraCalibration>,
    /// RMS reprojection error of the joint refinement over all cameras' corners, pixels.
    pub rms_px: f64,
    /// For each camera after the first, the number of instants where it and another
    /// already-placed camera saw the board together.
    pub shared_views: Vec<usize>,
}

/// Calibrates a rig: `views[k][i]` is camera `k`'s view at instant `i` (`None` where it did
/// not see the whole board); all cameras have the same number of instants. Each camera is
/// calibrated alone, then the poses between them are estimated from the instants that
/// several cameras saw, and everything is refined jointly.
pub fn calibrate_rig(
    board: &Board,
    views: &[Vec<Option<BoardView>>],
    sizes: &[(u32, u32)],
    options: &CalibrateOptions,
) -> CalibResult<RigCalibration> {
    rig::calibrate(board, views, sizes, options)
}

mod init;
mod projection;
mod quality;
mod rig;
mod single;
mod solver;

pub use quality::{
    COVERAGE_GRID, MAX_RELATIVE_FOCAL_STD, MIN_COVERAGE, MIN_TILT_DEG, RECOMMENDED_VIEWS,
};
pub use single::MIN_VIEWS;
