//! The QuickTime metadata reader on movies built to Apple's layout (`tests/data/quicktime`,
//! written by `make_fixtures.rs` there), each also read by exiftool, the independent reader:
//! both must find the same focal length, lens, make and model. Then damaged and unusual
//! files: cut short, boxes that overflow, garbage keys, other formats, and a 5 GB movie
//! whose `moov` follows its `mdat`, read without reading the `mdat`. Needs ffmpeg and
//! exiftool (`apt-get install libimage-exiftool-perl`); a missing tool fails the test.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use monohand_media::video::{
    parse_quicktime_metadata, probe, read_quicktime_metadata, MetadataValue, QuickTimeError,
    VideoInput,
};
use monohand_testkit::{decodable_frames, exiftool, ffmpeg};
use serde_json::Value;
use std::io::{Cursor, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/quicktime")
}

/// What a fixture states, as `make_fixtures.rs` wrote it.
struct Fixture {
    file: &'static str,
    /// The 35 mm-equivalent focal length, mm.
    focal: Option<f64>,
    /// How it is stored (exiftool's JSON value, with `-n`).
    stored: Option<&'static str>,
    lens: Option<&'static str>,
    make: Option<&'static str>,
    model: Option<&'static str>,
    /// The frames as ffmpeg decodes them (upright).
    size: (usize, usize),
}

const LENS: &str = "iPhone 15 Pro back camera 6.765mm f/1.78";

const FIXTURES: [Fixture; 8] = [
    Fixture {
        file: "plain.mov",
        focal: None,
        stored: None,
        lens: None,
        make: None,
        model: None,
        size: (160, 120),
    },
    Fixture {
        file: "iphone_int.mov",
        focal: Some(24.0),
        stored: Some("24"),
        lens: Some(LENS),
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (160, 120),
    },
    Fixture {
        file: "faststart_float.mov",
        focal: Some(26.5),
        stored: Some("26.5"),
        lens: Some(LENS),
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (160, 120),
    },
    Fixture {
        file: "text_focal.mp4",
        focal: Some(50.0),
        stored: Some("\"50.00mm\""),
        lens: None,
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (160, 120),
    },
    Fixture {
        file: "mdat64_float64.mov",
        focal: Some(28.0),
        stored: Some("28"),
        lens: None,
        make: None,
        model: None,
        size: (160, 120),
    },
    Fixture {
        file: "rotated.mov",
        focal: Some(26.0),
        stored: Some("26"),
        lens: Some(LENS),
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (120, 160),
    },
    Fixture {
        file: "implausible.mov",
        focal: Some(3000.0),
        stored: Some("3000"),
        lens: None,
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (160, 120),
    },
    Fixture {
        file: "movie_keys_ffmpeg.mov",
        focal: None,
        stored: None,
        lens: None,
        make: Some("Apple"),
        model: Some("iPhone 15 Pro"),
        size: (160, 120),
    },
];

/// A tag of exiftool's JSON as text (`null` when absent).
fn tag(tags: &Value, name: &str) -> Option<String> {
    tags.get(name).map(Value::to_string)
}

/// Every fixture, read by monohand and by exiftool: the same focal length (exiftool's
/// `Track1:CameraFocalLength35mmEquivalent`, the first video track's key), lens model
/// (`Track1:CameraLensModel`), make and model (`Keys:Make`, `Keys:Model`). Each is also a
/// movie ffmpeg decodes (3 frames, the size listed), so the boxes written into it left it
/// whole.
#[test]
fn the_reader_and_exiftool_agree_on_every_fixture() {
    let listed: Vec<&str> = FIXTURES.iter().map(|f| f.file).collect();
    let mut on_disk: Vec<String> = std::fs::read_dir(fixtures())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".mov") || n.ends_with(".mp4"))
        .collect();
    on_disk.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(on_disk, sorted, "every fixture is checked here");
    for f in &FIXTURES {
        let path = fixtures().join(f.file);
        let ours = read_quicktime_metadata(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", f.file))
            .camera();
        let json: Value = serde_json::from_str(&exiftool(&path)).unwrap();
        let theirs = &json[0];
        assert_eq!(
            ours.focal_35mm_mm().map(Result::unwrap),
            f.focal,
            "{}",
            f.file
        );
        assert_eq!(
            tag(theirs, "Track1:CameraFocalLength35mmEquivalent").as_deref(),
            f.stored,
            "{}: exiftool",
            f.file
        );
        let text = |key: &str| tag(theirs, key).map(|t| t.trim_matches('"').to_string());
        assert_eq!(ours.lens_model.as_deref(), f.lens, "{}", f.file);
        assert_eq!(
            text("Track1:CameraLensModel").as_deref(),
            f.lens,
            "{}",
            f.file
        );
        assert_eq!(ours.make.as_deref(), f.make, "{}", f.file);
        assert_eq!(text("Keys:Make").as_deref(), f.make, "{}", f.file);
        assert_eq!(ours.model.as_deref(), f.model, "{}", f.file);
        assert_eq!(text("Keys:Model").as_deref(), f.model, "{}", f.file);
        assert_eq!(decodable_frames(&path), 3, "{}", f.file);
        let info = probe(&VideoInput::File(path.clone())).unwrap();
        assert_eq!((info.width, info.height), f.size, "{}", f.file);
    }
}

