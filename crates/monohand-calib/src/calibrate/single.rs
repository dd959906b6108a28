//! One camera's calibration: closed-form start, LM, outlier views, uncertainty, warnings.

use super::init::{fisheye_start, focal_from_homographies, homography, pose_from_homography};
use super::projection::{Intr, Pose, N_INTR};
use super::quality::{intrinsics_std, warnings};
use super::solver::{errors, solve, Problem, Solved, State};
use super::{BoardView, CalibrateOptions, CameraCalibration, DistortionModel, ViewResult};
use crate::board::Board;
use crate::error::{CalibError, CalibResult};
use monohand_core::camera::{Camera, Distortion, Extrinsics, Intrinsics, LensModel};
use nalgebra::{Matrix3, Vector3};

/// Views a calibration needs at least.
pub const MIN_VIEWS: usize = 3;

/// Checks the views against the board (corner counts, finite corners) and the options.
pub(crate) fn check_inputs<'a>(
    board: &Board,
    views: impl Iterator<Item = &'a BoardView>,
    size: (u32, u32),
    options: &CalibrateOptions,
) -> CalibResult<()> {
    if size.0 == 0 || size.1 == 0 {
        return Err(CalibError::Inconsistent(format!(
            "an image of {}x{} pixels",
            size.0, size.1
        )));
    }
    if options.outlier_factor.is_nan() || options.outlier_factor <= 1.0 {
        return Err(CalibError::Inconsistent(format!(
            "outlier factor {} (give a number above 1, or infinity to keep every view)",
            options.outlier_factor
        )));
    }
    for v in views {
        if v.corners.len() != board.len() {
            return Err(CalibError::Inconsistent(format!(
                "view {:?} has {} corners, the {}x{} board {}",
                v.name,
                v.corners.len(),
                board.cols,
                board.rows,
                board.len()
            )));
        }
        if let Some(i) = v
            .corners
            .iter()
            .position(|p| !(p.x.is_finite() && p.y.is_finite()))
        {
            return Err(CalibError::Inconsistent(format!(
                "view {:?}: corner {i} is not a finite pixel ({}, {})",
                v.name, v.corners[i].x, v.corners[i].y
            )));
        }
    }
    Ok(())
}

/// Which of a camera's 12 intrinsics are estimated under `model`: fx fy cx cy, then the
/// model's coefficients (the pinhole's k1 k2 p1 p2 k3 [k4 k5 k6], the fisheye's k1..k4).
pub(crate) fn free_intrinsics(model: DistortionModel) -> [bool; N_INTR] {
    let n = match model {
        DistortionModel::Standard => 9,
        DistortionModel::Rational => 12,
        DistortionModel::Fisheye => 8,
    };
    std::array::from_fn(|i| i < n)
}

/// The packed intrinsics of a camera of lens model `lens` as a validated camera with
/// `extrinsics` (a fisheye's coefficients past its four are dropped: they are held at zero).
pub(crate) fn to_camera(
    lens: LensModel,
    p: &Intr,
    size: (u32, u32),
    extrinsics: Extrinsics,
) -> CalibResult<Camera> {
    let mut coeffs = [p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11]];
    if lens == LensModel::Fisheye {
        coeffs[4..].fill(0.0);
    }
    Camera::new(
        Intrinsics {
            fx: p[0],
            fy: p[1],
            cx: p[2],
            cy: p[3],
            width: size.0,
            height: size.1,
        },
        Distortion {
            model: lens,
            coeffs,
        },
        extrinsics,
    )
    .map_err(|e| CalibError::Failed(format!("the estimate is not a camera: {e}")))
}

/// A pose as the project's extrinsics.
pub(crate) fn to_extrinsics(p: &Pose) -> Extrinsics {
    Extrinsics {
        rotation: p.r,
        translation: p.t,
    }
}

