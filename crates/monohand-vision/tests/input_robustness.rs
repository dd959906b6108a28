//! Awkward inputs: corrupt files, a 1x1 image, 16-bit, grayscale and RGBA PNGs, a WebP named
//! `.jpg`, a CMYK JPEG, and images without hands.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use std::path::PathBuf;

use image::{DynamicImage, ImageFormat};
use monohand_vision::{HandPipeline, ModelOptions, PipelineOptions, VisionError};

fn pipeline() -> Option<HandPipeline> {
    let store = common::models()?;
    let models = ModelOptions {
        model_dir: Some(store.dir().to_path_buf()),
        ..Default::default()
    };
    Some(HandPipeline::new(&models, PipelineOptions::default()).expect("pipeline"))
}

#[test]
fn corrupt_truncated_and_non_image_files_give_clear_errors() {
    let scratch = tempfile::tempdir().expect("tmp dir");
    let Some(src) = common::shared("images/hamer/test2.jpg") else {
        return;
    };
    let Some(p) = pipeline() else { return };
    let bytes = std::fs::read(src).expect("read");
    let truncated = scratch.path().join("truncated.jpg");
    std::fs::write(&truncated, &bytes[..bytes.len() / 3]).expect("write");
    match p.detect_file(&truncated) {
        Err(VisionError::ImageDecode { what, reason }) => {
            assert!(what.contains("truncated.jpg"));
            println!("truncated JPEG: {reason}");
        }
        // Some decoders fill missing scanlines; then the result must still be a valid list.
        Ok(found) => println!(
            "truncated JPEG decoded partially: {} hands",
            found.hands.len()
        ),
        Err(e) => panic!("unexpected error kind: {e}"),
    }
    let text = scratch.path().join("notes.jpg");
    std::fs::write(&text, b"this is not an image").expect("write");
    let e = p.detect_file(&text).expect_err("text file");
    assert!(matches!(e, VisionError::ImageDecode { .. }), "{e}");
    let e = p
        .detect_file(&scratch.path().join("does-not-exist.png"))
        .expect_err("missing");
    assert!(matches!(e, VisionError::ImageRead { .. }), "{e}");
}

#[test]
fn one_pixel_image_is_a_clear_error() {
    let scratch = tempfile::tempdir().expect("tmp dir");
    let Some(p) = pipeline() else { return };
    let path = scratch.path().join("one.png");
    DynamicImage::new_rgb8(1, 1).save(&path).expect("save");
    let e = p.detect_file(&path).expect_err("1x1");
    assert!(e.to_string().contains("too small"), "{e}");
}

#[test]
fn sixteen_bit_grey_and_rgba_versions_find_the_same_hand() {
    let scratch = tempfile::tempdir().expect("tmp dir");
    let Some(src) = common::shared("images/pinto/hand.png") else {
        return;
    };
    let Some(p) = pipeline() else { return };
    let base = p.detect_file(&src).expect("detect");
    assert_eq!(base.hands.len(), 1);
    let wrist = base.hands[0].keypoints.points[0];
    let img = image::open(&src).expect("open");
    let variants = [
        ("rgb16.png", DynamicImage::ImageRgb16(img.to_rgb16())),
        ("rgba8.png", DynamicImage::ImageRgba8(img.to_rgba8())),
        ("rgba16.png", DynamicImage::ImageRgba16(img.to_rgba16())),
        ("grey8.png", DynamicImage::ImageLuma8(img.to_luma8())),
        ("grey16.png", DynamicImage::ImageLuma16(img.to_luma16())),
    ];
    for (name, v) in variants {
        let path = scratch.path().join(name);
        v.save_with_format(&path, ImageFormat::Png).expect("save");
        let found = p.detect_file(&path).expect(name);
        assert_eq!(found.hands.len(), 1, "{name}");
        let w = found.hands[0].keypoints.points[0];
        let d = ((w[0] - wrist[0]).powi(2) + (w[1] - wrist[1]).powi(2)).sqrt();
        println!("{name}: wrist moved {d:.2} px");
        assert!(d < 10.0, "{name}: wrist moved {d:.1} px");
    }
}

#[test]
fn webp_disguised_as_jpg_decodes() {
    let Some(src) = common::shared("images/wilor/test3.jpg") else {
        return;
    };
    let Some(p) = pipeline() else { return };
    let found = p
        .detect_file(&src)
        .expect("WebP named .jpg must decode by content");
    assert_eq!(found.image_size, (600, 600));
    assert!(!found.hands.is_empty(), "stacked hands photo");
}

#[test]
fn cmyk_jpeg_decodes_to_its_colours() {
    // tests/fixtures/cmyk_quadrants.jpg: 64x64, made with Pillow from an RGB image of four
    // quadrants (red, green, blue, white) converted to CMYK (Adobe JPEG, as print
    // workflows and some scanners write them).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/cmyk_quadrants.jpg");
    let rgb = monohand_vision::image_io::load_rgb(&path).expect("CMYK JPEG decodes");
    assert_eq!(rgb.dimensions(), (64, 64));
    for ((x, y), want) in [
        ((16, 16), [220, 30, 30]),
        ((48, 16), [30, 200, 60]),
        ((16, 48), [30, 60, 220]),
        ((48, 48), [255, 255, 255]),
    ] {
        let got = rgb.get_pixel(x, y).0;
        assert!(
            got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= 12),
            "pixel ({x}, {y}): {got:?}, want {want:?}"
        );
    }
}

#[test]
fn images_without_hands_return_empty() {
    let scratch = tempfile::tempdir().expect("tmp dir");
    let Some(p) = pipeline() else { return };
    // A flat grey image and a smooth gradient.
    let grey = scratch.path().join("grey.png");
    DynamicImage::ImageRgb8(image::RgbImage::from_pixel(
        320,
        240,
        image::Rgb([128, 128, 128]),
    ))
    .save(&grey)
    .expect("save");
    assert!(p.detect_file(&grey).expect("grey").hands.is_empty());
    let grad = scratch.path().join("gradient.png");
    DynamicImage::ImageRgb8(image::RgbImage::from_fn(400, 300, |x, y| {
        image::Rgb([(x / 2) as u8, (y / 2) as u8, 90])
    }))
    .save(&grad)
    .expect("save");
    assert!(p.detect_file(&grad).expect("gradient").hands.is_empty());
    // A real photo region without hands: the right half of the STB frame (wall pattern).
    if let Some(stb) = common::shared("stb_b1counting/images/B1Counting/BB_left_0.png") {
        let img = image::open(stb).expect("open").to_rgb8();
        let wall = image::imageops::crop_imm(&img, 0, 0, 380, 160).to_image();
        let path = scratch.path().join("wall.png");
        wall.save(&path).expect("save");
        let found = p.detect_file(&path).expect("wall");
        assert!(
            found.hands.is_empty(),
            "no hand on the wall crop: {:?}",
            found.hands
        );
    }
}
