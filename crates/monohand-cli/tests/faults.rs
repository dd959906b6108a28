//! Faults in the middle of a `monohand run`, each made real: the decoding ffmpeg killed, the
//! output file hitting a size limit (a full disk), the overlay folder replaced by a file,
//! SIGTERM, a pipe that stops delivering, several processes fetching the networks into one
//! cache, and a damaged cached network. Each asserts the exit status (docs/pipeline.md#exit-status)
//! and that what was written is valid. Needs ffmpeg, the networks and `../shared`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic
#![cfg(unix)]

mod common;

use common::{monohand, networks_ready, p};
use monohand_io::jsonl::{read_jsonl, FrameRecord};
use monohand_testkit::{decodable_frames, hand_png, photo_clip};
use monohand_vision::models::{sha256_hex, ModelFile};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Exit statuses, as documented (docs/pipeline.md#exit-status).
const INPUT_ENDED_EARLY: i32 = 3;
const OUTPUT_FAILED: i32 = 4;
const INTERRUPTED: i32 = 130;

/// `n` frames (600x450, 30 fps, MPEG-4 in Matroska) of the shared photo seen by a camera
/// that pans in a circle, made by ffmpeg.
fn moving_video(n: usize, out: &Path) {
    let circle = "crop=600:450:'20+15*sin(2*PI*t)':'15+10*cos(2*PI*t)'";
    photo_clip(out, n, Some(circle), &["-q:v", "2"]);
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args(args)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap()
}

/// Waits until `path` holds at least `n` lines.
fn wait_for_lines(path: &Path, n: usize) {
    let t = Instant::now();
    while std::fs::read_to_string(path).map_or(0, |s| s.lines().count()) < n {
        assert!(t.elapsed().as_secs() < 120, "no output after 2 minutes");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The records, which must be frames 0, 1, 2, ... in order.
fn consecutive_frames(path: &Path) -> Vec<FrameRecord> {
    let frames = read_jsonl(path).unwrap();
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f.frame, i as u64);
    }
    frames
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A complete binary glTF: the magic and a total length equal to the file's.
fn assert_valid_glb(path: &Path) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..4], b"glTF");
    let len = u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize;
    assert_eq!(len, b.len(), "the glTF header's length is the file's");
}

#[test]
fn ffmpeg_killed_mid_video_keeps_the_frames_before_and_exits_3() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("long.mkv");
    moving_video(90, &video);
    let out = dir.path().join("hands.jsonl");
    let overlay = dir.path().join("overlay.mp4");
    let child = spawn(&["run", p(&video), "-o", p(&out), "--overlay", p(&overlay)]);
    wait_for_lines(&out, 3);
    // The decoder is the ffmpeg child whose command line maps the input's video stream.
    let decoder = children_of(child.id())
        .into_iter()
        .find(|(_, cmd)| cmd.contains("-map") && cmd.contains(p(&video)))
        .expect("the decoding ffmpeg is running");
    let killed = Command::new("kill")
        .args(["-KILL", &decoder.0.to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let run = child.wait_with_output().unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(INPUT_ENDED_EARLY), "{err}");
    assert!(err.contains("ffmpeg failed (signal: 9"), "{err}");
    let frames = consecutive_frames(&out);
    eprintln!("ffmpeg killed: {} of 90 frames written", frames.len());
    assert!(frames.len() >= 3 && frames.len() < 90, "{}", frames.len());
    assert!(frames.iter().all(|f| f.hands.len() == 1));
    assert_eq!(
        decodable_frames(&overlay),
        frames.len(),
        "the overlay video was finalised"
    );
}

/// The processes whose parent is `pid`, with their command lines.
fn children_of(pid: u32) -> Vec<(u32, String)> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(child) = entry
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<u32>().ok())
        else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        // pid (comm) state ppid ...: the command may hold spaces, so split after ')'.
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|s| s.parse::<u32>().ok());
        if ppid == Some(pid) {
            let cmd = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
            found.push((child, String::from_utf8_lossy(&cmd).replace('\0', " ")));
        }
    }
    found
}

#[test]
fn a_full_disk_leaves_whole_records_and_exits_4() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("clip.mkv");
    moving_video(30, &video);
    let out = dir.path().join("hands.jsonl");
    // A file-size limit of 16 KiB on the run (RLIMIT_FSIZE, in 512-byte blocks for sh):
    // writes past it fail with EFBIG, as writes to a full disk fail with ENOSPC. SIGXFSZ
    // is ignored so the write fails instead of killing the process.
    let limit = 16 * 1024;
    let run = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {}; exec \"$0\" run \"$1\" -o \"$2\"",
            limit / 512
        ))
        .arg(env!("CARGO_BIN_EXE_monohand"))
        .arg(&video)
        .arg(&out)
        .output()
        .unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(OUTPUT_FAILED), "{err}");
    assert!(err.contains("File too large"), "{err}");
    assert!(err.contains("cut back to its last whole record"), "{err}");
    assert!(
        err.contains("an output could not be written after"),
        "{err}"
    );
    let size = std::fs::metadata(&out).unwrap().len();
    assert!(size <= limit, "{size} bytes");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.ends_with('\n'), "the file ends with a whole line");
    let frames = consecutive_frames(&out);
    eprintln!("disk full: {} whole frames in {size} bytes", frames.len());
    assert!(!frames.is_empty() && frames.len() < 30, "{}", frames.len());
    assert!(frames.iter().all(|f| f.hands.len() == 1));
}

