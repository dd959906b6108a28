//! The skinned glTF in a real browser: `monohand run` on a real photo writes a `.glb`
//! with the WebXR hand mesh posed by the fit; headless Chromium loads it with three.js
//! (installed from the npm registry into the test's scratch folder, not committed) from
//! the file's own camera, and the screenshot must show the hand where the JSON says.
//!
//! Needs `chromium` and `npm` (and network for the first `npm install`): a missing one
//! fails the test. `.ci/run` installs chromium.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;

use common::{monohand, ok};
use monohand_core::camera::Camera;
use monohand_io::jsonl::read_jsonl;
use monohand_testkit::hand_png;
use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The three.js release the page uses.
const THREE_VERSION: &str = "0.170.0";

/// three.js in the tests' scratch folder (`npm install` once; later runs reuse it).
fn three_js() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("three-{THREE_VERSION}"));
    let module = dir.join("node_modules/three/build/three.module.js");
    if !module.is_file() {
        std::fs::create_dir_all(&dir).unwrap();
        let out = Command::new("npm")
            .args(["install", "--no-audit", "--no-fund", "--silent", "--prefix"])
            .arg(&dir)
            .arg(format!("three@{THREE_VERSION}"))
            .output()
            .expect("npm (Node.js) is needed for the browser test of the glTF export");
        assert!(
            out.status.success(),
            "npm install three failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(module.is_file());
    dir.join("node_modules")
}

/// Serves `root` over HTTP on a local port (module scripts are not loaded from file://).
fn serve(root: PathBuf) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { continue };
            let mut line = String::new();
            if BufReader::new(&s).read_line(&mut line).is_err() {
                continue;
            }
            let path = line.split_whitespace().nth(1).unwrap_or("/").to_string();
            let rel = path.split('?').next().unwrap_or("").trim_start_matches('/');
            let file = root.join(rel);
            let (status, body) = match (rel.contains(".."), std::fs::read(&file)) {
                (false, Ok(b)) => ("200 OK", b),
                _ => ("404 Not Found", Vec::new()),
            };
            let mime = match file.extension().and_then(|e| e.to_str()) {
                Some("js") => "text/javascript",
                Some("html") => "text/html",
                Some("glb") => "model/gltf-binary",
                _ => "application/octet-stream",
            };
            let _ = write!(
                s,
                "HTTP/1.1 {status}\r\nContent-Type: {mime}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = s.write_all(&body);
        }
    });
    port
}

/// The page: the `.glb` rendered from its own camera at the first frame of its animation,
/// on black, at the photo's size.
fn page(w: u32, h: u32) -> String {
    format!(
        r#"<!doctype html><html><head><style>html,body{{margin:0;background:#000;overflow:hidden}}</style>
<script type="importmap">{{"imports": {{"three": "./node_modules/three/build/three.module.js",
"three/addons/": "./node_modules/three/examples/jsm/"}}}}</script></head>
<body><canvas id="c" width="{w}" height="{h}"></canvas>
<script type="module">
import * as THREE from 'three';
import {{ GLTFLoader }} from 'three/addons/loaders/GLTFLoader.js';
const canvas = document.getElementById('c');
const renderer = new THREE.WebGLRenderer({{canvas, antialias: false, preserveDrawingBuffer: true}});
renderer.setPixelRatio(1);
renderer.setSize({w}, {h}, false);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x000000);
scene.add(new THREE.AmbientLight(0xffffff, 1.0));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(-1, 1, 1);
scene.add(sun);
new GLTFLoader().load('hands.glb', (g) => {{
  scene.add(g.scene);
  g.scene.traverse((o) => {{ o.frustumCulled = false; }});
  const mixer = new THREE.AnimationMixer(g.scene);
  for (const a of g.animations) mixer.clipAction(a).play();
  mixer.setTime(0);
  scene.updateMatrixWorld(true);
  const cam = g.cameras[0];
  cam.aspect = {w} / {h};
  cam.updateProjectionMatrix();
  renderer.render(scene, cam);
  document.title = 'rendered';
}}, undefined, (e) => {{ document.title = 'error ' + e; }});
</script></body></html>"#
    )
}

