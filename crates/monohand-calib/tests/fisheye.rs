//! The fisheye calibration (`DistortionModel::Fisheye`, OpenCV's `cv::fisheye`): synthetic
//! wide cameras and a rig with known answers, the pinhole models on the same data, bad
//! input, and OpenCV's stereo sample against `cv2.fisheye.calibrate` on the same corners
//! (`tests/data/opencv_fisheye_reference.json`, made by `make_opencv_fisheye_reference.py`).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod support;

use monohand_calib::calibrate::{
    calibrate_camera, calibrate_rig, BoardView, CalibrateOptions, CameraCalibration,
    DistortionModel,
};
use monohand_calib::{Board, CalibError};
use monohand_core::camera::{Camera, Extrinsics, LensModel};
use nalgebra::{Point2, Rotation3, Unit, Vector3};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde_json::Value;
use std::time::Instant;
use support::{angle_deg, f, fixture_views, junk_views, read_json};

const FISHEYE: CalibrateOptions = CalibrateOptions {
    model: DistortionModel::Fisheye,
    outlier_factor: 3.0,
    max_iterations: 100,
    refine_rig_intrinsics: true,
};

/// About 150 degrees across 1280 px: OpenCV's mild fisheye coefficients.
fn wide() -> Camera {
    Camera::fisheye(
        480.0,
        481.0,
        642.0,
        357.0,
        1280,
        720,
        [0.02, -0.005, 0.0, 0.0],
    )
    .unwrap()
}

/// About 170 degrees across 1280 px, all four coefficients.
fn strong() -> Camera {
    Camera::fisheye(
        400.0,
        401.5,
        636.0,
        364.0,
        1280,
        720,
        [0.08, -0.03, 0.008, -0.001],
    )
    .unwrap()
}

/// The angle between a camera-frame point and the optical axis, degrees.
fn off_axis_deg(x: &Vector3<f64>) -> f64 {
    x.xy().norm().atan2(x.z).to_degrees()
}

/// A board pose (in the first camera) tilted 10-50 degrees, its centre 200-700 mm away
/// along the ray of a random pixel, whose corners are all less than 85 degrees off every
/// camera's axis and inside its image (10 px margin).
fn fisheye_pose(rng: &mut StdRng, board: &Board, cams: &[Camera]) -> Extrinsics {
    let obj = board.object_points();
    let centre = Vector3::new(
        (board.cols - 1) as f64 * board.square_mm / 2.0,
        (board.rows - 1) as f64 * board.square_mm / 2.0,
        0.0,
    );
    let k = cams[0].intrinsics;
    loop {
        let tilt = rng.random_range(10f64..50.0).to_radians();
        let dir = rng.random_range(0.0..std::f64::consts::TAU);
        let axis = Unit::new_normalize(Vector3::new(dir.cos(), dir.sin(), 0.0));
        let roll = rng.random_range(-0.5..0.5);
        let r =
            Rotation3::from_axis_angle(&axis, tilt) * Rotation3::from_euler_angles(0.0, 0.0, roll);
        let px = Point2::new(
            rng.random_range(0.0..k.width as f64),
            rng.random_range(0.0..k.height as f64),
        );
        let Some(ray) = cams[0].ray(px) else { continue };
        let p = ray * rng.random_range(200.0..700.0);
        let pose = Extrinsics {
            rotation: r,
            translation: p - r * centre,
        };
        let inside = cams.iter().all(|c| {
            obj.iter().all(|x| {
                let xc = c.extrinsics.transform(&pose.transform(x));
                let w = c.intrinsics;
                xc.z > 0.0
                    && off_axis_deg(&xc) < 85.0
                    && c.project(&pose.transform(x)).is_some_and(|q| {
                        q.x > 10.0
                            && q.y > 10.0
                            && q.x < w.width as f64 - 10.0
                            && q.y < w.height as f64 - 10.0
                    })
            })
        });
        if inside {
            return pose;
        }
    }
}

