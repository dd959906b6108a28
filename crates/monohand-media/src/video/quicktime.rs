//! The camera a QuickTime or MP4 file states in its own metadata, read from its boxes
//! without ffmpeg (ffprobe does not show a track's metadata keys).
//!
//! Apple's layout (QuickTime File Format, "Metadata"): a `meta` box holding `hdlr` (handler
//! type `mdta`), `keys` (the key names, numbered from 1) and `ilst` (one item per value,
//! whose box type is its key's number, holding `data` boxes: a type indicator, a locale and
//! the value). iPhones write the camera's keys on the video track (`moov/trak/meta`:
//! [`KEY_FOCAL_35MM`], [`KEY_LENS_MODEL`]) and the phone's on the movie (`moov/meta`:
//! [`KEY_MAKE`], [`KEY_MODEL`]); ffmpeg writes movie keys into `moov/udta/meta`. All these
//! places are read, both forms of `meta` (QuickTime's, without a version, and ISO's, with
//! 4 bytes of version and flags), and the classic user data texts (`udta/©mak`, ...).
//!
//! The file is not read whole: top-level boxes are skipped by seeking (`moov` may follow
//! gigabytes of `mdat`), only the boxes on the way to metadata are visited, and values over
//! [`MAX_VALUE_BYTES`] (artwork) are not read. Boxes of 64-bit size (size 1) and boxes that
//! run to the end of their parent (size 0) are read. A box that overflows its parent, a file
//! cut short before its `moov`, or keys that contradict their box are a [`QuickTimeError`],
//! never a panic.

use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// The 35 mm-equivalent focal length of the camera that filmed a video track, mm (Apple:
/// an integer, a float or a UTF-8 text such as `50.00mm`). Like EXIF's
/// `FocalLengthIn35mmFilm`, it gives the frame's diagonal the angle of view a 36 x 24 mm
/// frame has behind a lens of this focal length.
pub const KEY_FOCAL_35MM: &str = "com.apple.quicktime.camera.focal_length.35mm_equivalent";
/// The lens that filmed a video track, e.g. `iPhone 15 Pro back camera 6.765mm f/1.78`.
pub const KEY_LENS_MODEL: &str = "com.apple.quicktime.camera.lens_model";
/// The maker of the device that made the movie, e.g. `Apple`.
pub const KEY_MAKE: &str = "com.apple.quicktime.make";
/// The model of the device that made the movie, e.g. `iPhone 15 Pro`.
pub const KEY_MODEL: &str = "com.apple.quicktime.model";

/// Largest value read into memory, bytes; a larger value (a cover picture) is listed as
/// [`MetadataValue::Other`] without being read.
pub const MAX_VALUE_BYTES: u64 = 1 << 20;

/// Largest `keys` box read, bytes (it holds only the key names: real ones are a few
/// hundred bytes).
const MAX_KEYS_BYTES: u64 = 1 << 20;

/// Most boxes read in one box: a `moov` holds tens, and a forged one of millions of empty
/// boxes is refused rather than walked.
const MAX_CHILDREN: usize = 1 << 16;

/// Why a file's QuickTime metadata could not be read. The file is not named: the caller
/// says which file it read.
#[derive(Debug, thiserror::Error)]
pub enum QuickTimeError {
    /// The file could not be opened or read.
    #[error("cannot read it at byte {offset}: {source}")]
    Io {
        /// Where reading failed.
        offset: u64,
        /// Why.
        source: std::io::Error,
    },
    /// The file does not begin with a QuickTime or ISO media box (Matroska, AVI, ...).
    #[error("not a QuickTime or MP4 file: {why}")]
    NotQuickTime {
        /// What it begins with.
        why: String,
    },
    /// A file of boxes without a movie box.
    #[error(
        "no movie box (moov) in its {len} bytes: the recording was cut short, or the file \
         is not a movie"
    )]
    NoMovie {
        /// The file's length, bytes.
        len: u64,
    },
    /// A box that contradicts its parent or its own contents.
    #[error("box {path} at byte {offset}: {why}")]
    Malformed {
        /// The box, from the top (`moov/trak/meta/keys`).
        path: String,
        /// Where the box begins in the file.
        offset: u64,
        /// What is wrong with it.
        why: String,
    },
}

/// One value of a metadata item, decoded by its type indicator (Apple's "well-known types").
#[derive(Debug, Clone, PartialEq)]
pub enum MetadataValue {
    /// UTF-8 or UTF-16 text (types 1, 2, 4, 5).
    Text(String),
    /// A big-endian integer (types 21 and 22 of 1, 2, 3, 4 or 8 bytes; 65-67, 74-78).
    Integer(i64),
    /// A big-endian IEEE 754 float (types 23 and 24).
    Float(f64),
    /// Any other type (pictures, points, ...), or a value too large to read: its type
    /// indicator and length.
    Other {
        /// The type indicator (its well-known type, or the whole indicator when it is not
        /// drawn from the well-known set).
        type_code: u32,
        /// Length of the value, bytes.
        len: u64,
    },
}

