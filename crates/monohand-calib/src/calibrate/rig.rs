//! A rig's calibration: each camera alone, the cameras placed one after another from the
//! instants they share with those already placed, then one joint refinement.

use super::init::nearest_rotation;
use super::projection::{Pose, N_INTR};
use super::quality::{intrinsics_std, warnings};
use super::single::{calibrate as calibrate_one, free_intrinsics, to_camera, to_extrinsics};
use super::solver::{errors, solve, Problem, Solved, State};
use super::{BoardView, CalibrateOptions, CameraCalibration, RigCalibration};
use crate::board::Board;
use crate::error::{CalibError, CalibResult};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// For each camera, per instant, the board's pose in it if the camera's own calibration
/// used that view.
type Seen = Vec<Vec<Option<Pose>>>;

/// Checks the shapes and calibrates each camera alone; errors name the camera.
fn calibrate_each(
    board: &Board,
    views: &[Vec<Option<BoardView>>],
    sizes: &[(u32, u32)],
    options: &CalibrateOptions,
) -> CalibResult<(Vec<CameraCalibration>, Seen)> {
    if views.is_empty() || views.len() != sizes.len() {
        return Err(CalibError::Inconsistent(format!(
            "{} cameras' views and {} image sizes",
            views.len(),
            sizes.len()
        )));
    }
    let n = views[0].len();
    if let Some(k) = views.iter().position(|v| v.len() != n) {
        return Err(CalibError::Inconsistent(format!(
            "camera {k} has {} instants, camera 0 {n}",
            views[k].len()
        )));
    }
    let mut cals = Vec::with_capacity(views.len());
    let mut seen = Vec::with_capacity(views.len());
    for (k, (cam_views, &size)) in views.iter().zip(sizes).enumerate() {
        let own: Vec<BoardView> = cam_views.iter().flatten().cloned().collect();
        let cal = calibrate_one(board, &own, size, options).map_err(|e| match e {
            CalibError::Inconsistent(m) => CalibError::Inconsistent(format!("camera {k}: {m}")),
            CalibError::Failed(m) => CalibError::Failed(format!("camera {k}: {m}")),
            other => other,
        })?;
        let mut results = cal.views.iter();
        let poses = cam_views
            .iter()
            .map(|v| {
                v.as_ref()?;
                let r = results.next()?;
                r.dropped.is_none().then_some(Pose {
                    r: r.board_pose.rotation,
                    t: r.board_pose.translation,
                })
            })
            .collect();
        cals.push(cal);
        seen.push(poses);
    }
    Ok((cals, seen))
}

/// The rotation nearest (chordal L2) to the mean of `rs`.
fn chordal_mean(rs: &[Rotation3<f64>]) -> Option<Rotation3<f64>> {
    let m: Matrix3<f64> = rs.iter().map(|r| r.matrix()).sum();
    Some(Rotation3::from_matrix(&nearest_rotation(&m)?))
}

/// Component-wise median of non-empty `ts`.
fn median3(ts: &[Vector3<f64>]) -> Vector3<f64> {
    Vector3::from_fn(|i, _| {
        let mut c: Vec<f64> = ts.iter().map(|t| t[i]).collect();
        c.sort_by(f64::total_cmp);
        let n = c.len();
        if n % 2 == 1 {
            c[n / 2]
        } else {
            0.5 * (c[n / 2 - 1] + c[n / 2])
        }
    })
}

/// Places the cameras: camera 0 at the identity, then repeatedly the camera sharing the
/// most instants with the placed ones, from those instants (chordal mean of the rotations,
/// median of the translations). Returns each camera's pose from camera 0 and its shared
/// instants.
fn place(seen: &Seen) -> CalibResult<(Vec<Pose>, Vec<usize>)> {
    let nc = seen.len();
    let mut rel: Vec<Option<Pose>> = vec![None; nc];
    rel[0] = Some(Pose::identity());
    let mut shared = vec![0; nc];
    // Per instant, the board in camera 0 through the first placed camera that saw it.
    let board_in_0 = |rel: &[Option<Pose>], i: usize| {
        (0..nc).find_map(|j| Some(rel[j]?.inverse().compose(&seen[j][i]?)))
    };
    for _ in 1..nc {
        let count = |k: usize| {
            (0..seen[k].len())
                .filter(|&i| seen[k][i].is_some() && board_in_0(&rel, i).is_some())
                .count()
        };
        let next = (0..nc)
            .filter(|&k| rel[k].is_none())
            .map(|k| (k, count(k)))
            .fold(None, |best: Option<(usize, usize)>, (k, c)| match best {
                Some((_, bc)) if bc >= c => best,
                _ => Some((k, c)),
            });
        let Some((k, c)) = next else { break };
        if c == 0 {
            let placed: Vec<String> = (0..nc)
                .filter(|&j| rel[j].is_some())
                .map(|j| j.to_string())
                .collect();
            return Err(CalibError::Inconsistent(format!(
                "camera {k} saw the board at no instant where camera(s) {} saw it too: it cannot be placed in the rig",
                placed.join(", ")
            )));
        }
        let per: Vec<Pose> = (0..seen[k].len())
            .filter_map(|i| Some(seen[k][i]?.compose(&board_in_0(&rel, i)?.inverse())))
            .collect();
        let rs: Vec<Rotation3<f64>> = per.iter().map(|p| p.r).collect();
        let r = chordal_mean(&rs)
            .ok_or_else(|| CalibError::Failed(format!("camera {k}: no mean rotation")))?;
        // With the board at B_i in camera 0 and T_k,i = P B_i: t = t_k,i - R t_B,i.
        let ts: Vec<Vector3<f64>> = (0..seen[k].len())
            .filter_map(|i| {
                let b = board_in_0(&rel, i)?;
                Some(seen[k][i]?.t - r * b.t)
            })
            .collect();
        rel[k] = Some(Pose { r, t: median3(&ts) });
        shared[k] = c;
    }
    let rel = rel
        .into_iter()
        .enumerate()
        .map(|(k, p)| {
            p.ok_or_else(|| CalibError::Inconsistent(format!("camera {k} was not placed")))
        })
        .collect::<CalibResult<Vec<Pose>>>()?;
    Ok((rel, shared))
}

