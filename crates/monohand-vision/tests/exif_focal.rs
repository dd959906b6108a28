//! The focal length a photo's EXIF states, read on JPEGs the test writes with known tags, on
//! the real EXIF of `../shared/data/images/hamer/test1.jpg`, and on the tag sets of real
//! phone photos (their sources are named at each test).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod exif_support;

use std::io::Cursor;

use exif_support::{camera_block, tag, tiff_block, with_exif, Value};
use image::{DynamicImage, ImageFormat, RgbImage};
use monohand_vision::image_io::{decode_photo, load_photo, ExifFocal, PhotoFocal};

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

fn focal_of(orientation: u16, tags: &[(u16, Value)]) -> (u32, u32, ExifFocal) {
    let bytes = with_exif(&jpeg(640, 480), &tiff_block(orientation, tags));
    let photo = decode_photo(&bytes, "test.jpg").expect("the photo decodes");
    (photo.image.width(), photo.image.height(), photo.focal)
}

/// The focal length used, failing the test with the reason when there is none.
fn used(f: ExifFocal) -> PhotoFocal {
    match f {
        ExifFocal::Used(f) => f,
        other => panic!("no focal length used: {other:?}"),
    }
}

/// The reason the stated focal length was refused, failing the test when it was not.
fn refused(f: ExifFocal) -> String {
    match f {
        ExifFocal::Refused(why) => why,
        other => panic!("not refused: {other:?}"),
    }
}

#[test]
fn focal_length_in_35mm_film_is_read_on_the_diagonal() {
    let (w, h, focal) = focal_of(1, &[(tag::FOCAL_35MM, Value::Short(26))]);
    assert_eq!((w, h), (640, 480));
    let focal = used(focal);
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
    assert!((used(focal).px - expected).abs() < 1e-9);
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
    let focal = used(focal_of(1, &tags).2);
    assert!((focal.px - 1062.5).abs() < 1e-9, "{}", focal.px);
    assert_eq!(
        focal.fallback.as_deref(),
        Some("the image is 640x480, resized from the 1280x960 the EXIF was written for")
    );
    assert_eq!(
        focal.source,
        "EXIF FocalLength 4.25 mm at 5000 pixels per cm on the sensor"
    );
    // The 35 mm equivalent wins when both are there.
    let mut both = tags.to_vec();
    both.push((tag::FOCAL_35MM, Value::Short(50)));
    let focal = used(focal_of(1, &both).2);
    assert!((focal.equivalent_35mm(640, 480) - 50.0).abs() < 1e-9);
}

#[test]
fn missing_unknown_or_impossible_focal_lengths_are_not_used_and_the_photo_still_decodes() {
    // No EXIF at all.
    let photo = decode_photo(&jpeg(640, 480), "plain.jpg").expect("decodes");
    assert_eq!(photo.focal, ExifFocal::None);
    // An EXIF block without focal tags.
    assert_eq!(focal_of(1, &[]).2, ExifFocal::None);
    // 0 is "unknown" in the standard.
    assert_eq!(
        focal_of(1, &[(tag::FOCAL_35MM, Value::Short(0))]).2,
        ExifFocal::None
    );
    // A 3 mm 35 mm-equivalent is no real lens (a 161 degree field of view across 640
    // pixels); 2500 mm neither (0.8 degrees): refused, saying why.
    let why = refused(focal_of(1, &[(tag::FOCAL_35MM, Value::Short(3))]).2);
    assert!(
        why.contains("FocalLengthIn35mmFilm 3 mm") && why.contains("5-150"),
        "{why}"
    );
    let why = refused(focal_of(1, &[(tag::FOCAL_35MM, Value::Short(2500))]).2);
    assert!(why.contains("0.8 degree"), "{why}");
    // A zero denominator: no focal length in mm, and a resolution alone says nothing.
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(425, 0)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
    ];
    assert_eq!(focal_of(1, &tags).2, ExifFocal::None);
    // A resolution unit that is no length: the block is not read.
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(425, 100)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
        (tag::FOCAL_PLANE_UNIT, Value::Short(1)),
    ];
    assert_eq!(focal_of(1, &tags).2, ExifFocal::None);
    // A focal length in mm and nothing to say the sensor's size: refused, saying so.
    let why = refused(focal_of(1, &[(tag::FOCAL_LENGTH, Value::Rational(425, 100))]).2);
    assert!(why.contains("nothing says the sensor's size"), "{why}");
    // A damaged block: the TIFF cut in the middle of the EXIF IFD.
    let mut tiff = tiff_block(1, &[(tag::FOCAL_35MM, Value::Short(26))]);
    tiff.truncate(40);
    let photo = decode_photo(&with_exif(&jpeg(640, 480), &tiff), "cut.jpg").expect("decodes");
    assert_eq!(photo.image.dimensions(), (640, 480));
    assert_eq!(photo.focal, ExifFocal::None);
}

