use super::*;
use std::path::PathBuf;

/// The wacv18 webcam numbers, as cv::FileStorage (OpenCV 4) writes them in YAML.
const YAML: &str = r#"%YAML:1.0
---
calibration_time: "Wed 12 Nov 2025 10:00:00 CET"
nr_of_frames: 25
image_width: 640
image_height: 480
board_width: 9
board_height: 6
square_size: 25.
flags: 0
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 6.7724586254666637e+02, 0., 3.1994756334894319e+02, 0.,
       6.8024297317066178e+02, 2.3882859474169499e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ 1.8681114967853352e-01, -1.3734152813512340e+00, 0., 0.,
       2.6679646461641733e+00 ]
avg_reprojection_error: 2.2683652780513805e-01
per_view_reprojection_errors: !!opencv-matrix
   rows: 2
   cols: 1
   dt: f
   data: [ 2.10001156e-01, 2.43654758e-01 ]
"#;

/// The same, as cv::FileStorage writes XML.
const XML: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<calibration_time>"Wed 12 Nov 2025 10:00:00 CET"</calibration_time>
<nr_of_frames>25</nr_of_frames>
<image_width>640</image_width>
<image_height>480</image_height>
<camera_matrix type_id="opencv-matrix">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>
    6.7724586254666637e+02 0. 3.1994756334894319e+02 0.
    6.8024297317066178e+02 2.3882859474169499e+02 0. 0. 1.</data></camera_matrix>
<distortion_coefficients type_id="opencv-matrix">
  <rows>5</rows>
  <cols>1</cols>
  <dt>d</dt>
  <data>
    1.8681114967853352e-01 -1.3734152813512340e+00 0. 0.
    2.6679646461641733e+00</data></distortion_coefficients>
<avg_reprojection_error>2.2683652780513805e-01</avg_reprojection_error>
</opencv_storage>
"#;

/// A stereo right camera (cv::stereoCalibrate R, T) in OpenCV 3 style YAML (no `---`).
const STEREO_YAML: &str = include_str!("../../tests/data/stereo_right.yml");

fn wacv18_path() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/hand_models/wacv18/calib_webcam_mshd_vga.json");
    if p.exists() {
        Some(p)
    } else {
        panic!("wacv18 calibration not found at {}", p.display())
    }
}

fn check_webcam(c: &Camera) {
    let k = &c.intrinsics;
    assert!((k.fx - 677.2458625466664).abs() < 1e-9, "{k:?}");
    assert!((k.fy - 680.2429731706618).abs() < 1e-9);
    assert!((k.cx - 319.9475633489432).abs() < 1e-9);
    assert!((k.cy - 238.82859474169499).abs() < 1e-9);
    assert_eq!((k.width, k.height), (640, 480));
    let d = c.distortion.coeffs;
    assert!((d[0] - 0.18681114967853352).abs() < 1e-12);
    assert!((d[1] + 1.373415281351234).abs() < 1e-12);
    assert!((d[4] - 2.6679646461641733).abs() < 1e-12);
    assert_eq!(&d[5..], &[0.0; 3]);
}

fn err(text: &str) -> String {
    parse_calibration(text, "cam.cfg").unwrap_err().to_string()
}

#[test]
fn real_wacv18_file() {
    let Some(p) = wacv18_path() else { return };
    let cal = read_calibration(&p).unwrap();
    assert_eq!(cal.format, CalibrationFormat::Wacv18Json);
    check_webcam(&cal.camera);
    assert!(cal.camera.extrinsics.is_identity());
    let pose = cal.target_pose.unwrap();
    let angle = pose.rotation.angle();
    let rv: f64 = (0.1679926547280827f64.powi(2)
        + 0.0489874819276265f64.powi(2)
        + 1.6331950639580286f64.powi(2))
    .sqrt();
    assert!((angle - rv).abs() < 1e-12);
    assert!((pose.translation.z - 19.02926322842629).abs() < 1e-12);
    assert!((cal.reprojection_error_px.unwrap() - 0.22683652780513805).abs() < 1e-15);
}

#[test]
fn opencv_yaml_and_xml_match_the_json() {
    let y = parse_calibration(YAML, "cam.yml").unwrap();
    assert_eq!(y.format, CalibrationFormat::OpenCvYaml);
    check_webcam(&y.camera);
    assert!((y.reprojection_error_px.unwrap() - 0.22683652780513805).abs() < 1e-15);
    let x = parse_calibration(XML, "cam.xml").unwrap();
    assert_eq!(x.format, CalibrationFormat::OpenCvXml);
    check_webcam(&x.camera);
    assert_eq!(x.camera, y.camera);
    // Windows line endings and a BOM change nothing.
    let crlf = format!("\u{feff}{}", YAML.replace('\n', "\r\n"));
    assert_eq!(
        parse_calibration(&crlf, "cam.yml").unwrap().camera,
        y.camera
    );
}

