//! Calibration tests: synthetic cameras and rigs with known answers, bad input, and OpenCV's
//! stereo sample against OpenCV's own results (fixtures in `tests/data`, made by
//! `tests/data/make_opencv_fixtures.py`).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod support;

use monohand_calib::calibrate::{
    calibrate_camera, calibrate_rig, BoardView, CalibWarning, CalibrateOptions, CameraCalibration,
    DistortionModel,
};
use monohand_calib::{Board, CalibError};
use monohand_core::camera::{Camera, Distortion, Extrinsics, Intrinsics};
use nalgebra::{Point2, Rotation3, Unit, Vector3};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde_json::Value;
use std::time::Instant;
use support::{angle_deg, f, fixture_views, junk_views, read_json};

// ---------------------------------------------------------------- synthetic data

fn camera(coeffs: [f64; 8]) -> Camera {
    Camera::new(
        Intrinsics {
            fx: 900.0,
            fy: 905.0,
            cx: 650.0,
            cy: 350.0,
            width: 1280,
            height: 720,
        },
        Distortion {
            coeffs,
            ..Distortion::default()
        },
        Extrinsics::default(),
    )
    .unwrap()
}

const STANDARD: [f64; 8] = [-0.3, 0.12, 1e-3, -5e-4, -0.02, 0.0, 0.0, 0.0];
const RATIONAL: [f64; 8] = [0.5, -0.1, 1e-3, -5e-4, 0.01, 0.8, 0.02, 0.0];