/// The corners of `board` at `pose` (in `cam`'s reference frame) seen by `cam`, with
/// Gaussian noise of `rms` px (2D RMS: `rms / sqrt 2` per coordinate).
fn view(
    board: &Board,
    cam: &Camera,
    pose: &Extrinsics,
    rms: f64,
    rng: &mut StdRng,
) -> Vec<Point2<f64>> {
    let noise = Normal::new(0.0, rms / std::f64::consts::SQRT_2).unwrap();
    board
        .object_points()
        .iter()
        .map(|x| {
            let q = cam.project(&pose.transform(x)).unwrap();
            Point2::new(q.x + noise.sample(rng), q.y + noise.sample(rng))
        })
        .collect()
}

/// `n` views of a 9x6 board of 25 mm squares through `cam`, 0.2 px of noise; and the
/// largest angle off the axis of their corners.
fn fisheye_views(cam: &Camera, n: usize, seed: u64) -> (Board, Vec<BoardView>, f64) {
    let board = Board::new(9, 6, 25.0).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut widest: f64 = 0.0;
    let views = (0..n)
        .map(|i| {
            let pose = fisheye_pose(&mut rng, &board, &[*cam]);
            for x in board.object_points() {
                widest = widest.max(off_axis_deg(&pose.transform(&x)));
            }
            BoardView {
                name: format!("view {i}"),
                corners: view(&board, cam, &pose, 0.2, &mut rng),
            }
        })
        .collect();
    (board, views, widest)
}

fn report(label: &str, cal: &CameraCalibration) {
    let k = cal.camera.intrinsics;
    println!(
        "{label}: {} fx {:.3} fy {:.3} cx {:.3} cy {:.3} coeffs {:?} rms {:.4} px; std fx {:.3} fy {:.3} cx {:.3} cy {:.3} coeffs {:?}; views {}/{}",
        cal.camera.distortion.model, k.fx, k.fy, k.cx, k.cy,
        cal.camera.distortion.listed().iter().map(|d| (d * 1e5).round() / 1e5).collect::<Vec<_>>(),
        cal.rms_px, cal.std.fx, cal.std.fy, cal.std.cx, cal.std.cy,
        cal.std.distortion[..4].iter().map(|d| (d * 1e5).round() / 1e5).collect::<Vec<_>>(),
        cal.used_views(), cal.views.len()
    );
}

/// The estimate agrees with the truth within 5 of its own standard deviations (which come
/// from the residuals, so from the noise) in every number, those deviations are small,
/// and the RMS is the noise's 0.2 px less the fit's share of the degrees of freedom.
fn assert_recovers(label: &str, cal: &CameraCalibration, truth: &Camera) {
    assert_eq!(cal.camera.distortion.model, LensModel::Fisheye, "{label}");
    let (k, t) = (cal.camera.intrinsics, truth.intrinsics);
    let got = [k.fx, k.fy, k.cx, k.cy];
    let want = [t.fx, t.fy, t.cx, t.cy];
    let std = [cal.std.fx, cal.std.fy, cal.std.cx, cal.std.cy];
    let names = ["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"];
    let c = cal.camera.distortion.coeffs;
    let tc = truth.distortion.coeffs;
    for (i, name) in names.iter().enumerate() {
        let (g, w, s) = match i {
            0..4 => (got[i], want[i], std[i]),
            _ => (c[i - 4], tc[i - 4], cal.std.distortion[i - 4]),
        };
        let sigmas = (g - w).abs() / s;
        println!("  {label} {name}: {g:.6} vs {w:.6}, {sigmas:.2} sigma (sigma {s:.2e})");
        assert!(s > 0.0 && s.is_finite(), "{label} {name}: sigma {s}");
        assert!(
            sigmas < 5.0,
            "{label} {name}: {g} vs {w}, {sigmas:.1} sigma"
        );
    }
    // 0.2 px of noise over 15-20 views of 54 corners pins the focal length and the
    // principal point to under a pixel (measured: 0.25-0.48 px).
    assert!(std[0] < 1.0 && std[1] < 1.0, "{label}: focal sigma {std:?}");
    assert!(
        std[2] < 1.0 && std[3] < 1.0,
        "{label}: centre sigma {std:?}"
    );
    assert!(c[4..].iter().all(|&v| v == 0.0));
    assert!(
        cal.rms_px > 0.17 && cal.rms_px < 0.23,
        "{label}: rms {}",
        cal.rms_px
    );
}

