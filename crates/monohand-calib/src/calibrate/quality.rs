//! The warnings of a calibration: too few views, too flat, too central, an uncertain focal
//! length; and its uncertainty from the solver's covariance.

use super::projection::{Pose, N_INTR};
use super::solver::Solved;
use super::{CalibWarning, IntrinsicsStd};
use nalgebra::Point2;

/// Views recommended. The focal length's standard deviation falls roughly as `1/sqrt(N)`
/// and OpenCV's and Zhang's guidance is 10-20 varied views; below 10 a 1% focal error is
/// common even on a good rig.
pub const RECOMMENDED_VIEWS: usize = 10;

/// Largest board tilt (degrees, board normal against the optical axis) below which the
/// views are "too flat". The focal length is told from the distance only through the
/// foreshortening of a tilted board: face-on, `f` and `z` scale together and only `f/z` is
/// seen. Zhang's analysis and OpenCV's guidance want tilts of 20-45 degrees; under 15
/// degrees the foreshortening across a 9x6 board at typical distances is a pixel or two and
/// the focal length is poorly determined.
pub const MIN_TILT_DEG: f64 = 15.0;

/// The image is divided into this grid of cells (columns, rows) to measure the corners'
/// coverage.
pub const COVERAGE_GRID: (usize, usize) = (8, 6);

/// Fraction of [`COVERAGE_GRID`]'s cells that must see a corner. The distortion grows with
/// the radius (k1 r^2, k2 r^4, k3 r^6): with corners only in the middle half of the image
/// the high-order terms are extrapolated at the edges, where a hand near the border is.
pub const MIN_COVERAGE: f64 = 0.5;

/// `sigma(f) / f` above which the focal length is "uncertain": a hand's depth is as
/// uncertain in relative terms (1% is 5 mm at 50 cm), the size of a finger's width error
/// the rest of the pipeline already has.
pub const MAX_RELATIVE_FOCAL_STD: f64 = 0.01;

/// One standard deviation of each intrinsic from the solve: `s^2 (J^T J)^-1` with
/// `s^2 = SSE / (2 N_corners - N_params)`, for camera `cam`'s 12 globals (infinite where
/// the normal equations were singular, zero for the fixed ones).
pub(crate) fn intrinsics_std(solved: &Solved, n_corners: usize, cam: usize) -> IntrinsicsStd {
    let dof = (2 * n_corners).saturating_sub(solved.n_params).max(1) as f64;
    let s2 = solved.sse / dof;
    let mut std = [0.0; N_INTR];
    for (c, &gi) in solved.free.iter().enumerate() {
        if gi / N_INTR == cam && gi < N_INTR * solved.state.intr.len() {
            std[gi % N_INTR] = match &solved.cov {
                Some(cov) => (s2 * cov[(c, c)].max(0.0)).sqrt(),
                None => f64::INFINITY,
            };
        }
    }
    IntrinsicsStd {
        fx: std[0],
        fy: std[1],
        cx: std[2],
        cy: std[3],
        distortion: [
            std[4], std[5], std[6], std[7], std[8], std[9], std[10], std[11],
        ],
    }
}

/// The warnings for a camera from its used views' board poses (in the camera) and corners.
pub(crate) fn warnings<'a>(
    poses: &[Pose],
    corners: impl Iterator<Item = &'a [Point2<f64>]>,
    size: (u32, u32),
    focal: (f64, f64),
    std: &IntrinsicsStd,
) -> Vec<CalibWarning> {
    let mut out = Vec::new();
    if poses.len() < RECOMMENDED_VIEWS {
        out.push(CalibWarning::TooFewViews {
            used: poses.len(),
            recommended: RECOMMENDED_VIEWS,
        });
    }
    let max_tilt_deg = poses
        .iter()
        .map(|p| p.r.matrix()[(2, 2)].abs().min(1.0).acos().to_degrees())
        .fold(0.0f64, f64::max);
    if max_tilt_deg < MIN_TILT_DEG {
        out.push(CalibWarning::TooFlat { max_tilt_deg });
    }
    let coverage = coverage(corners, size);
    if coverage < MIN_COVERAGE {
        out.push(CalibWarning::TooCentral { coverage });
    }
    let relative = (std.fx / focal.0).max(std.fy / focal.1);
    if relative.is_nan() || relative > MAX_RELATIVE_FOCAL_STD {
        out.push(CalibWarning::UncertainFocal { relative });
    }
    out
}

/// Fraction of the image's [`COVERAGE_GRID`] cells that hold at least one corner.
pub(crate) fn coverage<'a>(
    corners: impl Iterator<Item = &'a [Point2<f64>]>,
    size: (u32, u32),
) -> f64 {
    let (gc, gr) = COVERAGE_GRID;
    let mut seen = [[false; COVERAGE_GRID.0]; COVERAGE_GRID.1];
    let (w, h) = (size.0 as f64, size.1 as f64);
    for p in corners.flatten() {
        if p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h {
            let c = ((p.x / w * gc as f64) as usize).min(gc - 1);
            let r = ((p.y / h * gr as f64) as usize).min(gr - 1);
            seen[r][c] = true;
        }
    }
    seen.iter().flatten().filter(|&&s| s).count() as f64 / (gc * gr) as f64
}