impl MetadataValue {
    /// The value as a number: an integer, a float, or a text that is a number, optionally
    /// followed by `mm` (`26`, `26.00mm`, `50 mm`).
    pub fn as_number(&self) -> Option<f64> {
        match self {
            MetadataValue::Integer(i) => Some(*i as f64),
            MetadataValue::Float(f) => Some(*f),
            MetadataValue::Text(t) => {
                let t = t.trim();
                let t = t.strip_suffix("mm").unwrap_or(t).trim_end();
                t.parse::<f64>().ok()
            }
            MetadataValue::Other { .. } => None,
        }
    }

    /// The value as text, when it is text.
    pub fn as_text(&self) -> Option<&str> {
        match self {
            MetadataValue::Text(t) => Some(t),
            _ => None,
        }
    }
}

impl fmt::Display for MetadataValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MetadataValue::Text(t) => write!(f, "{t:?}"),
            MetadataValue::Integer(i) => write!(f, "{i}"),
            MetadataValue::Float(x) => write!(f, "{x}"),
            MetadataValue::Other { type_code, len } => {
                write!(f, "a value of type {type_code} ({len} bytes)")
            }
        }
    }
}

/// One metadata item: its key and its (first) value.
#[derive(Debug, Clone, PartialEq)]
pub struct MetadataItem {
    /// The key as written (`com.apple.quicktime.make`); the box type for items without
    /// keys (classic user data such as `©mak`, iTunes-style items such as `©too`).
    pub key: String,
    /// Its value; of several (one per language), the first.
    pub value: MetadataValue,
}

/// The metadata of a QuickTime or MP4 file that [`read_quicktime_metadata`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct QuickTimeMetadata {
    /// The movie's items: `moov/meta`, `moov/udta/meta` and the classic texts of
    /// `moov/udta`, in the file's order.
    pub movie: Vec<MetadataItem>,
    /// The items of the first video track (the stream ffmpeg decodes): its `trak/meta`,
    /// `trak/udta/meta` and `trak/mdia/meta`.
    pub video_track: Vec<MetadataItem>,
}

impl QuickTimeMetadata {
    /// The value of `key`: the video track's, else the movie's.
    pub fn value(&self, key: &str) -> Option<&MetadataValue> {
        let find =
            |items: &[MetadataItem]| -> Option<usize> { items.iter().position(|i| i.key == key) };
        find(&self.video_track)
            .map(|i| &self.video_track[i].value)
            .or_else(|| find(&self.movie).map(|i| &self.movie[i].value))
    }

    /// What the metadata says about the camera that filmed the video.
    pub fn camera(&self) -> VideoCameraTags {
        let text = |key: &str| {
            self.value(key)
                .and_then(MetadataValue::as_text)
                .map(|t| t.trim_matches(|c: char| c.is_whitespace() || c == '\0'))
                .filter(|t| !t.is_empty())
                .map(str::to_string)
        };
        VideoCameraTags {
            focal_35mm: self.value(KEY_FOCAL_35MM).cloned(),
            lens_model: text(KEY_LENS_MODEL),
            make: text(KEY_MAKE).or_else(|| text("©mak")),
            model: text(KEY_MODEL).or_else(|| text("©mod")),
        }
    }
}

/// What a video's metadata says about its camera ([`QuickTimeMetadata::camera`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VideoCameraTags {
    /// [`KEY_FOCAL_35MM`] as written.
    pub focal_35mm: Option<MetadataValue>,
    /// [`KEY_LENS_MODEL`].
    pub lens_model: Option<String>,
    /// [`KEY_MAKE`] (or the classic `©mak`).
    pub make: Option<String>,
    /// [`KEY_MODEL`] (or the classic `©mod`).
    pub model: Option<String>,
}

/// A stated focal length that is not a number of millimetres
/// ([`VideoCameraTags::focal_35mm_mm`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key} is {value}, not a focal length in mm")]
pub struct NotAFocalLength {
    /// The key, for the user.
    pub key: &'static str,
    /// The value stated.
    pub value: String,
}

impl VideoCameraTags {
    /// The 35 mm-equivalent focal length in mm, or why the value stated is none; `None`
    /// when no focal length is stated.
    pub fn focal_35mm_mm(&self) -> Option<Result<f64, NotAFocalLength>> {
        let v = self.focal_35mm.as_ref()?;
        Some(
            v.as_number()
                .filter(|f| f.is_finite())
                .ok_or_else(|| NotAFocalLength {
                    key: self.focal_name(),
                    value: v.to_string(),
                }),
        )
    }

    /// The device: make and model (`Apple iPhone 15 Pro`; the model alone when it names
    /// the make already).
    pub fn camera_name(&self) -> Option<String> {
        match (&self.make, &self.model) {
            (Some(make), Some(model)) if model.to_lowercase().starts_with(&make.to_lowercase()) => {
                Some(model.clone())
            }
            (Some(make), Some(model)) => Some(format!("{make} {model}")),
            (make, model) => make.clone().or_else(|| model.clone()),
        }
    }

    /// How the focal length is named for the user.
    fn focal_name(&self) -> &'static str {
        "QuickTime focal_length.35mm_equivalent"
    }

    /// The stated focal length and camera, for the user: `QuickTime
    /// focal_length.35mm_equivalent 26 mm (Apple iPhone 15 Pro, lens "iPhone 15 Pro back
    /// camera 6.765mm f/1.78")`.
    pub fn describe(&self) -> String {
        let mut s = self.focal_name().to_string();
        match self.focal_35mm.as_ref().map(|v| (v, v.as_number())) {
            Some((_, Some(f))) => s.push_str(&format!(" {} mm", round2(f))),
            Some((v, None)) => s.push_str(&format!(" {v}")),
            None => s.push_str(" absent"),
        }
        let mut about = Vec::new();
        if let Some(name) = self.camera_name() {
            about.push(name);
        }
        if let Some(lens) = &self.lens_model {
            about.push(format!("lens {lens:?}"));
        }
        if !about.is_empty() {
            s.push_str(&format!(" ({})", about.join(", ")));
        }
        s
    }
}