/// A board pose (in the first camera) tilted 10-50 degrees, 300-900 mm away, whose corners
/// all fall inside every camera of `cams` (with a 10 px margin).
fn random_pose(rng: &mut StdRng, board: &Board, cams: &[Camera]) -> Extrinsics {
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
        let z = rng.random_range(300.0..900.0);
        let (u, v) = (
            rng.random_range(0.0..k.width as f64),
            rng.random_range(0.0..k.height as f64),
        );
        let p = Vector3::new((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
        let pose = Extrinsics {
            rotation: r,
            translation: p - r * centre,
        };
        let inside = cams.iter().all(|c| {
            obj.iter().all(|x| match c.project(&pose.transform(x)) {
                Some(q) => {
                    q.x > 10.0
                        && q.y > 10.0
                        && q.x < c.intrinsics.width as f64 - 10.0
                        && q.y < c.intrinsics.height as f64 - 10.0
                }
                None => false,
            })
        });
        if inside {
            return pose;
        }
    }
}

/// The corners of `board` at `pose` in `cam`, with Gaussian noise of `rms` px (2D RMS:
/// `rms / sqrt 2` per coordinate).
fn view(
    board: &Board,
    cam: &Camera,
    pose: &Extrinsics,
    rms: f64,
    rng: &mut StdRng,
    name: String,
) -> BoardView {
    let noise = Normal::new(0.0, rms / std::f64::consts::SQRT_2).unwrap();
    let corners = board
        .object_points()
        .iter()
        .map(|x| {
            let q = cam.project(&pose.transform(x)).unwrap();
            Point2::new(q.x + noise.sample(rng), q.y + noise.sample(rng))
        })
        .collect();
    BoardView { name, corners }
}

fn synthetic_views(cam: &Camera, n: usize, seed: u64) -> (Board, Vec<BoardView>) {
    let board = Board::new(9, 6, 25.0).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let views = (0..n)
        .map(|i| {
            let pose = random_pose(&mut rng, &board, &[*cam]);
            view(&board, cam, &pose, 0.2, &mut rng, format!("view {i}"))
        })
        .collect();
    (board, views)
}

fn report(label: &str, cal: &CameraCalibration) {
    let k = cal.camera.intrinsics;
    println!(
        "{label}: fx {:.3} fy {:.3} cx {:.3} cy {:.3} dist {:?} rms {:.4} px, std fx {:.3} fy {:.3} cx {:.3} cy {:.3}, views {}/{}, warnings {:?}",
        k.fx, k.fy, k.cx, k.cy, cal.camera.distortion.coeffs.map(|d| (d * 1e5).round() / 1e5), cal.rms_px,
        cal.std.fx, cal.std.fy, cal.std.cx, cal.std.cy, cal.used_views(), cal.views.len(), cal.warnings
    );
}

fn assert_recovers(cal: &CameraCalibration, truth: &Camera) {
    let (k, t) = (cal.camera.intrinsics, truth.intrinsics);
    assert!((k.fx / t.fx - 1.0).abs() < 0.002, "fx {} vs {}", k.fx, t.fx);
    assert!((k.fy / t.fy - 1.0).abs() < 0.002, "fy {} vs {}", k.fy, t.fy);
    assert!((k.cx - t.cx).abs() < 2.0, "cx {} vs {}", k.cx, t.cx);
    assert!((k.cy - t.cy).abs() < 2.0, "cy {} vs {}", k.cy, t.cy);
    // 0.2 px of 2D noise: the RMS is 0.2 px less the fit's share of degrees of freedom.
    assert!(cal.rms_px > 0.17 && cal.rms_px < 0.23, "rms {}", cal.rms_px);
}

#[test]
fn synthetic_standard_camera_is_recovered() {
    let cam = camera(STANDARD);
    let (board, views) = synthetic_views(&cam, 15, 1);
    let t0 = Instant::now();
    let cal = calibrate_camera(&board, &views, 1280, 720, &CalibrateOptions::default()).unwrap();
    println!(
        "calibrated 15 views in {:.1} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    report("standard", &cal);
    assert_eq!(cal.used_views(), 15);
    assert_recovers(&cal, &cam);
    // The uncertainty is honest: the errors are within a few standard deviations.
    let k = cal.camera.intrinsics;
    assert!(
        (k.fx - 900.0).abs() < 5.0 * cal.std.fx + 0.05,
        "fx off by more than 5 sigma"
    );
    assert!(cal.std.fx > 0.0 && cal.std.fx < 5.0);
    let d = cal.depth_std_mm(500.0);
    println!("  depth std at 500 mm: {d:.3} mm");
    assert!(d > 0.0 && d < 5.0);
    let d = cal.camera.distortion.coeffs;
    assert!(
        (d[0] - STANDARD[0]).abs() < 0.01 && (d[1] - STANDARD[1]).abs() < 0.05,
        "{d:?}"
    );
    assert!(!cal.warnings.iter().any(|w| matches!(
        w,
        CalibWarning::TooFlat { .. } | CalibWarning::UncertainFocal { .. }
    )));
}

#[test]
fn synthetic_rational_camera_is_recovered() {
    let cam = camera(RATIONAL);
    let (board, views) = synthetic_views(&cam, 15, 2);
    let options = CalibrateOptions {
        model: DistortionModel::Rational,
        ..CalibrateOptions::default()
    };
    let cal = calibrate_camera(&board, &views, 1280, 720, &options).unwrap();
    report("rational", &cal);
    assert_eq!(cal.used_views(), 15);
    assert_recovers(&cal, &cam);
}

// ---------------------------------------------------------------- OpenCV's stereo sample

/// The fixtures (corners and OpenCV's results); fails if OpenCV's photographs are missing
/// from the shared data (the fixtures are made from them).
fn opencv_fixtures() -> (Value, Value) {
    let photos = monohand_testkit::shared_data().join("calibration/opencv_stereo_chessboard");
    for name in ["left01.jpg", "right14.jpg"] {
        assert!(
            photos.join(name).is_file(),
            "OpenCV's stereo sample is missing at {} (../shared/data beside the repository)",
            photos.display()
        );
    }
    (
        read_json("opencv_corners.json"),
        read_json("opencv_reference.json"),
    )
}

fn fixture_board(corners: &Value) -> Board {
    Board::new(
        corners["cols"].as_u64().unwrap() as usize,
        corners["rows"].as_u64().unwrap() as usize,
        corners["square_mm"].as_f64().unwrap(),
    )
    .unwrap()
}

/// Every view kept, as OpenCV does.
const KEEP_ALL: CalibrateOptions = CalibrateOptions {
    model: DistortionModel::Standard,
    outlier_factor: f64::INFINITY,
    max_iterations: 100,
    refine_rig_intrinsics: true,
};

#[test]
fn opencv_sample_each_camera_matches_opencv() {
    let (corners, reference) = opencv_fixtures();
    let board = fixture_board(&corners);
    for side in ["left", "right"] {
        let views: Vec<BoardView> = fixture_views(&corners, side)
            .into_iter()
            .flatten()
            .collect();
        let r = &reference[side];
        let dflt =
            calibrate_camera(&board, &views, 640, 480, &CalibrateOptions::default()).unwrap();
        for v in dflt.views.iter().filter(|v| v.dropped.is_some()) {
            println!(
                "  {side}, default options: {} dropped: {}",
                v.name,
                v.dropped.as_deref().unwrap_or("")
            );
        }
        report(&format!("{side} (default options)"), &dflt);
        // OpenCV keeps every view: so does the comparison.
        let t0 = Instant::now();
        let cal = calibrate_camera(&board, &views, 640, 480, &KEEP_ALL).unwrap();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        report(side, &cal);
        let k = cal.camera.intrinsics;
        let (dfx, dfy) = (k.fx / f(&r["fx"]) - 1.0, k.fy / f(&r["fy"]) - 1.0);
        let (dcx, dcy) = (k.cx - f(&r["cx"]), k.cy - f(&r["cy"]));
        let drms = cal.rms_px - f(&r["rms"]);
        println!(
            "  {side} vs OpenCV (fx {:.2} fy {:.2} cx {:.2} cy {:.2} rms {:.4}): fx {:+.3}% fy {:+.3}% cx {dcx:+.3} px cy {dcy:+.3} px rms {drms:+.4} px; {} views in {ms:.1} ms",
            f(&r["fx"]), f(&r["fy"]), f(&r["cx"]), f(&r["cy"]), f(&r["rms"]), dfx * 100.0, dfy * 100.0, views.len()
        );
        println!(
            "  {side}: depth std at 500 mm from sigma(f): {:.2} mm",
            cal.depth_std_mm(500.0)
        );
        assert_eq!(cal.used_views(), views.len(), "{:?}", cal.views);
        // The uncertainty is OpenCV's stdDeviationsIntrinsics, each view's RMS its
        // perViewErrors.
        let ours = [cal.std.fx, cal.std.fy, cal.std.cx, cal.std.cy]
            .into_iter()
            .chain(cal.std.distortion[..5].iter().copied());
        for (i, (a, b)) in ours.zip(r["std"].as_array().unwrap()).enumerate() {
            println!("  {side} std[{i}]: {a:.6} (OpenCV {:.6})", f(b));
            assert!(
                (a / f(b) - 1.0).abs() < 0.02,
                "{side}: std[{i}] {a} vs {}",
                f(b)
            );
        }
        for (v, b) in cal.views.iter().zip(r["per_view_rms"].as_array().unwrap()) {
            assert!(
                (v.rms_px - f(b)).abs() < 0.01,
                "{}: {} vs {}",
                v.name,
                v.rms_px,
                f(b)
            );
        }
        assert!(dfx.abs() < 0.005 && dfy.abs() < 0.005, "{side}: focal off");
        assert!(
            dcx.abs() < 2.0 && dcy.abs() < 2.0,
            "{side}: principal point off"
        );
        assert!(drms.abs() < 0.05, "{side}: rms off");
    }
}

#[test]
fn opencv_sample_rig_matches_stereo_calibrate() {
    let (corners, reference) = opencv_fixtures();
    let board = fixture_board(&corners);
    let views = vec![
        fixture_views(&corners, "left"),
        fixture_views(&corners, "right"),
    ];
    for (refine, key) in [(false, "stereo_fix_intrinsic"), (true, "stereo_free")] {
        let options = CalibrateOptions {
            refine_rig_intrinsics: refine,
            ..KEEP_ALL
        };
        let t0 = Instant::now();
        let rig = calibrate_rig(&board, &views, &[(640, 480), (640, 480)], &options).unwrap();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let r = &reference[key];
        let rv = Vector3::new(f(&r["rvec"][0]), f(&r["rvec"][1]), f(&r["rvec"][2]));
        let t_ref = Vector3::new(f(&r["t_mm"][0]), f(&r["t_mm"][1]), f(&r["t_mm"][2]));
        let e = rig.cameras[1].camera.extrinsics;
        let dr = angle_deg(&(e.rotation * Rotation3::new(rv).inverse()));
        let dlen = e.translation.norm() / t_ref.norm() - 1.0;
        let ddir = e.translation.angle(&t_ref).to_degrees();
        println!(
            "rig (intrinsics {}), vs OpenCV {key} (rms {:.4}, R {:.3} deg, T {:.3?} mm): rms {:.4} px, R {:.3} deg, T {:.3?} mm; rotation off {dr:.4} deg, baseline length {:+.3}%, direction {ddir:.3} deg; shared {:?}; {ms:.1} ms",
            if refine { "refined" } else { "fixed" }, f(&r["rms"]), angle_deg(&Rotation3::new(rv)), t_ref.as_slice(), rig.rms_px,
            angle_deg(&e.rotation), e.translation.as_slice(), dlen * 100.0, rig.shared_views
        );
        for (k, side) in ["left", "right"].iter().enumerate() {
            let c = rig.cameras[k].camera.intrinsics;
            let o = &r[*side];
            println!(
                "  {side}: fx {:.3} fy {:.3} cx {:.3} cy {:.3} (OpenCV {:.3} {:.3} {:.3} {:.3})",
                c.fx,
                c.fy,
                c.cx,
                c.cy,
                f(&o["fx"]),
                f(&o["fy"]),
                f(&o["cx"]),
                f(&o["cy"])
            );
        }
        assert!(rig.cameras[0].camera.extrinsics.is_identity());
        assert_eq!(rig.shared_views, vec![13]);
        assert!(dr < 0.3, "rotation off by {dr} degrees");
        assert!(
            dlen.abs() < 0.01,
            "baseline length off by {}%",
            dlen * 100.0
        );
        assert!(ddir < 1.0, "baseline direction off by {ddir} degrees");
        assert!(
            (rig.rms_px - f(&r["rms"])).abs() < 0.05,
            "rms {} vs {}",
            rig.rms_px,
            f(&r["rms"])
        );
    }
}

// ---------------------------------------------------------------- rigs, outliers, bad input

#[test]
fn synthetic_rig_is_recovered() {
    let board = Board::new(9, 6, 25.0).unwrap();
    let left = camera(STANDARD);
    // Camera 1's centre 60 mm along camera 0's x, turned 5 degrees about y.
    let r = Rotation3::from_axis_angle(&Vector3::y_axis(), 5f64.to_radians());
    let truth = Extrinsics {
        rotation: r,
        translation: -(r * Vector3::new(60.0, 0.0, 0.0)),
    };
    let mut right = camera([-0.25, 0.08, -1e-3, 2e-4, 0.0, 0.0, 0.0, 0.0]);
    right.intrinsics.fx = 880.0;
    right.intrinsics.fy = 884.0;
    right.intrinsics.cx = 630.0;
    let right_placed = right.with_extrinsics(truth);
    let mut rng = StdRng::seed_from_u64(7);
    let (mut v0, mut v1) = (Vec::new(), Vec::new());
    for i in 0..15 {
        let pose = random_pose(&mut rng, &board, &[left, right_placed]);
        v0.push(Some(view(
            &board,
            &left,
            &pose,
            0.2,
            &mut rng,
            format!("left {i}"),
        )));
        let in_right = Extrinsics {
            rotation: truth.rotation * pose.rotation,
            translation: truth.rotation * pose.translation + truth.translation,
        };
        v1.push(Some(view(
            &board,
            &right,
            &in_right,
            0.2,
            &mut rng,
            format!("right {i}"),
        )));
    }
    // Two instants only one camera saw.
    v0[3] = None;
    v1[8] = None;
    let rig = calibrate_rig(
        &board,
        &[v0, v1],
        &[(1280, 720), (1280, 720)],
        &CalibrateOptions::default(),
    )
    .unwrap();
    let e = rig.cameras[1].camera.extrinsics;
    let dr = angle_deg(&(e.rotation * truth.rotation.inverse()));
    let base = rig.cameras[1].camera.centre();
    let dlen = base.norm() / 60.0 - 1.0;
    println!(
        "synthetic rig: rms {:.4} px, rotation off {dr:.4} deg, baseline {:.3?} mm ({:+.3}%), shared {:?}",
        rig.rms_px, base.as_slice(), dlen * 100.0, rig.shared_views
    );
    assert_eq!(rig.shared_views, vec![13]);
    assert!(rig.cameras[0].camera.extrinsics.is_identity());
    assert!(dr < 0.1, "rotation off by {dr} degrees");
    assert!(dlen.abs() < 0.005, "baseline off by {}%", dlen * 100.0);
    assert!(rig.rms_px > 0.17 && rig.rms_px < 0.23);
    assert_recovers(&rig.cameras[0], &left);
    assert_recovers(&rig.cameras[1], &right);
    assert_eq!(rig.cameras[0].views.len(), 14);
    assert_eq!(rig.cameras[1].views.len(), 14);
    // A camera that never saw the board with the others cannot be placed.
    let v = rig_views_disjoint(&board, &left);
    let e = calibrate_rig(
        &board,
        &v,
        &[(1280, 720), (1280, 720)],
        &CalibrateOptions::default(),
    )
    .unwrap_err();
    println!("{e}");
    assert!(
        matches!(&e, CalibError::Inconsistent(m) if m.contains("camera 1")),
        "{e}"
    );
}

/// Two cameras that saw the board at different instants (4 views each).
fn rig_views_disjoint(board: &Board, cam: &Camera) -> Vec<Vec<Option<BoardView>>> {
    let mut rng = StdRng::seed_from_u64(9);
    let mut a = Vec::new();
    let mut b = Vec::new();
    for i in 0..8 {
        let pose = random_pose(&mut rng, board, &[*cam]);
        let v = Some(view(board, cam, &pose, 0.2, &mut rng, format!("{i}")));
        if i % 2 == 0 {
            a.push(v);
            b.push(None);
        } else {
            a.push(None);
            b.push(v);
        }
    }
    vec![a, b]
}

#[test]
fn an_outlier_view_is_dropped() {
    let cam = camera(STANDARD);
    let (board, clean) = synthetic_views(&cam, 15, 1);
    let mut views = clean.clone();
    // View 4's corners each moved 5 px in a varying direction.
    for (j, p) in views[4].corners.iter_mut().enumerate() {
        let a = j as f64 * 2.4;
        *p += nalgebra::Vector2::new(a.cos(), a.sin()) * 5.0;
    }
    let cal = calibrate_camera(&board, &views, 1280, 720, &CalibrateOptions::default()).unwrap();
    let reason = cal.views[4].dropped.clone().expect("view 4 dropped");
    println!("view 4 dropped: {reason}");
    assert!(reason.contains("RMS") && reason.contains("px"), "{reason}");
    assert_eq!(cal.used_views(), 14);
    assert!(cal
        .views
        .iter()
        .enumerate()
        .all(|(i, v)| (i == 4) == v.dropped.is_some()));
    assert_recovers(&cal, &cam);
    let without: Vec<BoardView> = clean
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 4)
        .map(|(_, v)| v.clone())
        .collect();
    let alone =
        calibrate_camera(&board, &without, 1280, 720, &CalibrateOptions::default()).unwrap();
    let (a, b) = (cal.camera.intrinsics, alone.camera.intrinsics);
    // The same optimum, reached from another start: equal to well under the noise.
    assert!(
        (a.fx - b.fx).abs() < 1e-3 && (a.cx - b.cx).abs() < 1e-3,
        "{a:?} vs {b:?}"
    );
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let cam = camera(STANDARD);
    let (board, views) = synthetic_views(&cam, 6, 3);
    let o = CalibrateOptions::default();
    let e = calibrate_camera(&board, &views[..2], 1280, 720, &o).unwrap_err();
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
    let mut short = views.clone();
    short[1].corners.pop();
    let e = calibrate_camera(&board, &short, 1280, 720, &o).unwrap_err();
    println!("{e}");
    assert!(
        matches!(&e, CalibError::Inconsistent(m) if m.contains("53 corners")),
        "{e}"
    );
    let mut nan = views.clone();
    nan[2].corners[7].x = f64::NAN;
    let e = calibrate_camera(&board, &nan, 1280, 720, &o).unwrap_err();
    println!("{e}");
    assert!(matches!(e, CalibError::Inconsistent(_)), "{e}");
    assert!(calibrate_camera(&board, &views, 0, 720, &o).is_err());
    // Collinear corners: that view dropped with why, the rest calibrated.
    let mut flat = views.clone();
    for (j, p) in flat[0].corners.iter_mut().enumerate() {
        *p = Point2::new(100.0 + j as f64, 200.0 + 2.0 * j as f64);
    }
    let cal = calibrate_camera(&board, &flat, 1280, 720, &o).unwrap();
    println!("{:?}", cal.views[0].dropped);
    assert!(cal.views[0]
        .dropped
        .as_deref()
        .unwrap_or("")
        .contains("homography"));
    assert!(cal.views[0].rms_px.is_nan());
    // Three of them degenerate: too few left.
    for v in flat.iter_mut().take(4) {
        v.corners = vec![Point2::new(5.0, 5.0); 54];
    }
    let e = calibrate_camera(&board, &flat, 1280, 720, &o).unwrap_err();
    assert!(
        matches!(e, CalibError::TooFewViews { usable: 2, .. }),
        "{e}"
    );
    // Garbage corners (random pixels): an error or a result, never a panic.
    let junk = junk_views();
    let r = calibrate_camera(&board, &junk, 1280, 720, &o);
    println!("junk: {:?}", r.as_ref().map(|c| c.rms_px));
    // Rigs: mismatched shapes.
    let rv = vec![views.iter().cloned().map(Some).collect::<Vec<_>>()];
    // A rig of one camera, intrinsics fixed: nothing left to refine but the boards.
    let one = CalibrateOptions {
        refine_rig_intrinsics: false,
        ..o
    };
    let rig = calibrate_rig(&board, &rv, &[(1280, 720)], &one).unwrap();
    assert!(rig.shared_views.is_empty() && rig.cameras[0].camera.extrinsics.is_identity());
    assert!(matches!(
        calibrate_rig(&board, &rv, &[], &o),
        Err(CalibError::Inconsistent(_))
    ));
    let mut two = vec![rv[0].clone(), rv[0].clone()];
    two[1].pop();
    assert!(matches!(
        calibrate_rig(&board, &two, &[(1280, 720); 2], &o),
        Err(CalibError::Inconsistent(_))
    ));
}

#[test]
fn face_on_views_warn_too_flat() {
    let cam = camera(STANDARD);
    let board = Board::new(9, 6, 25.0).unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    let views: Vec<BoardView> = (0..12)
        .map(|i| {
            let pose = Extrinsics {
                rotation: Rotation3::from_euler_angles(0.0, 0.0, rng.random_range(-0.3..0.3)),
                translation: Vector3::new(
                    rng.random_range(-250.0..50.0),
                    rng.random_range(-150.0..30.0),
                    rng.random_range(450.0..700.0),
                ),
            };
            view(&board, &cam, &pose, 0.2, &mut rng, format!("face-on {i}"))
        })
        .collect();
    match calibrate_camera(&board, &views, 1280, 720, &CalibrateOptions::default()) {
        Ok(cal) => {
            report("face-on", &cal);
            assert!(
                cal.warnings
                    .iter()
                    .any(|w| matches!(w, CalibWarning::TooFlat { .. })),
                "{:?}",
                cal.warnings
            );
            for w in &cal.warnings {
                println!("  warning: {w}");
            }
        }
        Err(e) => {
            println!("face-on: {e}");
            assert!(matches!(e, CalibError::Failed(_)));
        }
    }
}

#[test]
fn few_central_views_warn() {
    let cam = camera(STANDARD);
    let (board, views) = synthetic_views(&cam, 5, 4);
    let mut central = views.clone();
    // Squeeze every view's corners towards the image centre (no longer a real camera, but
    // the coverage is what is measured).
    for v in &mut central {
        for p in &mut v.corners {
            *p = Point2::new(640.0 + (p.x - 640.0) * 0.3, 360.0 + (p.y - 360.0) * 0.3);
        }
    }
    let cal = calibrate_camera(&board, &central, 1280, 720, &CalibrateOptions::default()).unwrap();
    report("central", &cal);
    assert!(cal.warnings.contains(&CalibWarning::TooFewViews {
        used: 5,
        recommended: 10
    }));
    assert!(cal
        .warnings
        .iter()
        .any(|w| matches!(w, CalibWarning::TooCentral { coverage } if *coverage < 0.5)));
}

#[test]
fn same_input_same_bits() {
    let cam = camera(STANDARD);
    let (board, views) = synthetic_views(&cam, 12, 6);
    let a = calibrate_camera(&board, &views, 1280, 720, &CalibrateOptions::default()).unwrap();
    let b = calibrate_camera(&board, &views, 1280, 720, &CalibrateOptions::default()).unwrap();
    assert_eq!(a, b);
    let bits = |c: &CameraCalibration| {
        let k = c.camera.intrinsics;
        let mut v = vec![
            k.fx.to_bits(),
            k.fy.to_bits(),
            k.cx.to_bits(),
            k.cy.to_bits(),
            c.rms_px.to_bits(),
        ];
        v.extend(c.camera.distortion.coeffs.iter().map(|d| d.to_bits()));
        v.extend(
            c.views
                .iter()
                .flat_map(|v| v.board_pose.translation.iter().map(|t| t.to_bits())),
        );
        v
    };
    assert_eq!(bits(&a), bits(&b));
}

#[test]
#[allow(clippy::needless_range_loop)] // views[camera][instant], filled by instant
fn a_third_camera_is_chained_through_the_second() {
    let board = Board::new(9, 6, 25.0).unwrap();
    let cam = camera(STANDARD);
    let place = |deg: f64, x: f64| {
        let r = Rotation3::from_axis_angle(&Vector3::y_axis(), deg.to_radians());
        Extrinsics {
            rotation: r,
            translation: -(r * Vector3::new(x, 0.0, 0.0)),
        }
    };
    let poses = [Extrinsics::default(), place(4.0, 60.0), place(8.0, 120.0)];
    let cams: Vec<Camera> = poses.iter().map(|p| cam.with_extrinsics(*p)).collect();
    let mut rng = StdRng::seed_from_u64(21);
    let mut views = vec![vec![None; 16]; 3];
    for i in 0..16 {
        // Instants 0-7 seen by cameras 0 and 1, 8-15 by cameras 1 and 2.
        let pair = if i < 8 { [0, 1] } else { [1, 2] };
        let pose = random_pose(&mut rng, &board, &[cams[pair[0]], cams[pair[1]]]);
        for k in pair {
            let e = poses[k];
            let in_k = Extrinsics {
                rotation: e.rotation * pose.rotation,
                translation: e.rotation * pose.translation + e.translation,
            };
            views[k][i] = Some(view(&board, &cam, &in_k, 0.2, &mut rng, format!("{k}/{i}")));
        }
    }
    let rig = calibrate_rig(
        &board,
        &views,
        &[(1280, 720); 3],
        &CalibrateOptions::default(),
    )
    .unwrap();
    assert_eq!(rig.shared_views, vec![8, 8]);
    for (k, (cal, truth)) in rig.cameras.iter().zip(&poses).enumerate().skip(1) {
        let e = cal.camera.extrinsics;
        let dr = angle_deg(&(e.rotation * truth.rotation.inverse()));
        let dt = (e.translation - truth.translation).norm();
        println!("chained rig, camera {k}: rotation off {dr:.4} deg, translation off {dt:.3} mm");
        assert!(
            dr < 0.1 * k as f64 && dt < 0.01 * 60.0 * k as f64,
            "camera {k}"
        );
    }
}
