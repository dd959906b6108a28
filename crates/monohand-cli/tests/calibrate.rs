//! `monohand calibrate` as a user runs it, on OpenCV's real stereo chessboard photographs
//! (`../shared/data/calibration/opencv_stereo_chessboard`, 13 pairs, 9x6 inner corners):
//! the documented commands, against OpenCV's own calibration of the same photos
//! (`crates/monohand-calib/tests/data/calibrate_opencv_corners.py`); a video; the
//! printable board; and the bad inputs, each refused with no file written.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, ok, p};
use monohand_calib::corners::find_chessboard;
use monohand_calib::{Board, GrayImage};
use monohand_core::camera::LensModel;
use monohand_io::calibration::read_calibration;
use monohand_testkit::{ffmpeg, shared_data};
use nalgebra::{Rotation3, Vector3};
use std::path::{Path, PathBuf};

fn photos() -> PathBuf {
    let dir = shared_data().join("calibration/opencv_stereo_chessboard");
    assert!(
        dir.join("left01.jpg").is_file(),
        "{} is missing",
        dir.display()
    );
    dir
}

/// Copies the photos whose names start with `prefix` (the first `n`) into `dir`.
fn copy(prefix: &str, n: usize, dir: &Path) -> Vec<PathBuf> {
    std::fs::create_dir_all(dir).unwrap();
    let mut names: Vec<PathBuf> = std::fs::read_dir(photos())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|f| f.file_name().unwrap().to_string_lossy().starts_with(prefix))
        .collect();
    names.sort();
    names
        .iter()
        .take(n)
        .map(|f| {
            let to = dir.join(f.file_name().unwrap());
            std::fs::copy(f, &to).unwrap();
            to
        })
        .collect()
}

/// Checks a camera file against OpenCV's fx fy cx cy rms, to the targets.
fn near_opencv(file: &Path, cv: [f64; 5]) {
    let cal = read_calibration(file).unwrap();
    let k = cal.camera.intrinsics;
    let rms = cal.reprojection_error_px.expect("rms_px in the file");
    println!(
        "{}: fx {:.3} fy {:.3} cx {:.3} cy {:.3} rms {rms:.4}; OpenCV {cv:?}",
        file.display(),
        k.fx,
        k.fy,
        k.cx,
        k.cy
    );
    assert!((k.fx / cv[0] - 1.0).abs() < 0.005 && (k.fy / cv[1] - 1.0).abs() < 0.005);
    assert!((k.cx - cv[2]).abs() < 2.0 && (k.cy - cv[3]).abs() < 2.0);
    assert!((rms - cv[4]).abs() < 0.05);
    assert_eq!((k.width, k.height), (640, 480));
}

/// OpenCV on its own corners refined with a window that fits these squares (winSize 5).
const LEFT: [f64; 5] = [532.827, 532.946, 342.487, 233.856, 0.1954];
const RIGHT: [f64; 5] = [537.453, 536.969, 327.586, 248.882, 0.2070];

#[test]
fn the_documented_command_calibrates_a_camera_as_opencv_does() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("left");
    copy("left", 13, &dir);
    let cam = tmp.path().join("cam.json");
    // Exactly the documented command.
    let out = monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        p(&dir),
        "-o",
        p(&cam),
    ]);
    ok(&out);
    near_opencv(&cam, LEFT);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cam).unwrap()).unwrap();
    assert_eq!(json["views"], 13);
    assert_eq!(json["board"]["square_mm"], 25.0);
    assert!(json["std"]["fx"].as_f64().unwrap() < 2.0);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("a hand at 0.5 m is ±"), "{said}");

    // OpenCV's tutorials' settings (the shared README's numbers): a 23x23 subpixel window,
    // every view kept. The OpenCV YAML and the report come on request.
    let tutorial = tmp.path().join("tutorial.json");
    let report = tmp.path().join("report.md");
    ok(&monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        p(&dir),
        "-o",
        p(&tutorial),
        "--subpix-window",
        "11",
        "--keep-all-views",
        "--opencv-yaml",
        "--report",
        p(&report),
    ]));
    near_opencv(&tutorial, [536.073, 536.016, 342.370, 235.537, 0.4087]);
    let yaml = read_calibration(tmp.path().join("tutorial.yaml")).unwrap();
    assert_eq!(yaml.camera, read_calibration(&tutorial).unwrap().camera);
    let md = std::fs::read_to_string(&report).unwrap();
    assert!(md.contains("| left02.jpg |") && md.contains("![where the corners were seen"));
    let picture = image::open(tmp.path().join("report-cam0.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(picture.dimensions(), (640, 480));
}

/// `--model fisheye`: OpenCV's fisheye (k1..k4) on a 60 degree lens fits as the pinhole
/// does (monohand-calib's end_to_end measured fx 532.33, RMS 0.203 px on these corners;
/// OpenCV's pinhole 532.827, 0.1954), and the files state the model.
#[test]
fn the_fisheye_model_is_written_as_one() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("left");
    copy("left", 13, &dir);
    let cam = tmp.path().join("fisheye.json");
    let out = monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        p(&dir),
        "-o",
        p(&cam),
        "--model",
        "fisheye",
        "--opencv-yaml",
    ]);
    ok(&out);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cam).unwrap()).unwrap();
    assert_eq!(json["model"], "fisheye", "{json:#}");
    assert_eq!(json["dist"].as_array().unwrap().len(), 4, "{json:#}");
    assert_eq!(json["std"]["dist"].as_array().unwrap().len(), 4, "{json:#}");
    let rms = json["rms_px"].as_f64().unwrap();
    assert!(rms < 0.25, "rms {rms}");
    let back = read_calibration(&cam).unwrap().camera;
    assert_eq!(back.distortion.model, LensModel::Fisheye);
    assert!(
        (back.intrinsics.fx / LEFT[0] - 1.0).abs() < 0.005,
        "{back:?}"
    );
    let yaml = read_calibration(tmp.path().join("fisheye.yaml")).unwrap();
    assert_eq!(yaml.camera, back);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("fisheye (k1..k4)"), "{said}");
}

