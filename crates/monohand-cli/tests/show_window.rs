//! `run --show` as a person uses it: a real window on a virtual X server (Xvfb), a
//! screenshot of it taken with `xwd`, its pixels compared with the overlay the library draws
//! from the JSON the same run wrote, then Q pressed (`xdotool`) and the run ends cleanly.
//!
//! Needs `Xvfb`, `xwd` and `xdotool` (Debian: xvfb, x11-apps, xdotool; `.ci/run` installs
//! them): a missing one fails the test.
#![cfg(feature = "show")]
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand_io::jsonl::read_jsonl;
use monohand_media::scene::{Layers, SceneRenderer};
use monohand_testkit::hand_png;
use monohand_vision::RgbImage;
use std::io::Read;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A process killed when dropped (the X server, a stuck run).
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts Xvfb on a free display; returns it and `:N`.
fn xvfb() -> (Killed, String) {
    let mut child = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "1024x768x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb is needed for the --show test (apt-get install xvfb)");
    let mut out = child.stdout.take().unwrap();
    let mut num = String::new();
    let mut byte = [0u8; 1];
    while out.read(&mut byte).unwrap() == 1 && byte[0] != b'\n' {
        num.push(byte[0] as char);
    }
    assert!(!num.is_empty(), "Xvfb gave no display number");
    (Killed(child), format!(":{}", num.trim()))
}

/// Parses an XWD dump (ZPixmap, 24/32 bits per pixel) into an RGB image.
fn parse_xwd(b: &[u8]) -> RgbImage {
    let f = |i: usize| u32::from_be_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
    let (header, format, w, h) = (f(0) as usize, f(2), f(4), f(5));
    let (byte_order, bpp, line) = (f(7), f(11) as usize, f(12) as usize);
    let (rm, gm, bm, ncolors) = (f(14), f(15), f(16), f(19) as usize);
    assert_eq!(format, 2, "ZPixmap");
    assert_eq!(bpp, 32, "32 bits per pixel");
    let data = &b[header + 12 * ncolors..];
    let chan = |v: u32, m: u32| ((v & m) >> m.trailing_zeros()) as u8;
    RgbImage::from_fn(w, h, |x, y| {
        let o = y as usize * line + x as usize * 4;
        let px = [data[o], data[o + 1], data[o + 2], data[o + 3]];
        let v = if byte_order == 0 {
            u32::from_le_bytes(px)
        } else {
            u32::from_be_bytes(px)
        };
        image::Rgb([chan(v, rm), chan(v, gm), chan(v, bm)])
    })
}

/// A screenshot of the window named `name` on `display`, once it is mapped.
fn screenshot(display: &str, name: &str) -> Option<RgbImage> {
    let dump = Command::new("xwd")
        .args(["-silent", "-name", name, "-display", display])
        .output()
        .expect("xwd is needed for the --show tests (apt-get install x11-apps)");
    (dump.status.success() && dump.stdout.len() > 100).then(|| parse_xwd(&dump.stdout))
}

