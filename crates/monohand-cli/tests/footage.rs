//! The footage people really have, through `monohand run`, on files each test makes with
//! ffmpeg from the shared photo: a portrait phone video with rotation metadata, variable
//! frame rate, a long stretch without hands, tiny and 8K images. Needs ffmpeg, the
//! networks and `../shared`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;
#[path = "../../monohand-vision/tests/exif_support/mod.rs"]
mod exif_support;

use common::{monohand, networks_ready, ok, p};
use monohand_core::prelude::*;
use monohand_io::calibration::write_camera_json;
use monohand_io::jsonl::read_jsonl;
use monohand_testkit::{ffmpeg, hand_png, photo_clip};

/// A portrait phone video (stored 640x480 with rotation metadata): decoded upright; a
/// calibration of the stored frames is refused, saying why, before anything is written;
/// one of the upright frames is accepted.
#[test]
fn a_rotated_phone_video_is_upright_and_a_landscape_calibration_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let land = dir.path().join("land.mp4");
    let phone = dir.path().join("phone.mp4");
    photo_clip(&land, 3, None, &["-q:v", "2"]);
    ffmpeg(&[
        "-i",
        p(&land),
        "-c",
        "copy",
        "-metadata:s:v:0",
        "rotate=90",
        p(&phone),
    ]);
    let stored = dir.path().join("stored.json");
    write_camera_json(&stored, &Camera::generic(640, 480).unwrap()).unwrap();
    let out = dir.path().join("never.jsonl");
    let r = monohand(&["run", p(&phone), "--camera", p(&stored), "-o", p(&out)]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(
        err.contains("the video is stored 640x480 and carries rotation metadata of 90 degrees")
            && err.contains("decoded upright at 480x640"),
        "{err}"
    );
    assert!(!out.exists());

    assert!(networks_ready());
    let upright = dir.path().join("upright.json");
    write_camera_json(&upright, &Camera::generic(480, 640).unwrap()).unwrap();
    let overlay = dir.path().join("overlay");
    ok(&monohand(&[
        "run",
        p(&phone),
        "--camera",
        p(&upright),
        "-o",
        p(&out),
        "--overlay",
        p(&overlay),
    ]));
    let frames = read_jsonl(&out).unwrap();
    assert_eq!(frames.len(), 3);
    assert!(
        frames.iter().all(|f| f.hands.len() == 1),
        "the hand is found upright"
    );
    let drawn = monohand_vision::image_io::load_rgb(&overlay.join("frame_000000.png")).unwrap();
    assert_eq!(drawn.dimensions(), (480, 640));
}

/// Variable frame rate, and a long stretch without hands: 45 frames of an empty grey wall
/// at 30 fps, a 2-second gap in the stream's clock, then 10 frames of the hand. The output
/// has one record per frame with the stream's times, no hand in the first 45 and the hand
/// from the first frame it is in.
#[test]
fn variable_frame_rate_and_a_long_stretch_without_hands() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("vfr.mkv");
    // The option's name in this ffmpeg (`-vsync` is gone from FFmpeg 7.0).
    let sync = monohand_media::video::FfmpegTools::default()
        .features()
        .fps_mode_option();
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "color=c=gray:s=640x480:r=30:d=1.5",
        "-loop",
        "1",
        "-framerate",
        "30",
        "-t",
        "0.3334",
        "-i",
        p(&hand_png()),
        "-filter_complex",
        "[0:v]format=yuv420p[a];[1:v]format=yuv420p,setsar=1[b];[a][b]concat=n=2:v=1,\
         setpts='if(lt(N,45),N/30,N/30+2)/TB'",
        "-c:v",
        "mpeg4",
        "-q:v",
        "2",
        sync,
        "vfr",
        p(&video),
    ]);
    let out = dir.path().join("hands.jsonl");
    ok(&monohand(&["run", p(&video), "-o", p(&out)]));
    let frames = read_jsonl(&out).unwrap();
    assert_eq!(frames.len(), 55, "one record per frame of the stream");
    for (i, f) in frames.iter().enumerate() {
        let want = i as f64 / 30.0 + if i < 45 { 0.0 } else { 2.0 };
        let t = f.time_s.expect("time_s");
        assert!((t - want).abs() < 1.5e-3, "frame {i}: {t} s, want {want}");
        if i < 45 {
            assert!(f.hands.is_empty(), "frame {i}: a hand on the wall");
        } else {
            assert_eq!(f.hands.len(), 1, "frame {i}: the hand is found");
        }
    }
}

