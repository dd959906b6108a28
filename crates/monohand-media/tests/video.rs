//! Round trips through the real `ffmpeg` tools with a picture from the shared data.
//! Every test fails, saying why, where ffmpeg or the shared data is missing.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand_io::IoError;
use monohand_media::video::{
    probe, yuv420_to_rgb, Encoder, FfmpegTools, RgbImage, VideoInput, VideoReader, VideoWriter,
    Yuv420, YuvMatrix,
};
use monohand_testkit::{ffmpeg, hand_png, photo_clip};
use std::path::Path;

const FRAMES: usize = 20;
const W: usize = 320;
const H: usize = 240;

/// The tools; fails the test if ffmpeg is not installed.
fn tools() -> Option<FfmpegTools> {
    let t = FfmpegTools::default();
    assert!(
        t.available(),
        "ffmpeg is not installed (apt-get install ffmpeg)"
    );
    Some(t)
}

/// The picture, decoded by ffmpeg as a one-frame video; `None` (and a message)
/// without the shared data.
fn picture() -> Option<RgbImage> {
    let mut r = VideoReader::open(&VideoInput::File(hand_png())).unwrap();
    assert_eq!((r.info().width, r.info().height), (640, 480));
    let f = r.next_frame().unwrap().unwrap();
    assert!(r.next_frame().unwrap().is_none());
    Some(f.image)
}

/// Frame `i` of a pan across the picture: a `W x H` window moving right and down.
fn pan_frame(pic: &RgbImage, i: usize) -> RgbImage {
    let (x0, y0) = (8 * i, 4 * i);
    let mut f = RgbImage::new(W as u32, H as u32);
    for y in 0..H {
        let src = 3 * ((y0 + y) * pic.width() as usize + x0);
        let row = &pic.as_raw()[src..src + 3 * W];
        (*f)[3 * y * W..3 * (y + 1) * W].copy_from_slice(row);
    }
    f
}

fn mean_abs_diff(a: &RgbImage, b: &RgbImage) -> f64 {
    assert_eq!(a.len(), b.len());
    let s: u64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(&x, &y)| x.abs_diff(y) as u64)
        .sum();
    s as f64 / a.len() as f64
}

fn write_pan(tools: &FfmpegTools, encoder: Encoder, path: &Path, pic: &RgbImage) {
    let mut w = VideoWriter::create_with(tools, encoder, path, W, H, 10.0).unwrap();
    for i in 0..FRAMES {
        w.write(&pan_frame(pic, i)).unwrap();
    }
    assert_eq!(w.frames_written(), FRAMES as u64);
    w.finish().unwrap();
}

#[test]
fn pan_round_trip_with_each_encoder() {
    let Some(tools) = tools() else { return };
    let Some(pic) = picture() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut encoders = vec![Encoder::Mpeg4];
    if tools.has_encoder("libx264") {
        encoders.push(Encoder::Libx264);
    } else {
        eprintln!("libx264 missing: only the mpeg4 fallback is tested");
    }
    for enc in encoders {
        let path = dir.path().join(format!("pan_{enc:?}.mp4"));
        write_pan(&tools, enc, &path, &pic);
        let info = probe(&VideoInput::File(path.clone())).unwrap();
        assert_eq!((info.width, info.height), (W, H), "{enc:?}");
        assert!((info.fps.unwrap() - 10.0).abs() < 1e-9, "{info:?}");
        assert_eq!(info.frame_count, Some(FRAMES as u64));
        let mut reader = VideoReader::open(&VideoInput::File(path.clone())).unwrap();
        let mut buf = RgbImage::new(0, 0);
        let mut n = 0;
        while let Some((index, t)) = reader.read_into(&mut buf).unwrap() {
            assert_eq!(index, n as u64);
            assert!((t - n as f64 / 10.0).abs() < 1e-9);
            let d = mean_abs_diff(&buf, &pan_frame(&pic, n));
            assert!(d < 6.0, "{enc:?} frame {n}: mean abs diff {d}");
            // The right frame, not just a similar one: the neighbour differs more.
            if n + 3 < FRAMES {
                let other = mean_abs_diff(&buf, &pan_frame(&pic, n + 3));
                assert!(
                    other > d + 2.0,
                    "{enc:?} frame {n}: {d} vs neighbour {other}"
                );
            }
            n += 1;
        }
        assert_eq!(n, FRAMES, "{enc:?}");
        // After the end it stays ended.
        assert!(reader.read_into(&mut buf).unwrap().is_none());
        // Stopping early (dropping mid-video) ends ffmpeg without hanging.
        let mut early = VideoReader::open(&VideoInput::File(path.clone())).unwrap();
        assert_eq!(early.next_frame().unwrap().unwrap().index, 0);
        drop(early);
    }
}