#[test]
fn the_documented_rig_command_writes_one_camera_per_view() {
    let tmp = tempfile::tempdir().unwrap();
    let (left, right) = (tmp.path().join("left"), tmp.path().join("right"));
    copy("left", 13, &left);
    copy("right", 13, &right);
    let rig = tmp.path().join("rig");
    ok(&monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        "--view",
        p(&left),
        "--view",
        p(&right),
        "-o",
        &format!("{}/", p(&rig)),
    ]));
    let mut files: Vec<String> = std::fs::read_dir(&rig)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    files.sort();
    assert_eq!(files, ["cam0.json", "cam1.json"]);
    let cam0 = read_calibration(rig.join("cam0.json")).unwrap().camera;
    assert!(cam0.extrinsics.is_identity());
    // The rig refines the intrinsics with the poses between the cameras (as
    // stereoCalibrate's flags 0): still within the single cameras' targets.
    near_opencv(&rig.join("cam0.json"), LEFT);
    near_opencv(&rig.join("cam1.json"), RIGHT);
    let e = read_calibration(rig.join("cam1.json"))
        .unwrap()
        .camera
        .extrinsics;
    // cv2.stereoCalibrate (flags 0) on OpenCV's winSize-5 corners.
    let cv_r = Rotation3::new(Vector3::new(
        0.007127046303147738,
        0.004200612759476957,
        -0.0035190992125640995,
    ));
    let cv_t = Vector3::new(-83.17641882612769, 0.9197708130198782, -0.11818825942730671);
    let angle = (e.rotation * cv_r.inverse()).angle().to_degrees();
    let length = e.translation.norm() / cv_t.norm() - 1.0;
    let direction = e.translation.angle(&cv_t).to_degrees();
    println!(
        "rig: {angle:.4} deg, baseline {:+.3}%, direction {direction:.3} deg",
        length * 100.0
    );
    assert!(angle < 0.3 && length.abs() < 0.01 && direction < 1.0);

    // The same rig from patterns in the shared folder (no copies), as `run` reads it.
    let rig2 = tmp.path().join("rig2");
    let pattern = |s: &str| format!("{}/{s}*.jpg", photos().display());
    ok(&monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        "--view",
        &pattern("left"),
        "--view",
        &pattern("right"),
        "-o",
        p(&rig2),
    ]));
    for k in 0..2 {
        let a = std::fs::read_to_string(rig.join(format!("cam{k}.json"))).unwrap();
        let b = std::fs::read_to_string(rig2.join(format!("cam{k}.json"))).unwrap();
        let strip = |s: &str| {
            s.lines()
                .filter(|l| !l.contains("\"date\""))
                .collect::<Vec<_>>()
                .join("\n")
        };
        assert_eq!(strip(&a), strip(&b), "cam{k}");
    }
}

#[test]
fn a_video_gives_one_view_per_pose_not_every_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let frames = tmp.path().join("frames");
    for (i, f) in copy("left", 13, &tmp.path().join("photos"))
        .iter()
        .enumerate()
    {
        std::fs::create_dir_all(&frames).unwrap();
        std::fs::copy(f, frames.join(format!("f{i:02}.jpg"))).unwrap();
    }
    // Each photo held for a second at 10 frames a second, losslessly: 130 frames.
    let video = tmp.path().join("board.mkv");
    ffmpeg(&[
        "-framerate",
        "1",
        "-i",
        &format!("{}/f%02d.jpg", p(&frames)),
        "-vf",
        "fps=10",
        "-pix_fmt",
        "yuv444p",
        "-c:v",
        "ffv1",
        p(&video),
    ]);
    let cam = tmp.path().join("cam.json");
    let report = tmp.path().join("video.md");
    ok(&monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        p(&video),
        "-o",
        p(&cam),
        "--report",
        p(&report),
    ]));
    // Examined 5 times a second (65 frames); a view is kept at most once per photo held
    // (left14's pose is 15 px from left11's, under the 20 px that make a new view).
    let md = std::fs::read_to_string(&report).unwrap();
    let kept: Vec<u64> = md
        .lines()
        .filter(|l| l.starts_with("| frame ") && l.ends_with("| yes |"))
        .map(|l| l[8..].split(' ').next().unwrap().parse().unwrap())
        .collect();
    let photos: std::collections::BTreeSet<u64> = kept.iter().map(|f| f / 10).collect();
    assert_eq!(photos.len(), kept.len(), "two views of one photo: {kept:?}");
    assert!((11..=13).contains(&kept.len()), "{kept:?}");
    assert!(
        md.contains(&format!("{} views used of 65 frames examined", kept.len())),
        "{md}"
    );
    assert!(md.contains("too like a view already kept"), "{md}");
    near_opencv(&cam, LEFT);
}

