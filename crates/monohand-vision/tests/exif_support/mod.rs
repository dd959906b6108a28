//! Writes JPEGs with a chosen EXIF block, for the tests of the EXIF focal length (shared by
//! monohand-vision's and monohand-cli's tests through `#[path]`).
//!
//! The block is built byte by byte from the TIFF 6.0 / EXIF 2.3 layout, independently of the
//! reader under test: a little-endian TIFF header, IFD0 with the orientation (0x0112) and the
//! pointer to the EXIF IFD (0x8769), then the EXIF IFD with the given tags.
#![allow(dead_code)]

/// A value of one EXIF tag.
#[derive(Clone, Copy, Debug)]
pub enum Value {
    /// TIFF SHORT (type 3).
    Short(u16),
    /// TIFF LONG (type 4).
    Long(u32),
    /// TIFF RATIONAL (type 5): numerator, denominator.
    Rational(u32, u32),
    /// TIFF ASCII (type 2), NUL-terminated in the file.
    Ascii(&'static str),
}

/// The raw EXIF (TIFF) block with `orientation` in IFD0 and `tags` in the EXIF IFD.
pub fn tiff_block(orientation: u16, tags: &[(u16, Value)]) -> Vec<u8> {
    camera_block(orientation, None, tags)
}

/// [`tiff_block`] with the camera's `Make` and `Model` (0x010F, 0x0110) in IFD0, as
/// cameras write them.
pub fn camera_block(
    orientation: u16,
    make_model: Option<(&'static str, &'static str)>,
    tags: &[(u16, Value)],
) -> Vec<u8> {
    let mut ifd0: Vec<(u16, Value)> = vec![(0x0112, Value::Short(orientation))];
    if let Some((make, model)) = make_model {
        ifd0.push((0x010F, Value::Ascii(make)));
        ifd0.push((0x0110, Value::Ascii(model)));
    }
    ifd0.sort_by_key(|t| t.0);
    let mut tags = tags.to_vec();
    tags.sort_by_key(|t| t.0);
    // Layout: header (8), IFD0 (its entries and the EXIF IFD pointer), its data, the EXIF
    // IFD, its data.
    let ifd0_len = 2 + 12 * (ifd0.len() + 1) + 4;
    let ifd0_data: usize = ifd0.iter().map(|(_, v)| data_len(v)).sum();
    let exif_ifd = 8 + ifd0_len + ifd0_data;
    let mut out = b"II*\0".to_vec();
    out.extend(8u32.to_le_bytes());
    let mut data = Vec::new();
    out.extend(((ifd0.len() + 1) as u16).to_le_bytes());
    let ifd0_data_start = 8 + ifd0_len;
    for &(tag, value) in &ifd0 {
        put(&mut out, &mut data, ifd0_data_start, tag, value);
    }
    entry(&mut out, 0x8769, 4, 1, exif_ifd as u32);
    out.extend(0u32.to_le_bytes());
    out.extend(std::mem::take(&mut data));
    assert_eq!(out.len(), exif_ifd);
    // The EXIF IFD; rationals and long strings go after it.
    let data_start = exif_ifd + 2 + 12 * tags.len() + 4;
    out.extend((tags.len() as u16).to_le_bytes());
    for (tag, value) in tags {
        put(&mut out, &mut data, data_start, tag, value);
    }
    out.extend(0u32.to_le_bytes());
    out.extend(data);
    out
}

/// Bytes a value takes outside its IFD entry.
fn data_len(v: &Value) -> usize {
    match v {
        Value::Rational(..) => 8,
        Value::Ascii(s) if s.len() + 1 > 4 => s.len() + 1,
        _ => 0,
    }
}

/// One IFD entry for `value`, its data (if it does not fit the entry) appended to `data`,
/// which starts at `data_start` in the block.
fn put(out: &mut Vec<u8>, data: &mut Vec<u8>, data_start: usize, tag: u16, value: Value) {
    match value {
        Value::Short(v) => entry(out, tag, 3, 1, u32::from(v)),
        Value::Long(v) => entry(out, tag, 4, 1, v),
        Value::Rational(n, d) => {
            entry(out, tag, 5, 1, (data_start + data.len()) as u32);
            data.extend(n.to_le_bytes());
            data.extend(d.to_le_bytes());
        }
        Value::Ascii(s) => {
            let mut bytes = s.as_bytes().to_vec();
            bytes.push(0);
            let count = bytes.len() as u32;
            if bytes.len() <= 4 {
                bytes.resize(4, 0);
                out.extend(tag.to_le_bytes());
                out.extend(2u16.to_le_bytes());
                out.extend(count.to_le_bytes());
                out.extend(bytes);
            } else {
                entry(out, tag, 2, count, (data_start + data.len()) as u32);
                data.extend(bytes);
            }
        }
    }
}

fn entry(out: &mut Vec<u8>, tag: u16, kind: u16, count: u32, value: u32) {
    out.extend(tag.to_le_bytes());
    out.extend(kind.to_le_bytes());
    out.extend(count.to_le_bytes());
    if kind == 3 {
        // A SHORT sits in the first two bytes of the value field.
        out.extend((value as u16).to_le_bytes());
        out.extend([0, 0]);
    } else {
        out.extend(value.to_le_bytes());
    }
}

/// `jpeg` (a JPEG file) with an APP1 EXIF segment holding `tiff` inserted after its SOI.
pub fn with_exif(jpeg: &[u8], tiff: &[u8]) -> Vec<u8> {
    assert_eq!(&jpeg[..2], &[0xFF, 0xD8], "not a JPEG");
    let len = (2 + 6 + tiff.len()) as u16;
    let mut out = jpeg[..2].to_vec();
    out.extend([0xFF, 0xE1]);
    out.extend(len.to_be_bytes());
    out.extend(b"Exif\0\0");
    out.extend(tiff);
    out.extend(&jpeg[2..]);
    out
}

/// The tags used by the tests.
pub mod tag {
    /// FocalLengthIn35mmFilm, SHORT, mm.
    pub const FOCAL_35MM: u16 = 0xA405;
    /// FocalLength, RATIONAL, mm.
    pub const FOCAL_LENGTH: u16 = 0x920A;
    /// FocalPlaneXResolution, RATIONAL, pixels per unit.
    pub const FOCAL_PLANE_X_RES: u16 = 0xA20E;
    /// FocalPlaneResolutionUnit, SHORT: 2 inch, 3 cm.
    pub const FOCAL_PLANE_UNIT: u16 = 0xA210;
    /// PixelXDimension, LONG.
    pub const PIXEL_X: u16 = 0xA002;
    /// PixelYDimension, LONG.
    pub const PIXEL_Y: u16 = 0xA003;
    /// DigitalZoomRatio, RATIONAL.
    pub const DIGITAL_ZOOM: u16 = 0xA404;
}
