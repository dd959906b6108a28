//! Writes the QuickTime metadata fixtures beside this file (`tests/quicktime.rs` reads them,
//! with exiftool as the independent reader):
//!
//!     cargo run -p monohand-media --example make_quicktime_fixtures
//!
//! Each is 3 frames of ffmpeg's `testsrc` (160x120, MPEG-4 part 2) with Apple's camera
//! metadata written in by `monohand_testkit::quicktime` (see README.md here for the list).
//! ffmpeg's output differs between its versions, so a rerun changes the bytes but not what
//! the tests check.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a fixture script: a failure is a panic

use monohand_testkit::quicktime::{
    keys, with_64_bit_mdat, with_apple_keys, with_open_ended_last_box, Value,
};
use monohand_testkit::{exiftool, ffmpeg};
use std::path::{Path, PathBuf};

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/quicktime");
    let scratch = tempfile::tempdir().unwrap();
    let mut written: Vec<PathBuf> = Vec::new();
    let fixtures = apple_fixtures(scratch.path())
        .into_iter()
        .chain(remuxed_fixtures(scratch.path()));
    for (name, bytes) in fixtures {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        written.push(path);
    }
    for path in &written {
        print_tags(path);
    }
}

/// Three frames of `testsrc` encoded by ffmpeg into `scratch/name` with `options`.
fn base(scratch: &Path, name: &str, options: &[&str]) -> Vec<u8> {
    let out = scratch.join(name);
    let mut args = vec![
        "-f",
        "lavfi",
        "-i",
        "testsrc=size=160x120:rate=30",
        "-frames:v",
        "3",
        "-c:v",
        "mpeg4",
        "-q:v",
        "8",
    ];
    args.extend(options);
    args.push(out.to_str().unwrap());
    ffmpeg(&args);
    std::fs::read(out).unwrap()
}

/// `src` copied by ffmpeg into `scratch/name` with `options` (metadata written by ffmpeg).
fn remux(scratch: &Path, src: &str, name: &str, options: &[&str]) -> Vec<u8> {
    let out = scratch.join(name);
    let src = scratch.join(src);
    let mut args = vec!["-i", src.to_str().unwrap(), "-c", "copy"];
    args.extend(options);
    args.push(out.to_str().unwrap());
    ffmpeg(&args);
    std::fs::read(out).unwrap()
}

const IPHONE: [(&str, Value); 2] = [
    (keys::MAKE, Value::Text("Apple")),
    (keys::MODEL, Value::Text("iPhone 15 Pro")),
];

const LENS: Value = Value::Text("iPhone 15 Pro back camera 6.765mm f/1.78");

/// The fixtures with Apple's keys written in by the testkit: each file's name and bytes.
fn apple_fixtures(scratch: &Path) -> Vec<(&'static str, Vec<u8>)> {
    let plain = base(scratch, "plain.mov", &[]);
    let faststart = base(scratch, "faststart.mov", &["-movflags", "faststart"]);
    let mp4 = base(scratch, "plain.mp4", &[]);
    vec![
        ("plain.mov", plain.clone()),
        (
            "iphone_int.mov",
            with_apple_keys(
                &plain,
                &[(keys::LENS_MODEL, LENS), (keys::FOCAL_35MM, Value::Int(24))],
                &IPHONE,
            ),
        ),
        (
            "faststart_float.mov",
            with_open_ended_last_box(&with_apple_keys(
                &faststart,
                &[
                    (keys::FOCAL_35MM, Value::Float32(26.5)),
                    (keys::LENS_MODEL, LENS),
                ],
                &IPHONE,
            )),
        ),
        (
            "text_focal.mp4",
            with_apple_keys(&mp4, &[(keys::FOCAL_35MM, Value::Text("50.00mm"))], &IPHONE),
        ),
        (
            "mdat64_float64.mov",
            with_64_bit_mdat(&with_apple_keys(
                &plain,
                &[(keys::FOCAL_35MM, Value::Float64(28.0))],
                &[],
            )),
        ),
        (
            "implausible.mov",
            with_apple_keys(&plain, &[(keys::FOCAL_35MM, Value::Int(3000))], &IPHONE),
        ),
    ]
}

/// The fixtures remuxed by ffmpeg first (`plain.mov` from [`apple_fixtures`]): a rotated
/// track, and movie-level keys as ffmpeg writes them.
fn remuxed_fixtures(scratch: &Path) -> Vec<(&'static str, Vec<u8>)> {
    let rotated = remux(
        scratch,
        "plain.mov",
        "rotated.mov",
        &["-metadata:s:v:0", "rotate=90"],
    );
    let movie_only = remux(
        scratch,
        "plain.mov",
        "movie_only.mov",
        &[
            "-movflags",
            "use_metadata_tags",
            "-metadata",
            "com.apple.quicktime.make=Apple",
            "-metadata",
            "com.apple.quicktime.model=iPhone 15 Pro",
        ],
    );
    vec![
        (
            "rotated.mov",
            with_apple_keys(
                &rotated,
                &[(keys::FOCAL_35MM, Value::Int(26)), (keys::LENS_MODEL, LENS)],
                &IPHONE,
            ),
        ),
        ("movie_keys_ffmpeg.mov", movie_only),
    ]
}

/// Prints what exiftool reads of a fixture's camera tags.
fn print_tags(path: &Path) {
    let json = exiftool(path);
    let tags: Vec<&str> = json
        .lines()
        .filter(|l| {
            [
                "Make",
                "Model",
                "CameraFocalLength35mm",
                "CameraLensModel",
                "ImageWidth",
            ]
            .iter()
            .any(|t| l.contains(t))
        })
        .map(str::trim)
        .collect();
    println!(
        "{} ({} bytes), exiftool: {}",
        path.file_name().unwrap().to_string_lossy(),
        std::fs::metadata(path).unwrap().len(),
        tags.join(" ")
    );
}
