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
}

/// The raw EXIF (TIFF) block with `orientation` in IFD0 and `tags` in the EXIF IFD.
pub fn tiff_block(orientation: u16, tags: &[(u16, Value)]) -> Vec<u8> {
    let mut tags = tags.to_vec();
    tags.sort_by_key(|t| t.0);
    let exif_ifd = 8 + 2 + 2 * 12 + 4;
    let data_start = exif_ifd + 2 + 12 * tags.len() + 4;
    let mut out = b"II*\0".to_vec();
    out.extend(8u32.to_le_bytes());
    // IFD0: orientation and the EXIF IFD pointer.
    out.extend(2u16.to_le_bytes());
    entry(&mut out, 0x0112, 3, 1, u32::from(orientation));
    entry(&mut out, 0x8769, 4, 1, exif_ifd as u32);
    out.extend(0u32.to_le_bytes());
    // The EXIF IFD; rationals go after it.
    let mut data = Vec::new();
    out.extend((tags.len() as u16).to_le_bytes());
    for (tag, value) in tags {
        match value {
            Value::Short(v) => entry(&mut out, tag, 3, 1, u32::from(v)),
            Value::Long(v) => entry(&mut out, tag, 4, 1, v),
            Value::Rational(n, d) => {
                entry(&mut out, tag, 5, 1, (data_start + data.len()) as u32);
                data.extend(n.to_le_bytes());
                data.extend(d.to_le_bytes());
            }
        }
    }
    out.extend(0u32.to_le_bytes());
    out.extend(data);
    out
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
}