#[test]
fn truncated_video_gives_good_frames_then_an_error() {
    let Some(tools) = tools() else { return };
    let Some(pic) = picture() else { return };
    let dir = tempfile::tempdir().unwrap();
    // MP4 (index at the end: nothing is decodable) and MKV (streamable: a prefix is).
    for ext in ["mp4", "mkv"] {
        let path = dir.path().join(format!("full.{ext}"));
        write_pan(&tools, Encoder::Mpeg4, &path, &pic);
        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.path().join(format!("cut.{ext}"));
        std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();
        let name = cut.display().to_string();
        let mut good = 0;
        let err = match VideoReader::open(&VideoInput::File(cut.clone())) {
            Err(e) => e,
            Ok(reader) => {
                let mut err = None;
                for f in reader {
                    match f {
                        Ok(f) => {
                            assert_eq!(f.index, good);
                            assert!(mean_abs_diff(&f.image, &pan_frame(&pic, good as usize)) < 6.0);
                            good += 1;
                        }
                        Err(e) => {
                            err = Some(e);
                            break;
                        }
                    }
                }
                err.expect("a truncated video must end with an error")
            }
        };
        let msg = err.to_string();
        assert!(matches!(err, IoError::Video { .. }), "{msg}");
        assert!(msg.contains(&name), "{msg}");
        assert!(good < FRAMES as u64, "{ext}: {good} frames from a cut file");
        eprintln!("{ext}: {good} good frames, then: {msg}");
        if ext == "mkv" {
            assert!(good > 0, "the streamable prefix should decode");
            assert!(
                msg.contains(&format!("after {good} good frame(s)")),
                "{msg}"
            );
        }
    }
}

#[test]
fn not_a_video_and_missing_files_are_clear_errors() {
    let Some(_tools) = tools() else { return };
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("notes.mp4");
    std::fs::write(&txt, "this is not a video\n").unwrap();
    let e = VideoReader::open(&VideoInput::File(txt.clone())).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("notes.mp4") && msg.contains("Invalid data"),
        "{msg}"
    );
    // A text file that ffmpeg itself would read as a video of its characters (tty demuxer).
    let notes = dir.path().join("notes.txt");
    std::fs::write(&notes, "one line of notes\n".repeat(200)).unwrap();
    let msg = VideoReader::open(&VideoInput::File(notes))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("notes.txt") && msg.contains("a text file"),
        "{msg}"
    );
    let empty = dir.path().join("empty.mkv");
    std::fs::write(&empty, b"").unwrap();
    let msg = VideoReader::open(&VideoInput::File(empty))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("empty.mkv"), "{msg}");
    let missing = dir.path().join("missing.mp4");
    let msg = probe(&VideoInput::File(missing)).unwrap_err().to_string();
    assert!(
        msg.contains("missing.mp4") && msg.contains("no such file"),
        "{msg}"
    );
}

#[test]
fn writer_reports_ffmpeg_errors_and_size_mismatches() {
    let Some(tools) = tools() else { return };
    let dir = tempfile::tempdir().unwrap();
    // A directory that does not exist: ffmpeg fails; the error says so.
    let bad = dir.path().join("no/such/dir/out.mp4");
    let mut w = VideoWriter::create_with(&tools, Encoder::Mpeg4, &bad, 64, 48, 25.0).unwrap();
    let frame = RgbImage::new(64, 48);
    let mut result = Ok(());
    for _ in 0..50 {
        result = w.write(&frame);
        if result.is_err() {
            break;
        }
    }
    let e = match result {
        Err(e) => e,
        Ok(()) => w.finish().unwrap_err(),
    };
    assert!(e.to_string().contains("out.mp4"), "{e}");
    let ok = dir.path().join("ok.mkv");
    let mut w = VideoWriter::create_with(&tools, Encoder::Mpeg4, &ok, 64, 48, 25.0).unwrap();
    let e = w.write(&RgbImage::new(32, 48)).unwrap_err().to_string();
    assert!(e.contains("32x48") && e.contains("64x48"), "{e}");
    assert!(VideoWriter::create_with(&tools, Encoder::Mpeg4, &ok, 0, 48, 25.0).is_err());
    assert!(VideoWriter::create_with(&tools, Encoder::Mpeg4, &ok, 8, 8, f64::NAN).is_err());
}