#[test]
fn synthetic_fisheyes_are_recovered_and_the_pinhole_cannot_follow() {
    for (label, cam, seed) in [("wide", wide(), 1), ("strong", strong(), 2)] {
        let (board, views, widest) = fisheye_views(&cam, 20, seed);
        println!(
            "{label}: {:.1} degrees across the image, corners up to {widest:.1} degrees off the axis",
            cam.field_of_view_deg()
        );
        let t0 = Instant::now();
        let cal = calibrate_camera(&board, &views, 1280, 720, &FISHEYE).unwrap();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        report(&format!("{label} ({ms:.0} ms)"), &cal);
        assert_eq!(cal.used_views(), 20, "{:?}", cal.views);
        assert_recovers(label, &cal, &cam);
        // The fisheye is right out to the image's edge, past where the corners were.
        let (edge, _) = border_error(&cal.camera, &cam);
        println!("  {label}: fisheye off by {edge:.2} px at most along the image's border");
        assert!(edge < 4.0, "{label}: {edge} px at the border");
        // The pinhole models on the same corners: the standard one cannot follow even
        // where the corners are; the rational one can there, but not past them (and not at
        // all at 90 degrees or more).
        let pinhole = |model| {
            let options = CalibrateOptions {
                model,
                outlier_factor: f64::INFINITY,
                ..FISHEYE
            };
            let p = calibrate_camera(&board, &views, 1280, 720, &options).unwrap();
            report(&format!("{label}, {model:?}"), &p);
            assert_eq!(p.camera.distortion.model, LensModel::Pinhole);
            let (edge, lost) = border_error(&p.camera, &cam);
            println!(
                "  {label}, {model:?}: rms {:.2} x the fisheye's; off by {edge:.1} px at most along the border, {lost} border pixels' rays not imaged",
                p.rms_px / cal.rms_px
            );
            (p.rms_px, edge, lost)
        };
        let (rms, _, _) = pinhole(DistortionModel::Standard);
        assert!(rms > 4.0 * cal.rms_px, "{label}: standard rms {rms}");
        let (_, edge, _) = pinhole(DistortionModel::Rational);
        assert!(edge > 50.0, "{label}: rational {edge} px at the border");
    }
}

/// The largest pixel error of `cam` against `truth` over the image's border (every 4th
/// pixel, 2 px in): each border pixel's true ray projected by `cam`; and the number of
/// those rays `cam` does not image at all.
fn border_error(cam: &Camera, truth: &Camera) -> (f64, usize) {
    let (w, h) = (
        truth.intrinsics.width as f64,
        truth.intrinsics.height as f64,
    );
    let along = |n: f64| {
        (0..)
            .map(|i| 2.0 + 4.0 * i as f64)
            .take_while(move |v| *v <= n - 3.0)
    };
    let border: Vec<Point2<f64>> = along(w)
        .flat_map(|x| [Point2::new(x, 2.0), Point2::new(x, h - 3.0)])
        .chain(along(h).flat_map(|y| [Point2::new(2.0, y), Point2::new(w - 3.0, y)]))
        .collect();
    let (mut worst, mut lost) = (0.0f64, 0);
    for px in border {
        let ray = truth.ray(px).unwrap();
        match cam.project_cam(&ray) {
            Some(q) => worst = worst.max((q - px).norm()),
            None => lost += 1,
        }
    }
    (worst, lost)
}