/// `v` to two decimals, without trailing zeros (`26`, `25.7`).
fn round2(v: f64) -> String {
    format!("{}", (v * 100.0).round() / 100.0)
}

/// Reads the metadata of the QuickTime or MP4 file at `path` (see the module docs).
pub fn read_quicktime_metadata(path: &Path) -> Result<QuickTimeMetadata, QuickTimeError> {
    let file = File::open(path).map_err(|source| QuickTimeError::Io { offset: 0, source })?;
    parse_quicktime_metadata(BufReader::new(file))
}

/// Box types a QuickTime or ISO media file may begin with.
const FIRST_BOXES: [&[u8; 4]; 12] = [
    b"ftyp", b"moov", b"mdat", b"wide", b"free", b"skip", b"pnot", b"uuid", b"styp", b"sidx",
    b"junk", b"PICT",
];

/// [`read_quicktime_metadata`] on any seekable bytes.
pub fn parse_quicktime_metadata<R: Read + Seek>(
    mut r: R,
) -> Result<QuickTimeMetadata, QuickTimeError> {
    let len = r
        .seek(SeekFrom::End(0))
        .map_err(|source| QuickTimeError::Io { offset: 0, source })?;
    if len < 8 {
        return Err(QuickTimeError::NotQuickTime {
            why: format!("{len} bytes, shorter than one box"),
        });
    }
    let mut first = [0u8; 8];
    read_at(&mut r, 0, &mut first)?;
    if !FIRST_BOXES.iter().any(|k| first[4..8] == k[..]) {
        return Err(QuickTimeError::NotQuickTime {
            why: format!(
                "it begins with the bytes {}, not a box such as ftyp, moov or mdat",
                first.map(|b| format!("{b:02x}")).join(" ")
            ),
        });
    }
    let mut pos = 0;
    while len - pos >= 8 {
        let head = read_head(&mut r, pos, len, "")?;
        if &head.kind == b"moov" {
            return read_moov(&mut r, head);
        }
        pos = head.end;
    }
    Err(QuickTimeError::NoMovie { len })
}

/// A box: its type, where it begins, where its contents begin and where it ends.
#[derive(Clone, Debug)]
struct BoxHead {
    kind: [u8; 4],
    /// The box's path from the top, for errors (`moov/trak/meta`).
    path: String,
    offset: u64,
    body: u64,
    end: u64,
}

impl BoxHead {
    fn malformed(&self, why: impl Into<String>) -> QuickTimeError {
        QuickTimeError::Malformed {
            path: self.path.clone(),
            offset: self.offset,
            why: why.into(),
        }
    }

    fn len(&self) -> u64 {
        self.end - self.body
    }
}

/// A box type for the user: its four characters, or its number when they are not text.
fn kind_name(kind: &[u8; 4]) -> String {
    if kind.iter().all(|b| (0x20..0x7f).contains(b)) {
        kind.iter().map(|&b| b as char).collect()
    } else if kind[0] == 0xa9 && kind[1..].iter().all(|b| (0x20..0x7f).contains(b)) {
        std::iter::once('©')
            .chain(kind[1..].iter().map(|&b| b as char))
            .collect()
    } else {
        format!("#{}", u32::from_be_bytes(*kind))
    }
}

fn read_at<R: Read + Seek>(r: &mut R, offset: u64, buf: &mut [u8]) -> Result<(), QuickTimeError> {
    r.seek(SeekFrom::Start(offset))
        .and_then(|_| r.read_exact(buf))
        .map_err(|source| QuickTimeError::Io { offset, source })
}

/// Reads `len` bytes at `offset` (the caller bounds `len`).
fn read_vec<R: Read + Seek>(r: &mut R, offset: u64, len: u64) -> Result<Vec<u8>, QuickTimeError> {
    let mut buf = vec![0u8; len as usize];
    read_at(r, offset, &mut buf)?;
    Ok(buf)
}

/// The header of the box at `pos` inside a parent (at `parent`) that ends at `end`.
fn read_head<R: Read + Seek>(
    r: &mut R,
    pos: u64,
    end: u64,
    parent: &str,
) -> Result<BoxHead, QuickTimeError> {
    let mut h = [0u8; 8];
    read_at(r, pos, &mut h)?;
    let kind = [h[4], h[5], h[6], h[7]];
    let path = match parent {
        "" => kind_name(&kind),
        p => format!("{p}/{}", kind_name(&kind)),
    };
    let room = end - pos;
    let malformed = |why: String| QuickTimeError::Malformed {
        path: path.clone(),
        offset: pos,
        why,
    };
    let (size, header) = match u32::from_be_bytes([h[0], h[1], h[2], h[3]]) {
        0 => (room, 8),
        1 => {
            if room < 16 {
                return Err(malformed(format!(
                    "a 64-bit size, but only {room} bytes are left for its header"
                )));
            }
            let mut l = [0u8; 8];
            read_at(r, pos + 8, &mut l)?;
            (u64::from_be_bytes(l), 16)
        }
        s => (u64::from(s), 8),
    };
    if size < header {
        return Err(malformed(format!(
            "a size of {size} bytes, less than its {header}-byte header"
        )));
    }
    if size > room {
        let within = if parent.is_empty() {
            "the file".to_string()
        } else {
            parent.to_string()
        };
        return Err(malformed(format!(
            "a size of {size} bytes, but {within} has only {room} bytes from it on (cut short?)"
        )));
    }
    Ok(BoxHead {
        kind,
        path,
        offset: pos,
        body: pos + header,
        end: pos + size,
    })
}