/// How each fixture stores its focal length, as the reader decodes it: iPhones' integer
/// (type 21), a float32 and a float64 (types 23, 24), and Apple's documented text form.
#[test]
fn each_value_type_is_decoded_as_stored() {
    let focal = |file: &str| {
        read_quicktime_metadata(&fixtures().join(file))
            .unwrap()
            .camera()
            .focal_35mm
            .unwrap()
    };
    assert_eq!(focal("iphone_int.mov"), MetadataValue::Integer(24));
    assert_eq!(focal("faststart_float.mov"), MetadataValue::Float(26.5));
    assert_eq!(focal("mdat64_float64.mov"), MetadataValue::Float(28.0));
    assert_eq!(
        focal("text_focal.mp4"),
        MetadataValue::Text("50.00mm".into())
    );
}

fn bytes(file: &str) -> Vec<u8> {
    std::fs::read(fixtures().join(file)).unwrap()
}

fn parse(b: &[u8]) -> Result<monohand_media::video::QuickTimeMetadata, QuickTimeError> {
    parse_quicktime_metadata(Cursor::new(b))
}

/// Where the box type `kind` first occurs in `b`.
fn at(b: &[u8], kind: &[u8; 4]) -> usize {
    b.windows(4).position(|w| w == kind).unwrap() - 4
}

/// A movie cut short: with `moov` last (a recording stopped before its end, or a partial
/// download), an error that says so; with `moov` first, the camera is still read.
#[test]
fn a_movie_cut_short() {
    let whole = bytes("iphone_int.mov");
    let moov = at(&whole, b"moov");
    for cut in [moov + 8, moov + 200, whole.len() - 1] {
        let e = parse(&whole[..cut]).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("box moov at byte {moov}: a size of"))
                && e.contains("cut short"),
            "{e}"
        );
    }
    let e = parse(&whole[..moov]).unwrap_err();
    assert!(matches!(e, QuickTimeError::NoMovie { .. }), "{e}");
    let e = parse(&whole[..100]).unwrap_err().to_string();
    assert!(e.starts_with("box mdat at byte 28"), "{e}");
    let first = bytes("faststart_float.mov");
    let mdat = at(&first, b"mdat");
    let cut = parse(&first[..mdat + 100]).unwrap().camera();
    assert_eq!(cut.focal_35mm_mm(), Some(Ok(26.5)));
}

/// Boxes whose sizes overflow their parent or the file, and keys that contradict their box:
/// errors naming the box and its place; never a panic.
#[test]
fn sizes_that_overflow_and_garbage_keys() {
    let good = bytes("iphone_int.mov");
    let mut trak = good.clone();
    let p = at(&trak, b"trak");
    trak[p..p + 4].copy_from_slice(&0xffff_fff0u32.to_be_bytes());
    let e = parse(&trak).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "box moov/trak at byte {p}: a size of 4294967280 bytes"
        )),
        "{e}"
    );
    // A 64-bit size over the file.
    let mut wide = bytes("mdat64_float64.mov");
    let p = at(&wide, b"mdat");
    wide[p + 8..p + 16].copy_from_slice(&(1u64 << 40).to_be_bytes());
    let e = parse(&wide).unwrap_err().to_string();
    assert!(e.contains("box mdat") && e.contains("1099511627776"), "{e}");
    // Keys: more stated than stored, and a key of size 0.
    let keys = at(&good, b"keys");
    let mut many = good.clone();
    many[keys + 12..keys + 16].copy_from_slice(&u32::MAX.to_be_bytes());
    let e = parse(&many).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "box moov/trak/meta/keys at byte {keys}: 4294967295 keys stated"
        )),
        "{e}"
    );
    let mut zero = good.clone();
    zero[keys + 16..keys + 20].copy_from_slice(&[0; 4]);
    let e = parse(&zero).unwrap_err().to_string();
    assert!(e.contains("key 1 has a size of 0 bytes"), "{e}");
    // An item list whose keys are gone.
    let mut gone = good.clone();
    gone[keys + 4..keys + 8].copy_from_slice(b"free");
    let e = parse(&gone).unwrap_err().to_string();
    assert!(
        e.contains("an mdta item list (ilst) without its keys"),
        "{e}"
    );
}