#[test]
fn a_fisheye_rig_is_recovered() {
    let board = Board::new(9, 6, 25.0).unwrap();
    let left = wide();
    // Camera 1's centre 60 mm along camera 0's x, turned 5 degrees about y.
    let r = Rotation3::from_axis_angle(&Vector3::y_axis(), 5f64.to_radians());
    let truth = Extrinsics {
        rotation: r,
        translation: -(r * Vector3::new(60.0, 0.0, 0.0)),
    };
    let right = Camera::fisheye(
        470.0,
        470.5,
        632.0,
        362.0,
        1280,
        720,
        [0.03, -0.01, 0.002, 0.0],
    )
    .unwrap();
    let placed = right.with_extrinsics(truth);
    let mut rng = StdRng::seed_from_u64(7);
    let (mut v0, mut v1) = (Vec::new(), Vec::new());
    for i in 0..16 {
        let pose = fisheye_pose(&mut rng, &board, &[left, placed]);
        let corners = view(&board, &left, &pose, 0.2, &mut rng);
        v0.push(Some(BoardView {
            name: format!("left {i}"),
            corners,
        }));
        let corners = view(&board, &placed, &pose, 0.2, &mut rng);
        v1.push(Some(BoardView {
            name: format!("right {i}"),
            corners,
        }));
    }
    // Two instants only one camera saw.
    v0[3] = None;
    v1[8] = None;
    let t0 = Instant::now();
    let rig = calibrate_rig(&board, &[v0, v1], &[(1280, 720); 2], &FISHEYE).unwrap();
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let e = rig.cameras[1].camera.extrinsics;
    let dr = angle_deg(&(e.rotation * truth.rotation.inverse()));
    let base = rig.cameras[1].camera.centre();
    let dlen = base.norm() / 60.0 - 1.0;
    println!(
        "fisheye rig ({ms:.0} ms): rms {:.4} px, rotation off {dr:.4} deg, baseline {:.3?} mm ({:+.3}%), shared {:?}",
        rig.rms_px, base.as_slice(), dlen * 100.0, rig.shared_views
    );
    report("rig left", &rig.cameras[0]);
    report("rig right", &rig.cameras[1]);
    assert_eq!(rig.shared_views, vec![14]);
    assert!(rig.cameras[0].camera.extrinsics.is_identity());
    assert!(dr < 0.1, "rotation off by {dr} degrees");
    assert!(dlen.abs() < 0.005, "baseline off by {}%", dlen * 100.0);
    assert!(rig.rms_px > 0.17 && rig.rms_px < 0.23, "{}", rig.rms_px);
    assert_recovers("rig left", &rig.cameras[0], &left);
    assert_recovers("rig right", &rig.cameras[1], &right);
}

#[test]
fn bad_fisheye_input_is_an_error_not_a_panic() {
    let cam = wide();
    let (board, views, _) = fisheye_views(&cam, 6, 3);
    let e = calibrate_camera(&board, &views[..2], 1280, 720, &FISHEYE).unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::TooFewViews {
                usable: 2,
                needed: 3
            }
        ),
        "{e}"
    );
    // Collinear corners: that view dropped with why, the rest calibrated.
    let mut flat = views.clone();
    for (j, p) in flat[0].corners.iter_mut().enumerate() {
        *p = Point2::new(100.0 + j as f64, 200.0 + 2.0 * j as f64);
    }
    let cal = calibrate_camera(&board, &flat, 1280, 720, &FISHEYE).unwrap();
    // Under the fisheye's start the line bends (it misses the centre), so the view may
    // get a homography and be dropped as an outlier by the refinement instead.
    let why = cal.views[0].dropped.clone().unwrap_or_default();
    println!("collinear: {why}");
    assert!(
        why.contains("homography") || why.contains("outlier"),
        "{why}"
    );
    assert_eq!(cal.used_views(), 5);
    // Corners thousands of pixels out: past 90 degrees under every start, so no pose.
    let mut far = views.clone();
    for v in far.iter_mut().take(4) {
        for p in &mut v.corners {
            *p = Point2::new(p.x * 40.0 + 1e5, p.y * 40.0 - 3e4);
        }
    }
    let e = calibrate_camera(&board, &far, 1280, 720, &FISHEYE).unwrap_err();
    println!("far: {e}");
    assert!(
        matches!(e, CalibError::TooFewViews { usable: 2, .. }),
        "{e}"
    );
    // Garbage corners (random pixels): an error or a result, never a panic.
    let junk = junk_views();
    let r = calibrate_camera(&board, &junk, 1280, 720, &FISHEYE);
    println!("junk: {:?}", r.as_ref().map(|c| c.rms_px));
    let mut nan = views.clone();
    nan[2].corners[7].y = f64::INFINITY;
    assert!(matches!(
        calibrate_camera(&board, &nan, 1280, 720, &FISHEYE),
        Err(CalibError::Inconsistent(_))
    ));
}