#[test]
fn the_printed_board_is_found_at_its_size() {
    let tmp = tempfile::tempdir().unwrap();
    for ext in ["svg", "pdf", "png"] {
        let f = tmp.path().join(format!("board.{ext}"));
        let out = monohand(&[
            "calibrate",
            "--board",
            "9x6",
            "--square-mm",
            "25",
            "--print-board",
            p(&f),
        ]);
        ok(&out);
        assert!(String::from_utf8_lossy(&out.stderr).contains("measure a printed square"));
        assert!(std::fs::metadata(&f).unwrap().len() > 500);
    }
    assert!(std::fs::read(tmp.path().join("board.pdf"))
        .unwrap()
        .starts_with(b"%PDF-1.4"));
    // The PNG (300 dpi) is a board the corner finder finds, squares 25 mm = 295.3 px apart.
    let png = image::open(tmp.path().join("board.png"))
        .unwrap()
        .to_luma8();
    let small = image::imageops::resize(
        &png,
        png.width() / 4,
        png.height() / 4,
        image::imageops::FilterType::Triangle,
    );
    let grey = GrayImage::new(
        small.width() as usize,
        small.height() as usize,
        small.as_raw(),
    )
    .unwrap();
    let found = find_chessboard(&grey, &Board::new(9, 6, 25.0).unwrap()).unwrap();
    let step = (found.corners[1] - found.corners[0]).norm() * 4.0;
    assert!((step - 25.0 * 300.0 / 25.4).abs() < 2.0, "{step}");
    let bad = tmp.path().join("board.txt");
    let out = monohand(&[
        "calibrate",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        "--print-board",
        p(&bad),
    ]);
    assert!(!out.status.success() && !bad.exists());
}

/// Runs a calibration that must fail with `expect` in its message and write nothing.
fn refused(args: &[&str], expect: &str, nothing_at: &Path) {
    let out = monohand(args);
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {said}");
    assert!(said.contains(expect), "{args:?}: {said}");
    assert!(
        !nothing_at.exists(),
        "{args:?} wrote {}",
        nothing_at.display()
    );
}

/// `calibrate --board BOARD --square-mm 25 INPUTS.. -o OUT`, refused with `expect` and
/// nothing written at `out`.
fn refused_board(board: &str, inputs: &[&str], out: &Path, expect: &str) {
    let mut args = vec!["calibrate", "--board", board, "--square-mm", "25"];
    args.extend_from_slice(inputs);
    args.extend_from_slice(&["-o", p(out)]);
    refused(&args, expect, out);
}

#[test]
fn bad_inputs_are_refused_with_the_reason_and_no_file() {
    let tmp = tempfile::tempdir().unwrap();
    let cam = tmp.path().join("cam.json");
    // No board: photos of a hand.
    let hands = tmp.path().join("hands");
    std::fs::create_dir_all(&hands).unwrap();
    for i in 0..3 {
        std::fs::copy(
            monohand_testkit::hand_png(),
            hands.join(format!("h{i}.png")),
        )
        .unwrap();
    }
    refused_board("9x6", &[p(&hands)], &cam, "found in 0 frame(s) of 3");
    // Too few views.
    let two = tmp.path().join("two");
    copy("left", 2, &two);
    refused_board("9x6", &[p(&two)], &cam, "found in 2 frame(s) of 2, too few");
    // A board size that does not match the photos.
    let left = tmp.path().join("left");
    copy("left", 13, &left);
    refused_board(
        "8x6",
        &[p(&left)],
        &cam,
        "a chessboard with 9x6 inner corners",
    );
    // A rig whose inputs differ in length.
    let right = tmp.path().join("right");
    copy("right", 12, &right);
    let rig = tmp.path().join("rig");
    let views = ["--view", p(&left), "--view", p(&right)];
    refused_board("9x6", &views, &rig, "different numbers of images");
    // Nothing to read, and a square that is not a length.
    let missing = tmp.path().join("missing");
    refused_board("9x6", &[p(&missing)], &cam, "no such file");
    let c = p(&cam);
    let args = [
        "calibrate",
        "--board",
        "9x6",
        "--square-mm=-3",
        p(&left),
        "-o",
        c,
    ];
    refused(&args, "square size", &cam);
    // A board that is not COLSxROWS is clap's usage error.
    let out = monohand(&[
        "calibrate",
        "--board",
        "9by6",
        "--square-mm",
        "25",
        p(&left),
        "-o",
        c,
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!cam.exists());
}