#[test]
fn dropped_writer_leaves_a_playable_file_and_odd_sizes_work() {
    let Some(tools) = tools() else { return };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dropped.mp4");
    {
        let mut w = VideoWriter::create_with(&tools, Encoder::Mpeg4, &path, 33, 17, 5.0).unwrap();
        let mut f = RgbImage::new(33, 17);
        for i in 0..7u8 {
            f.fill(30 * i);
            w.write(&f).unwrap();
        }
        // Dropped without finish(), as on an early return.
    }
    let r = VideoReader::open(&VideoInput::File(path)).unwrap();
    // Padded to even size for yuv420p.
    assert_eq!((r.info().width, r.info().height), (34, 18));
    let frames: Vec<_> = r.collect::<Result<_, _>>().unwrap();
    assert_eq!(frames.len(), 7);
    let mid = frames[6].image.get_pixel(10, 8).0;
    assert!(mid.iter().all(|&c| c.abs_diff(180) < 8), "{mid:?}");
}

/// Every frame of a video, with its time.
fn read_all(path: &Path) -> Vec<(f64, RgbImage)> {
    let mut r = VideoReader::open(&VideoInput::File(path.to_path_buf())).unwrap();
    let mut out = Vec::new();
    while let Some(f) = r.next_frame().unwrap() {
        assert_eq!(f.index, out.len() as u64);
        out.push((f.timestamp_s, f.image));
    }
    out
}

/// Variable frame rate: five frames at 30 fps, a pause of 0.37 s, three more. Every frame
/// comes out once (ffmpeg's default for raw output would duplicate frames to fill the
/// pause, 18 in all), with the stream's own times.
#[test]
fn variable_frame_rate_keeps_the_stream_clock() {
    tools();
    let _ = picture();
    let dir = tempfile::tempdir().unwrap();
    let vfr = dir.path().join("vfr.mkv");
    // The option's name in this ffmpeg (`-vsync` is gone from FFmpeg 7.0).
    let sync = FfmpegTools::default().features().fps_mode_option();
    let pause = "scale=64:48,setpts='if(lt(N,5),N/30,(N+10)/30)/TB'";
    photo_clip(&vfr, 8, Some(pause), &[sync, "vfr"]);
    let frames = read_all(&vfr);
    let times: Vec<f64> = frames.iter().map(|f| f.0).collect();
    let want = [0.0, 0.033, 0.067, 0.1, 0.133, 0.5, 0.533, 0.567];
    assert_eq!(times.len(), want.len(), "{times:?}");
    for (t, w) in times.iter().zip(want) {
        assert!((t - w).abs() < 1.5e-3, "{times:?}");
    }
}

/// A phone video: stored landscape (64x48) with rotation metadata of 90 degrees. It is
/// probed and decoded upright (48x64), turned a quarter turn as a phone shows it.
#[test]
fn a_rotated_phone_video_is_decoded_upright() {
    tools();
    let _ = picture();
    let dir = tempfile::tempdir().unwrap();
    let land = dir.path().join("land.mp4");
    let phone = dir.path().join("phone.mp4");
    ffmpeg(&[
        "-i",
        hand_png().to_str().unwrap(),
        "-vf",
        "scale=64:48",
        "-frames:v",
        "1",
        "-c:v",
        "mpeg4",
        "-q:v",
        "1",
        land.to_str().unwrap(),
    ]);
    ffmpeg(&[
        "-i",
        land.to_str().unwrap(),
        "-c",
        "copy",
        "-metadata:s:v:0",
        "rotate=90",
        phone.to_str().unwrap(),
    ]);
    let info = probe(&VideoInput::File(phone.clone())).unwrap();
    assert_eq!((info.width, info.height), (48, 64));
    assert_eq!(info.rotation_deg.abs(), 90, "{info:?}");
    let upright = read_all(&phone).remove(0).1;
    assert_eq!(upright.dimensions(), (48, 64));
    let stored = read_all(&land).remove(0).1;
    let cw = image::imageops::rotate90(&stored);
    let ccw = image::imageops::rotate270(&stored);
    let (d_cw, d_ccw) = (mean_abs_diff(&upright, &cw), mean_abs_diff(&upright, &ccw));
    // Exactly the stored frame turned by a quarter turn (no re-encoding in between). Which
    // way is ffmpeg's reading of the metadata (5.1 turns this file counter-clockwise).
    let (near, far) = (d_cw.min(d_ccw), d_cw.max(d_ccw));
    assert!(
        near < 1.0 && far > 10.0,
        "clockwise {d_cw} vs counter-clockwise {d_ccw}"
    );
}

