//! The focal length a photo's EXIF states, read on JPEGs the test writes with known tags.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod exif_support;

use std::io::Cursor;

use exif_support::{tag, tiff_block, with_exif, Value};
use image::{DynamicImage, ImageFormat, RgbImage};
use monohand_vision::image_io::{decode_photo, PhotoFocal};

/// A plain 640x480 JPEG (a gradient, so the encoder has something to do).
fn jpeg(w: u32, h: u32) -> Vec<u8> {
    let img = RgbImage::from_fn(w, h, |x, y| {
        image::Rgb([(x % 256) as u8, (y % 256) as u8, 90])
    });
    let mut buf = Cursor::new(Vec::new());
    DynamicImage::ImageRgb8(img)
        .write_to(&mut buf, ImageFormat::Jpeg)
        .expect("encode");
    buf.into_inner()
}

fn focal_of(orientation: u16, tags: &[(u16, Value)]) -> (u32, u32, Option<PhotoFocal>) {
    let bytes = with_exif(&jpeg(640, 480), &tiff_block(orientation, tags));
    let photo = decode_photo(&bytes, "test.jpg").expect("the photo decodes");
    (photo.image.width(), photo.image.height(), photo.focal)
}

#[test]
fn focal_length_in_35mm_film_is_read_on_the_diagonal() {
    let (w, h, focal) = focal_of(1, &[(tag::FOCAL_35MM, Value::Short(26))]);
    assert_eq!((w, h), (640, 480));
    let focal = focal.expect("a focal length");
    // 26 mm on a 36 x 24 mm frame's diagonal, scaled to the 800-pixel diagonal.
    let expected = 26.0 * 800.0 / (36.0f64).hypot(24.0);
    assert!(
        (focal.px - expected).abs() < 1e-9,
        "{} vs {expected}",
        focal.px
    );
    assert_eq!(focal.source, "EXIF FocalLengthIn35mmFilm 26 mm");
    assert!((focal.equivalent_35mm(640, 480) - 26.0).abs() < 1e-9);
}

#[test]
fn a_rotated_photo_keeps_its_focal_length_in_pixels() {
    let (w, h, focal) = focal_of(6, &[(tag::FOCAL_35MM, Value::Short(26))]);
    assert_eq!((w, h), (480, 640), "orientation 6 is applied");
    let expected = 26.0 * 800.0 / (36.0f64).hypot(24.0);
    assert!((focal.expect("a focal length").px - expected).abs() < 1e-9);
}

#[test]
fn focal_length_with_the_sensor_resolution_is_scaled_to_the_stored_width() {
    // 4.25 mm, 5000 pixels per cm on the sensor, for a 1280-pixel-wide original that was
    // saved at 640: 4.25 * 500 px/mm * 640 / 1280.
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(425, 100)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
        (tag::FOCAL_PLANE_UNIT, Value::Short(3)),
        (tag::PIXEL_X, Value::Long(1280)),
    ];
    let focal = focal_of(1, &tags).2.expect("a focal length");
    assert!((focal.px - 1062.5).abs() < 1e-9, "{}", focal.px);
    assert_eq!(
        focal.source,
        "EXIF FocalLength 4.25 mm at 5000 pixels per cm on the sensor"
    );
    // The 35 mm equivalent wins when both are there.
    let mut both = tags.to_vec();
    both.push((tag::FOCAL_35MM, Value::Short(50)));
    let focal = focal_of(1, &both).2.expect("a focal length");
    assert!((focal.equivalent_35mm(640, 480) - 50.0).abs() < 1e-9);
}

#[test]
fn missing_unknown_or_impossible_focal_lengths_give_none_and_the_photo_still_decodes() {
    // No EXIF at all.
    let photo = decode_photo(&jpeg(640, 480), "plain.jpg").expect("decodes");
    assert!(photo.focal.is_none());
    // An EXIF block without focal tags.
    assert!(focal_of(1, &[]).2.is_none());
    // 0 is "unknown" in the standard.
    assert!(focal_of(1, &[(tag::FOCAL_35MM, Value::Short(0))])
        .2
        .is_none());
    // A 3 mm 35 mm-equivalent is no real lens; 2500 mm neither.
    assert!(focal_of(1, &[(tag::FOCAL_35MM, Value::Short(3))])
        .2
        .is_none());
    assert!(focal_of(1, &[(tag::FOCAL_35MM, Value::Short(2500))])
        .2
        .is_none());
    // A zero denominator.
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(425, 0)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
    ];
    assert!(focal_of(1, &tags).2.is_none());
    // A resolution unit that is no length.
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(425, 100)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
        (tag::FOCAL_PLANE_UNIT, Value::Short(1)),
    ];
    assert!(focal_of(1, &tags).2.is_none());
    // A damaged block: the TIFF cut in the middle of the EXIF IFD.
    let mut tiff = tiff_block(1, &[(tag::FOCAL_35MM, Value::Short(26))]);
    tiff.truncate(40);
    let photo = decode_photo(&with_exif(&jpeg(640, 480), &tiff), "cut.jpg").expect("decodes");
    assert_eq!(photo.image.dimensions(), (640, 480));
    assert!(photo.focal.is_none());
}

#[test]
fn a_png_has_no_focal_length() {
    let mut buf = Cursor::new(Vec::new());
    DynamicImage::ImageRgb8(RgbImage::new(64, 48))
        .write_to(&mut buf, ImageFormat::Png)
        .expect("encode");
    let photo = decode_photo(buf.get_ref(), "t.png").expect("decodes");
    assert!(photo.focal.is_none());
}
