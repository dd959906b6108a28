//! The calibration formats robotics uses, read from files in their real layouts
//! (`tests/data`): OpenCV FileStorage with a stated fisheye model, ROS `camera_info`
//! YAML and Kalibr camera chains. Each camera must project as the tool that wrote its
//! file does: the OpenCV numbers below are `tests/data/cv_reference.py`'s output
//! (opencv-python-headless 5.0.0).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use monohand_core::camera::{Camera, Distortion, Extrinsics, LensModel};
use monohand_io::calibration::{
    calibrated_camera_json, detect_format, opencv_yaml, parse_calibration, read_calibration,
    read_calibrations, CalibrationFormat, CalibrationInfo, CameraStd,
};
use nalgebra::{Matrix4, Point2, Rotation3, Vector3, Vector4};
use std::path::PathBuf;

// OpenCV 5.0.0
const POINTS: [[f64; 3]; 5] = [
    [100.0, -50.0, 400.0],
    [300.0, 200.0, 100.0],
    [-500.0, 120.0, 60.0],
    [10.0, 5.0, 2000.0],
    [1000.0, -300.0, 17.0],
];
const FISHEYE_PIXELS: [[f64; 2]; 5] = [
    [756.5697071586155, 300.96514642069224],
    [1168.4171628359259, 712.1114418906172],
    [-52.30052115320984, 525.5321250767704],
    [641.8976276356198, 360.6988138178099],
    [1367.1595867461135, 141.20212397616592],
];
const PIXELS: [[f64; 2]; 5] = [
    [639.5, 359.5],
    [0.0, 0.0],
    [1279.0, 719.0],
    [900.0, 100.0],
    [320.0, 500.0],
];
const FISHEYE_RAYS: [[f64; 3]; 5] = [
    [0.0, 0.0, 1.0],
    [
        -0.8695402856850354,
        -0.48881897217165005,
        0.07039676140163446,
    ],
    [0.8695402856850354, 0.48881897217165005, 0.07039676140163446],
    [0.48771277634078214, -0.485840558389378, 0.7253242031104873],
    [-0.6045110909367195, 0.2658335157327358, 0.7509320094706781],
];
const ROS_POINTS: [[f64; 3]; 3] = [
    [100.0, -50.0, 400.0],
    [-150.0, 120.0, 300.0],
    [0.0, 0.0, 500.0],
];
const PLUMB_BOB_PIXELS: [[f64; 2]; 3] = [
    [469.91419141915696, 169.27162456662086],
    [57.723413403005, 454.456318230108],
    [321.7, 243.28],
];
const RATIONAL_PIXELS: [[f64; 2]; 3] = [
    [470.61497331027056, 168.91433719881866],
    [53.350147393713485, 457.9371353865729],
    [321.7, 243.28],
];

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn text(name: &str) -> String {
    std::fs::read_to_string(data(name)).unwrap()
}