/// 10-bit, 4:4:4 and odd-sized sources decode to the same 8-bit RGB picture.
#[test]
fn ten_bit_yuv444_and_odd_sizes_decode() {
    tools();
    let _ = picture();
    let dir = tempfile::tempdir().unwrap();
    for (name, size, pix_fmt) in [
        ("p10.mkv", "64:48", "yuv420p10le"),
        ("odd420.mkv", "63:47", "yuv420p10le"),
        ("p444.mkv", "64:48", "yuv444p"),
        ("odd.mkv", "63:47", "yuv444p"),
        ("odd10.mkv", "63:47", "yuv444p10le"),
    ] {
        let path = dir.path().join(name);
        let reference = dir.path().join(format!("{name}.png"));
        let vf = format!("scale={size}");
        ffmpeg(&[
            "-i",
            hand_png().to_str().unwrap(),
            "-vf",
            &vf,
            "-frames:v",
            "1",
            reference.to_str().unwrap(),
        ]);
        ffmpeg(&[
            "-i",
            reference.to_str().unwrap(),
            "-c:v",
            "ffv1",
            "-pix_fmt",
            pix_fmt,
            path.to_str().unwrap(),
        ]);
        let frames = read_all(&path);
        assert_eq!(frames.len(), 1, "{name}");
        let want = read_all(&reference).remove(0).1;
        assert_eq!(frames[0].1.dimensions(), want.dimensions(), "{name}");
        let d = mean_abs_diff(&frames[0].1, &want);
        // 4:2:0 halves the colour resolution of the 64x48 picture: about 2 levels.
        assert!(d < 3.0, "{name}: mean abs diff {d}");
    }
}

/// 8-bit 4:2:0 video, the commonest kind, reaches the reader as ffmpeg decodes it and is
/// converted to RGB by `yuv420_to_rgb` with the stream's matrix and range: the frames are
/// exactly that conversion of ffmpeg's own planes, and within a few levels of the RGB
/// ffmpeg makes itself (which truncates where this rounds).
#[test]
fn yuv420_streams_are_converted_with_their_matrix_and_range() {
    tools();
    let _ = picture();
    let dir = tempfile::tempdir().unwrap();
    let png = hand_png();
    let png = png.to_str().unwrap();
    for (name, size, vf_extra, tags, want) in [
        (
            "untagged.mp4",
            "320:240",
            "",
            &[][..],
            (YuvMatrix::Bt601, false),
        ),
        (
            "bt709.mp4",
            "320:240",
            ":out_color_matrix=bt709",
            &["-colorspace", "bt709"][..],
            (YuvMatrix::Bt709, false),
        ),
        (
            "full.mp4",
            "320:240",
            ":out_range=full",
            &[][..],
            (YuvMatrix::Bt601, true),
        ),
    ] {
        let path = dir.path().join(name);
        let p = path.to_str().unwrap();
        let format = if want.1 { "yuvj420p" } else { "yuv420p" };
        let vf = format!("scale={size}{vf_extra},format={format}");
        let codec = if name.ends_with(".mkv") {
            "ffv1"
        } else {
            "libx264"
        };
        let mut args = vec!["-i", png, "-vf", &vf, "-frames:v", "1", "-c:v", codec];
        args.extend_from_slice(tags);
        args.push(p);
        ffmpeg(&args);

        let info = probe(&VideoInput::File(path.clone())).unwrap();
        let layout = Yuv420::of_stream(&info).unwrap_or_else(|| panic!("{name}: {info:?}"));
        assert_eq!((layout.matrix, layout.full_range), want, "{name}");
        let ours = read_all(&path).remove(0).1;

        // ffmpeg's planes, converted here.
        let raw = dir.path().join(format!("{name}.yuv"));
        let r = raw.to_str().unwrap();
        ffmpeg(&["-i", p, "-f", "rawvideo", "-pix_fmt", format, r]);
        let planes = std::fs::read(&raw).unwrap();
        let (w, h) = (info.width, info.height);
        let mut converted = vec![0u8; w * h * 3];
        assert!(yuv420_to_rgb(&planes, (w, h), layout, &mut converted));
        assert!(
            ours.as_raw() == &converted,
            "{name}: not the reader's frame"
        );

        // ffmpeg's own RGB.
        let theirs = dir.path().join(format!("{name}.png"));
        let t = theirs.to_str().unwrap();
        ffmpeg(&["-i", p, "-pix_fmt", "rgb24", t]);
        let theirs = read_all(&theirs).remove(0).1;
        let worst = ours
            .as_raw()
            .iter()
            .zip(theirs.as_raw())
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        let mean = mean_abs_diff(&ours, &theirs);
        // Measured with ffmpeg 5.1: worst 3, mean about 1 (its truncation). The wrong
        // matrix is 11-13 levels off at worst.
        assert!(
            worst <= 4 && mean < 1.5,
            "{name}: worst {worst}, mean {mean}"
        );
    }
}