/// The photo at 32x24 pixels and at 8K (7680x5760): the hand is found in both (the
/// networks see a resized copy), no error, no panic.
#[test]
fn tiny_and_huge_images() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let tiny = dir.path().join("tiny.png");
    let huge = dir.path().join("huge.png");
    ffmpeg(&["-i", p(&hand_png()), "-vf", "scale=32:24", p(&tiny)]);
    ffmpeg(&["-i", p(&hand_png()), "-vf", "scale=7680:5760", p(&huge)]);
    for (img, hands) in [(&tiny, 1), (&huge, 1)] {
        let out = dir.path().join("o.jsonl");
        ok(&monohand(&["run", p(img), "-o", p(&out)]));
        let frames = read_jsonl(&out).unwrap();
        assert_eq!(frames.len(), 1);
        assert!(frames[0].error.is_none(), "{:?}", frames[0].error);
        assert_eq!(frames[0].hands.len(), hands, "{}", img.display());
    }
}

/// Photos that state their focal length in EXIF get their own camera when no `--camera` is
/// given, and the user is told once; a photo without it gets the generic 60 degree guess.
/// The same pixels at twice the focal length put the hand twice as far (within 3%: the
/// hand's own depth does not scale), and the generic camera's focal length (0.866 x the
/// width) against the 26 mm phone lens's (0.751 x) moves it by their ratio.
#[test]
fn a_photo_with_its_focal_length_in_exif_gets_its_own_camera() {
    use exif_support::{tag, tiff_block, with_exif, Value};
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir(&photos).unwrap();
    let plain = photos.join("c_no_exif.jpg");
    ffmpeg(&["-i", p(&hand_png()), "-q:v", "2", p(&plain)]);
    let jpeg = std::fs::read(&plain).unwrap();
    for (name, f35) in [("a_26mm.jpg", 26), ("b_52mm.jpg", 52)] {
        let tiff = tiff_block(1, &[(tag::FOCAL_35MM, Value::Short(f35))]);
        std::fs::write(photos.join(name), with_exif(&jpeg, &tiff)).unwrap();
    }
    let out = dir.path().join("out.jsonl");
    let run = monohand(&["run", p(&photos), "-o", p(&out)]);
    ok(&run);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(
        stderr
            .matches("the camera comes from the photo's EXIF FocalLengthIn35mmFilm 26 mm")
            .count(),
        1,
        "{stderr}"
    );
    assert!(!stderr.contains("52 mm"), "said once: {stderr}");
    assert_eq!(
        stderr
            .matches("assuming a generic camera for 640x480")
            .count(),
        1,
        "{stderr}"
    );
    let frames = read_jsonl(&out).unwrap();
    let depth: Vec<f64> = frames
        .iter()
        .map(|f| {
            assert_eq!(f.hands.len(), 1, "{:?}", f.source);
            f.hands[0].joints_3d_mm.expect("3D")[0][2]
        })
        .collect();
    let names: Vec<_> = frames.iter().map(|f| f.source.clone().unwrap()).collect();
    assert_eq!(names, ["a_26mm.jpg", "b_52mm.jpg", "c_no_exif.jpg"]);
    let twice = depth[1] / depth[0];
    assert!(
        (twice - 2.0).abs() < 0.06,
        "52 mm / 26 mm depth ratio {twice}"
    );
    let f26 = 26.0 * 800.0 / 36f64.hypot(24.0);
    let generic = 320.0 / 30f64.to_radians().tan();
    let ratio = depth[2] / depth[0];
    assert!(
        (ratio - generic / f26).abs() < 0.03 * generic / f26,
        "generic / 26 mm depth ratio {ratio}, focal ratio {}",
        generic / f26
    );
}

/// How many pixels differ between two images of one size.
fn differing(a: &image::RgbImage, b: &image::RgbImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count()
}