/// The boxes inside `parent`'s contents from `start` on.
fn children_from<R: Read + Seek>(
    r: &mut R,
    parent: &BoxHead,
    start: u64,
) -> Result<Vec<BoxHead>, QuickTimeError> {
    let mut out = Vec::new();
    let mut pos = start;
    while parent.end.saturating_sub(pos) >= 8 {
        if out.len() == MAX_CHILDREN {
            return Err(parent.malformed(format!("more than {MAX_CHILDREN} boxes in it")));
        }
        let head = read_head(r, pos, parent.end, &parent.path)?;
        pos = head.end;
        out.push(head);
    }
    Ok(out)
}

/// The boxes inside `parent`.
fn children<R: Read + Seek>(r: &mut R, parent: &BoxHead) -> Result<Vec<BoxHead>, QuickTimeError> {
    children_from(r, parent, parent.body)
}

/// The movie's metadata and its first video track's.
fn read_moov<R: Read + Seek>(
    r: &mut R,
    moov: BoxHead,
) -> Result<QuickTimeMetadata, QuickTimeError> {
    let mut out = QuickTimeMetadata::default();
    let mut video_found = false;
    for child in children(r, &moov)? {
        match &child.kind {
            b"trak" if !video_found => {
                if let Some(items) = read_trak(r, &child)? {
                    out.video_track = items;
                    video_found = true;
                }
            }
            b"meta" => out.movie.extend(read_meta(r, &child)?),
            b"udta" => out.movie.extend(read_udta(r, &child)?),
            _ => {}
        }
    }
    Ok(out)
}

/// A track's metadata if it is a video track (its media handler is `vide`), else `None`.
fn read_trak<R: Read + Seek>(
    r: &mut R,
    trak: &BoxHead,
) -> Result<Option<Vec<MetadataItem>>, QuickTimeError> {
    let mut video = false;
    // Read only once the track is known to be video: another track's broken metadata is
    // none of the camera's business.
    let mut metas = Vec::new();
    for child in children(r, trak)? {
        match &child.kind {
            b"mdia" => {
                for m in children(r, &child)? {
                    match &m.kind {
                        b"hdlr" => video = handler_type(r, &m)? == *b"vide",
                        b"meta" => metas.push(m),
                        _ => {}
                    }
                }
            }
            b"meta" => metas.push(child),
            b"udta" => metas.extend(
                children(r, &child)?
                    .into_iter()
                    .filter(|b| &b.kind == b"meta"),
            ),
            _ => {}
        }
    }
    if !video {
        return Ok(None);
    }
    let mut items = Vec::new();
    for meta in &metas {
        items.extend(read_meta(r, meta)?);
    }
    Ok(Some(items))
}

/// The handler type of a `hdlr` box (after its version, flags and component type).
fn handler_type<R: Read + Seek>(r: &mut R, hdlr: &BoxHead) -> Result<[u8; 4], QuickTimeError> {
    if hdlr.len() < 12 {
        return Err(hdlr.malformed(format!(
            "{} bytes, too short for a handler type",
            hdlr.len()
        )));
    }
    let mut t = [0u8; 4];
    read_at(r, hdlr.body + 8, &mut t)?;
    Ok(t)
}

/// A user data box's metadata: its `meta` boxes and its classic texts (`©mak`, ...).
fn read_udta<R: Read + Seek>(
    r: &mut R,
    udta: &BoxHead,
) -> Result<Vec<MetadataItem>, QuickTimeError> {
    let mut items = Vec::new();
    for child in children(r, udta)? {
        if &child.kind == b"meta" {
            items.extend(read_meta(r, &child)?);
        } else if child.kind[0] == 0xa9 {
            if let Some(text) = classic_text(r, &child)? {
                items.push(MetadataItem {
                    key: kind_name(&child.kind),
                    value: MetadataValue::Text(text),
                });
            }
        }
    }
    Ok(items)
}

/// The first text of a classic user data text box: a 16-bit length, a 16-bit language
/// and the text (Mac Roman for the old Macintosh language codes, below 0x400, read here
/// as Latin-1; UTF-8 otherwise). `None` for a box that is not a text (some `©` boxes
/// are iTunes-style containers) or is too large.
fn classic_text<R: Read + Seek>(r: &mut R, b: &BoxHead) -> Result<Option<String>, QuickTimeError> {
    if b.len() < 4 || b.len() > MAX_VALUE_BYTES {
        return Ok(None);
    }
    let buf = read_vec(r, b.body, b.len())?;
    let n = usize::from(u16::from_be_bytes([buf[0], buf[1]]));
    let lang = u16::from_be_bytes([buf[2], buf[3]]);
    let Some(text) = buf.get(4..4 + n) else {
        return Ok(None);
    };
    Ok(Some(if lang < 0x400 {
        text.iter().map(|&c| c as char).collect()
    } else {
        String::from_utf8_lossy(text).into_owned()
    }))
}