// ---------------------------------------------------------------- OpenCV's stereo sample

/// The largest pixel distance between where `a` and `b` image the rays of `a`'s pixels
/// (every 8th pixel of the image): how far apart the two lenses are, whatever their
/// coefficients (a narrow lens's k1..k4 are strongly correlated). Pixels past the reach
/// of `a` or `b` (where a polynomial folds) are counted, not compared.
fn lens_difference(a: &Camera, b: &Camera) -> (f64, usize) {
    let k = a.intrinsics;
    let (mut worst, mut past): (f64, usize) = (0.0, 0);
    for y in (0..k.height).step_by(8) {
        for x in (0..k.width).step_by(8) {
            let px = Point2::new(x as f64, y as f64);
            match a.ray(px).and_then(|r| b.project_cam(&r)) {
                Some(q) => worst = worst.max((q - px).norm()),
                None => past += 1,
            }
        }
    }
    (worst, past)
}

fn opencv_camera(r: &Value) -> Camera {
    let k: Vec<f64> = r["k"].as_array().unwrap().iter().map(f).collect();
    Camera::fisheye(
        f(&r["fx"]),
        f(&r["fy"]),
        f(&r["cx"]),
        f(&r["cy"]),
        640,
        480,
        [k[0], k[1], k[2], k[3]],
    )
    .unwrap()
}

/// Every view kept, as OpenCV does.
const KEEP_ALL: CalibrateOptions = CalibrateOptions {
    outlier_factor: f64::INFINITY,
    ..FISHEYE
};

