//! The camera a video states in its QuickTime metadata (an iPhone's 35 mm-equivalent focal
//! length on the video track), through `monohand run` without `--camera`: the records say
//! `video-metadata` with the focal length on the frame's diagonal; a calibration given with
//! `--camera` wins; a video without the keys, or with an implausible focal length, gets the
//! generic camera (the second with why). On clips ffmpeg makes from the shared photo with
//! Apple's keys written in by `monohand_testkit::quicktime`, and on the small movies of
//! `crates/monohand-media/tests/data/quicktime` (no hand in them: their records still say
//! the camera). Needs ffmpeg, the networks and `../shared`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, networks_ready, ok, p};
use monohand_core::prelude::*;
use monohand_io::calibration::write_camera_json;
use monohand_io::jsonl::{read_jsonl, CameraSource, FrameRecord};
use monohand_testkit::photo_clip;
use monohand_testkit::quicktime::{keys, with_apple_keys, Value};
use std::path::Path;

/// The diagonal of a 36 x 24 mm frame, mm.
const DIAGONAL_35MM: f64 = 43.266_615_305_567_875;

/// `monohand run VIDEO -o OUT [extra]`: the records and the standard error.
fn run(video: &Path, out: &Path, extra: &[&str]) -> (Vec<FrameRecord>, String) {
    let mut args = vec!["run", p(video), "-o", p(out)];
    args.extend_from_slice(extra);
    let r = monohand(&args);
    ok(&r);
    (
        read_jsonl(out).unwrap(),
        String::from_utf8_lossy(&r.stderr).into_owned(),
    )
}

/// The clip of the shared photo (640x480, 3 frames), plain and with an iPhone's keys stating
/// `focal` (mm, 35 mm equivalent).
fn clips(dir: &Path, focal: i32) -> (std::path::PathBuf, std::path::PathBuf) {
    let plain = dir.join("plain.mov");
    photo_clip(&plain, 3, None, &["-q:v", "2"]);
    let iphone = dir.join(format!("iphone_{focal}mm.mov"));
    let lens = Value::Text("iPhone 15 Pro back camera 6.765mm f/1.78");
    std::fs::write(
        &iphone,
        with_apple_keys(
            &std::fs::read(&plain).unwrap(),
            &[
                (keys::LENS_MODEL, lens),
                (keys::FOCAL_35MM, Value::Int(focal)),
            ],
            &[
                (keys::MAKE, Value::Text("Apple")),
                (keys::MODEL, Value::Text("iPhone 15 Pro")),
            ],
        ),
    )
    .unwrap();
    (plain, iphone)
}

/// A 26 mm-equivalent iPhone video: every frame's camera is `video-metadata` with
/// fx = fy = 26 x 800 / 43.27 = 480.7 px (the 800 px diagonal of 640x480) and the principal
/// point at the centre, said once on stderr. The same file with `--camera` uses the file;
/// the same pixels without the keys get the generic camera (fx 554.3 px) as before, and the
/// hand moves away by the focal lengths' ratio (within 3%).
#[test]
fn a_video_that_states_its_focal_length_gets_that_camera() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let (plain, iphone) = clips(dir.path(), 26);
    let (frames, stderr) = run(&iphone, &dir.path().join("iphone.jsonl"), &[]);
    assert_eq!(frames.len(), 3);
    let fx = 26.0 * 800.0 / DIAGONAL_35MM;
    for f in &frames {
        assert_eq!(f.cameras.len(), 1, "{:?}", f.cameras);
        let c = &f.cameras[0];
        assert_eq!(c.source, CameraSource::VideoMetadata);
        assert_eq!(c.reason, None);
        let k = c.intrinsics;
        assert!((k.fx - fx).abs() < 1e-6 && k.fy == k.fx, "{k:?}");
        assert_eq!((k.width, k.height, k.cx, k.cy), (640, 480, 319.5, 239.5));
        assert_eq!(f.hands.len(), 1, "frame {}", f.frame);
    }
    let said = "the camera comes from the video's QuickTime focal_length.35mm_equivalent 26 mm \
                (Apple iPhone 15 Pro, lens \"iPhone 15 Pro back camera 6.765mm f/1.78\"): \
                fx = fy = 480.7 px for 640x480 (67.3 degree horizontal field of view";
    assert_eq!(stderr.matches(said).count(), 1, "{stderr}");
    assert!(!stderr.contains("assuming a generic camera"), "{stderr}");

    // --camera wins.
    let given = Camera::centred(700.0, 640, 480).unwrap();
    let cam = dir.path().join("cam.json");
    write_camera_json(&cam, &given).unwrap();
    let (with_file, stderr) = run(
        &iphone,
        &dir.path().join("file.jsonl"),
        &["--camera", p(&cam)],
    );
    for f in &with_file {
        assert_eq!(f.cameras[0].source, CameraSource::File);
        assert_eq!(f.cameras[0].intrinsics.fx, 700.0);
    }
    assert!(!stderr.contains("QuickTime"), "{stderr}");

    // Without the keys: the generic camera, as before.
    let (generic, stderr) = run(&plain, &dir.path().join("plain.jsonl"), &[]);
    let fx_generic = 320.0 / 30f64.to_radians().tan();
    for f in &generic {
        let c = &f.cameras[0];
        assert_eq!(
            (c.source, c.reason.as_deref()),
            (CameraSource::Generic, None)
        );
        assert!((c.intrinsics.fx - fx_generic).abs() < 1e-9);
    }
    assert_eq!(
        stderr
            .matches("assuming a generic camera for 640x480")
            .count(),
        1,
        "{stderr}"
    );
    let depth = |frames: &[FrameRecord]| frames[2].hands[0].joints_3d_mm.expect("3D")[0][2];
    let ratio = depth(&generic) / depth(&frames);
    eprintln!(
        "the hand's wrist at {:.0} mm (26 mm) and {:.0} mm (generic): ratio {ratio:.3}, focal \
         ratio {:.3}",
        depth(&frames),
        depth(&generic),
        fx_generic / fx
    );
    assert!(
        (ratio - fx_generic / fx).abs() < 0.03 * fx_generic / fx,
        "generic / 26 mm depth ratio {ratio}, focal ratio {}",
        fx_generic / fx
    );
}