/// The items of a `meta` box: with the `mdta` handler, its `ilst` items named by its
/// `keys`; with another (ISO's `mdir`), its `ilst` items named by their box types.
fn read_meta<R: Read + Seek>(
    r: &mut R,
    meta: &BoxHead,
) -> Result<Vec<MetadataItem>, QuickTimeError> {
    // QuickTime's `meta` holds boxes at once; ISO's begins with 4 bytes of version and
    // flags. In the first the second word is a box type, in the second a box size.
    let start = if meta.len() >= 8 {
        let mut w = [0u8; 8];
        read_at(r, meta.body, &mut w)?;
        let kind = &w[4..8];
        let quicktime = [b"hdlr", b"keys", b"ilst", b"free"]
            .iter()
            .any(|k| kind == &k[..]);
        if quicktime {
            meta.body
        } else {
            meta.body + 4
        }
    } else {
        meta.end
    };
    let (mut handler, mut keys, mut ilst) = (None, None, None);
    for child in children_from(r, meta, start)? {
        match &child.kind {
            b"hdlr" => handler = Some(handler_type(r, &child)?),
            b"keys" => keys = Some(read_keys(r, &child)?),
            b"ilst" => ilst = Some(child),
            _ => {}
        }
    }
    let Some(ilst) = ilst else {
        return Ok(Vec::new());
    };
    let keys = match (handler, keys) {
        (Some(h), Some(keys)) if &h == b"mdta" => Some(keys),
        (Some(h), None) if &h == b"mdta" => {
            return Err(meta.malformed("an mdta item list (ilst) without its keys"));
        }
        _ => None,
    };
    read_items(r, &ilst, keys.as_deref())
}

/// The key names of a `keys` box, in order (key 1 first).
fn read_keys<R: Read + Seek>(r: &mut R, b: &BoxHead) -> Result<Vec<String>, QuickTimeError> {
    if b.len() > MAX_KEYS_BYTES {
        return Err(b.malformed(format!(
            "{} bytes of keys, over the {MAX_KEYS_BYTES} read",
            b.len()
        )));
    }
    let buf = read_vec(r, b.body, b.len())?;
    let word = |p: usize| {
        buf.get(p..p + 4)
            .map(|w| u32::from_be_bytes([w[0], w[1], w[2], w[3]]))
    };
    let Some(count) = word(4) else {
        return Err(b.malformed(format!("{} bytes, too short for a count of keys", b.len())));
    };
    let mut keys = Vec::new();
    let mut p = 8usize;
    for i in 0..count {
        let Some(size) = word(p).map(|s| s as usize) else {
            return Err(b.malformed(format!("{count} keys stated, but the box ends after {i}")));
        };
        if size < 8 || size > buf.len() - p {
            return Err(b.malformed(format!(
                "key {} has a size of {size} bytes, not 8 or more within the box's {} bytes \
                 left",
                i + 1,
                buf.len() - p
            )));
        }
        let name = String::from_utf8_lossy(&buf[p + 8..p + size]);
        keys.push(name.trim_end_matches('\0').to_string());
        p += size;
    }
    Ok(keys)
}

/// The items of an `ilst` box: each named by its key (its box type is the key's number,
/// from 1) or, without keys, by its box type; an item whose number names no key is
/// skipped, as is an item without a `data` box.
fn read_items<R: Read + Seek>(
    r: &mut R,
    ilst: &BoxHead,
    keys: Option<&[String]>,
) -> Result<Vec<MetadataItem>, QuickTimeError> {
    let mut items = Vec::new();
    for item in children(r, ilst)? {
        let key = match keys {
            Some(keys) => {
                let index = u32::from_be_bytes(item.kind) as usize;
                match index.checked_sub(1).and_then(|i| keys.get(i)) {
                    Some(k) => k.clone(),
                    None => continue,
                }
            }
            None => kind_name(&item.kind),
        };
        let data = children(r, &item)?.into_iter().find(|b| &b.kind == b"data");
        if let Some(data) = data {
            let value = read_value(r, &data)?;
            items.push(MetadataItem { key, value });
        }
    }
    Ok(items)
}

/// The value of a `data` box: its type indicator (a set byte, 0 for the well-known types,
/// and the type in 24 bits), its locale (4 bytes), then the value.
fn read_value<R: Read + Seek>(r: &mut R, data: &BoxHead) -> Result<MetadataValue, QuickTimeError> {
    if data.len() < 8 {
        return Err(data.malformed(format!(
            "{} bytes, too short for a type and a locale",
            data.len()
        )));
    }
    let mut t = [0u8; 4];
    read_at(r, data.body, &mut t)?;
    let indicator = u32::from_be_bytes(t);
    let len = data.len() - 8;
    let other = MetadataValue::Other {
        type_code: indicator,
        len,
    };
    if t[0] != 0 || len > MAX_VALUE_BYTES {
        return Ok(other);
    }
    let v = read_vec(r, data.body + 8, len)?;
    Ok(decode_value(indicator, &v).unwrap_or(other))
}