/// Files that are not QuickTime or MP4 are said to be so: Matroska, a PNG, an empty file.
#[test]
fn other_formats_are_not_quicktime() {
    let dir = tempfile::tempdir().unwrap();
    let mkv = dir.path().join("clip.mkv");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc=size=64x48:rate=30",
        "-frames:v",
        "2",
        "-c:v",
        "mpeg4",
        mkv.to_str().unwrap(),
    ]);
    let png = dir.path().join("frame.png");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc=size=64x48",
        "-frames:v",
        "1",
        png.to_str().unwrap(),
    ]);
    let empty = dir.path().join("empty.mov");
    std::fs::write(&empty, b"").unwrap();
    for path in [&mkv, &png, &empty] {
        let e = read_quicktime_metadata(path).unwrap_err();
        assert!(
            matches!(e, QuickTimeError::NotQuickTime { .. }),
            "{}: {e}",
            path.display()
        );
    }
    let e = read_quicktime_metadata(&dir.path().join("absent.mov")).unwrap_err();
    assert!(matches!(e, QuickTimeError::Io { offset: 0, .. }), "{e}");
}

/// A movie of `gap` bytes of `mdat` (never stored: read as zeros) between a fixture's
/// `ftyp` and its `moov`, counting the bytes read.
struct Huge {
    head: Vec<u8>,
    gap: u64,
    moov: Vec<u8>,
    pos: u64,
    read: u64,
}

impl Huge {
    fn len(&self) -> u64 {
        self.head.len() as u64 + self.gap + self.moov.len() as u64
    }
}

impl Read for Huge {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let head = self.head.len() as u64;
        let n = (buf.len() as u64).min(self.len().saturating_sub(self.pos)) as usize;
        for (i, b) in buf[..n].iter_mut().enumerate() {
            let p = self.pos + i as u64;
            *b = if p < head {
                self.head[p as usize]
            } else if p < head + self.gap {
                0
            } else {
                self.moov[(p - head - self.gap) as usize]
            };
        }
        self.pos += n as u64;
        self.read += n as u64;
        Ok(n)
    }
}

impl Seek for Huge {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.pos = match to {
            SeekFrom::Start(p) => p,
            SeekFrom::End(d) => (self.len() as i64 + d) as u64,
            SeekFrom::Current(d) => (self.pos as i64 + d) as u64,
        };
        Ok(self.pos)
    }
}

/// A 5 GB recording with its `moov` at the end (an iPhone's layout): the 64-bit `mdat` is
/// skipped by seeking, and under 16 KB of the file are read.
#[test]
fn a_5_gb_movie_is_read_without_reading_its_media() {
    let good = bytes("iphone_int.mov");
    let moov = at(&good, b"moov");
    let gap: u64 = 5 << 30;
    let mut head = bytes("iphone_int.mov")[..at(&good, b"wide")].to_vec();
    head.extend_from_slice(&1u32.to_be_bytes());
    head.extend_from_slice(b"mdat");
    head.extend_from_slice(&(gap + 16).to_be_bytes());
    let mut huge = Huge {
        head,
        gap,
        moov: good[moov..].to_vec(),
        pos: 0,
        read: 0,
    };
    let cam = parse_quicktime_metadata(&mut huge).unwrap().camera();
    assert_eq!(cam.focal_35mm_mm(), Some(Ok(24.0)));
    assert_eq!(cam.lens_model.as_deref(), Some(LENS));
    assert!(huge.read < 16 << 10, "{} bytes read", huge.read);
}
