//! Reading images: format sniffed from the content (a WebP named `.jpg` still decodes), EXIF
//! orientation applied, every pixel format (8/16-bit, grey, RGBA, CMYK JPEG) converted to 8-bit RGB.

use std::io::Cursor;
use std::path::Path;

use image::{DynamicImage, ImageDecoder, ImageReader, RgbImage};

use crate::error::{Result, VisionError};

/// Smallest accepted side length in pixels: anything smaller cannot show a detectable hand.
pub const MIN_SIDE: u32 = 16;

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
    let bytes = std::fs::read(path).map_err(|source| VisionError::ImageRead {
        path: path.into(),
        source,
    })?;
    decode_rgb(&bytes, &path.display().to_string())
}

/// Decodes an in-memory encoded image (JPEG, PNG or WebP); `what` names it in errors.
pub fn decode_rgb(bytes: &[u8], what: &str) -> Result<RgbImage> {
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
    Ok(rgb)
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
}