/// [`super::calibrate_rig`].
pub(crate) fn calibrate(
    board: &Board,
    views: &[Vec<Option<BoardView>>],
    sizes: &[(u32, u32)],
    options: &CalibrateOptions,
) -> CalibResult<RigCalibration> {
    let (mut cals, seen) = calibrate_each(board, views, sizes, options)?;
    let (rel, shared) = place(&seen)?;
    let nc = views.len();
    let object = board.object_points();
    // The instants some camera used, the board in camera 0 at each.
    let (instants, boards): (Vec<usize>, Vec<Pose>) = (0..views[0].len())
        .filter_map(|i| {
            let b = (0..nc).find_map(|k| Some(rel[k].inverse().compose(&seen[k][i]?)))?;
            Some((i, b))
        })
        .unzip();
    let pb = Problem {
        object: &object,
        blocks: instants
            .iter()
            .map(|&i| {
                (0..nc)
                    .filter(|&k| seen[k][i].is_some())
                    .filter_map(|k| Some((k, views[k][i].as_ref()?.corners.as_slice())))
                    .collect()
            })
            .collect(),
        n_cameras: nc,
        lens: options.model.lens(),
    };
    let intr: Vec<_> = cals
        .iter()
        .map(|c| {
            let (k, d) = (c.camera.intrinsics, c.camera.distortion.coeffs);
            let mut p = [0.0; N_INTR];
            p[..4].copy_from_slice(&[k.fx, k.fy, k.cx, k.cy]);
            p[4..].copy_from_slice(&d);
            p
        })
        .collect();
    let fi = free_intrinsics(options.model);
    let free: Vec<bool> = (0..pb.n_global())
        .map(|g| match g < N_INTR * nc {
            true => options.refine_rig_intrinsics && fi[g % N_INTR],
            false => true,
        })
        .collect();
    let start = State { intr, rel, boards };
    let solved = solve(&pb, start, &free, options.max_iterations)
        .filter(|s| s.sse.is_finite())
        .ok_or_else(|| {
            CalibError::Failed("the rig's refinement could not project the board".into())
        })?;
    let n_corners = pb.n_corners();
    for (k, cal) in cals.iter_mut().enumerate() {
        update_camera(
            cal, k, &views[k], sizes[k], &pb, &instants, &solved, options,
        )?;
    }
    Ok(RigCalibration {
        cameras: cals,
        rms_px: (solved.sse / n_corners.max(1) as f64).sqrt(),
        shared_views: shared[1..].to_vec(),
    })
}

/// Camera `k`'s calibration from the joint fit: the camera, its views' board poses and
/// RMS, its own RMS, its uncertainty (if its intrinsics were refined) and warnings.
#[allow(clippy::too_many_arguments)]
fn update_camera(
    cal: &mut CameraCalibration,
    k: usize,
    views: &[Option<BoardView>],
    size: (u32, u32),
    pb: &Problem,
    instants: &[usize],
    solved: &Solved,
    options: &CalibrateOptions,
) -> CalibResult<()> {
    let s = &solved.state;
    let errs = errors(pb, s);
    cal.camera = to_camera(pb.lens, &s.intr[k], size, to_extrinsics(&s.rel[k]))?;
    // `cal.views` are this camera's views in instant order.
    let mut own = views
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_some())
        .map(|(i, _)| i);
    let (mut sse, mut n) = (0.0, 0);
    let mut poses = Vec::new();
    for v in cal.views.iter_mut() {
        let Some(i) = own.next() else { break };
        let Some(b) = instants.iter().position(|&x| x == i) else {
            continue;
        };
        let Some(o) = pb.blocks[b].iter().position(|&(c, _)| c == k) else {
            continue;
        };
        let pose = s.rel[k].compose(&s.boards[b]);
        v.board_pose = to_extrinsics(&pose);
        poses.push(pose);
        if let Some(Some((e, m))) = errs[b].get(o) {
            v.rms_px = (e / *m as f64).sqrt();
            sse += e;
            n += m;
        }
    }
    cal.rms_px = (sse / n.max(1) as f64).sqrt();
    if options.refine_rig_intrinsics {
        cal.std = intrinsics_std(solved, pb.n_corners(), k);
    }
    let used = pb
        .blocks
        .iter()
        .flat_map(|b| b.iter().filter(|(c, _)| *c == k).map(|(_, c)| *c));
    cal.warnings = warnings(&poses, used, size, (s.intr[k][0], s.intr[k][1]), &cal.std);
    Ok(())
}