/// A stated focal length that fails the checks (3000 mm: a 0.7 degree field of view across
/// 640 px) is refused with the reason in the records and said once; the generic camera is
/// used.
#[test]
fn an_implausible_stated_focal_length_falls_back_to_the_generic_camera() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let (_, iphone) = clips(dir.path(), 3000);
    let (frames, stderr) = run(&iphone, &dir.path().join("out.jsonl"), &[]);
    let why = "the video's focal length was not used: QuickTime focal_length.35mm_equivalent \
               3000 mm (Apple iPhone 15 Pro, lens \"iPhone 15 Pro back camera 6.765mm f/1.78\") \
               gives fx 55470 px for 640x480, a 0.7 degree";
    for f in &frames {
        let c = &f.cameras[0];
        assert_eq!(c.source, CameraSource::Generic);
        assert!(
            c.reason.as_deref().is_some_and(|r| r.starts_with(why)),
            "{:?}",
            c.reason
        );
        assert_eq!(c.intrinsics, Camera::generic(640, 480).unwrap().intrinsics);
    }
    assert_eq!(stderr.matches(why).count(), 1, "{stderr}");
    assert!(
        stderr.contains("assuming a generic camera for 640x480"),
        "{stderr}"
    );
}

/// The movies of monohand-media's metadata tests through `run`: each stated focal length
/// on its frames' diagonal (200 px for 160x120; a portrait video's frames come upright at
/// 120x160, the diagonal and fx the same, the principal point turned), the implausible one
/// refused, and the ones without a focal length generic without a reason.
#[test]
fn the_metadata_fixtures_through_run() {
    assert!(networks_ready());
    let fixtures =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../monohand-media/tests/data/quicktime");
    let dir = tempfile::tempdir().unwrap();
    for (file, focal, size) in [
        ("plain.mov", None, (160, 120)),
        ("iphone_int.mov", Some(24.0), (160, 120)),
        ("faststart_float.mov", Some(26.5), (160, 120)),
        ("text_focal.mp4", Some(50.0), (160, 120)),
        ("mdat64_float64.mov", Some(28.0), (160, 120)),
        ("rotated.mov", Some(26.0), (120, 160)),
        ("implausible.mov", None, (160, 120)),
        ("movie_keys_ffmpeg.mov", None, (160, 120)),
    ] {
        let out = dir.path().join(format!("{file}.jsonl"));
        let (frames, _) = run(&fixtures.join(file), &out, &[]);
        assert_eq!(frames.len(), 3, "{file}");
        for f in &frames {
            let c = &f.cameras[0];
            let k = c.intrinsics;
            assert_eq!((k.width, k.height), size, "{file}");
            assert_eq!(
                (k.cx, k.cy),
                (f64::from(size.0) / 2.0 - 0.5, f64::from(size.1) / 2.0 - 0.5),
                "{file}"
            );
            match focal {
                Some(f35) => {
                    assert_eq!(c.source, CameraSource::VideoMetadata, "{file}");
                    let fx = f35 * 200.0 / DIAGONAL_35MM;
                    assert!((k.fx - fx).abs() < 1e-6, "{file}: {k:?}");
                }
                None => {
                    assert_eq!(c.source, CameraSource::Generic, "{file}");
                    assert_eq!(
                        c.reason.is_some(),
                        file == "implausible.mov",
                        "{file}: {:?}",
                        c.reason
                    );
                }
            }
        }
    }
}