#[test]
fn a_png_has_no_focal_length() {
    let mut buf = Cursor::new(Vec::new());
    DynamicImage::ImageRgb8(RgbImage::new(64, 48))
        .write_to(&mut buf, ImageFormat::Png)
        .expect("encode");
    let photo = decode_photo(buf.get_ref(), "t.png").expect("decodes");
    assert_eq!(photo.focal, ExifFocal::None);
}

/// `../shared/data/images/<rel>`; a missing file fails the test.
fn shared_image(rel: &str) -> std::path::PathBuf {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/images")
        .join(rel);
    assert!(
        path.is_file(),
        "{} not found (../shared beside the repository)",
        path.display()
    );
    path
}

/// `hamer/test1.jpg`: a Canon EOS 5DS R photo (88 mm) exported at 848x565 by Lightroom,
/// whose EXIF keeps the sensor's own `FocalPlaneXResolution` (2413.33 px/cm, for its
/// 8688-pixel-wide frame) but has no `FocalLengthIn35mmFilm` and no `PixelXDimension`.
/// Read against 848 pixels the resolution gave fx 21237 px (2.3 degrees); the sensor
/// database's 36 mm wide sensor gives 88 * 848 / 36 = 2072.9 px.
#[test]
fn a_resized_camera_photo_gets_its_camera_from_the_sensor_database() {
    let photo = load_photo(&shared_image("hamer/test1.jpg")).expect("the photo decodes");
    assert_eq!(photo.image.dimensions(), (848, 565));
    let focal = used(photo.focal);
    let want = 88.0 * 848.0 / 36.0;
    assert!((focal.px / 2073.0 - 1.0).abs() < 0.02, "{}", focal.px);
    assert!((focal.px - want).abs() < 1e-9, "{} vs {want}", focal.px);
    assert_eq!(focal.sensor_width_mm, Some(36.0));
    assert_eq!(
        focal.source,
        "EXIF FocalLength 88 mm on the Canon EOS 5DS R's 36 mm wide sensor (sensor database)"
    );
    let why = focal.fallback.expect("why not the focal plane resolution");
    assert!(
        why.contains("no FocalLengthIn35mmFilm")
            && why.contains("2413.33 pixels per cm implies a sensor 3.5 mm wide")
            && why.contains("resized"),
        "{why}"
    );
}

/// The same tags as `hamer/test1.jpg` (its FocalLength, FocalPlaneXResolution and unit), on a
/// camera the sensor database does not know: the focal plane resolution alone gives a 2.3
/// degree field of view, so it is refused and the reason says the photo was resized.
#[test]
fn a_resized_photo_of_an_unknown_camera_is_refused_with_the_reason() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(88, 1)),
        (tag::FOCAL_PLANE_X_RES, Value::Rational(7240, 3)),
        (tag::FOCAL_PLANE_UNIT, Value::Short(3)),
    ];
    let block = camera_block(1, Some(("Nocamera", "Model Z 1")), &tags);
    let photo = decode_photo(&with_exif(&jpeg(848, 565), &block), "t.jpg").expect("decodes");
    let why = refused(photo.focal);
    assert!(
        why.contains("fx 21237 px for 848x565")
            && why.contains("2.3 degree")
            && why.contains("a sensor 3.5 mm wide")
            && why.contains("resized"),
        "{why}"
    );
}