#[test]
fn opencv_sample_matches_cv_fisheye_calibrate() {
    let corners = read_json("opencv_corners.json");
    let reference = read_json("opencv_fisheye_reference.json");
    let board = Board::new(9, 6, f(&corners["square_mm"])).unwrap();
    println!("OpenCV {}", reference["opencv_version"]);
    for side in ["left", "right"] {
        let views: Vec<BoardView> = fixture_views(&corners, side)
            .into_iter()
            .flatten()
            .collect();
        let r = &reference[side];
        let t0 = Instant::now();
        let cal = calibrate_camera(&board, &views, 640, 480, &KEEP_ALL).unwrap();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        report(&format!("{side} ({ms:.0} ms)"), &cal);
        let cv = opencv_camera(r);
        let k = cal.camera.intrinsics;
        let (dfx, dfy) = (k.fx / f(&r["fx"]) - 1.0, k.fy / f(&r["fy"]) - 1.0);
        let (dcx, dcy) = (k.cx - f(&r["cx"]), k.cy - f(&r["cy"]));
        let drms = cal.rms_px - f(&r["rms"]);
        let (lens, past) = lens_difference(&cal.camera, &cv);
        let (_, cv_past) = lens_difference(&cv, &cv);
        println!(
            "  {side} vs cv2.fisheye.calibrate (fx {:.3} fy {:.3} cx {:.3} cy {:.3} k {:?} rms {:.4}): fx {dfx:+.1e} fy {dfy:+.1e} (relative) cx {dcx:+.1e} px cy {dcy:+.1e} px rms {drms:+.1e} px; the lenses {lens:.1e} px apart at most; pixels past the reach of ours or OpenCV's: {past} (OpenCV's alone: {cv_past}) of {}",
            f(&r["fx"]), f(&r["fy"]), f(&r["cx"]), f(&r["cy"]), r["k"].as_array().unwrap().iter().map(f).collect::<Vec<_>>(), f(&r["rms"]),
            80 * 60
        );
        // The same cost's minimum on the same corners: what is left is where each solver
        // stops (measured: focal lengths within 2e-8, principal points within 2.1e-5 px,
        // RMS within 1e-13 px, the lenses within 4e-4 px of each other). The bounds leave
        // room for another platform's rounding, not for another minimum.
        assert_eq!(cal.used_views(), views.len());
        for (v, b) in cal.views.iter().zip(r["per_view_rms"].as_array().unwrap()) {
            assert!(
                (v.rms_px - f(b)).abs() < 1e-4,
                "{}: {} vs {}",
                v.name,
                v.rms_px,
                f(b)
            );
        }
        assert!(dfx.abs() < 1e-5 && dfy.abs() < 1e-5, "{side}: focal off");
        assert!(dcx.abs() < 0.01 && dcy.abs() < 0.01, "{side}: centre off");
        assert!(drms.abs() < 1e-5, "{side}: rms off by {drms}");
        assert!(lens < 0.01, "{side}: the lenses {lens} px apart");
        assert_eq!(past, cv_past, "{side}: pixels past the lens's reach");
    }
}

#[test]
fn opencv_sample_rig_matches_cv_fisheye_stereo_calibrate() {
    let corners = read_json("opencv_corners.json");
    let reference = read_json("opencv_fisheye_reference.json");
    let board = Board::new(9, 6, f(&corners["square_mm"])).unwrap();
    let views = vec![
        fixture_views(&corners, "left"),
        fixture_views(&corners, "right"),
    ];
    let options = CalibrateOptions {
        refine_rig_intrinsics: false,
        ..KEEP_ALL
    };
    let rig = calibrate_rig(&board, &views, &[(640, 480), (640, 480)], &options).unwrap();
    let r = &reference["stereo_fix_intrinsic"];
    let v = |key: &str| Vector3::new(f(&r[key][0]), f(&r[key][1]), f(&r[key][2]));
    let t_ref = v("t_mm");
    let e = rig.cameras[1].camera.extrinsics;
    let dr = angle_deg(&(e.rotation * Rotation3::new(v("rvec")).inverse()));
    let dlen = e.translation.norm() / t_ref.norm() - 1.0;
    let ddir = e.translation.angle(&t_ref).to_degrees();
    println!(
        "fisheye rig vs cv2.fisheye.stereoCalibrate (rms {:.4}, T {:.3?} mm): rms {:.4} px, T {:.3?} mm; rotation off {dr:.1e} deg, baseline length {dlen:+.1e} (relative), direction {ddir:.1e} deg, rms {:+.1e} px",
        f(&r["rms"]), t_ref.as_slice(), rig.rms_px, e.translation.as_slice(), rig.rms_px - f(&r["rms"])
    );
    for cal in &rig.cameras {
        assert_eq!(cal.camera.distortion.model, LensModel::Fisheye);
    }
    // As for one camera (measured: 4.2e-6 degrees, 1.5e-9 of the baseline, 2.6e-8 px).
    assert_eq!(rig.shared_views, vec![13]);
    assert!(dr < 1e-3, "rotation off by {dr} degrees");
    assert!(dlen.abs() < 1e-5, "baseline off by {dlen}");
    assert!(ddir < 1e-3, "baseline direction off by {ddir} degrees");
    assert!(
        (rig.rms_px - f(&r["rms"])).abs() < 1e-5,
        "rms {}",
        rig.rms_px
    );
}