/// The closed-form start: each view's homography (a view without one is dropped with the
/// reason), the focal lengths with the principal point at the centre, each view's pose.
fn closed_form(
    object: &[Vector3<f64>],
    views: &[BoardView],
    size: (u32, u32),
    dropped: &mut [Option<String>],
) -> (Intr, Vec<Option<Pose>>) {
    let hs: Vec<Option<Matrix3<f64>>> = views
        .iter()
        .zip(dropped.iter_mut())
        .map(|(v, d)| match homography(object, &v.corners) {
            Ok(h) => Some(h),
            Err(e) => {
                *d = Some(format!("no homography: {e}"));
                None
            }
        })
        .collect();
    let (w, h) = (size.0 as f64, size.1 as f64);
    let (cx, cy) = ((w - 1.0) / 2.0, (h - 1.0) / 2.0);
    let side = w.max(h);
    let plausible = |f: f64| f > 0.1 * side && f < 20.0 * side;
    let usable: Vec<Matrix3<f64>> = hs.iter().flatten().copied().collect();
    // Face-on views do not determine the focal length: start from a 60 degree field of view.
    let generic = 0.5 * w / (30.0f64).to_radians().tan();
    let (fx, fy) = focal_from_homographies(&usable, cx, cy)
        .filter(|&(fx, fy)| plausible(fx) && plausible(fy))
        .unwrap_or((generic, generic));
    let k = Matrix3::new(fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0);
    let poses = hs
        .iter()
        .zip(dropped.iter_mut())
        .map(|(h, d)| {
            let pose = pose_from_homography(&k, h.as_ref()?);
            if pose.is_none() {
                *d = Some("no pose from the homography (the board behind the camera?)".into());
            }
            pose
        })
        .collect();
    let mut intr = [0.0; N_INTR];
    intr[..4].copy_from_slice(&[fx, fy, cx, cy]);
    (intr, poses)
}

/// The fisheye's start ([`fisheye_start`]): the principal point at the centre, an
/// equidistant lens's focal length (the best of a ladder and of Zhang's on the raw corners)
/// and each view's pose under it; a view without one is dropped with the reason.
fn fisheye_closed_form(
    object: &[Vector3<f64>],
    views: &[BoardView],
    size: (u32, u32),
    dropped: &mut [Option<String>],
) -> (Intr, Vec<Option<Pose>>) {
    let (w, h) = (size.0 as f64, size.1 as f64);
    let (cx, cy) = ((w - 1.0) / 2.0, (h - 1.0) / 2.0);
    let raw: Vec<Matrix3<f64>> = views
        .iter()
        .filter_map(|v| homography(object, &v.corners).ok())
        .collect();
    let pinhole = focal_from_homographies(&raw, cx, cy).map(|(fx, fy)| (fx * fy).sqrt());
    let corners: Vec<&[_]> = views.iter().map(|v| v.corners.as_slice()).collect();
    let (f, starts) = fisheye_start(object, &corners, size, (cx, cy), pinhole);
    let poses = starts
        .into_iter()
        .zip(dropped.iter_mut())
        .map(|(p, d)| match p {
            Ok(p) => Some(p),
            Err(e) => {
                *d = Some(format!("no start under the fisheye: {e}"));
                None
            }
        })
        .collect();
    let mut intr = [0.0; N_INTR];
    intr[..4].copy_from_slice(&[f, f, cx, cy]);
    (intr, poses)
}

/// Solves over the views `used` (indices into `views`) from `intr` and their poses.
fn solve_views(
    object: &[Vector3<f64>],
    views: &[BoardView],
    used: &[usize],
    intr: Intr,
    poses: &[Option<Pose>],
    options: &CalibrateOptions,
) -> CalibResult<Solved> {
    if used.len() < MIN_VIEWS {
        return Err(CalibError::TooFewViews {
            usable: used.len(),
            needed: MIN_VIEWS,
        });
    }
    let pb = one_camera(object, views, used, options.model.lens());
    let start = State {
        intr: vec![intr],
        rel: vec![Pose::identity()],
        boards: used
            .iter()
            .map(|&i| poses[i].unwrap_or_else(Pose::identity))
            .collect(),
    };
    let free = free_intrinsics(options.model);
    solve(&pb, start, &free, options.max_iterations)
        .filter(|s| s.sse.is_finite())
        .ok_or_else(|| CalibError::Failed("the refinement could not project the board".into()))
}

/// Per used view, its RMS (OpenCV's: per corner, Euclidean).
fn view_rms(
    object: &[Vector3<f64>],
    views: &[BoardView],
    used: &[usize],
    s: &State,
    lens: LensModel,
) -> Vec<f64> {
    let pb = one_camera(object, views, used, lens);
    errors(&pb, s)
        .iter()
        .map(|b| match b.first() {
            Some(Some((sse, n))) => (sse / (*n).max(1) as f64).sqrt(),
            _ => f64::INFINITY,
        })
        .collect()
}

