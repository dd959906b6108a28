//! Reading images: format sniffed from the content (a WebP named `.jpg` still decodes), EXIF
//! orientation applied, every pixel format (8/16-bit, grey, RGBA, CMYK JPEG) converted to 8-bit RGB.
//!
//! [`load_photo`] also reads the focal length a camera wrote into the EXIF ([`PhotoFocal`]), so
//! that a photo without a calibration still gets its own field of view.

use std::io::Cursor;
use std::path::Path;

use image::{DynamicImage, ImageDecoder, ImageReader, RgbImage};

use crate::error::{Result, VisionError};

/// Smallest accepted side length in pixels: anything smaller cannot show a detectable hand.
pub const MIN_SIDE: u32 = 16;

/// The largest image decoded, in pixels (2^27, about 134 megapixels: a 108-megapixel phone
/// photo passes; its 8-bit RGB copy takes 3 bytes per pixel, 402 MB at the limit). A larger
/// image is refused before any pixel is decoded, with this limit in the message.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 27;

/// File extensions (lower-case) treated as images by [`images_in_folder`].
pub const IMAGE_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "webp"];

/// Image files directly inside `dir`, sorted by file name (the `frame` order of
/// `monohand detect FOLDER`). Selection is by extension; content is checked when decoding.
pub fn images_in_folder(dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let io = |source| VisionError::ImageRead {
        path: dir.into(),
        source,
    };
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

/// Reads and decodes an image file (see the module docs).
pub fn load_rgb(path: &Path) -> Result<RgbImage> {
    load_photo(path).map(|p| p.image)
}

/// Decodes an in-memory encoded image (JPEG, PNG or WebP); `what` names it in errors.
pub fn decode_rgb(bytes: &[u8], what: &str) -> Result<RgbImage> {
    decode_photo(bytes, what).map(|p| p.image)
}

/// A decoded photo and the focal length its EXIF states, if any.
#[derive(Clone, Debug)]
pub struct Photo {
    /// The pixels, upright (EXIF orientation applied), 8-bit RGB.
    pub image: RgbImage,
    /// The focal length from the EXIF, in pixels of `image`; `None` when the file has no
    /// usable focal length (see [`PhotoFocal`]).
    pub focal: Option<PhotoFocal>,
}

/// A focal length in pixels, read from a photo's EXIF.
///
/// In order of preference (the order COLMAP uses too):
/// 1. `FocalLengthIn35mmFilm` (tag 0xA405, what phones write): the focal length that gives
///    a 36 x 24 mm frame the same angle of view. By its definition (CIPA DC-008) the angle is
///    the diagonal's, so `px = f35 * diagonal_px / 43.27` with 43.27 mm the diagonal of 36 x 24.
/// 2. `FocalLength` (0x920A) in mm with the sensor's `FocalPlaneXResolution` (0xA20E, pixels
///    per `FocalPlaneResolutionUnit` 0xA210: inch, cm, mm or µm), scaled from the EXIF's
///    `PixelXDimension` (0xA002) to the stored image's width when the two differ.
///
/// Both assume the photo shows the whole sensor frame (no crop after capture) and square
/// pixels. Values outside [`PhotoFocal::PLAUSIBLE_35MM`] (as a 35 mm equivalent) are
/// ignored as broken.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotoFocal {
    /// Focal length in pixels (the same on both axes).
    pub px: f64,
    /// The tags it came from, for the user (for example `FocalLengthIn35mmFilm 26 mm`).
    pub source: String,
}

impl PhotoFocal {
    /// 35 mm-equivalent focal lengths taken as real, in mm: from a 4 mm fisheye-like
    /// wide angle (about 157 degrees across the diagonal) to a 2000 mm telephoto.
    pub const PLAUSIBLE_35MM: std::ops::RangeInclusive<f64> = 4.0..=2000.0;

    /// The 35 mm-equivalent focal length of this focal for an image of this size, mm.
    pub fn equivalent_35mm(&self, width: u32, height: u32) -> f64 {
        self.px * DIAGONAL_35MM / (width as f64).hypot(height as f64)
    }
}

/// Diagonal of a 36 x 24 mm frame, mm.
const DIAGONAL_35MM: f64 = 43.266_615_305_567_875;

/// Reads and decodes a photo with its EXIF focal length (see the module docs).
pub fn load_photo(path: &Path) -> Result<Photo> {
    let bytes = std::fs::read(path).map_err(|source| VisionError::ImageRead {
        path: path.into(),
        source,
    })?;
    decode_photo(&bytes, &path.display().to_string())
}