/// The mesh stays near the joints' box `(x0, y0, x1, y1)`: nothing drawn far outside it.
/// Returns the red and blue drawn inside it (the mesh's colour is the hand's side colour:
/// orange right, cyan left).
fn mesh_near_joints(img: &image::RgbImage, (x0, y0, x1, y1): (f64, f64, f64, f64)) -> (u64, u64) {
    let m = 0.25 * (x1 - x0).max(y1 - y0);
    let mut inside = 0usize;
    let mut outside = 0usize;
    let (mut red, mut blue) = (0u64, 0u64);
    for (x, y, p) in img.enumerate_pixels() {
        if p.0.iter().all(|&v| v <= 40) {
            continue;
        }
        let (fx, fy) = (x as f64, y as f64);
        if fx >= x0 - m && fx <= x1 + m && fy >= y0 - m && fy <= y1 + m {
            inside += 1;
            red += p.0[0] as u64;
            blue += p.0[2] as u64;
        } else {
            outside += 1;
        }
    }
    assert!(inside > 2000, "the hand covers {inside} pixels");
    assert!(
        outside < inside / 50,
        "{outside} pixels drawn away from the hand"
    );
    (red, blue)
}

/// A headless Chromium screenshot (640x480) of the page served on `port`.
fn screenshot(dir: &Path, port: u16) -> PathBuf {
    let shot = dir.join("shot.png");
    let profile = dir.join("profile");
    let run = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--hide-scrollbars",
            "--window-size=640,480",
            "--virtual-time-budget=20000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        // Chromium's own temporary files (its singleton socket, left even on a clean exit)
        // in the test's folder, removed with it, not in /tmp.
        .env("TMPDIR", dir)
        .arg(format!("http://127.0.0.1:{port}/index.html"))
        .output()
        .expect(
            "chromium is needed for the browser test of the glTF export (apt-get install chromium)",
        );
    assert!(
        shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    shot
}

#[test]
fn the_skinned_hand_renders_in_chromium_where_the_fit_says() {
    let photo = hand_png();
    let dir = tempfile::tempdir().unwrap();
    let site = dir.path().join("site");
    std::fs::create_dir(&site).unwrap();
    // three.js beside the page (a symlink to the scratch install).
    std::os::unix::fs::symlink(three_js(), site.join("node_modules")).unwrap();
    // The run: a generic camera written out, so that the glTF camera is the image's.
    let cam_path = dir.path().join("cam.json");
    let cam_run = monohand(&["camera", "--width", "640", "--height", "480"]);
    ok(&cam_run);
    std::fs::write(&cam_path, &cam_run.stdout).unwrap();
    let out = dir.path().join("hand.jsonl");
    let glb = site.join("hands.glb");
    ok(&monohand(&[
        "run",
        photo.to_str().unwrap(),
        "--camera",
        cam_path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--gltf",
        glb.to_str().unwrap(),
    ]));
    let bytes = std::fs::read(&glb).unwrap();
    assert!(
        String::from_utf8_lossy(&bytes).contains("\"skins\""),
        "a skinned mesh"
    );
    std::fs::write(site.join("index.html"), page(640, 480)).unwrap();
    let port = serve(site.clone());

    let shot = screenshot(dir.path(), port);
    let img = monohand_vision::image_io::load_rgb(&shot).unwrap();
    assert_eq!(img.dimensions(), (640, 480));

    // The fitted joints, projected with the same camera, must fall on the rendered hand.
    let camera: Camera = monohand_io::calibration::read_camera(&cam_path).unwrap();
    let frames = read_jsonl(&out).unwrap();
    let hand = &frames[0].hands[0];
    let joints = hand.joints_3d_mm.unwrap();
    let lit = |x: i64, y: i64| -> bool {
        (x >= 0 && y >= 0 && x < 640 && y < 480)
            && img.get_pixel(x as u32, y as u32).0.iter().any(|&v| v > 40)
    };
    let mut on_hand = 0;
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for j in &joints {
        let p = camera.project(&nalgebra::Vector3::from(*j)).unwrap();
        x0 = x0.min(p.x);
        y0 = y0.min(p.y);
        x1 = x1.max(p.x);
        y1 = y1.max(p.y);
        let (x, y) = (p.x.round() as i64, p.y.round() as i64);
        if (-2..=2).any(|dy| (-2..=2).any(|dx| lit(x + dx, y + dy))) {
            on_hand += 1;
        }
    }
    assert!(
        on_hand >= 19,
        "{on_hand} of 21 fitted joints on the rendered hand"
    );
    let (red, blue) = mesh_near_joints(&img, (x0, y0, x1, y1));
    let side_is_right = hand.side == monohand_core::hand_model::HandSide::Right;
    assert_eq!(
        red > blue,
        side_is_right,
        "red {red}, blue {blue}, {:?}",
        hand.side
    );
}