/// A photo whose tags come from a real phone's EXIF (`make`, `model`, orientation and
/// `tags` as the phone wrote them), on synthetic pixels of `w` x `h` as stored.
fn phone(
    make_model: (&'static str, &'static str),
    orientation: u16,
    tags: &[(u16, Value)],
    w: u32,
    h: u32,
) -> (u32, u32, ExifFocal) {
    let block = camera_block(orientation, Some(make_model), tags);
    let photo = decode_photo(&with_exif(&jpeg(w, h), &block), "phone.jpg").expect("decodes");
    (photo.image.width(), photo.image.height(), photo.focal)
}

/// Diagonal of the 36 x 24 mm frame.
const D35: f64 = 43.266_615_305_567_875;

/// The field of view across the diagonal of a focal length in pixels, degrees.
fn diagonal_fov(px: f64, w: u32, h: u32) -> f64 {
    2.0 * (0.5 * f64::from(w).hypot(f64::from(h)) / px)
        .atan()
        .to_degrees()
}

// The phone tag sets below are real: they are the EXIF of photos in metadata-extractor's
// image collection (github.com/drewnoakes/metadata-extractor-images, commit 4beba640,
// "You are free to use these media files however you wish"), as its text dumps
// (`*/metadata/java/*.txt`) list them. The dumps print FocalLength to one decimal (Apple's
// 4.25 mm lens as 4.3). Only the pixels are synthetic, smaller than the phones' own.

/// iPhone 11 Pro, main camera (`heic/IMG_2927.HEIC`): Make Apple, Model iPhone 11 Pro,
/// orientation 1, FocalLength 4.3 mm, FocalLengthIn35mmFilm 26, PixelXDimension 4032,
/// PixelYDimension 3024. Apple gives the main camera as 26 mm: a 79.5 degree diagonal
/// field of view. Here the photo was resized to 1008x756 (a quarter), and the camera
/// agrees with FocalLength over the sensor database's 5.76 mm wide sensor within 3%.
#[test]
fn an_iphone_photo_resized_keeps_the_phones_field_of_view() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(43, 10)),
        (tag::FOCAL_35MM, Value::Short(26)),
        (tag::PIXEL_X, Value::Long(4032)),
        (tag::PIXEL_Y, Value::Long(3024)),
    ];
    let (w, h, f) = phone(("Apple", "iPhone 11 Pro"), 1, &tags, 1008, 756);
    let f = used(f);
    let fov = diagonal_fov(f.px, w, h);
    let apple = 2.0 * (0.5 * D35 / 26.0).atan().to_degrees();
    assert!(
        (fov - apple).abs() < 0.01 && (fov - 79.5).abs() < 0.1,
        "{fov}"
    );
    assert_eq!(f.source, "EXIF FocalLengthIn35mmFilm 26 mm");
    assert!(f
        .fallback
        .as_deref()
        .is_some_and(|n| n.contains("resized from the 4032x3024")));
    let from_db = 4.3 * 1008.0 / 5.76;
    assert!((f.px / from_db - 1.0).abs() < 0.03, "{} vs {from_db}", f.px);
}