#[test]
fn an_overlay_folder_that_cannot_be_written_exits_4_and_keeps_the_rest() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("clip.mkv");
    moving_video(90, &video);
    let out = dir.path().join("hands.jsonl");
    let glb = dir.path().join("hands.glb");
    let overlay = dir.path().join("overlay");
    let child = spawn(&[
        "run",
        p(&video),
        "-o",
        p(&out),
        "--overlay",
        p(&overlay),
        "--gltf",
        p(&glb),
    ]);
    wait_for_lines(&out, 3);
    // The folder goes away and a file takes its name: no frame can be written into it
    // (for every user, root included, unlike a read-only folder).
    std::fs::rename(&overlay, dir.path().join("moved")).unwrap();
    std::fs::write(&overlay, b"not a folder").unwrap();
    let run = child.wait_with_output().unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(OUTPUT_FAILED), "{err}");
    assert!(err.contains("cannot write"), "{err}");
    assert!(
        err.contains("an output could not be written after"),
        "{err}"
    );
    let frames = consecutive_frames(&out);
    assert!(frames.len() >= 3 && frames.len() < 90, "{}", frames.len());
    // The glTF was still written, complete.
    assert_valid_glb(&glb);
    assert!(!dir.path().join("hands.glb.tmp").exists());
    // Every frame drawn before is a whole PNG. The one being written when the folder moved
    // stays under its temporary name in the moved folder (its rename into the gone folder
    // failed), never as a damaged frame_*.png.
    let mut temporary = 0;
    for e in std::fs::read_dir(dir.path().join("moved")).unwrap() {
        let path = e.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with(".tmp-frame_") {
            temporary += 1;
            continue;
        }
        assert!(
            name.starts_with("frame_") && name.ends_with(".png"),
            "{name}"
        );
        monohand_vision::image_io::load_rgb(&path).unwrap();
    }
    assert!(temporary <= 1, "{temporary} temporary files");

    // Unwritable from the start (its parent is a file): refused before anything exists.
    let never = dir.path().join("never.jsonl");
    let r = monohand(&[
        "run",
        p(&video),
        "-o",
        p(&never),
        "--overlay",
        p(&overlay.join("sub")),
    ]);
    assert_eq!(r.status.code(), Some(1), "{}", stderr(&r));
    assert!(
        stderr(&r).contains("cannot create the folder"),
        "{}",
        stderr(&r)
    );
    assert!(!never.exists());
}

#[test]
fn sigterm_closes_every_file_like_ctrl_c_and_exits_130() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("long.mkv");
    moving_video(90, &video);
    let out = dir.path().join("hands.jsonl");
    let overlay = dir.path().join("overlay.mp4");
    let glb = dir.path().join("hands.glb");
    let child = spawn(&[
        "run",
        p(&video),
        "-o",
        p(&out),
        "--overlay",
        p(&overlay),
        "--gltf",
        p(&glb),
    ]);
    wait_for_lines(&out, 3);
    let sent = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let run = child.wait_with_output().unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(INTERRUPTED), "{err}");
    assert!(err.contains("(interrupted)"), "{err}");
    let frames = consecutive_frames(&out);
    assert!(frames.len() >= 3 && frames.len() < 90, "{}", frames.len());
    assert_eq!(decodable_frames(&overlay), frames.len());
    assert_valid_glb(&glb);
}

