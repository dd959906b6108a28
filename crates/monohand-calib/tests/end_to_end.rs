//! The corner finder and the calibration together on OpenCV's real stereo photographs,
//! against OpenCV's own calibration of them: what `monohand calibrate` computes, without
//! the command line.
//!
//! Two references, both OpenCV's (`tests/data/calibrate_opencv_corners.py`, opencv-python
//! 5.0.0, on OpenCV's own corners in `opencv_stereo_chessboard_corners.txt`):
//! - its tutorials' settings, `cornerSubPix` with `winSize (11, 11)` (a 23x23 window; the
//!   shared README's numbers), reproduced by `find_chessboard_with(.., Some(11))` and
//!   every view kept (OpenCV drops none);
//! - a window that fits these squares, `winSize (5, 5)`, which is what the corner finder
//!   uses by default here (the 23x23 window reaches the next corners and drags 45 of the
//!   1404 corners by over 0.3 px, one by 6.4 px; docs/calibration.md).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use monohand_calib::calibrate::{
    calibrate_camera, calibrate_rig, BoardView, CalibrateOptions, CameraCalibration,
    DistortionModel,
};
use monohand_calib::corners::find_chessboard_with;
use monohand_calib::{Board, GrayImage};
use monohand_core::camera::LensModel;
use monohand_testkit::shared_data;
use nalgebra::{Rotation3, Vector3};

fn views(prefix: &str, board: &Board, half_window: Option<usize>) -> Vec<BoardView> {
    let dir = shared_data().join("calibration/opencv_stereo_chessboard");
    assert!(dir.is_dir(), "{} is missing", dir.display());
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with(prefix) && n.ends_with(".jpg"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 13);
    names
        .iter()
        .map(|n| {
            let img = image::open(dir.join(n)).unwrap().to_luma8();
            let (w, h) = (img.width() as usize, img.height() as usize);
            let grey = GrayImage::new(w, h, img.as_raw()).unwrap();
            let found = find_chessboard_with(&grey, board, half_window)
                .unwrap_or_else(|e| panic!("{n}: {e}"));
            BoardView {
                name: n.clone(),
                corners: found.corners,
            }
        })
        .collect()
}

/// fx fy cx cy rms.
fn check(what: &str, cal: &CameraCalibration, cv: [f64; 5]) {
    let k = cal.camera.intrinsics;
    let got = [k.fx, k.fy, k.cx, k.cy, cal.rms_px];
    println!("{what}: fx fy cx cy rms {got:.4?}, OpenCV {cv:?}");
    assert!((got[0] / cv[0] - 1.0).abs() < 0.005, "{what}: fx");
    assert!((got[1] / cv[1] - 1.0).abs() < 0.005, "{what}: fy");
    assert!((got[2] - cv[2]).abs() < 2.0, "{what}: cx");
    assert!((got[3] - cv[3]).abs() < 2.0, "{what}: cy");
    assert!((got[4] - cv[4]).abs() < 0.05, "{what}: rms");
}

const BOARD: (usize, usize, f64) = (9, 6, 25.0);

#[test]
fn each_camera_matches_opencv_with_a_window_that_fits_the_squares() {
    let board = Board::new(BOARD.0, BOARD.1, BOARD.2).unwrap();
    let opts = CalibrateOptions::default();
    for (prefix, cv) in [
        ("left", [532.827, 532.946, 342.487, 233.856, 0.1954]),
        ("right", [537.453, 536.969, 327.586, 248.882, 0.2070]),
    ] {
        let cal = calibrate_camera(&board, &views(prefix, &board, None), 640, 480, &opts).unwrap();
        assert_eq!(cal.used_views(), 13, "{prefix}: no view dropped");
        check(prefix, &cal, cv);
    }
}

