//! `run --each DIR --output-dir OUT`: every video and image of a folder into a records file
//! of its own, complete or absent; a rerun after a kill redoes only the unfinished inputs and
//! gives what one uninterrupted run gives. Needs ffmpeg, the networks and `../shared`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod common;
use common::*;
use monohand_io::jsonl::{read_jsonl, FrameRecord};
use monohand_testkit::{hand_png, photo_clip, run_ok};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// `n` frames of the shared photo seen by a camera panning by `dx` pixels a frame.
fn clip(out: &Path, n: usize, dx: usize) {
    let crop = format!("crop=560:420:'10+{dx}*n':20");
    photo_clip(out, n, Some(&crop), &["-q:v", "2"]);
}

fn records(path: &Path) -> Vec<FrameRecord> {
    read_jsonl(path)
        .unwrap()
        .into_iter()
        .map(|mut r| {
            r.timings_ms = None;
            r
        })
        .collect()
}

/// Killed part-way (SIGKILL, by its own process id) and rerun: the same outputs, and no
/// partial file left.
fn killed_and_rerun(job: &[&str], outputs: &[PathBuf], want: &[Vec<FrameRecord>], out: &Path) {
    for o in outputs {
        std::fs::remove_file(o).unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_monohand"))
        .args(job)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !outputs[0].exists() && t.elapsed() < Duration::from_secs(300) {
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let rerun = monohand(job);
    assert_eq!(rerun.status.code(), Some(3));
    for (o, w) in outputs.iter().zip(want) {
        assert_eq!(&records(o), w, "{}", o.display());
    }
    let partials: Vec<_> = std::fs::read_dir(out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(partials.is_empty(), "{partials:?}");
}

#[test]
fn each_input_is_complete_or_absent_and_a_rerun_redoes_only_what_is_missing() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("clips");
    std::fs::create_dir(&dir).unwrap();
    for (k, name) in ["a.mkv", "b.mkv", "c.mkv"].iter().enumerate() {
        clip(&dir.join(name), 8, k + 1);
    }
    std::fs::copy(hand_png(), dir.join("photo.png")).unwrap();
    std::fs::write(
        dir.join("damaged.mp4"),
        b"\x00\x00\x00\x18ftypmp42 not a video",
    )
    .unwrap();
    std::fs::write(dir.join("notes.txt"), b"not an input").unwrap();
    let out = tmp.path().join("out");
    let job = [
        "run",
        "--each",
        p(&dir),
        "--output-dir",
        p(&out),
        "--hands",
        "1",
    ];
    let each = |extra: &[&str]| {
        let mut args = job.to_vec();
        args.extend_from_slice(extra);
        monohand(&args)
    };
    let first = each(&[]);
    let said = String::from_utf8_lossy(&first.stderr).to_string();
    // A failed input is said and sets status 3; the others are done.
    assert_eq!(first.status.code(), Some(3), "{said}");
    assert!(said.contains("damaged.mp4: failed"), "{said}");
    assert!(
        said.contains("5 inputs: 4 done, 0 already done, 1 failed"),
        "{said}"
    );
    let outputs = ["a.mkv", "b.mkv", "c.mkv", "photo.png"].map(|n| out.join(format!("{n}.jsonl")));
    for o in &outputs {
        assert!(o.is_file(), "{} missing", o.display());
    }
    assert!(!out.join("damaged.mp4.jsonl").exists());
    assert!(!out.join("notes.txt.jsonl").exists());
    // Each output is what a single run of its input gives.
    let single = tmp.path().join("single.jsonl");
    ok(&monohand(&[
        "run",
        p(&dir.join("b.mkv")),
        "-o",
        p(&single),
        "--hands",
        "1",
    ]));
    assert_eq!(records(&outputs[1]), records(&single));
    assert_eq!(records(&outputs[1]).len(), 8);
    assert!(records(&outputs[3])[0]
        .hands
        .iter()
        .any(|h| h.joints_3d_mm.is_some()));
    // --offline smooths the videos; the photo, alone, is fitted as it is.
    let offline = tmp.path().join("offline");
    let mut args = job.to_vec();
    args[4] = p(&offline);
    args.push("--offline");
    assert_eq!(monohand(&args).status.code(), Some(3));
    assert_eq!(
        records(&offline.join("photo.png.jsonl")),
        records(&outputs[3])
    );
    assert_ne!(records(&offline.join("a.mkv.jsonl")), records(&outputs[0]));

    // A rerun skips what is done; a missing output and a stale partial file are redone.
    let want: Vec<_> = outputs.iter().map(|o| records(o)).collect();
    std::fs::remove_file(&outputs[0]).unwrap();
    std::fs::write(out.join("c.mkv.jsonl.partial"), b"{\"frame\": 0}\n").unwrap();
    std::fs::remove_file(&outputs[2]).unwrap();
    let again = each(&[]);
    let said = String::from_utf8_lossy(&again.stderr).to_string();
    assert!(
        said.contains("5 inputs: 2 done, 2 already done, 1 failed"),
        "{said}"
    );
    assert!(said.contains("b.mkv: already done"), "{said}");
    for (o, w) in outputs.iter().zip(&want) {
        assert_eq!(&records(o), w, "{}", o.display());
    }
    assert!(!out.join("c.mkv.jsonl.partial").exists());

    killed_and_rerun(&job, &outputs, &want, &out);
}

#[test]
fn each_needs_a_folder_of_inputs_and_an_output_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let out = monohand(&["run", "--each", p(tmp.path())]);
    assert!(!out.status.success());
    let out = monohand(&[
        "run",
        "--each",
        p(tmp.path()),
        "--output-dir",
        p(&tmp.path().join("o")),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no videos"), "{err}");
}

/// A small filesystem of its own (tmpfs, `size` bytes) mounted at `dir`, unmounted when
/// dropped: a disk that really fills up. Mounting needs root, as CI has; without it the test
/// fails and says so.
struct SmallDisk(std::path::PathBuf);

impl SmallDisk {
    fn mount(dir: &Path, size: u64) -> Self {
        std::fs::create_dir_all(dir).unwrap();
        run_ok(
            Command::new("mount")
                .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
                .arg(dir),
            &format!(
                "could not mount a {size}-byte tmpfs at {} (the full-disk test needs root, as CI has)",
                dir.display()
            ),
        );
        SmallDisk(dir.to_path_buf())
    }

    /// Gives the disk `size` bytes, keeping its files.
    fn resize(&self, size: u64) {
        run_ok(
            Command::new("mount")
                .args(["-o", &format!("remount,size={size}")])
                .arg(&self.0),
            &format!("could not resize the tmpfs at {}", self.0.display()),
        );
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_stops_the_job_with_status_4_and_keeps_the_finished_outputs() {
    const PAGE: u64 = 4096;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("clips");
    std::fs::create_dir(&dir).unwrap();
    let names = ["a.mkv", "b.mkv", "c.mkv"];
    for (k, name) in names.iter().enumerate() {
        clip(&dir.join(name), 8, k + 1);
    }
    let job = |out: &Path| {
        monohand(&[
            "run",
            "--each",
            p(&dir),
            "--output-dir",
            p(out),
            "--hands",
            "1",
        ])
    };
    let roomy = tmp.path().join("roomy");
    ok(&job(&roomy));
    let size = |n: &str| {
        std::fs::metadata(roomy.join(format!("{n}.jsonl")))
            .unwrap()
            .len()
    };
    // Room for a.mkv's records (and 1 KiB for their timings differing), a page more, and
    // not for b.mkv's as well: the disk fills up during b.mkv.
    let room = (size("a.mkv") + 1024).div_ceil(PAGE) * PAGE + PAGE;
    assert!(size("b.mkv") > 2 * PAGE + 1024, "{} bytes", size("b.mkv"));
    let out = tmp.path().join("small");
    let disk = SmallDisk::mount(&out, room);

    let full = job(&out);
    let said = String::from_utf8_lossy(&full.stderr).to_string();
    assert_eq!(full.status.code(), Some(4), "{said}");
    assert!(said.contains("No space left on device"), "{said}");
    assert!(said.contains("a.mkv: done"), "{said}");
    assert!(said.contains("b.mkv: stopped"), "{said}");
    assert!(said.contains("the 1 complete outputs"), "{said}");
    assert_eq!(
        records(&out.join("a.mkv.jsonl")),
        records(&roomy.join("a.mkv.jsonl"))
    );
    // Nothing half-written under a final name; the partial file holds whole records.
    assert!(!out.join("b.mkv.jsonl").exists());
    assert!(!out.join("c.mkv.jsonl").exists());
    let partial = out.join("b.mkv.jsonl.partial");
    if partial.exists() {
        let text = std::fs::read_to_string(&partial).unwrap();
        assert!(text.is_empty() || text.ends_with('\n'));
        let frames = records(&partial);
        assert!(frames.len() < 8, "{}", frames.len());
    }

    // Room again: the rerun keeps a.mkv's output and does the rest.
    disk.resize(16 << 20);
    let rerun = job(&out);
    let said = String::from_utf8_lossy(&rerun.stderr).to_string();
    ok(&rerun);
    assert!(said.contains("a.mkv: already done"), "{said}");
    assert!(
        said.contains("3 inputs: 2 done, 1 already done, 0 failed"),
        "{said}"
    );
    for n in names {
        let name = format!("{n}.jsonl");
        assert_eq!(
            records(&out.join(&name)),
            records(&roomy.join(&name)),
            "{n}"
        );
    }
}