/// A value of well-known type `code`, or `None` for a type not decoded here or a length
/// the type does not allow.
fn decode_value(code: u32, v: &[u8]) -> Option<MetadataValue> {
    let int = |signed: bool| -> Option<i64> {
        if v.is_empty() || v.len() > 8 {
            return None;
        }
        let mut x: u64 = 0;
        for &b in v {
            x = (x << 8) | u64::from(b);
        }
        let bits = 8 * v.len() as u32;
        if signed {
            // Sign-extend from `bits`.
            let shift = 64 - bits;
            Some(((x << shift) as i64) >> shift)
        } else {
            i64::try_from(x).ok()
        }
    };
    let sized = |n: usize, signed: bool| (v.len() == n).then(|| int(signed)).flatten();
    let value = match code {
        1 | 4 => MetadataValue::Text(String::from_utf8_lossy(v).into_owned()),
        2 | 5 => {
            let units = v.chunks_exact(2).map(|c| u16::from_be_bytes([c[0], c[1]]));
            MetadataValue::Text(
                char::decode_utf16(units)
                    .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
                    .collect(),
            )
        }
        21 | 22 if matches!(v.len(), 1 | 2 | 3 | 4 | 8) => MetadataValue::Integer(int(code == 21)?),
        23 if v.len() == 4 => {
            MetadataValue::Float(f64::from(f32::from_be_bytes([v[0], v[1], v[2], v[3]])))
        }
        24 => MetadataValue::Float(f64::from_be_bytes(v.try_into().ok()?)),
        65 => MetadataValue::Integer(sized(1, true)?),
        66 => MetadataValue::Integer(sized(2, true)?),
        67 => MetadataValue::Integer(sized(4, true)?),
        74 => MetadataValue::Integer(sized(8, true)?),
        75 => MetadataValue::Integer(sized(1, false)?),
        76 => MetadataValue::Integer(sized(2, false)?),
        77 => MetadataValue::Integer(sized(4, false)?),
        78 => MetadataValue::Integer(sized(8, false)?),
        _ => return None,
    };
    Some(value)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::io::Cursor;

    /// A box of 32-bit size.
    fn bx(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
        let mut b = ((body.len() + 8) as u32).to_be_bytes().to_vec();
        b.extend_from_slice(kind);
        b.extend_from_slice(body);
        b
    }

    fn cat(parts: &[Vec<u8>]) -> Vec<u8> {
        parts.concat()
    }

    fn hdlr(handler: &[u8; 4]) -> Vec<u8> {
        let mut body = vec![0u8; 8];
        body.extend_from_slice(handler);
        body.extend_from_slice(&[0u8; 12]);
        body.push(0);
        bx(b"hdlr", &body)
    }

    fn data(type_code: u32, value: &[u8]) -> Vec<u8> {
        let mut body = type_code.to_be_bytes().to_vec();
        body.extend_from_slice(&[0u8; 4]);
        body.extend_from_slice(value);
        bx(b"data", &body)
    }

    /// An mdta `meta` box (QuickTime's form, or ISO's with `iso`) of these keys and values.
    fn mdta_meta(items: &[(&str, u32, Vec<u8>)], iso: bool) -> Vec<u8> {
        let mut keys = vec![0u8; 4];
        keys.extend_from_slice(&(items.len() as u32).to_be_bytes());
        let mut ilst = Vec::new();
        for (i, (key, code, value)) in items.iter().enumerate() {
            keys.extend_from_slice(&((key.len() + 8) as u32).to_be_bytes());
            keys.extend_from_slice(b"mdta");
            keys.extend_from_slice(key.as_bytes());
            ilst.extend(bx(&(i as u32 + 1).to_be_bytes(), &data(*code, value)));
        }
        let mut body = if iso { vec![0u8; 4] } else { Vec::new() };
        body.extend(cat(&[
            hdlr(b"mdta"),
            bx(b"keys", &keys),
            bx(b"ilst", &ilst),
        ]));
        bx(b"meta", &body)
    }

    fn trak(handler: &[u8; 4], extra: &[u8]) -> Vec<u8> {
        let mdia = bx(b"mdia", &cat(&[bx(b"mdhd", &[0u8; 24]), hdlr(handler)]));
        bx(
            b"trak",
            &cat(&[bx(b"tkhd", &[0u8; 84]), mdia, extra.to_vec()]),
        )
    }

    fn parse(bytes: &[u8]) -> Result<QuickTimeMetadata, QuickTimeError> {
        parse_quicktime_metadata(Cursor::new(bytes))
    }

    fn iphone_moov(focal: (u32, Vec<u8>)) -> Vec<u8> {
        let track_meta = mdta_meta(
            &[
                (
                    KEY_LENS_MODEL,
                    1,
                    b"iPhone 15 Pro back camera 6.765mm f/1.78".to_vec(),
                ),
                (KEY_FOCAL_35MM, focal.0, focal.1),
            ],
            false,
        );
        let movie_meta = mdta_meta(
            &[
                (KEY_MAKE, 1, b"Apple".to_vec()),
                (KEY_MODEL, 1, b"iPhone 15 Pro".to_vec()),
            ],
            false,
        );
        bx(
            b"moov",
            &cat(&[
                bx(b"mvhd", &[0u8; 100]),
                trak(
                    b"soun",
                    &mdta_meta(&[(KEY_FOCAL_35MM, 21, vec![99])], false),
                ),
                trak(b"vide", &track_meta),
                movie_meta,
            ]),
        )
    }

    fn ftyp() -> Vec<u8> {
        bx(b"ftyp", b"qt  \0\0\0\0qt  ")
    }

    #[test]
    fn an_iphone_layout_gives_the_video_tracks_camera_and_the_movies_device() {
        let file = cat(&[
            ftyp(),
            bx(b"mdat", &[7u8; 300]),
            iphone_moov((21, 26i32.to_be_bytes().to_vec())),
        ]);
        let meta = parse(&file).unwrap();
        let cam = meta.camera();
        assert_eq!(
            cam.focal_35mm,
            Some(MetadataValue::Integer(26)),
            "not the sound track's 99"
        );
        assert_eq!(cam.focal_35mm_mm(), Some(Ok(26.0)));
        assert_eq!(cam.make.as_deref(), Some("Apple"));
        assert_eq!(cam.camera_name().as_deref(), Some("Apple iPhone 15 Pro"));
        assert_eq!(
            cam.describe(),
            "QuickTime focal_length.35mm_equivalent 26 mm (Apple iPhone 15 Pro, lens \
             \"iPhone 15 Pro back camera 6.765mm f/1.78\")"
        );
        assert_eq!(meta.video_track.len(), 2);
        assert_eq!(meta.movie.len(), 2);
    }

    #[test]
    fn every_number_type_apple_lists_is_read() {
        let f32_26 = 26.5f32.to_be_bytes().to_vec();
        for (code, bytes, want) in [
            (21, vec![0xf3], Some(-13.0)),
            (21, vec![0, 26], Some(26.0)),
            (21, vec![0, 0, 26], Some(26.0)),
            (21, 26i64.to_be_bytes().to_vec(), Some(26.0)),
            (22, vec![0xff], Some(255.0)),
            (23, f32_26, Some(26.5)),
            (24, 26.25f64.to_be_bytes().to_vec(), Some(26.25)),
            (65, vec![0xfe], Some(-2.0)),
            (66, (-300i16).to_be_bytes().to_vec(), Some(-300.0)),
            (67, 26i32.to_be_bytes().to_vec(), Some(26.0)),
            (74, 26i64.to_be_bytes().to_vec(), Some(26.0)),
            (75, vec![26], Some(26.0)),
            (76, vec![0, 26], Some(26.0)),
            (77, 26u32.to_be_bytes().to_vec(), Some(26.0)),
            (78, u64::MAX.to_be_bytes().to_vec(), None),
            (1, b"50.00mm".to_vec(), Some(50.0)),
            (1, b" 24 ".to_vec(), Some(24.0)),
            (1, b"wide".to_vec(), None),
            (21, vec![0; 5], None),
            (23, vec![0; 8], None),
            (13, vec![0xff, 0xd8], None),
        ] {
            let file = cat(&[ftyp(), iphone_moov((code, bytes.clone()))]);
            let v = parse(&file).unwrap().camera().focal_35mm.unwrap();
            assert_eq!(v.as_number(), want, "type {code} {bytes:?}: {v:?}");
        }
        let utf16: Vec<u8> = "Äpple".encode_utf16().flat_map(u16::to_be_bytes).collect();
        assert_eq!(
            decode_value(2, &utf16),
            Some(MetadataValue::Text("Äpple".into()))
        );
        let cam = parse(&cat(&[ftyp(), iphone_moov((1, b"wide".to_vec()))]))
            .unwrap()
            .camera();
        assert_eq!(
            cam.focal_35mm_mm().map(|r| r.map_err(|e| e.to_string())),
            Some(Err(
                "QuickTime focal_length.35mm_equivalent is \"wide\", not a focal length in mm"
                    .into()
            ))
        );
    }

    /// ffmpeg's layout (`-movflags use_metadata_tags`): ISO's `meta` with version and flags
    /// in `moov/udta`, and classic texts beside it; a 64-bit `mdat` before `moov`, and
    /// `moov` running to the end of the file (size 0).
    #[test]
    fn iso_meta_classic_texts_64_bit_and_open_ended_boxes() {
        let mut mdat = 1u32.to_be_bytes().to_vec();
        mdat.extend_from_slice(b"mdat");
        mdat.extend_from_slice(&(16u64 + 40).to_be_bytes());
        mdat.extend_from_slice(&[0u8; 40]);
        let mut classic = 5u16.to_be_bytes().to_vec();
        classic.extend_from_slice(&0x55c4u16.to_be_bytes());
        classic.extend_from_slice(b"Canon");
        let udta = bx(
            b"udta",
            &cat(&[
                mdta_meta(&[(KEY_MODEL, 1, b"EOS R5".to_vec())], true),
                bx(b"\xa9mak", &classic),
            ]),
        );
        let track = mdta_meta(&[(KEY_FOCAL_35MM, 23, 35f32.to_be_bytes().to_vec())], true);
        let mut moov = bx(b"moov", &cat(&[trak(b"vide", &track), udta]));
        moov[..4].copy_from_slice(&[0; 4]);
        let meta = parse(&cat(&[ftyp(), mdat, moov])).unwrap();
        let cam = meta.camera();
        assert_eq!(cam.focal_35mm_mm(), Some(Ok(35.0)));
        assert_eq!(cam.make.as_deref(), Some("Canon"));
        assert_eq!(cam.camera_name().as_deref(), Some("Canon EOS R5"));
        assert_eq!(meta.movie[1].key, "©mak");
    }

    #[test]
    fn a_file_without_keys_has_no_camera_and_other_files_say_what_they_are() {
        let plain = cat(&[ftyp(), bx(b"moov", &trak(b"vide", &[]))]);
        assert_eq!(parse(&plain).unwrap(), QuickTimeMetadata::default());
        assert_eq!(parse(&plain).unwrap().camera(), VideoCameraTags::default());
        let mkv = [0x1a, 0x45, 0xdf, 0xa3, 0x9f, 0x42, 0x86, 0x81, 1];
        let e = parse(&mkv).unwrap_err().to_string();
        assert!(
            e.starts_with("not a QuickTime or MP4 file: it begins with the bytes 1a 45"),
            "{e}"
        );
        let e = parse(b"tiny").unwrap_err().to_string();
        assert!(e.contains("4 bytes, shorter than one box"), "{e}");
        let e = parse(&cat(&[ftyp(), bx(b"mdat", &[0; 64])]))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("no movie box (moov) in its 92 bytes"), "{e}");
    }

    #[test]
    fn broken_boxes_are_errors_that_say_where() {
        let good = cat(&[ftyp(), iphone_moov((21, vec![26]))]);
        // The moov cut short.
        let e = parse(&good[..good.len() - 10]).unwrap_err().to_string();
        assert!(e.starts_with("box moov at byte 20: a size of"), "{e}");
        assert!(e.contains("but the file has only"), "{e}");
        // A box inside that claims more than its parent holds.
        let mut over = good.clone();
        let at = find(&over, b"keys") - 4;
        over[at..at + 4].copy_from_slice(&0x7fff_ffffu32.to_be_bytes());
        let e = parse(&over).unwrap_err().to_string();
        assert!(
            e.contains("moov/trak/meta/keys") && e.contains("2147483647"),
            "{e}"
        );
        // A size under its header, and a 64-bit size that overflows.
        let mut small = good.clone();
        let at = find(&small, b"mvhd") - 4;
        small[at..at + 4].copy_from_slice(&3u32.to_be_bytes());
        let e = parse(&small).unwrap_err().to_string();
        assert!(
            e.contains("moov/mvhd") && e.contains("less than its 8-byte header"),
            "{e}"
        );
        let mut wide = good.clone();
        let at = find(&wide, b"mvhd") - 4;
        wide[at..at + 4].copy_from_slice(&1u32.to_be_bytes());
        wide[at + 8..at + 16].copy_from_slice(&u64::MAX.to_be_bytes());
        let e = parse(&wide).unwrap_err().to_string();
        assert!(
            e.contains("moov/mvhd") && e.contains("18446744073709551615"),
            "{e}"
        );
    }

    #[test]
    fn garbage_keys_are_errors() {
        let good = cat(&[ftyp(), iphone_moov((21, vec![26]))]);
        let keys = find(&good, b"keys");
        // More keys stated than the box holds.
        let mut many = good.clone();
        many[keys + 8..keys + 12].copy_from_slice(&1000u32.to_be_bytes());
        let e = parse(&many).unwrap_err().to_string();
        assert!(
            e.contains("meta/keys") && e.contains("1000 keys stated"),
            "{e}"
        );
        // A key whose size is under its header, or past the box.
        for size in [3u32, 0xffff] {
            let mut bad = good.clone();
            bad[keys + 12..keys + 16].copy_from_slice(&size.to_be_bytes());
            let e = parse(&bad).unwrap_err().to_string();
            assert!(
                e.contains(&format!("key 1 has a size of {size} bytes")),
                "{e}"
            );
        }
        // Items that name no key are skipped.
        let mut stray = good.clone();
        let ilst = find(&stray, b"ilst");
        stray[ilst + 8..ilst + 12].copy_from_slice(&77u32.to_be_bytes());
        let meta = parse(&stray).unwrap();
        assert_eq!(meta.camera().lens_model, None);
        assert_eq!(meta.camera().focal_35mm, Some(MetadataValue::Integer(26)));
    }

    /// Where `kind` first occurs in the video track's part of `file` (after the sound
    /// track), as a box type.
    fn find(file: &[u8], kind: &[u8; 4]) -> usize {
        let vide = file.windows(4).position(|w| w == b"vide").unwrap();
        let from = if kind == b"ftyp" || kind == b"mvhd" {
            0
        } else {
            vide
        };
        from + file[from..].windows(4).position(|w| w == kind).unwrap()
    }

    /// Every truncation of a good file: an answer or an error, never a panic (mutations:
    /// `tests/fuzz_quicktime.rs`).
    #[test]
    fn every_truncation_is_an_answer_or_an_error() {
        let good = cat(&[
            ftyp(),
            bx(b"mdat", &[1; 50]),
            iphone_moov((23, 26f32.to_be_bytes().to_vec())),
        ]);
        assert!(parse(&good).is_ok());
        for n in 0..good.len() {
            assert!(parse(&good[..n]).is_err(), "cut at {n}");
        }
    }
}