/// What `monohand calibrate --model fisheye` computes on these photos: the fisheye model
/// (k1..k4) fits a 60 degree lens about as well as the pinhole does, with the same focal
/// length (both are `f theta` near the axis). OpenCV's pinhole numbers (window 5) are the
/// reference; tests/fisheye.rs compares with cv2.fisheye.calibrate on the same corners.
#[test]
fn the_fisheye_model_fits_the_photos_as_the_pinhole_does() {
    let board = Board::new(BOARD.0, BOARD.1, BOARD.2).unwrap();
    let opts = CalibrateOptions {
        model: DistortionModel::Fisheye,
        ..CalibrateOptions::default()
    };
    for (prefix, cv) in [
        ("left", [532.827, 532.946, 342.487, 233.856, 0.1954]),
        ("right", [537.453, 536.969, 327.586, 248.882, 0.2070]),
    ] {
        let cal = calibrate_camera(&board, &views(prefix, &board, None), 640, 480, &opts).unwrap();
        let d = cal.camera.distortion;
        println!(
            "{prefix}, fisheye: k {:?}, {} views",
            d.listed(),
            cal.used_views()
        );
        assert_eq!(d.model, LensModel::Fisheye);
        assert_eq!(cal.used_views(), 13, "{prefix}: no view dropped");
        check(&format!("{prefix}, fisheye"), &cal, cv);
    }
}

#[test]
fn each_camera_matches_opencv_tutorials_settings() {
    let board = Board::new(BOARD.0, BOARD.1, BOARD.2).unwrap();
    let opts = CalibrateOptions {
        outlier_factor: f64::INFINITY,
        ..CalibrateOptions::default()
    };
    // The shared README's numbers (OpenCV 4.x: 536.1 536.0 342.4 235.5 0.41, right 542.4
    // 541.6 328.3 247.0 0.46), to more digits from opencv-python 5.0.0.
    for (prefix, cv) in [
        ("left", [536.073, 536.016, 342.370, 235.537, 0.4087]),
        ("right", [542.355, 541.615, 328.324, 246.947, 0.4586]),
    ] {
        let v = views(prefix, &board, Some(11));
        let cal = calibrate_camera(&board, &v, 640, 480, &opts).unwrap();
        check(&format!("{prefix}, 23x23 window"), &cal, cv);
    }
}

/// The right camera's rotation (degrees off) and baseline (relative length, degrees of
/// direction) against OpenCV's `stereoCalibrate`.
fn rig_against(
    rig_views: [Vec<BoardView>; 2],
    rvec: [f64; 3],
    t: [f64; 3],
    opts: &CalibrateOptions,
) {
    let board = Board::new(BOARD.0, BOARD.1, BOARD.2).unwrap();
    let [l, r] = rig_views.map(|v| v.into_iter().map(Some).collect::<Vec<_>>());
    let rig = calibrate_rig(&board, &[l, r], &[(640, 480); 2], opts).unwrap();
    let e = rig.cameras[1].camera.extrinsics;
    let cv_r = Rotation3::new(Vector3::from(rvec));
    let cv_t = Vector3::from(t);
    let angle = (e.rotation * cv_r.inverse()).angle().to_degrees();
    let length = e.translation.norm() / cv_t.norm() - 1.0;
    let direction = e.translation.angle(&cv_t).to_degrees();
    println!(
        "rig: rotation {angle:.4} deg from OpenCV's, baseline {:.2} mm ({:+.3}%), direction {direction:.3} deg; rms {:.4}",
        e.translation.norm(),
        length * 100.0,
        rig.rms_px
    );
    assert!(angle < 0.3, "rotation {angle} degrees off");
    assert!(length.abs() < 0.01, "baseline {length}");
    assert!(direction < 1.0, "direction {direction} degrees off");
}

#[test]
fn the_rig_matches_opencv_stereo_calibrate() {
    let board = Board::new(BOARD.0, BOARD.1, BOARD.2).unwrap();
    rig_against(
        [views("left", &board, None), views("right", &board, None)],
        [
            0.007127046303147738,
            0.004200612759476957,
            -0.0035190992125640995,
        ],
        [-83.17641882612769, 0.9197708130198782, -0.11818825942730671],
        &CalibrateOptions::default(),
    );
    let keep_all = CalibrateOptions {
        outlier_factor: f64::INFINITY,
        ..CalibrateOptions::default()
    };
    rig_against(
        [
            views("left", &board, Some(11)),
            views("right", &board, Some(11)),
        ],
        [
            0.004564878223965036,
            0.0031486420770993353,
            -0.0038208762071128485,
        ],
        [
            -83.44763659552572,
            0.9639598768235129,
            -0.007466267400071932,
        ],
        &keep_all,
    );
}