#[test]
fn opencv_stereo_extrinsics() {
    let c = parse_calibration(STEREO_YAML, "right.yml").unwrap().camera;
    assert_eq!((c.intrinsics.width, c.intrinsics.height), (640, 480));
    assert!((c.centre() - Vector3::new(120.054, 0.0, 0.0)).norm() < 1e-9);
    let x = Vector3::new(0.0, 0.0, 600.0);
    assert!((c.project(&x).unwrap().x - (318.47345 - 822.79041 * 120.054 / 600.0)).abs() < 1e-6);
    // Rotation vector form of R.
    let rv = STEREO_YAML.replace(
        "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 9.9999999999999989e-01, 0., 0., 0., 1., 0., 0., 0., 1. ]",
        "   rows: 3\n   cols: 1\n   dt: d\n   data: [ 0., 0.1, 0. ]",
    );
    let c2 = parse_calibration(&rv, "right.yml").unwrap().camera;
    assert!((c2.extrinsics.rotation.angle() - 0.1).abs() < 1e-12);
}

#[test]
fn monohand_json_round_trip() {
    let mut cam = Camera::pinhole(800.0, 810.0, 320.5, 240.5, 640, 480).unwrap();
    cam.distortion = Distortion::from_slice(&[0.1, -0.2, 0.001, 0.002, 0.05]).unwrap();
    cam.extrinsics = Extrinsics {
        rotation: Rotation3::from_euler_angles(0.1, -0.2, 0.3),
        translation: Vector3::new(-100.0, 5.0, 2.0),
    };
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cam.json");
    write_camera_json(&p, &cam).unwrap();
    let back = read_camera(&p).unwrap();
    assert_eq!(back.intrinsics, cam.intrinsics);
    assert_eq!(back.distortion, cam.distortion);
    assert!((back.extrinsics.rotation.matrix() - cam.extrinsics.rotation.matrix()).norm() < 1e-12);
    assert_eq!(back.extrinsics.translation, cam.extrinsics.translation);
    // A plain camera writes only the six intrinsics.
    let plain = camera_to_json(&Camera::generic(640, 480).unwrap());
    assert_eq!(plain.as_object().unwrap().len(), 6);
    // Rotation vector form.
    let c = parse_calibration(
        r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480, "R": [0, 0.2, 0], "t": [1, 2, 3]}"#,
        "c.json",
    )
    .unwrap()
    .camera;
    assert!((c.extrinsics.rotation.angle() - 0.2).abs() < 1e-12);
}

#[test]
fn a_generic_camera_reads_back_with_its_field_of_view_noted() {
    let cam = Camera::with_hfov(1280, 720, 70.0).unwrap();
    let json = generic_camera_json(&cam, 70.0);
    assert_eq!(json["hfov_deg"], 70.0);
    assert!(json["comment"]
        .as_str()
        .unwrap()
        .starts_with("generic camera"));
    let back = parse_calibration(&json.to_string(), "cam.json")
        .unwrap()
        .camera;
    assert_eq!(back.intrinsics, cam.intrinsics);
}

