//! Writes Apple's camera metadata into a movie ffmpeg made, as an iPhone lays it out
//! (QuickTime File Format, "Metadata"): a `meta` box (QuickTime's form: no version and
//! flags) with a `hdlr` of type `mdta`, a `keys` box (each key: size, namespace `mdta`,
//! name) and an `ilst` box (per key, an item whose box type is the key's number from 1,
//! holding a `data` box: the type indicator, a zero locale and the value), at the end of the
//! first video `trak` for the track's keys and at the end of `moov` for the movie's.
//!
//! `trak` and `moov` grow by the boxes added, and when `moov` comes before `mdat` every
//! chunk offset (`stco`, `co64`) moves by as much, so the movie still plays. This writer
//! shares no code with the reader in `monohand-media`; exiftool reads what it writes in the
//! tests of both.
//!
//! Everything here panics on a file it does not understand: a failed fixture fails its test.

/// A metadata value and the type indicator it is written with.
#[derive(Clone, Copy, Debug)]
pub enum Value<'a> {
    /// UTF-8 text (type 1).
    Text(&'a str),
    /// A big-endian signed integer in 4 bytes (type 21, as iPhones write the focal length).
    Int(i32),
    /// A big-endian float32 (type 23).
    Float32(f32),
    /// A big-endian float64 (type 24).
    Float64(f64),
}

impl Value<'_> {
    fn data_box(&self) -> Vec<u8> {
        let (code, bytes): (u32, Vec<u8>) = match *self {
            Value::Text(t) => (1, t.as_bytes().to_vec()),
            Value::Int(i) => (21, i.to_be_bytes().to_vec()),
            Value::Float32(f) => (23, f.to_be_bytes().to_vec()),
            Value::Float64(f) => (24, f.to_be_bytes().to_vec()),
        };
        let mut body = code.to_be_bytes().to_vec();
        body.extend_from_slice(&[0; 4]);
        body.extend(bytes);
        boxed(b"data", &body)
    }
}

/// The keys an iPhone writes about its camera.
pub mod keys {
    /// The track's 35 mm-equivalent focal length.
    pub const FOCAL_35MM: &str = "com.apple.quicktime.camera.focal_length.35mm_equivalent";
    /// The track's lens.
    pub const LENS_MODEL: &str = "com.apple.quicktime.camera.lens_model";
    /// The movie's maker.
    pub const MAKE: &str = "com.apple.quicktime.make";
    /// The movie's model.
    pub const MODEL: &str = "com.apple.quicktime.model";
}

/// A box of 32-bit size.
pub fn boxed(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
    let size = u32::try_from(body.len() + 8).expect("a box under 4 GB");
    let mut b = size.to_be_bytes().to_vec();
    b.extend_from_slice(kind);
    b.extend_from_slice(body);
    b
}