/// A board rendered through a known camera with strong distortion (the pixels made by
/// following each pixel's ray through the lens onto the board, 2x2 samples a
/// pixel), then found and calibrated: the true intrinsics come back.
#[test]
fn a_rendered_board_through_a_strongly_distorted_lens_gives_the_camera_back() {
    use monohand_core::camera::{Camera, Distortion, Extrinsics, Intrinsics};
    let (w, h) = (1280usize, 720usize);
    let truth = Camera::new(
        Intrinsics {
            fx: 900.0,
            fy: 905.0,
            cx: 650.0,
            cy: 350.0,
            width: w as u32,
            height: h as u32,
        },
        Distortion::from_slice(&[-0.3, 0.12, 1e-3, -5e-4, -0.02]).unwrap(),
        Extrinsics::default(),
    )
    .unwrap();
    let board = Board::new(9, 6, 25.0).unwrap();
    let k = truth.intrinsics;
    let mut views = Vec::new();
    // Poses: the board tilted 15-45 degrees about varied axes, 350-550 mm away, over the image.
    for i in 0..14 {
        let a = i as f64;
        let tilt = (15.0 + 30.0 * ((a * 0.37).sin() * 0.5 + 0.5)).to_radians();
        let axis = nalgebra::Unit::new_normalize(Vector3::new(
            (a * 1.3).cos(),
            (a * 1.3).sin(),
            0.2 * (a * 0.7).cos(),
        ));
        let r = Rotation3::from_axis_angle(&axis, tilt);
        let centre = Vector3::new(
            110.0 * (a * 2.1).cos(),
            70.0 * (a * 1.7).sin(),
            380.0 + 15.0 * a,
        );
        let t = centre - r * Vector3::new(100.0, 62.5, 0.0);
        let n = r * Vector3::z();
        let mut px = vec![0u8; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut sum = 0.0;
                for (dx, dy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let d = nalgebra::Vector2::new(
                        (x as f64 + dx - k.cx) / k.fx,
                        (y as f64 + dy - k.cy) / k.fy,
                    );
                    let u = truth.distortion.undistort(d).unwrap();
                    let ray = Vector3::new(u.x, u.y, 1.0);
                    let s = n.dot(&t) / n.dot(&ray);
                    let p = r.inverse() * (ray * s - t);
                    let (c, q) = ((p.x / 25.0 + 1.0).floor(), (p.y / 25.0 + 1.0).floor());
                    let inside = (0.0..10.0).contains(&c) && (0.0..7.0).contains(&q);
                    sum += if inside && (c + q) as i64 % 2 == 0 {
                        30.0
                    } else {
                        220.0
                    };
                }
                px[y * w + x] = (sum / 4.0) as u8;
            }
        }
        let grey = GrayImage::new(w, h, &px).unwrap();
        if let Ok(found) = monohand_calib::corners::find_chessboard(&grey, &board) {
            views.push(BoardView {
                name: format!("render {i}"),
                corners: found.corners,
            });
        }
    }
    assert!(views.len() >= 12, "{} of 14 renders found", views.len());
    let cal = calibrate_camera(
        &board,
        &views,
        w as u32,
        h as u32,
        &CalibrateOptions::default(),
    )
    .unwrap();
    let got = cal.camera.intrinsics;
    println!(
        "rendered: fx {:.2} fy {:.2} cx {:.2} cy {:.2} rms {:.3} from {} views; dist {:?}",
        got.fx,
        got.fy,
        got.cx,
        got.cy,
        cal.rms_px,
        views.len(),
        cal.camera.distortion.coeffs
    );
    assert!((got.fx / 900.0 - 1.0).abs() < 0.002, "fx {}", got.fx);
    assert!((got.fy / 905.0 - 1.0).abs() < 0.002, "fy {}", got.fy);
    assert!((got.cx - 650.0).abs() < 2.0 && (got.cy - 350.0).abs() < 2.0);
}