/// The largest pixel distance between a camera's projections and OpenCV's.
fn worst_pixel(cam: &Camera, points: &[[f64; 3]], want: &[[f64; 2]]) -> f64 {
    points
        .iter()
        .zip(want)
        .map(|(p, w)| {
            let px = cam.project(&Vector3::from(*p)).expect("seen");
            (px - Point2::new(w[0], w[1])).norm()
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_issues_fisheye_file_projects_as_cv_fisheye() {
    // Issue 44's file: OpenCV FileStorage, `distortion_model: fisheye`, 4 coefficients.
    for file in ["opencv_fisheye.yaml", "opencv_fisheye_sample.yml"] {
        let cal = read_calibration(data(file)).unwrap();
        assert_eq!(cal.format, CalibrationFormat::OpenCvYaml);
        let cam = cal.camera;
        assert_eq!(cam.distortion.model, LensModel::Fisheye, "{file}");
        assert_eq!(cam.distortion.listed(), &[0.02, -0.005, 0.0, 0.0]);
        let worst = worst_pixel(&cam, &POINTS, &FISHEYE_PIXELS);
        println!("{file}: cv::fisheye::projectPoints within {worst:.1e} px");
        assert!(worst < 1e-9, "{file}: {worst} px");
        // cv::fisheye::undistortPoints, as rays.
        let mut worst_ray: f64 = 0.0;
        for (p, want) in PIXELS.iter().zip(&FISHEYE_RAYS) {
            let ray = cam.ray(Point2::new(p[0], p[1])).unwrap();
            worst_ray = worst_ray.max((ray - Vector3::from(*want)).norm());
        }
        println!("{file}: cv::fisheye::undistortPoints within {worst_ray:.1e}");
        assert!(worst_ray < 1e-12, "{file}: {worst_ray}");
        assert!((cam.field_of_view_deg() - 150.0).abs() < 1e-9);
    }
    // Without its model key the same numbers are a pinhole's k1 k2 p1 p2, as OpenCV's
    // calibrateCamera writes them: the key decides, never the count.
    let pinhole = text("opencv_fisheye.yaml").replace("distortion_model: fisheye\n", "");
    let cam = parse_calibration(&pinhole, "cam.yaml").unwrap().camera;
    assert_eq!(cam.distortion.model, LensModel::Pinhole);
    assert!(worst_pixel(&cam, &POINTS[1..2], &FISHEYE_PIXELS[1..2]) > 50.0);
}

#[test]
fn ros_camera_info_files_project_as_opencv() {
    let cal = read_calibration(data("ros_plumb_bob.yaml")).unwrap();
    assert_eq!(cal.format, CalibrationFormat::RosCameraInfo);
    assert_eq!(cal.camera.distortion.model, LensModel::Pinhole);
    assert_eq!(
        cal.camera.distortion.listed(),
        &[-0.412, 0.188, 0.0012, -0.0007, -0.041]
    );
    let worst = worst_pixel(&cal.camera, &ROS_POINTS, &PLUMB_BOB_PIXELS);
    assert!(worst < 1e-9, "plumb_bob: {worst} px");
    // camera_calibration_parsers' layout (yaml-cpp), rational_polynomial.
    let cal = read_calibration(data("ros_rational.yaml")).unwrap();
    assert_eq!(cal.camera.distortion.listed().len(), 8);
    let worst = worst_pixel(&cal.camera, &ROS_POINTS, &RATIONAL_PIXELS);
    assert!(worst < 1e-9, "rational_polynomial: {worst} px");
    // equidistant: issue 44's fisheye, its focal length written to 5 decimals
    // (479.53022 for 479.5302224...): OpenCV's pixels within 2.3e-6 x 1.6 px.
    let cal = read_calibration(data("ros_equidistant.yaml")).unwrap();
    assert_eq!(
        (cal.camera.intrinsics.width, cal.camera.intrinsics.height),
        (1280, 720)
    );
    assert_eq!(cal.camera.distortion.model, LensModel::Fisheye);
    let worst = worst_pixel(&cal.camera, &POINTS[..4], &FISHEYE_PIXELS[..4]);
    println!("ros equidistant: cv::fisheye::projectPoints within {worst:.1e} px");
    assert!(worst < 1e-5, "equidistant: {worst} px");
    for f in [
        "ros_plumb_bob.yaml",
        "ros_rational.yaml",
        "ros_equidistant.yaml",
    ] {
        assert_eq!(
            detect_format(&text(f)),
            Some(CalibrationFormat::RosCameraInfo),
            "{f}"
        );
    }
}

/// A Kalibr `T_cn_cnm1` as written in the fixtures, metres.
fn kalibr_transform(rows: [[f64; 4]; 3]) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    for (r, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            m[(r, c)] = *v;
        }
    }
    m
}

/// `cam1` of both chains: `cam0` to `cam1`, metres.
fn t10() -> Matrix4<f64> {
    kalibr_transform([
        [
            0.996170421530,
            -0.006954694495,
            0.087155742748,
            -0.120340000000,
        ],
        [
            0.006981260298,
            0.999975630705,
            0.000000000000,
            0.001520000000,
        ],
        [
            -0.087153618824,
            0.000608456927,
            0.996194698092,
            -0.000870000000,
        ],
    ])
}

/// The point `x` (mm) of one camera's frame in another's, through `t` (metres).
fn through(t: &Matrix4<f64>, x: &Vector3<f64>) -> Vector3<f64> {
    let h = t * Vector4::new(x.x / 1000.0, x.y / 1000.0, x.z / 1000.0, 1.0);
    Vector3::new(h.x, h.y, h.z) * 1000.0
}

#[test]
fn a_kalibr_rig_maps_cam0s_points_into_each_camera() {
    let cams = read_calibrations(data("kalibr_camchain_imucam.yaml")).unwrap();
    assert_eq!(cams.len(), 2);
    let (c0, c1) = (cams[0].camera, cams[1].camera);
    assert_eq!(cams[0].format, CalibrationFormat::KalibrCamchain);
    // cam0: pinhole-radtan, k1 k2 r1 r2 = OpenCV's k1 k2 p1 p2, at the reference.
    assert!(c0.extrinsics.is_identity());
    assert_eq!(
        c0.distortion,
        Distortion::from_slice(&[-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]).unwrap()
    );
    assert_eq!((c0.intrinsics.fx, c0.intrinsics.cy), (458.654, 248.375));
    // cam1: pinhole-equi, placed by T_c1_c0.
    assert_eq!(c1.distortion.model, LensModel::Fisheye);
    let x = Vector3::new(-80.0, 35.0, 650.0);
    let want = through(&t10(), &x);
    let got = c1.extrinsics.transform(&x);
    println!("cam1: {:.2e} mm from T_c1_c0 X", (got - want).norm());
    assert!((got - want).norm() < 1e-6, "{got} vs {want}");
    // cam1's centre in cam0: 120 mm to the right (Kalibr's -0.12034 m is cam0's in cam1).
    assert!(
        (c1.centre() - Vector3::new(119.79, -2.356, 11.355)).norm() < 0.01,
        "{}",
        c1.centre()
    );
    // And its pixel is its lens's projection of that point.
    let px = c1.project(&x).unwrap();
    assert!((px - c1.project_cam(&want).unwrap()).norm() < 1e-6);
    // One camera of a chain is named; the chain alone is refused, naming them.
    let file = data("kalibr_camchain_imucam.yaml");
    let e = read_calibration(&file).unwrap_err().to_string();
    assert!(
        e.contains("camera chain of 2 cameras") && e.contains("#cam1"),
        "{e}"
    );
    let one = read_calibration(format!("{}#cam1", file.display())).unwrap();
    assert_eq!(one.camera, c1);
    let e = read_calibration(format!("{}#cam2", file.display())).unwrap_err();
    assert!(e.to_string().contains("no cam2"), "{e}");
    let e = read_calibration(format!("{}#cam1", data("ros_plumb_bob.yaml").display()));
    assert!(e.unwrap_err().to_string().contains("one camera"));
}

#[test]
fn a_three_camera_kalibr_chain_in_block_style_chains_its_transforms() {
    // PyYAML's block style (lists of lists as `- - x`), as Kalibr under Python 3 writes.
    let cams = read_calibrations(data("kalibr_camchain_block.yaml")).unwrap();
    assert_eq!(cams.len(), 3);
    assert_eq!(cams[0].camera.distortion.model, LensModel::Fisheye);
    assert_eq!(cams[1].camera.distortion.listed().len(), 4);
    assert!(cams[2].camera.distortion.is_ideal());
    let t21 = kalibr_transform([
        [
            0.984807753012,
            0.000000000000,
            -0.173648177667,
            -0.099810000000,
        ],
        [
            -0.009088043428,
            0.998629534755,
            -0.051540855469,
            0.010200000000,
        ],
        [
            0.173410198875,
            0.052335956243,
            0.983458108213,
            0.020460000000,
        ],
    ]);
    let x = Vector3::new(40.0, -60.0, 500.0);
    let in1 = cams[1].camera.extrinsics.transform(&x);
    let in2 = cams[2].camera.extrinsics.transform(&x);
    assert!((in1 - through(&t10(), &x)).norm() < 1e-6);
    let want = through(&(t21 * t10()), &x);
    println!(
        "cam2: {:.2e} mm from T_c2_c1 T_c1_c0 X",
        (in2 - want).norm()
    );
    assert!((in2 - want).norm() < 1e-6, "{in2} vs {want}");
    // cam2 from cam1 alone is T_c2_c1.
    let e1 = cams[1].camera.extrinsics;
    let back = e1.rotation.inverse() * (in1 - e1.translation);
    assert!((back - x).norm() < 1e-9);
    assert!((through(&t21, &in1) - in2).norm() < 1e-6);
    assert_eq!(
        detect_format(&text("kalibr_camchain_block.yaml")),
        Some(CalibrationFormat::KalibrCamchain)
    );
}

fn info() -> CalibrationInfo {
    CalibrationInfo {
        rms_px: 0.31,
        views: 24,
        board_cols: 9,
        board_rows: 6,
        square_mm: 25.0,
        date: "2026-01-05T10:00:00Z".into(),
        std: None,
    }
}

#[test]
fn a_fisheye_round_trips_through_the_projects_json_and_opencv_yaml() {
    let cam = read_calibration(data("opencv_fisheye.yaml"))
        .unwrap()
        .camera;
    let cam = cam.with_extrinsics(Extrinsics {
        rotation: Rotation3::from_euler_angles(0.01, -0.2, 0.03),
        translation: Vector3::new(-95.0, 1.5, 4.0),
    });
    let json = calibrated_camera_json(&cam, &info());
    assert_eq!(json["model"], "fisheye");
    assert_eq!(json["dist"], serde_json::json!([0.02, -0.005, 0.0, 0.0]));
    let back = parse_calibration(&json.to_string(), "cam.json")
        .unwrap()
        .camera;
    assert_eq!(back.distortion, cam.distortion);
    assert_eq!(back.intrinsics, cam.intrinsics);
    assert!((back.extrinsics.rotation.matrix() - cam.extrinsics.rotation.matrix()).amax() < 1e-12);
    let yaml = opencv_yaml(&cam, &info());
    assert!(yaml.contains("fisheye_model: 1\n"), "{yaml}");
    let back = parse_calibration(&yaml, "cam.yaml").unwrap().camera;
    assert_eq!(back.distortion, cam.distortion);
    assert_eq!(back.intrinsics, cam.intrinsics);
    // A fisheye with zero coefficients is still one (the equidistant projection).
    let mut zero = cam;
    zero.distortion = Distortion::fisheye([0.0; 4]).unwrap();
    let json = calibrated_camera_json(&zero, &info()).to_string();
    let back = parse_calibration(&json, "cam.json").unwrap().camera;
    assert_eq!(back.distortion.model, LensModel::Fisheye);
}

#[test]
fn a_fisheye_calibration_is_written_with_its_model_and_reads_back_as_one() {
    // What `monohand calibrate --model fisheye` writes: a fisheye camera of monohand-calib's
    // (a 168 degree lens, all four coefficients) with its RMS and 4 standard deviations.
    let cam = Camera::fisheye(
        399.702,
        401.098,
        634.943,
        363.895,
        1280,
        720,
        [0.08114, -0.03138, 0.00913, -0.00127],
    )
    .unwrap();
    let info = CalibrationInfo {
        rms_px: 0.196,
        std: Some(CameraStd {
            fx: 0.353,
            fy: 0.394,
            cx: 0.455,
            cy: 0.438,
            dist: vec![0.00214, 0.00321, 0.00205, 0.00044],
        }),
        ..info()
    };
    let json = calibrated_camera_json(&cam, &info);
    assert_eq!(json["model"], "fisheye");
    assert_eq!(json["dist"].as_array().unwrap().len(), 4);
    assert_eq!(json["std"]["dist"].as_array().unwrap().len(), 4);
    let back = parse_calibration(&json.to_string(), "cam.json").unwrap();
    assert_eq!(back.camera.distortion, cam.distortion);
    assert_eq!(back.camera.intrinsics, cam.intrinsics);
    assert_eq!(back.reprojection_error_px, Some(0.196));
    let yaml = opencv_yaml(&cam, &info);
    assert!(yaml.contains("fisheye_model: 1\n"), "{yaml}");
    assert!(yaml.contains("rows: 1\n   cols: 4\n"), "{yaml}");
    let back = parse_calibration(&yaml, "cam.yaml").unwrap();
    assert_eq!(back.camera.distortion.model, LensModel::Fisheye);
    assert_eq!(back.camera.distortion, cam.distortion);
    assert_eq!(back.camera.intrinsics, cam.intrinsics);
    assert_eq!(back.reprojection_error_px, Some(0.196));
    // Both read back project a ray 80 degrees off the axis where the camera does.
    let ray = Vector3::new(80f64.to_radians().tan(), 0.3, 1.0);
    let want = cam.project_cam(&ray).unwrap();
    let got = back.camera.project_cam(&ray).unwrap();
    assert!((got - want).norm() < 1e-9, "{got:?} vs {want:?}");
}