/// A photo whose EXIF states an 18 mm (35 mm equivalent) lens is fitted and drawn with that
/// camera: its record says so (`cameras`, source `exif`), and the same photo with that
/// camera given as a calibration file gives the same joints and an overlay that differs
/// in under 0.5% of its pixels (the overlay, the top view and the labels all use the
/// record's camera; before, they used the generic 60 degree camera).
#[test]
fn a_photo_is_drawn_with_the_camera_it_was_fitted_with() {
    use exif_support::{tag, tiff_block, with_exif, Value};
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.jpg");
    ffmpeg(&["-i", p(&hand_png()), "-q:v", "2", p(&plain)]);
    let photo = dir.path().join("phone_18mm.jpg");
    let tiff = tiff_block(1, &[(tag::FOCAL_35MM, Value::Short(18))]);
    std::fs::write(&photo, with_exif(&std::fs::read(&plain).unwrap(), &tiff)).unwrap();

    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(format!("{name}.jsonl"));
        let overlay = dir.path().join(format!("{name}.png"));
        let mut args = vec!["run", p(&photo), "-o", p(&out), "--overlay", p(&overlay)];
        args.extend_from_slice(extra);
        ok(&monohand(&args));
        let frames = read_jsonl(&out).unwrap();
        assert_eq!(frames.len(), 1);
        let image = monohand_vision::image_io::load_photo(&overlay)
            .unwrap()
            .image;
        (frames.into_iter().next().unwrap(), image)
    };
    let (exif, exif_overlay) = run(&[], "exif");
    assert_eq!(exif.cameras.len(), 1, "{:?}", exif.cameras);
    assert_eq!(
        exif.cameras[0].source,
        monohand_io::jsonl::CameraSource::Exif
    );
    let cam = exif.cameras[0].intrinsics;
    // 18 mm on the 43.27 mm diagonal of 35 mm film, for the 800 px diagonal of 640x480.
    let fx = 18.0 * 800.0 / 36f64.hypot(24.0);
    assert!((cam.fx - fx).abs() < 1e-6 && cam.fx == cam.fy, "{cam:?}");
    // The principal point at the image centre, in the pixel-centre convention.
    assert_eq!(
        (cam.width, cam.height, cam.cx, cam.cy),
        (640, 480, 319.5, 239.5)
    );

    let file = dir.path().join("cam.json");
    let camera = Camera::new(cam, Distortion::default(), Extrinsics::default()).unwrap();
    write_camera_json(&file, &camera).unwrap();
    let (given, given_overlay) = run(&["--camera", p(&file)], "file");
    assert_eq!(given.cameras.len(), 1);
    assert_eq!(
        given.cameras[0].source,
        monohand_io::jsonl::CameraSource::File
    );
    assert_eq!(given.cameras[0].intrinsics, cam);

    assert_eq!(exif.hands.len(), 1);
    assert_eq!(given.hands.len(), 1);
    let (a, b) = (
        exif.hands[0].joints_3d_mm.expect("3D"),
        given.hands[0].joints_3d_mm.expect("3D"),
    );
    for (x, y) in a.iter().zip(&b) {
        for k in 0..3 {
            assert!((x[k] - y[k]).abs() < 1e-6, "{a:?} against {b:?}");
        }
    }
    assert_eq!(exif_overlay.dimensions(), given_overlay.dimensions());
    let differ = differing(&exif_overlay, &given_overlay);
    let share = differ as f64 / (640.0 * 480.0);
    assert!(
        share < 0.005,
        "{differ} pixels differ ({:.2}%)",
        share * 100.0
    );

    // What the overlay was before: the EXIF fit drawn with the generic camera, which puts
    // the hand elsewhere. The test tells the two apart, and the renderer given the
    // record's camera reproduces the overlay exactly.
    use monohand_media::scene::{Layer, Layers, SceneRenderer};
    let layers = Layers::only(&[Layer::Bones, Layer::Top, Layer::Labels]);
    let frame = monohand_vision::image_io::load_photo(&photo).unwrap().image;
    let draw = |cameras: &[Camera]| {
        let mut image = frame.clone();
        let mut renderer = SceneRenderer::default();
        renderer.set_camera_source(Some("exif"));
        renderer.draw(&mut image, &exif.hands, cameras, &layers);
        image
    };
    assert!(
        draw(&[camera]) == exif_overlay,
        "the overlay is not drawn with the record's camera"
    );
    let generic = draw(&[]);
    let differ = differing(&exif_overlay, &generic);
    assert!(
        differ as f64 > 0.005 * 640.0 * 480.0,
        "only {differ} pixels differ with the generic camera"
    );
}

