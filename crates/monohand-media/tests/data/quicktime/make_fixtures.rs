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
    let base = |name: &str, options: &[&str]| -> Vec<u8> {
        let out = scratch.path().join(name);
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
    };
    let iphone = [
        (keys::MAKE, Value::Text("Apple")),
        (keys::MODEL, Value::Text("iPhone 15 Pro")),
    ];
    let lens = Value::Text("iPhone 15 Pro back camera 6.765mm f/1.78");
    let plain = base("plain.mov", &[]);
    let mut written: Vec<PathBuf> = Vec::new();
    let mut write = |name: &str, bytes: Vec<u8>| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        written.push(path);
    };
    write("plain.mov", plain.clone());
    write(
        "iphone_int.mov",
        with_apple_keys(
            &plain,
            &[(keys::LENS_MODEL, lens), (keys::FOCAL_35MM, Value::Int(24))],
            &iphone,
        ),
    );
    let faststart = base("faststart.mov", &["-movflags", "faststart"]);
    write(
        "faststart_float.mov",
        with_open_ended_last_box(&with_apple_keys(
            &faststart,
            &[
                (keys::FOCAL_35MM, Value::Float32(26.5)),
                (keys::LENS_MODEL, lens),
            ],
            &iphone,
        )),
    );
    let mp4 = base("plain.mp4", &[]);
    write(
        "text_focal.mp4",
        with_apple_keys(&mp4, &[(keys::FOCAL_35MM, Value::Text("50.00mm"))], &iphone),
    );
    write(
        "mdat64_float64.mov",
        with_64_bit_mdat(&with_apple_keys(
            &plain,
            &[(keys::FOCAL_35MM, Value::Float64(28.0))],
            &[],
        )),
    );
    let rotated = scratch.path().join("rotated.mov");
    let plain_path = scratch.path().join("plain.mov");
    ffmpeg(&[
        "-i",
        plain_path.to_str().unwrap(),
        "-c",
        "copy",
        "-metadata:s:v:0",
        "rotate=90",
        rotated.to_str().unwrap(),
    ]);
    write(
        "rotated.mov",
        with_apple_keys(
            &std::fs::read(&rotated).unwrap(),
            &[(keys::FOCAL_35MM, Value::Int(26)), (keys::LENS_MODEL, lens)],
            &iphone,
        ),
    );
    write(
        "implausible.mov",
        with_apple_keys(&plain, &[(keys::FOCAL_35MM, Value::Int(3000))], &iphone),
    );
    let movie_only = scratch.path().join("movie_only.mov");
    ffmpeg(&[
        "-i",
        plain_path.to_str().unwrap(),
        "-c",
        "copy",
        "-movflags",
        "use_metadata_tags",
        "-metadata",
        "com.apple.quicktime.make=Apple",
        "-metadata",
        "com.apple.quicktime.model=iPhone 15 Pro",
        movie_only.to_str().unwrap(),
    ]);
    write("movie_keys_ffmpeg.mov", std::fs::read(&movie_only).unwrap());
    for path in &written {
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
}