/// Decodes an in-memory photo with its EXIF focal length; `what` names it in errors. A
/// damaged EXIF block is no error: the photo is decoded without a focal length.
pub fn decode_photo(bytes: &[u8], what: &str) -> Result<Photo> {
    let err = |reason: String| VisionError::ImageDecode {
        what: what.into(),
        reason,
    };
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| err(e.to_string()))?;
    if reader.format().is_none() {
        return Err(err(
            "unknown image format (supported: JPEG, PNG, WebP)".into()
        ));
    }
    let mut decoder = reader.into_decoder().map_err(|e| err(e.to_string()))?;
    let (stored_width, stored_height) = decoder.dimensions();
    if u64::from(stored_width) * u64::from(stored_height) > MAX_IMAGE_PIXELS {
        return Err(VisionError::ImageUnusable {
            what: what.into(),
            reason: format!(
                "{stored_width}x{stored_height} pixels is over the largest image monohand \
                 decodes, {:.0} megapixels (image_io::MAX_IMAGE_PIXELS); downscale it first",
                MAX_IMAGE_PIXELS as f64 / 1e6
            ),
        });
    }
    // Read before `orientation`, which may consume the same block.
    let exif = decoder.exif_metadata().ok().flatten();
    let orientation = decoder.orientation().map_err(|e| err(e.to_string()))?;
    let mut img = DynamicImage::from_decoder(decoder).map_err(|e| err(e.to_string()))?;
    img.apply_orientation(orientation);
    let rgb = img.into_rgb8();
    if rgb.width() < MIN_SIDE || rgb.height() < MIN_SIDE {
        return Err(VisionError::ImageUnusable {
            what: what.into(),
            reason: format!(
                "{}x{} pixels is too small to contain a hand (minimum {MIN_SIDE}x{MIN_SIDE})",
                rgb.width(),
                rgb.height()
            ),
        });
    }
    let focal = exif.and_then(|raw| {
        focal_from_exif(raw, stored_width, rgb.width(), rgb.height())
            .map_err(|why| tracing::warn!("{what}: EXIF focal length not used: {why}"))
            .ok()
            .flatten()
    });
    Ok(Photo { image: rgb, focal })
}