/// `../shared/data/images/hamer/test1.jpg` without `--camera` (issue 33): a Canon EOS 5DS R
/// photo (88 mm) exported at 848x565, whose EXIF has the sensor's own focal plane
/// resolution but no 35 mm equivalent. The camera comes from the sensor database (36 mm
/// wide: fx = 88 x 848 / 36 = 2072.9 px; it was 21237 px, and the hands 22 m away), the
/// record says so and why, and both hands are between 1.5 and 3.5 m from the camera.
#[test]
fn a_resized_camera_photo_puts_the_hands_at_a_real_distance() {
    assert!(networks_ready());
    let photo = monohand_testkit::shared_data().join("images/hamer/test1.jpg");
    assert!(photo.is_file(), "{} not found", photo.display());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.jsonl");
    let run = monohand(&["run", p(&photo), "-o", p(&out)]);
    ok(&run);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("the camera comes from the photo's EXIF FocalLength 88 mm on the Canon EOS 5DS R's 36 mm wide sensor (sensor database)"),
        "{stderr}"
    );
    let frames = read_jsonl(&out).unwrap();
    let camera = &frames[0].cameras[0];
    assert_eq!(
        camera.source,
        monohand_io::jsonl::CameraSource::ExifSensorDb
    );
    assert!(
        (camera.intrinsics.fx / 2073.0 - 1.0).abs() < 0.02,
        "{:?}",
        camera.intrinsics
    );
    let why = camera.reason.as_deref().unwrap_or_default();
    assert!(
        why.contains("3.5 mm wide") && why.contains("resized"),
        "{why}"
    );
    let hands = &frames[0].hands;
    assert_eq!(hands.len(), 2, "{hands:?}");
    for h in hands {
        let joints = h.joints_3d_mm.expect("3D");
        let centre = joints
            .iter()
            .fold([0.0; 3], |c, j| [c[0] + j[0], c[1] + j[1], c[2] + j[2]])
            .map(|v| v / joints.len() as f64);
        let metres = centre[0].hypot(centre[1]).hypot(centre[2]) / 1000.0;
        assert!((1.5..=3.5).contains(&metres), "a hand {metres:.2} m away");
    }
}

/// A calibration made at twice the photos' size (1280x960 for 640x480 photos) is scaled
/// to them: the record says `file-scaled` and why, and the joints are those of the same
/// calibration made at 640x480. One of another shape (1280x720) is refused for the frame,
/// saying why.
#[test]
fn a_calibration_for_another_size_is_scaled_when_the_shape_matches() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let run = |camera: &Camera, name: &str| {
        let file = dir.path().join(format!("{name}.json"));
        write_camera_json(&file, camera).unwrap();
        let out = dir.path().join(format!("{name}.jsonl"));
        let run = monohand(&["run", p(&hand_png()), "--camera", p(&file), "-o", p(&out)]);
        (run, out)
    };
    let fitted = |camera: &Camera, name: &str| {
        let (run, out) = run(camera, name);
        ok(&run);
        let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
        (read_jsonl(&out).unwrap().remove(0), stderr)
    };
    let small = Camera::pinhole(560.0, 560.0, 322.5, 241.5, 640, 480).unwrap();
    let big = Camera::pinhole(1120.0, 1120.0, 645.5, 483.5, 1280, 960).unwrap();
    let (direct, _) = fitted(&small, "small");
    let (scaled, stderr) = fitted(&big, "big");
    assert_eq!(
        direct.cameras[0].source,
        monohand_io::jsonl::CameraSource::File
    );
    let c = &scaled.cameras[0];
    assert_eq!(c.source, monohand_io::jsonl::CameraSource::FileScaled);
    assert_eq!(c.intrinsics, small.intrinsics);
    assert_eq!(
        c.reason.as_deref(),
        Some("calibrated for 1280x960, scaled by 0.5000 to the frames' 640x480")
    );
    assert!(stderr.contains("scaled by 0.5000"), "{stderr}");
    assert_eq!(direct.hands.len(), 1);
    assert_eq!(scaled.hands.len(), 1);
    assert_eq!(direct.hands[0].joints_3d_mm, scaled.hands[0].joints_3d_mm);

    // The one photo gets no 3D, so the run fails; the record and the message say why.
    let (refused, out) = run(&Camera::generic(1280, 720).unwrap(), "hd");
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    let record = read_jsonl(&out).unwrap().remove(0);
    assert!(record.cameras.is_empty());
    let e = record.error.unwrap_or_default();
    assert!(
        e.contains("the calibration is for 1280x720")
            && e.contains("640x480")
            && e.contains("not the same frame scaled")
            && stderr.contains(&e),
        "{e}\n{stderr}"
    );
}