/// A QuickTime `meta` box of these keys (namespace `mdta`) and values.
pub fn mdta_meta(items: &[(&str, Value<'_>)]) -> Vec<u8> {
    let mut hdlr = vec![0u8; 8];
    hdlr.extend_from_slice(b"mdta");
    hdlr.extend_from_slice(&[0; 13]);
    let mut keys = vec![0u8; 4];
    keys.extend_from_slice(&(items.len() as u32).to_be_bytes());
    let mut ilst = Vec::new();
    for (i, (key, value)) in items.iter().enumerate() {
        keys.extend_from_slice(&(key.len() as u32 + 8).to_be_bytes());
        keys.extend_from_slice(b"mdta");
        keys.extend_from_slice(key.as_bytes());
        ilst.extend(boxed(&(i as u32 + 1).to_be_bytes(), &value.data_box()));
    }
    let body = [
        boxed(b"hdlr", &hdlr),
        boxed(b"keys", &keys),
        boxed(b"ilst", &ilst),
    ]
    .concat();
    boxed(b"meta", &body)
}

/// A box found in a buffer: where it begins, its header's length and where it ends.
#[derive(Clone, Copy, Debug)]
struct Found {
    kind: [u8; 4],
    start: usize,
    header: usize,
    end: usize,
}

/// The boxes in `buf[start..end]` (32- and 64-bit sizes, size 0 to the end).
fn boxes(buf: &[u8], start: usize, end: usize) -> Vec<Found> {
    let mut out = Vec::new();
    let mut p = start;
    while p + 8 <= end {
        let size32 = u32::from_be_bytes(buf[p..p + 4].try_into().unwrap());
        let kind: [u8; 4] = buf[p + 4..p + 8].try_into().unwrap();
        let (size, header) = match size32 {
            0 => (end - p, 8),
            1 => (
                u64::from_be_bytes(buf[p + 8..p + 16].try_into().unwrap()) as usize,
                16,
            ),
            s => (s as usize, 8),
        };
        assert!(size >= header && p + size <= end, "a box overflows at {p}");
        out.push(Found {
            kind,
            start: p,
            header,
            end: p + size,
        });
        p += size;
    }
    out
}

fn find(list: &[Found], kind: &[u8; 4]) -> Option<Found> {
    list.iter().copied().find(|b| &b.kind == kind)
}

/// Writes a new 32-bit size into the box at `start`, which must have one.
fn set_size(buf: &mut [u8], start: usize, size: usize) {
    assert_ne!(
        u32::from_be_bytes(buf[start..start + 4].try_into().unwrap()),
        1,
        "64-bit box sizes are not rewritten here"
    );
    let size = u32::try_from(size).expect("a box under 4 GB");
    buf[start..start + 4].copy_from_slice(&size.to_be_bytes());
}

/// Whether the track `trak` (a box of `moov`) is a video track.
fn is_video(moov: &[u8], trak: Found) -> bool {
    let children = boxes(moov, trak.start + trak.header, trak.end);
    let Some(mdia) = find(&children, b"mdia") else {
        return false;
    };
    let media = boxes(moov, mdia.start + mdia.header, mdia.end);
    find(&media, b"hdlr").is_some_and(|h| &moov[h.start + 16..h.start + 20] == b"vide")
}

/// Adds `delta` to every chunk offset of every track of `moov` (a whole box).
fn move_chunk_offsets(moov: &mut [u8], delta: i64) {
    let top = boxes(moov, 8, moov.len());
    for trak in top.iter().filter(|b| &b.kind == b"trak") {
        let mut level = *trak;
        for kind in [b"mdia", b"minf", b"stbl"] {
            level = find(&boxes(moov, level.start + level.header, level.end), kind)
                .expect("a track's sample table");
        }
        for table in boxes(moov, level.start + level.header, level.end) {
            let wide = match &table.kind {
                b"stco" => false,
                b"co64" => true,
                _ => continue,
            };
            let body = table.start + table.header;
            let n = u32::from_be_bytes(moov[body + 4..body + 8].try_into().unwrap()) as usize;
            let width = if wide { 8 } else { 4 };
            for i in 0..n {
                let at = body + 8 + i * width;
                if wide {
                    let v = u64::from_be_bytes(moov[at..at + 8].try_into().unwrap());
                    let v = (v as i64 + delta) as u64;
                    moov[at..at + 8].copy_from_slice(&v.to_be_bytes());
                } else {
                    let v = u32::from_be_bytes(moov[at..at + 4].try_into().unwrap());
                    let v = u32::try_from(i64::from(v) + delta).expect("a 32-bit offset");
                    moov[at..at + 4].copy_from_slice(&v.to_be_bytes());
                }
            }
        }
    }
}

/// `file` (a MOV or MP4 ffmpeg wrote) with `track` keys on its first video track and
/// `movie` keys on the movie (either may be empty: no box is then added there).
pub fn with_apple_keys(
    file: &[u8],
    track: &[(&str, Value<'_>)],
    movie: &[(&str, Value<'_>)],
) -> Vec<u8> {
    let top = boxes(file, 0, file.len());
    let moov = find(&top, b"moov").expect("a moov box");
    let mut new_moov = file[moov.start..moov.end].to_vec();
    if !track.is_empty() {
        let traks = boxes(&new_moov, 8, new_moov.len());
        let trak = traks
            .iter()
            .copied()
            .find(|t| &t.kind == b"trak" && is_video(&new_moov, *t))
            .expect("a video track");
        let meta = mdta_meta(track);
        set_size(
            &mut new_moov,
            trak.start,
            trak.end - trak.start + meta.len(),
        );
        new_moov.splice(trak.end..trak.end, meta);
    }
    if !movie.is_empty() {
        new_moov.extend(mdta_meta(movie));
    }
    let len = new_moov.len();
    set_size(&mut new_moov, 0, len);
    let delta = (new_moov.len() - (moov.end - moov.start)) as i64;
    let mdat = find(&top, b"mdat").expect("an mdat box");
    if moov.start < mdat.start {
        move_chunk_offsets(&mut new_moov, delta);
    }
    [&file[..moov.start], &new_moov[..], &file[moov.end..]].concat()
}

/// `file` with its `mdat` box's size written in 64 bits (size 1 and a 64-bit size: what a
/// recording over 4 GB has), the chunk offsets moved by the 8 bytes this adds.
pub fn with_64_bit_mdat(file: &[u8]) -> Vec<u8> {
    let top = boxes(file, 0, file.len());
    let mdat = find(&top, b"mdat").expect("an mdat box");
    assert_eq!(mdat.header, 8, "mdat has a 32-bit size already");
    let moov = find(&top, b"moov").expect("a moov box");
    let mut new_moov = file[moov.start..moov.end].to_vec();
    move_chunk_offsets(&mut new_moov, 8);
    let mut header = 1u32.to_be_bytes().to_vec();
    header.extend_from_slice(b"mdat");
    header.extend_from_slice(&((mdat.end - mdat.start + 8) as u64).to_be_bytes());
    let mdat_new = [&header[..], &file[mdat.start + 8..mdat.end]].concat();
    let mut out = Vec::new();
    for b in &top {
        match &b.kind {
            b"mdat" => out.extend_from_slice(&mdat_new),
            b"moov" => out.extend_from_slice(&new_moov),
            _ => out.extend_from_slice(&file[b.start..b.end]),
        }
    }
    out
}

/// `file` with its last box sized 0: "to the end of the file" (what a recorder that
/// cannot seek back writes for its final `mdat`).
pub fn with_open_ended_last_box(file: &[u8]) -> Vec<u8> {
    let top = boxes(file, 0, file.len());
    let last = *top.last().expect("a box");
    assert_eq!(last.header, 8, "the last box has a 32-bit size");
    let mut out = file.to_vec();
    out[last.start..last.start + 4].copy_from_slice(&[0; 4]);
    out
}