/// The focal length in pixels of an image `width` x `height` (upright; `stored_width` is its
/// width as stored, before the EXIF orientation) from its raw EXIF (TIFF) block. `Ok(None)`:
/// no focal length in it; `Err`: one that cannot be right.
fn focal_from_exif(
    raw: Vec<u8>,
    stored_width: u32,
    width: u32,
    height: u32,
) -> std::result::Result<Option<PhotoFocal>, String> {
    use exif::{In, Tag};
    let exif = exif::Reader::new()
        .read_raw(raw)
        .map_err(|e| format!("unreadable EXIF: {e}"))?;
    let number = |tag: Tag| -> Option<f64> {
        let field = exif.get_field(tag, In::PRIMARY)?;
        match &field.value {
            exif::Value::Rational(v) => v.first().map(|r| r.to_f64()),
            exif::Value::SRational(v) => v.first().map(|r| r.to_f64()),
            other => other.get_uint(0).map(f64::from),
        }
    };
    let diagonal = (width as f64).hypot(height as f64);
    let focal = if let Some(f35) = number(Tag::FocalLengthIn35mmFilm).filter(|&f| f > 0.0) {
        // 0 means "unknown" in the standard.
        PhotoFocal {
            px: f35 * diagonal / DIAGONAL_35MM,
            source: format!("EXIF FocalLengthIn35mmFilm {f35} mm"),
        }
    } else {
        let (Some(f_mm), Some(res)) =
            (number(Tag::FocalLength), number(Tag::FocalPlaneXResolution))
        else {
            return Ok(None);
        };
        // Pixels per unit on the sensor; the unit is the inch when the tag is absent.
        let unit_mm = match number(Tag::FocalPlaneResolutionUnit).map_or(2, |u| u as u32) {
            2 => 25.4,
            3 => 10.0,
            4 => 1.0,
            5 => 1e-3,
            u => return Err(format!("FocalPlaneResolutionUnit {u} is not a length")),
        };
        let scale = match number(Tag::PixelXDimension).filter(|&p| p > 0.0) {
            Some(p) => stored_width as f64 / p,
            None => 1.0,
        };
        PhotoFocal {
            px: f_mm * res / unit_mm * scale,
            source: format!(
                "EXIF FocalLength {f_mm} mm at {res} pixels per {} on the sensor",
                match unit_mm {
                    25.4 => "inch",
                    10.0 => "cm",
                    1.0 => "mm",
                    _ => "µm",
                }
            ),
        }
    };
    let f35 = focal.equivalent_35mm(width, height);
    if !(focal.px.is_finite() && PhotoFocal::PLAUSIBLE_35MM.contains(&f35)) {
        return Err(format!(
            "{} gives a 35 mm equivalent of {f35:.1} mm, outside {:?} mm",
            focal.source,
            PhotoFocal::PLAUSIBLE_35MM
        ));
    }
    Ok(Some(focal))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, ImageFormat, Luma, Rgba};

    fn encode(img: DynamicImage, fmt: ImageFormat) -> Vec<u8> {
        let mut buf = Cursor::new(Vec::new());
        img.write_to(&mut buf, fmt).expect("encode");
        buf.into_inner()
    }

    #[test]
    fn sixteen_bit_grey_png_becomes_rgb8() {
        let img = ImageBuffer::<Luma<u16>, _>::from_fn(20, 20, |x, _| Luma([(x * 3000) as u16]));
        let rgb = decode_rgb(
            &encode(DynamicImage::ImageLuma16(img), ImageFormat::Png),
            "t",
        )
        .expect("decode");
        assert_eq!(rgb.dimensions(), (20, 20));
        let p = rgb.get_pixel(10, 0);
        assert_eq!(p[0], p[1]);
        assert!((p[0] as i32 - 30000 * 255 / 65535).abs() <= 1);
    }

    #[test]
    fn folder_listing_is_sorted_and_filtered() {
        let dir = std::env::temp_dir().join(format!("monohand-folder-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        for n in ["b.PNG", "a.jpg", "c.txt", "d.webp"] {
            std::fs::write(dir.join(n), b"x").expect("write");
        }
        let names: Vec<_> = images_in_folder(&dir)
            .expect("list")
            .iter()
            .map(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .unwrap_or("")
                    .to_string()
            })
            .collect();
        assert_eq!(names, ["a.jpg", "b.PNG", "d.webp"]);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn rgba_drops_alpha() {
        let img = ImageBuffer::<Rgba<u8>, _>::from_pixel(17, 18, Rgba([10, 20, 30, 0]));
        let rgb = decode_rgb(
            &encode(DynamicImage::ImageRgba8(img), ImageFormat::Png),
            "t",
        )
        .expect("decode");
        assert_eq!(rgb.get_pixel(0, 0).0, [10, 20, 30]);
    }

    #[test]
    fn tiny_and_corrupt_images_are_clear_errors() {
        let one = DynamicImage::ImageRgb8(RgbImage::new(1, 1));
        let e = decode_rgb(&encode(one, ImageFormat::Png), "one.png").expect_err("1x1");
        assert!(e.to_string().contains("too small"), "{e}");
        let e = decode_rgb(b"\xff\xd8\xff\xe0garbage", "bad.jpg").expect_err("corrupt");
        assert!(matches!(e, VisionError::ImageDecode { .. }), "{e}");
        let e = decode_rgb(b"hello world", "text.jpg").expect_err("not an image");
        assert!(e.to_string().contains("unknown image format"), "{e}");
    }

    /// A PNG chunk: length, type, data, CRC-32 of type and data.
    fn png_chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
        let mut crc = 0xffff_ffffu32;
        for &byte in kind.iter().chain(data) {
            crc ^= u32::from(byte);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xedb8_8320
                } else {
                    crc >> 1
                };
            }
        }
        let mut out = (data.len() as u32).to_be_bytes().to_vec();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        out.extend_from_slice(&(!crc).to_be_bytes());
        out
    }

    /// The header of an 8-bit RGB PNG of `w` x `h` pixels, with a stub of pixel data.
    fn png_header(w: u32, h: u32) -> Vec<u8> {
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend(png_chunk(b"IHDR", &ihdr));
        png.extend(png_chunk(
            b"IDAT",
            &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
        ));
        png.extend(png_chunk(b"IEND", &[]));
        png
    }

    #[test]
    fn an_image_over_the_size_limit_is_refused_before_decoding() {
        // 60 000 x 40 000 pixels claimed by a 60-byte file: refused by its header, with the
        // limit named, before any allocation for its pixels.
        let e = decode_rgb(&png_header(60_000, 40_000), "huge.png").expect_err("too large");
        let msg = e.to_string();
        assert!(matches!(e, VisionError::ImageUnusable { .. }), "{msg}");
        assert!(
            msg.contains("60000x40000") && msg.contains("134 megapixels"),
            "{msg}"
        );
        // Just under the limit the header is accepted, and the stub of pixel data is the
        // error (a decode error, not the size).
        let e = decode_rgb(&png_header(16_384, 8_192), "big.png").expect_err("no pixels");
        assert!(matches!(e, VisionError::ImageDecode { .. }), "{e}");
    }
}