/// iPhone XR (`heic/Issue 263 dotnet.heic`): Make Apple, Model iPhone XR, orientation 6
/// (held upright), FocalLength 4.3 mm, DigitalZoomRatio 1.1, FocalLengthIn35mmFilm 28,
/// 4032x3024. The phone wrote the zoom into the 35 mm equivalent (its 26 mm main camera
/// times 1.1 is 28.6): the camera is 28 mm's, and the crop factor check divides the
/// zoom out (28 / (4.3 * 1.1) = 5.9, a 7.3 mm sensor diagonal, the XR's 1/2.55").
#[test]
fn an_iphone_photo_with_digital_zoom_uses_the_zoomed_equivalent() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(43, 10)),
        (tag::DIGITAL_ZOOM, Value::Rational(11, 10)),
        (tag::FOCAL_35MM, Value::Short(28)),
        (tag::PIXEL_X, Value::Long(4032)),
        (tag::PIXEL_Y, Value::Long(3024)),
    ];
    let (w, h, f) = phone(("Apple", "iPhone XR"), 6, &tags, 1008, 756);
    assert_eq!((w, h), (756, 1008), "upright");
    let f = used(f);
    assert!((f.px - 28.0 * 1260.0 / D35).abs() < 1e-9, "{}", f.px);
    // FocalLength with the zoom over the database's 5.76 mm wide XR sensor agrees.
    let from_db = 4.3 * 1.1 * 1008.0 / 5.76;
    assert!((f.px / from_db - 1.0).abs() < 0.03, "{} vs {from_db}", f.px);
}

/// Google Pixel 2 (`jpg/Google Pixel 2.jpg`): Make Google, Model Pixel 2, stored upright
/// 3024x4032 (orientation 1), FocalLength 4.4 mm, DigitalZoomRatio 0 ("not used"),
/// FocalLengthIn35mmFilm 27. Google's specification: a 1/2.55" sensor (7.06 mm diagonal);
/// 27 / 4.4 is a crop factor of 6.1, a 7.05 mm diagonal.
#[test]
fn a_pixel_photo_matches_its_sensor() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(44, 10)),
        (tag::DIGITAL_ZOOM, Value::Rational(0, 1)),
        (tag::FOCAL_35MM, Value::Short(27)),
        (tag::PIXEL_X, Value::Long(3024)),
        (tag::PIXEL_Y, Value::Long(4032)),
    ];
    let (w, h, f) = phone(("Google", "Pixel 2"), 1, &tags, 756, 1008);
    let f = used(f);
    assert!((f.px - 27.0 * 1260.0 / D35).abs() < 1e-9, "{}", f.px);
    let sensor_diagonal = D35 * 4.4 / 27.0;
    assert!((sensor_diagonal - 7.06).abs() < 0.05, "{sensor_diagonal}");
    // The 35 mm equivalent with this image's size is the phone's 27 mm.
    assert!((f.equivalent_35mm(w, h) - 27.0).abs() < 1e-9);
}

/// Samsung Galaxy S8 (`jpg/Samsung SM-G950F (Galaxy S8).jpg`): Make samsung, Model
/// SM-G950F, orientation 6, FocalLength 4.2 mm, FocalLengthIn35mmFilm 26, 4032x3024.
/// The database knows the S8 as "Galaxy S8", not by the model code the phone writes, so
/// only the 35 mm equivalent can give the camera.
#[test]
fn a_samsung_photo_turned_upright_keeps_its_focal_length() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(42, 10)),
        (tag::FOCAL_35MM, Value::Short(26)),
        (tag::PIXEL_X, Value::Long(4032)),
        (tag::PIXEL_Y, Value::Long(3024)),
    ];
    let (w, h, f) = phone(("samsung", "SM-G950F"), 6, &tags, 1008, 756);
    assert_eq!((w, h), (756, 1008));
    let f = used(f);
    assert!((f.px - 26.0 * 1260.0 / D35).abs() < 1e-9, "{}", f.px);
    assert!(monohand_vision::sensor_db::lookup("samsung", "SM-G950F").is_none());
}