#[test]
fn bad_json_cameras_name_file_and_field() {
    let base = r#""fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480"#;
    let e = err(&format!("{{{base}}}"));
    assert_eq!(e, "cam.cfg: field fx: missing");
    let e = err(&format!("{{\"fx\": -800, {base}}}"));
    assert!(
        e.contains("cam.cfg") && e.contains("field fx") && e.contains("positive"),
        "{e}"
    );
    let e = err(&format!("{{\"fx\": \"NaN\", {base}}}"));
    assert!(
        e.contains("field fx") && e.contains("expected a number"),
        "{e}"
    );
    let e = err(&format!("{{\"fx\": 800, {base}, \"dist\": [1, 2, 3]}}"));
    assert!(e.contains("field dist") && e.contains("got 3"), "{e}");
    let e = err(&format!(
        "{{\"fx\": 800, {base}, \"R\": [[1,0,0],[0,2,0],[0,0,1]]}}"
    ));
    assert!(e.contains("field R") && e.contains("not a rotation"), "{e}");
    let e = err(&format!("{{\"fx\": 800, {base}, \"t\": [1, 2]}}"));
    assert!(e.contains("field t") && e.contains("3 values"), "{e}");
    let e = err(&format!("{{\"fx\": 800, {base}, \"focal\": 3}}"));
    assert!(e.contains("field focal") && e.contains("unknown"), "{e}");
    let e = err(r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 0, "height": 480}"#);
    assert!(e.contains("field width"), "{e}");
    let e = err(r#"{"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640.5, "height": 480}"#);
    assert!(e.contains("field width"), "{e}");
    let e = err("{\"fx\": 800,");
    assert!(e.contains("cam.cfg") && e.contains("line 1"), "{e}");
    let e = err(r#"{"CameraMatrix": [[1, 0, 0], [0, 1, 0]], "Dims": [640, 480]}"#);
    assert!(e.contains("field CameraMatrix") && e.contains("3x3"), "{e}");
    let e = err(r#"{"CameraMatrix": [[600, 0, 320], [0, 600, 240], [0, 0, 1]]}"#);
    assert!(e.contains("field Dims") && e.contains("missing"), "{e}");
    assert!(err("hello").contains("unrecognised"));
    let e = read_camera("/nonexistent/cam.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/cam.json"), "{e}");
}

#[test]
fn bad_opencv_files_name_file_and_field() {
    // Wrong matrix size.
    let e = err(&YAML
        .replace("rows: 3\n   cols: 3", "rows: 2\n   cols: 3")
        .replace("0., 0., 1. ]", "]"));
    assert!(
        e.contains("cam.cfg") && e.contains("camera_matrix") && e.contains("2x3"),
        "{e}"
    );
    // Data count disagrees with rows x cols.
    let e = err(&YAML.replace("0., 0., 1. ]", "0., 0. ]"));
    assert!(
        e.contains("camera_matrix.data") && e.contains("rows x cols"),
        "{e}"
    );
    // NaN in data.
    let e = err(&YAML.replace("6.8024297317066178e+02", ".Nan"));
    assert!(
        e.contains("camera_matrix") && e.contains("not finite"),
        "{e}"
    );
    // Negative focal length.
    let e = err(&XML.replace("6.7724586254666637e+02", "-6.7724586254666637e+02"));
    assert!(e.contains("camera_matrix") && e.contains("positive"), "{e}");
    // Missing size.
    let e = err(&YAML.replace("image_width: 640\n", ""));
    assert!(
        e.contains("field image_width") && e.contains("missing"),
        "{e}"
    );
    // Missing camera matrix.
    let e = err("%YAML:1.0\nimage_width: 640\n");
    assert!(
        e.contains("field camera_matrix") && e.contains("missing"),
        "{e}"
    );
    // Not a number.
    let e = err(&YAML.replace("2.6679646461641733e+00", "abc"));
    assert!(
        e.contains("distortion_coefficients.data[4]") && e.contains("not a number"),
        "{e}"
    );
    // Bad distortion length.
    let e = err(&YAML
        .replace("rows: 5\n", "rows: 3\n")
        .replace(" 0., 0.,\n       2.6679646461641733e+00 ]", " 0. ]"));
    assert!(
        e.contains("distortion_coefficients") && e.contains("got 3"),
        "{e}"
    );
    // Syntax errors report the line.
    let e = err("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n  cols: 3\n");
    assert!(e.contains("cam.cfg: line 4"), "{e}");
    let e = err(&XML.replace("</camera_matrix>", "</camera>"));
    assert!(e.contains("cam.cfg: line") && e.contains("XML"), "{e}");
    // Truncated files are errors, never panics.
    for cut in (0..YAML.len()).step_by(7) {
        let _ = parse_calibration(&YAML[..cut], "cut.yml");
    }
    for cut in (0..XML.len()).step_by(7) {
        let _ = parse_calibration(&XML[..cut], "cut.xml");
    }
}

/// Issue 44's fisheye as cv::FileStorage writes it (`tests/data/cv_reference.py`).
const FISHEYE_YAML: &str = include_str!("../../tests/data/opencv_fisheye.yaml");

#[test]
fn opencv_files_are_read_as_the_model_they_state() {
    let fisheye = |text: &str| {
        parse_calibration(text, "cam.yml")
            .unwrap()
            .camera
            .distortion
    };
    assert_eq!(fisheye(FISHEYE_YAML).model, LensModel::Fisheye);
    for key in [
        "model: fisheye",
        "camera_model: fisheye",
        "distortion_model: equidistant",
        "fisheye_model: 1",
    ] {
        let text = FISHEYE_YAML.replace("distortion_model: fisheye", key);
        assert_eq!(fisheye(&text).model, LensModel::Fisheye, "{key}");
    }
    // Keys that agree, the more specific name winning.
    let both = FISHEYE_YAML.replace(
        "distortion_model: fisheye",
        "fisheye_model: 1\ndistortion_model: fisheye",
    );
    assert_eq!(fisheye(&both).model, LensModel::Fisheye);
    let pinhole = FISHEYE_YAML.replace("distortion_model: fisheye", "distortion_model: plumb_bob");
    assert_eq!(fisheye(&pinhole).model, LensModel::Pinhole);
    // XML states it the same way.
    let xml = XML
        .replace(
            "<image_width>",
            "<distortion_model>fisheye</distortion_model>\n<image_width>",
        )
        .replace("<rows>5</rows>", "<rows>4</rows>")
        .replace(" 0. 0.\n    2.6679646461641733e+00</data>", " 0. 0.</data>");
    assert_eq!(fisheye(&xml).model, LensModel::Fisheye);
}

#[test]
fn opencv_files_whose_model_is_not_understood_are_refused() {
    let e = err(&FISHEYE_YAML.replace(
        "distortion_model: fisheye",
        "distortion_model: kannala_brandt8",
    ));
    assert_eq!(
        e,
        "cam.cfg: distortion_model \"kannala_brandt8\" is not supported (pinhole: pinhole, \
         plumb_bob, radtan, rational_polynomial; fisheye: fisheye, equidistant)"
    );
    // A fisheye with five coefficients is neither a fisheye nor a pinhole.
    let five = FISHEYE_YAML
        .replace("rows: 4", "rows: 5")
        .replace("0., 0. ]", "0., 0., 0. ]");
    let e = err(&five);
    assert!(
        e.contains("field distortion_coefficients")
            && e.contains("distortion_model \"fisheye\" takes 4 coefficients (k1 k2 k3 k4), got 5"),
        "{e}"
    );
    let e = err(&FISHEYE_YAML.replace(
        "distortion_model: fisheye",
        "distortion_model: fisheye\nfisheye_model: 0",
    ));
    assert!(
        e.contains("field fisheye_model") && e.contains("states the pinhole model"),
        "{e}"
    );
    let e = err(&FISHEYE_YAML.replace("distortion_model: fisheye", "fisheye_model: 2"));
    assert!(e.contains("fisheye_model \"2\" is not supported"), "{e}");
    let e = err(&FISHEYE_YAML.replace("distortion_model: fisheye", "xi: 1.2"));
    assert!(e.contains("xi \"cv::omnidir\" is not supported"), "{e}");
    let e = err(&FISHEYE_YAML.replace("distortion_model: fisheye", "camera_model: omni"));
    assert!(e.contains("camera_model \"omni\" is not supported"), "{e}");
}

#[test]
fn the_projects_json_states_its_model() {
    let base =
        r#""fx": 479.5, "fy": 479.5, "cx": 639.5, "cy": 359.5, "width": 1280, "height": 720"#;
    let cam = parse_calibration(
        &format!(r#"{{{base}, "model": "fisheye", "dist": [0.02, -0.005, 0, 0]}}"#),
        "cam.json",
    )
    .unwrap()
    .camera;
    assert_eq!(
        cam.distortion,
        Distortion::fisheye([0.02, -0.005, 0.0, 0.0]).unwrap()
    );
    // Absent, the model is the pinhole, as before.
    let cam = parse_calibration(
        &format!(r#"{{{base}, "dist": [0.02, -0.005, 0, 0]}}"#),
        "c.json",
    )
    .unwrap()
    .camera;
    assert_eq!(cam.distortion.model, LensModel::Pinhole);
    let e = err(&format!(
        r#"{{{base}, "model": "omni", "dist": [0.1, 0, 0, 0]}}"#
    ));
    assert_eq!(
        e,
        "cam.cfg: model \"omni\" is not supported (pinhole: pinhole; fisheye: fisheye)"
    );
    let e = err(&format!(
        r#"{{{base}, "model": "fisheye", "dist": [0.1, 0, 0, 0, 0]}}"#
    ));
    assert!(
        e.contains("field dist") && e.contains("takes 0 or 4 coefficients"),
        "{e}"
    );
    let e = err(&format!(r#"{{{base}, "model": 2}}"#));
    assert!(e.contains("field model"), "{e}");
    // A fisheye past 180 degrees: refused with the reason.
    let e = err(concat!(
        r#"{"fx": 300, "fy": 300, "cx": 639.5, "cy": 359.5, "width": 1280, "height": 720, "#,
        r#""model": "fisheye", "dist": [0.02, -0.005, 0, 0]}"#
    ));
    assert!(
        e.contains("cameras past 180 degrees are not supported"),
        "{e}"
    );
}