/// Focuses the window named exactly `name` and holds Q for 300 ms as a person would (the
/// window polls its keys between frames, and a press and release that both fall between
/// two polls are not seen); the key goes through XTEST like a real keyboard.
fn press_q(display: &str, name: &str) {
    let xdotool = |args: &[&str]| {
        let out = Command::new("xdotool")
            .args(args)
            .env("DISPLAY", display)
            .output()
            .expect("xdotool is needed for the --show tests (apt-get install xdotool)");
        assert!(
            out.status.success(),
            "xdotool {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    xdotool(&["search", "--name", &format!("^{name}$"), "windowfocus"]);
    xdotool(&["keydown", "q", "sleep", "0.3", "keyup", "q"]);
}

/// Waits up to 20 s for the process to end; its status.
fn ended(run: &mut Killed) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(s) = run.0.try_wait().unwrap() {
            return s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the window's process did not end after Q"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn the_show_window_draws_the_hands_where_the_json_says_and_q_quits() {
    let photo_path = hand_png();
    let photo = monohand_vision::image_io::load_rgb(&photo_path).unwrap();
    let (_x, display) = xvfb();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hand.jsonl");
    let run = Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args(["run", photo_path.to_str().unwrap(), "--show", "-o"])
        .arg(&out)
        .env("DISPLAY", &display)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut run = Killed(run);

    // The window appears once the frame is processed; the still image stays on screen.
    let start = Instant::now();
    let shot = loop {
        if let Some(img) = screenshot(&display, "monohand") {
            // Drawn: the frame is there (not a blank window).
            if img.dimensions() == photo.dimensions() && img.pixels().any(|p| p.0 != [0, 0, 0]) {
                break img;
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no monohand window on {display}"
        );
        std::thread::sleep(Duration::from_millis(300));
    };
    // The JSON was written before the frame was shown.
    let frames = read_jsonl(&out).unwrap();
    assert_eq!(frames.len(), 1);
    let hands = &frames[0].hands;
    assert_eq!(hands.len(), 1, "one hand in the photo");
    // What the library draws for that JSON (generic camera, default layers).
    let mut expected = photo.clone();
    let mut renderer = SceneRenderer::default();
    renderer.set_camera_source(Some("generic"));
    renderer.draw(&mut expected, hands, &[], &Layers::default());
    let (mut same, mut differ, mut drawn) = (0usize, 0usize, 0usize);
    for (x, y, p) in shot.enumerate_pixels() {
        if y < 40 && x < 360 {
            continue; // the frame-rate line
        }
        let e = expected.get_pixel(x, y).0;
        let close = p.0.iter().zip(e).all(|(a, b)| a.abs_diff(b) <= 2);
        if close {
            same += 1;
        } else {
            differ += 1;
        }
        if e != photo.get_pixel(x, y).0 && close {
            drawn += 1;
        }
    }
    assert!(
        differ * 1000 < same,
        "{differ} pixels differ from the overlay of the JSON ({same} agree)"
    );
    assert!(drawn > 3000, "{drawn} overlay pixels seen in the window");
    // The fitted joints are covered by the drawn model in the window.
    let cam = monohand_core::camera::Camera::generic(640, 480).unwrap();
    let joints = hands[0].joints_3d_mm.unwrap();
    let on = joints
        .iter()
        .filter(|j| {
            let p = cam.project(&nalgebra::Vector3::from(**j)).unwrap();
            let (x, y) = (p.x.round() as u32, p.y.round() as u32);
            shot.get_pixel(x, y) != photo.get_pixel(x, y)
        })
        .count();
    assert!(on >= 19, "{on} of 21 joints drawn in the window");

    // Q quits: the run ends by itself, successfully.
    press_q(&display, "monohand");
    let status = ended(&mut run);
    assert!(status.success(), "{status}");
}

/// `calibrate --show` on a video of the board: the window shows the frames as they are
/// examined and, once the camera file is written, the result's picture (the corners seen as
/// green dots, the distortion field as yellow arrows) until Q.
#[test]
fn the_calibrate_window_shows_the_result_until_q() {
    let dir = tempfile::tempdir().unwrap();
    let photos = monohand_testkit::shared_data().join("calibration/opencv_stereo_chessboard");
    let frames = dir.path().join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for (i, n) in [1, 2, 3, 4, 5, 6].iter().enumerate() {
        std::fs::copy(
            photos.join(format!("left{n:02}.jpg")),
            frames.join(format!("f{i:02}.jpg")),
        )
        .unwrap();
    }
    let video = dir.path().join("board.mkv");
    monohand_testkit::ffmpeg(&[
        "-framerate",
        "1",
        "-i",
        frames.join("f%02d.jpg").to_str().unwrap(),
        "-vf",
        "fps=10",
        "-c:v",
        "ffv1",
        video.to_str().unwrap(),
    ]);
    let (_x, display) = xvfb();
    let cam = dir.path().join("cam.json");
    let run = Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args([
            "calibrate",
            "--board",
            "9x6",
            "--square-mm",
            "25",
            "--show",
            "-o",
        ])
        .arg(&cam)
        .arg(&video)
        .env("DISPLAY", &display)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut run = Killed(run);
    let start = Instant::now();
    while !cam.exists() {
        if let Some(status) = run.0.try_wait().unwrap() {
            let mut err = String::new();
            run.0
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            panic!("calibrate ended ({status}) before writing: {err}");
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no camera written"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // The picture is on screen once the file is written.
    let shot = loop {
        if let Some(img) = screenshot(&display, "monohand calibrate") {
            let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
            if img.dimensions() == (640, 480) && count([255, 210, 60]) > 200 {
                break img;
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no result picture on {display}"
        );
        std::thread::sleep(Duration::from_millis(300));
    };
    let green = shot.pixels().filter(|p| p.0 == [120, 220, 120]).count();
    assert!(green > 500, "{green} pixels of corner dots");
    press_q(&display, "monohand calibrate");
    let status = ended(&mut run);
    assert!(status.success(), "{status}");
}