/// Samsung Galaxy K Zoom (`jpg/Samsung SM-C115 (Galaxy K Zoom).jpg`): a phone with a 10x
/// optical zoom, at its long end: FocalLength 44 mm, FocalLengthIn35mmFilm 245,
/// DigitalZoomRatio 1, 5184x3888. An 8.1 degree horizontal field of view, a real one.
#[test]
fn a_zoom_phone_at_its_long_end_is_a_real_telephoto() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(44, 1)),
        (tag::DIGITAL_ZOOM, Value::Rational(1, 1)),
        (tag::FOCAL_35MM, Value::Short(245)),
        (tag::PIXEL_X, Value::Long(5184)),
        (tag::PIXEL_Y, Value::Long(3888)),
    ];
    let (w, _, f) = phone(("SAMSUNG", "SM-C115"), 1, &tags, 1296, 972);
    let f = used(f);
    let hfov = 2.0 * (0.5 * f64::from(w) / f.px).atan().to_degrees();
    assert!((hfov - 8.1).abs() < 0.05, "{hfov}");
}

/// A phone photo cropped to a square: the iPhone 11 Pro's tags (above) on a 3024x3024
/// image, one side of the 4032x3024 frame kept. Not resized, so the focal length in pixels
/// is the uncropped frame's: 26 mm on its 5040-pixel diagonal. Cropped *and* resized (a
/// 756x756 copy), where the lens's frame lies in the image is unknown: refused, saying why.
#[test]
fn a_cropped_phone_photo_keeps_the_uncropped_frames_focal_length() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(43, 10)),
        (tag::FOCAL_35MM, Value::Short(26)),
        (tag::PIXEL_X, Value::Long(4032)),
        (tag::PIXEL_Y, Value::Long(3024)),
    ];
    let (w, h, f) = phone(("Apple", "iPhone 11 Pro"), 1, &tags, 3024, 3024);
    assert_eq!((w, h), (3024, 3024));
    let f = used(f);
    assert!((f.px - 26.0 * 5040.0 / D35).abs() < 1e-9, "{}", f.px);
    assert!(
        f.fallback
            .as_deref()
            .is_some_and(|n| n.contains("cropped from the 4032x3024")),
        "{:?}",
        f.fallback
    );
    let (_, _, f) = phone(("Apple", "iPhone 11 Pro"), 1, &tags, 756, 756);
    let why = refused(f);
    assert!(why.contains("cropped and resized"), "{why}");
}

/// OnePlus 8 (`jpg/OnePlus8.jpg`): Make OnePlus, Model IN2023, FocalLength 3.1 mm,
/// FocalLengthIn35mmFilm 0 ("unknown"), 4000x3000, no focal plane resolution. Nothing says
/// the sensor's size: refused with that reason (the generic camera is used).
#[test]
fn a_phone_without_a_35mm_equivalent_is_said() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(31, 10)),
        (tag::FOCAL_35MM, Value::Short(0)),
        (tag::PIXEL_X, Value::Long(4000)),
        (tag::PIXEL_Y, Value::Long(3000)),
    ];
    let (_, _, f) = phone(("OnePlus", "IN2023"), 1, &tags, 1000, 750);
    let why = refused(f);
    assert!(
        why.contains("FocalLength 3.1 mm") && why.contains("the OnePlus IN2023 is not"),
        "{why}"
    );
}

/// An editor that rewrote FocalLengthIn35mmFilm after a 4x crop of the iPhone 11 Pro's
/// frame (104 mm against a 4.3 mm lens: a crop factor of 24, no camera's) is not believed;
/// FocalLength over the database's sensor width gives the camera instead.
#[test]
fn an_edited_35mm_equivalent_that_no_sensor_explains_is_refused() {
    let tags = [
        (tag::FOCAL_LENGTH, Value::Rational(43, 10)),
        (tag::FOCAL_35MM, Value::Short(104)),
    ];
    let (w, _, f) = phone(("Apple", "iPhone 11 Pro"), 1, &tags, 1008, 756);
    let f = used(f);
    assert!((f.px - 4.3 * f64::from(w) / 5.76).abs() < 1e-9, "{}", f.px);
    let why = f.fallback.expect("why not the 35 mm equivalent");
    assert!(why.contains("crop factor of 24.19"), "{why}");
}