#[test]
fn a_pipe_that_stops_delivering_ends_the_run_with_status_3() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("clip.mkv");
    moving_video(20, &clip);
    let bytes = std::fs::read(&clip).unwrap();
    let fifo = dir.path().join("camera.fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // The far end of the pipe, like a camera server: it serves each opener (ffprobe, then
    // ffmpeg) the stream from the start; the second time it keeps the pipe open and
    // sends nothing more.
    let (stop_tx, stop_rx) = std::sync::mpsc::channel::<()>();
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
            // ffprobe may stop reading early: a broken pipe is fine.
            let _ = f.write_all(&bytes);
            drop(f);
            // ffprobe may still hold the pipe when it is opened again: the stream (larger
            // than a pipe's buffer) then breaks on it, and is served to the next opener.
            loop {
                let mut f = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
                if f.write_all(&bytes).and_then(|()| f.flush()).is_ok() {
                    let _ = stop_rx.recv_timeout(Duration::from_secs(120));
                    return;
                }
            }
        })
    };
    let out = dir.path().join("hands.jsonl");
    let run = Command::new(env!("CARGO_BIN_EXE_monohand"))
        // 10 s: far longer than any wait for a frame while the stream flows, even on a
        // loaded machine, so only the real stall ends the run.
        .args(["run", p(&fifo), "-o", p(&out), "--stall-timeout", "10"])
        .output()
        .unwrap();
    let _ = stop_tx.send(());
    writer.join().unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(INPUT_ENDED_EARLY), "{err}");
    assert!(
        err.contains("no frame for 10.0 s: the source stopped delivering"),
        "{err}"
    );
    let frames = consecutive_frames(&out);
    // The frames ffmpeg decoded before the stall were processed; the last few sent can
    // still sit in its frame-threaded decoder when the source stops (16 or 17 of 20 on 2 cores).
    eprintln!("stalled pipe: {} of 20 frames", frames.len());
    assert!(
        frames.len() >= 10 && frames.len() <= 20,
        "{} frames",
        frames.len()
    );
    assert!(frames.iter().all(|f| f.hands.len() == 1));
}

/// A mediapipe wheel holding the cached networks at their wheel paths and a license (what
/// `monohand models fetch` extracts from; `MONOHAND_MEDIAPIPE_WHEEL` points at it), built
/// with Python's zipfile.
fn wheel_from_the_cache(dir: &Path) -> PathBuf {
    let cache = dirs_cache();
    let wheel = dir.join("mediapipe-0.10.14-test.whl");
    let mut script = String::from("import sys, zipfile\nz = zipfile.ZipFile(sys.argv[1], 'w')\n");
    for m in ModelFile::ALL {
        script.push_str(&format!(
            "z.write({:?}, {:?})\n",
            cache.join(m.file_name()).display().to_string(),
            m.wheel_path()
        ));
    }
    script.push_str(
        "z.writestr('mediapipe-0.10.14.dist-info/LICENSE', 'Apache License 2.0')\nz.close()\n",
    );
    let status = Command::new("python3")
        .args(["-c", &script])
        .arg(&wheel)
        .status()
        .expect("python3");
    assert!(status.success());
    wheel
}

/// The networks' cache that `networks_ready` filled.
fn dirs_cache() -> PathBuf {
    monohand_vision::models::ModelStore::new(None)
        .unwrap()
        .dir()
        .to_path_buf()
}

#[test]
fn concurrent_fetches_share_a_cache_and_a_damaged_network_is_fetched_again() {
    assert!(networks_ready());
    let dir = tempfile::tempdir().unwrap();
    let wheel = wheel_from_the_cache(dir.path());
    let cache = dir.path().join("cache");
    let fetch = || {
        Command::new(env!("CARGO_BIN_EXE_monohand"))
            .args(["models", "fetch"])
            .env("MONOHAND_MODEL_DIR", &cache)
            .env("MONOHAND_MEDIAPIPE_WHEEL", &wheel)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    // Four processes fill the same empty cache at once.
    let runs: Vec<Child> = (0..4).map(|_| fetch()).collect();
    for r in runs {
        let out = r.wait_with_output().unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let mut names: Vec<String> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "LICENSE.mediapipe.txt",
            "face_detection_short_range.tflite",
            "hand_landmark_full.tflite",
            "hand_landmark_lite.tflite",
            "palm_detection_full.tflite",
            "palm_detection_lite.tflite"
        ],
        "every file in place and no temporary file left"
    );
    for m in ModelFile::ALL {
        let bytes = std::fs::read(cache.join(m.file_name())).unwrap();
        assert_eq!(sha256_hex(&bytes), m.sha256(), "{}", m.file_name());
    }

    // A cached network damaged on disk: the run fetches it again once, says so, and works.
    let landmark = cache.join(ModelFile::HandLandmarkFull.file_name());
    let mut bytes = std::fs::read(&landmark).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&landmark, &bytes).unwrap();
    let out = dir.path().join("hands.jsonl");
    let run = Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args(["run", p(&hand_png()), "-o", p(&out)])
        .env("MONOHAND_MODEL_DIR", &cache)
        .env("MONOHAND_MEDIAPIPE_WHEEL", &wheel)
        .output()
        .unwrap();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(0), "{err}");
    assert!(err.contains("checksum mismatch"), "{err}");
    assert_eq!(
        err.matches("fetching the networks again").count(),
        1,
        "{err}"
    );
    assert_eq!(
        sha256_hex(&std::fs::read(&landmark).unwrap()),
        ModelFile::HandLandmarkFull.sha256()
    );
    assert_eq!(read_jsonl(&out).unwrap()[0].hands.len(), 1);
}
