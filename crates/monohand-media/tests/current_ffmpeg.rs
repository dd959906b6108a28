//! The reader with a current FFmpeg, which no longer has the `-vsync` option older ones
//! need (removed in FFmpeg 7.0): the static FFmpeg 9.0 build of PyPI's `imageio-ffmpeg`
//! 0.8.1, fetched with pip (its wheel's checksum checked by pip) and cached in
//! `~/.cache/monohand/test-tools` (or `$MONOHAND_TEST_TOOLS`). The test fails, saying why,
//! where the download or the shared data is missing.
#![cfg(all(target_os = "linux", target_arch = "x86_64"))]
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand_media::video::{Encoder, FfmpegTools, VideoInput, VideoReader, VideoWriter};
use monohand_testkit::{hand_png, run_ok};
use std::path::{Path, PathBuf};
use std::process::Command;

const WHEEL: &str = "imageio-ffmpeg==0.8.1";
const WHEEL_SHA256: &str = "050d6850601c3b3890bd2b28306f3b842b3daea390a561101174375a1c460bda";
const BINARY: &str = "imageio_ffmpeg/binaries/ffmpeg-linux-x86_64-v9.0.2";

/// The cached FFmpeg 9.0 executable, fetched first if needed.
fn current_ffmpeg() -> PathBuf {
    let dir = std::env::var_os("MONOHAND_TEST_TOOLS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let home = std::env::var_os("HOME").expect("HOME is not set");
            Path::new(&home).join(".cache/monohand/test-tools")
        });
    let exe = dir.join("ffmpeg-9.0.2");
    if exe.exists() {
        return exe;
    }
    std::fs::create_dir_all(&dir).unwrap();
    let work = tempfile::tempdir_in(&dir).unwrap();
    let req = work.path().join("requirements.txt");
    std::fs::write(&req, format!("{WHEEL} --hash=sha256:{WHEEL_SHA256}\n")).unwrap();
    run_ok(
        Command::new("python3")
            .args([
                "-m",
                "pip",
                "download",
                "--quiet",
                "--no-deps",
                "--only-binary=:all:",
            ])
            .args([
                "--platform",
                "manylinux_2_28_x86_64",
                "--require-hashes",
                "-r",
            ])
            .arg(&req)
            .arg("-d")
            .arg(work.path()),
        &format!("pip could not fetch {WHEEL} (python3 and pip fetch the FFmpeg build)"),
    );
    // Extract the one executable from the wheel (a zip), then move it into place whole.
    let part = work.path().join("ffmpeg");
    let script = "import glob, shutil, sys, zipfile\n\
                  w = zipfile.ZipFile(glob.glob(sys.argv[1] + '/*.whl')[0])\n\
                  with w.open(sys.argv[2]) as src, open(sys.argv[3], 'wb') as dst:\n\
                  \x20   shutil.copyfileobj(src, dst)\n";
    let status = Command::new("python3")
        .args(["-c", script])
        .arg(work.path())
        .arg(BINARY)
        .arg(&part)
        .status()
        .unwrap();
    assert!(
        status.success(),
        "could not extract {BINARY} from the wheel"
    );
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&part, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::rename(&part, &exe).unwrap();
    exe
}

/// Variable frame rate, made and read by FFmpeg 9.0: five frames at 30 fps, a pause of
/// 0.37 s, three more. Every frame comes out once with the stream's own times (as with the
/// system's ffmpeg in `video.rs`), and the pixels are those the system's ffmpeg reads.
#[test]
fn ffmpeg_9_reads_every_frame_with_its_time() {
    let photo = hand_png();
    let current = FfmpegTools {
        ffmpeg: current_ffmpeg(),
        ..FfmpegTools::default()
    };
    let version = Command::new(&current.ffmpeg)
        .arg("-version")
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&version.stdout).starts_with("ffmpeg version n9.0"));
    let features = current.features();
    assert!(features.fps_mode && features.showinfo_checksum_option);

    let dir = tempfile::tempdir().unwrap();
    let vfr = dir.path().join("vfr.mkv");
    run_ok(
        Command::new(&current.ffmpeg)
            .args(["-v", "error", "-y", "-loop", "1", "-framerate", "30", "-i"])
            .arg(&photo)
            .args(["-vf", "scale=64:48,setpts='if(lt(N,5),N/30,(N+10)/30)/TB'"])
            .args(["-frames:v", "8", "-c:v", "ffv1", "-fps_mode", "vfr"])
            .arg(&vfr),
        "FFmpeg 9.0 could not make the variable-frame-rate clip",
    );

    let read = |tools: &FfmpegTools| {
        let input = VideoInput::File(vfr.clone());
        let mut r = VideoReader::open_with(tools, &input).unwrap();
        let mut frames = Vec::new();
        while let Some(f) = r.next_frame().unwrap() {
            assert_eq!(f.index, frames.len() as u64);
            frames.push((f.timestamp_s, f.image));
        }
        frames
    };
    let frames = read(&current);
    let times: Vec<f64> = frames.iter().map(|f| f.0).collect();
    let want = [0.0, 0.033, 0.067, 0.1, 0.133, 0.5, 0.533, 0.567];
    assert_eq!(times.len(), want.len(), "{times:?}");
    for (t, w) in times.iter().zip(want) {
        assert!((t - w).abs() < 1.5e-3, "{times:?}");
    }
    assert_eq!((frames[0].1.width(), frames[0].1.height()), (64, 48));
    // Lossless: the system's ffmpeg decodes the same pixels.
    let system = read(&FfmpegTools::default());
    assert_eq!(system.len(), frames.len());
    for (a, b) in system.iter().zip(&frames) {
        assert!(a.1 == b.1, "the two ffmpegs decode different pixels");
    }

    // Written by FFmpeg 9.0 (H.264, as `run --video-out` writes), read back by both.
    let mp4 = dir.path().join("out.mp4");
    let encoder = Encoder::best_available(&current);
    assert_eq!(encoder, Encoder::Libx264);
    let mut w = VideoWriter::create_with(&current, encoder, &mp4, 64, 48, 30.0).unwrap();
    for (_, image) in &frames {
        w.write(image).unwrap();
    }
    w.finish().unwrap();
    for tools in [&current, &FfmpegTools::default()] {
        let mut r = VideoReader::open_with(tools, &VideoInput::File(mp4.clone())).unwrap();
        let mut n = 0;
        while let Some(f) = r.next_frame().unwrap() {
            let want = &frames[n].1;
            let diff = f
                .image
                .as_raw()
                .iter()
                .zip(want.as_raw())
                .map(|(&a, &b)| f64::from(a.abs_diff(b)))
                .sum::<f64>()
                / want.as_raw().len() as f64;
            assert!(diff < 6.0, "frame {n}: mean difference {diff}");
            n += 1;
        }
        assert_eq!(n, frames.len());
    }
}