/// The median of non-empty `v`.
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => s[n / 2],
        _ => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// [`super::calibrate_camera`].
pub(crate) fn calibrate(
    board: &Board,
    views: &[BoardView],
    size: (u32, u32),
    options: &CalibrateOptions,
) -> CalibResult<CameraCalibration> {
    check_inputs(board, views.iter(), size, options)?;
    if views.len() < MIN_VIEWS {
        return Err(CalibError::TooFewViews {
            usable: views.len(),
            needed: MIN_VIEWS,
        });
    }
    let object = board.object_points();
    let mut dropped: Vec<Option<String>> = vec![None; views.len()];
    let lens = options.model.lens();
    let (intr, mut poses) = match lens {
        LensModel::Pinhole => closed_form(&object, views, size, &mut dropped),
        LensModel::Fisheye => fisheye_closed_form(&object, views, size, &mut dropped),
    };
    let mut rms = vec![f64::NAN; views.len()];
    let mut used: Vec<usize> = (0..views.len()).filter(|&i| dropped[i].is_none()).collect();
    let first = solve_views(&object, views, &used, intr, &poses, options)?;
    let first_rms = view_rms(&object, views, &used, &first.state, lens);
    let med = median(&first_rms);
    let limit = (options.outlier_factor * med).max(1.0);
    for ((&i, &r), pose) in used.iter().zip(&first_rms).zip(&first.state.boards) {
        rms[i] = r;
        poses[i] = Some(*pose);
        if r.is_nan() || r > limit {
            dropped[i] = Some(format!(
                "an outlier: RMS {r:.2} px, over {:.1} x the median view's {med:.2} px",
                options.outlier_factor
            ));
        }
    }
    let solved = if used.iter().any(|&i| dropped[i].is_some()) {
        used.retain(|&i| dropped[i].is_none());
        solve_views(&object, views, &used, first.state.intr[0], &poses, options)?
    } else {
        first
    };
    let fit = Fit {
        used: &used,
        solved,
        lens,
    };
    finish(views, &object, size, fit, dropped, rms, poses)
}

/// The final solve: over which views, through which lens.
struct Fit<'a> {
    used: &'a [usize],
    solved: Solved,
    lens: LensModel,
}

/// The result from the final solve.
fn finish(
    views: &[BoardView],
    object: &[Vector3<f64>],
    size: (u32, u32),
    fit: Fit<'_>,
    dropped: Vec<Option<String>>,
    mut rms: Vec<f64>,
    mut poses: Vec<Option<Pose>>,
) -> CalibResult<CameraCalibration> {
    let Fit { used, solved, lens } = fit;
    for ((&i, &r), pose) in used
        .iter()
        .zip(&view_rms(object, views, used, &solved.state, lens))
        .zip(&solved.state.boards)
    {
        rms[i] = r;
        poses[i] = Some(*pose);
    }
    let n_corners = used.len() * object.len();
    let intr = solved.state.intr[0];
    let camera = to_camera(lens, &intr, size, Extrinsics::default())?;
    let std = intrinsics_std(&solved, n_corners, 0);
    let warnings = warnings(
        &solved.state.boards,
        used.iter().map(|&i| views[i].corners.as_slice()),
        size,
        (intr[0], intr[1]),
        &std,
    );
    let views = views
        .iter()
        .enumerate()
        .zip(dropped)
        .map(|((i, v), dropped)| ViewResult {
            name: v.name.clone(),
            board_pose: poses[i].as_ref().map(to_extrinsics).unwrap_or_default(),
            rms_px: rms[i],
            dropped,
        })
        .collect();
    Ok(CameraCalibration {
        camera,
        rms_px: (solved.sse / n_corners.max(1) as f64).sqrt(),
        views,
        std,
        warnings,
    })
}

/// The problem of one camera over the views `used`.
fn one_camera<'a>(
    object: &'a [Vector3<f64>],
    views: &'a [BoardView],
    used: &[usize],
    lens: LensModel,
) -> Problem<'a> {
    Problem {
        object,
        blocks: used
            .iter()
            .map(|&i| vec![(0, views[i].corners.as_slice())])
            .collect(),
        n_cameras: 1,
        lens,
    }
}
