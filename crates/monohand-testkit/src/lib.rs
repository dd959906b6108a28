//! # monohand-testkit
//!
//! Test helpers shared by monohand's test suites (a dev-dependency only, never
//! published): the paths of the shared data (`../shared/data` beside the repository,
//! which CI always has) and of its sample files, and the system tools the tests drive
//! (`ffmpeg`, `ffprobe`, `exiftool`), with the clips the video tests make from the shared
//! photo and Apple's camera metadata written into them ([`quicktime`]).
//!
//! Missing data or a missing tool fails the calling test with a message that says what
//! is missing and where it was looked for.

#![deny(missing_docs)]
// Test helpers panic on failure: a failed check fails the test that called it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

pub mod quicktime;

use std::path::{Path, PathBuf};
use std::process::Command;

/// `../shared/data` beside the repository (not checked: see the helpers below for the
/// files the tests use).
pub fn shared_data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

/// The shared photo of a hand, `../shared/data/images/pinto/hand.png` (640x480); fails
/// the test if it is missing.
pub fn hand_png() -> PathBuf {
    let path = shared_data().join("images/pinto/hand.png");
    assert!(
        path.is_file(),
        "{} not found (../shared beside the repository)",
        path.display()
    );
    path
}

/// The hand-graph-cnn development set (real frames with 3D labels),
/// `../shared/data/hand_graph_cnn_dev`. Missing data fails the test: it is part of
/// `../shared`, which CI always has beside the repository.
pub fn dev_set_dir() -> PathBuf {
    let d = shared_data().join("hand_graph_cnn_dev");
    assert!(
        d.join("labels.json").is_file(),
        "the development set is missing at {} (../shared/data beside the repository)",
        d.display()
    );
    d
}

/// The table rig's development set (4 calibrated views of a hand grasping on a table, with
/// a 3D reference), `../shared/data/table_rig_dev`; fails the test if it is missing.
pub fn table_rig_dir() -> PathBuf {
    let d = shared_data().join("table_rig_dev");
    assert!(
        d.join("reference_3d_mm.json").is_file() && d.join("cameras").is_dir(),
        "the table rig set is missing at {} (../shared/data beside the repository)",
        d.display()
    );
    d
}

/// The table rig's views, master camera first: their serials (`cameras/<serial>.json`,
/// `images/<serial>/`).
pub const TABLE_RIG_VIEWS: [&str; 4] = [
    "141122079464",
    "141722072294",
    "141722075121",
    "141722076181",
];

/// The STB dataset's sequence B1Counting, `../shared/data/stb_b1counting` (its labels
/// `labels/B1Counting_BB.mat` and stereo cameras `camera_params.json`); fails the test if
/// either is missing.
pub fn stb_dir() -> PathBuf {
    let d = shared_data().join("stb_b1counting");
    assert!(
        d.join("labels/B1Counting_BB.mat").is_file() && d.join("camera_params.json").is_file(),
        "STB data not found at {} (the shared data directory must sit beside the repository)",
        d.display()
    );
    d
}

/// Runs `cmd` to its end and returns its output; fails the test, with `what` and the
/// command's standard error, if it cannot be started or does not succeed.
pub fn run_ok(cmd: &mut Command, what: &str) -> std::process::Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run {cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{what} ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs ffmpeg with these arguments (quiet, overwriting: `ffmpeg -v error -y ARGS`);
/// fails the test if it fails or is missing (apt-get install ffmpeg).
pub fn ffmpeg(args: &[&str]) {
    run_ok(
        Command::new("ffmpeg")
            .args(["-v", "error", "-y"])
            .args(args),
        &format!("ffmpeg {args:?}"),
    );
}

/// A clip of `frames` frames at 30 fps made by ffmpeg from the shared photo ([`hand_png`]):
/// a camera panning over it when `filter` moves a `crop=` window (e.g.
/// `crop=560:420:'10+4*n':20`), any other video filter, or the photo as it is (`None`);
/// encoded as MPEG-4 with the output `options` (e.g. `-q:v 2`) into `out`, whose extension
/// picks the container. Fails the test if ffmpeg fails.
pub fn photo_clip(out: &Path, frames: usize, filter: Option<&str>, options: &[&str]) {
    let photo = hand_png();
    let n = frames.to_string();
    let mut args = vec![
        "-loop",
        "1",
        "-framerate",
        "30",
        "-i",
        photo.to_str().unwrap(),
    ];
    if let Some(filter) = filter {
        args.extend(["-vf", filter]);
    }
    args.extend(["-frames:v", &n, "-c:v", "mpeg4"]);
    args.extend(options);
    args.push(out.to_str().unwrap());
    ffmpeg(&args);
}

/// Frames in a video file as ffprobe decodes them (`ffprobe -count_frames`); fails the test
/// if it cannot read the file.
pub fn decodable_frames(video: &Path) -> usize {
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=nb_read_frames", "-of", "csv=p=0"])
        .arg(video)
        .output()
        .unwrap();
    assert!(
        probe.status.success(),
        "{}",
        String::from_utf8_lossy(&probe.stderr)
    );
    // A rotated video's line ends in an empty field for its side data (`3,`).
    let out = String::from_utf8_lossy(&probe.stdout);
    let count = out.trim().split(',').next().unwrap_or_default();
    count
        .parse()
        .unwrap_or_else(|e| panic!("ffprobe counted {out:?} frames: {e}"))
}

/// What exiftool reads in `file`, as its JSON (`exiftool -json -a -G1 -ee -n FILE`: every
/// tag, duplicates too, each named by its group, such as `Keys:Make` or
/// `Track1:CameraFocalLength35mmEquivalent`, with numbers unformatted); the tests' reader of
/// metadata independent of monohand's. Fails the test if exiftool is missing (Debian and
/// Ubuntu: `apt-get install libimage-exiftool-perl`) or cannot read the file.
pub fn exiftool(file: &Path) -> String {
    let out = Command::new("exiftool")
        .args(["-json", "-a", "-G1", "-ee", "-n"])
        .arg(file)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "exiftool, the independent reader of the video metadata tests, cannot run \
                 ({e}): apt-get install libimage-exiftool-perl"
            )
        });
    assert!(
        out.status.success(),
        "exiftool {} ({}): {}",
        file.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}
