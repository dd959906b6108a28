//! Fuzzing of the EXIF focal length reader (`image_io::decode_photo`, see docs/fuzzing.md):
//! a JPEG whose EXIF block is mutated must decode to the same pixels with or without a
//! focal length, or give an error; no panic, no allocation over the harness limit, no hang.
//! Seeds are TIFF blocks written like `exif_focal.rs`'s, with every focal tag the reader
//! uses. `MONOHAND_FUZZ_CASES` / `MONOHAND_FUZZ_SEED` as for the other fuzz tests.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod exif_support;
#[path = "../../monohand-io/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use std::io::Cursor;

use exif_support::{tag, tiff_block, with_exif, Value};
use fuzz_support::{cases, mutate_binary, run, Regions, TrackingAlloc};
use image::{DynamicImage, ImageFormat, RgbImage};
use monohand_vision::image_io::{decode_photo, PhotoFocal};

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated EXIF blocks in a default `cargo test`.
const CI_CASES: usize = 3000;

#[test]
fn fuzz_exif_focal_length() {
    let mut buf = Cursor::new(Vec::new());
    DynamicImage::ImageRgb8(RgbImage::from_fn(32, 24, |x, y| {
        image::Rgb([(8 * x) as u8, (8 * y) as u8, 50])
    }))
    .write_to(&mut buf, ImageFormat::Jpeg)
    .unwrap();
    let jpeg = buf.into_inner();
    let seeds = vec![
        tiff_block(1, &[(tag::FOCAL_35MM, Value::Short(26))]),
        tiff_block(
            6,
            &[
                (tag::FOCAL_LENGTH, Value::Rational(425, 100)),
                (tag::FOCAL_PLANE_X_RES, Value::Rational(5000, 1)),
                (tag::FOCAL_PLANE_UNIT, Value::Short(3)),
                (tag::PIXEL_X, Value::Long(64)),
            ],
        ),
        tiff_block(
            8,
            &[
                (tag::FOCAL_35MM, Value::Short(50)),
                (tag::FOCAL_LENGTH, Value::Rational(50, 1)),
                (tag::FOCAL_PLANE_X_RES, Value::Rational(4000, 1)),
            ],
        ),
    ];
    let mut with_focal = 0usize;
    let regions: Vec<Regions> = seeds.iter().map(|s| Regions(vec![(0, s.len())])).collect();
    let summary = run(
        "exif",
        &seeds,
        cases(CI_CASES),
        |rng, seeds| mutate_binary(rng, seeds, &regions),
        |tiff| {
            let photo = decode_photo(&with_exif(&jpeg, tiff), "fuzz.jpg")?;
            // The EXIF never breaks the pixels: 32x24, or 24x32 after an orientation.
            let (w, h) = photo.image.dimensions();
            assert!((w, h) == (32, 24) || (w, h) == (24, 32), "{w}x{h}");
            if let Some(f) = photo.focal.used() {
                with_focal += 1;
                assert!(PhotoFocal::PLAUSIBLE_35MM.contains(&f.equivalent_35mm(w, h)));
            }
            Ok::<_, monohand_vision::VisionError>(())
        },
    );
    // Some mutations must leave a focal tag readable (7% with the default seed), or the
    // harness would not be reaching the reader's arithmetic.
    assert!(
        summary.accepted == summary.cases && with_focal > summary.cases / 50,
        "{} of {} decoded, {with_focal} with a focal length",
        summary.accepted,
        summary.cases
    );
    eprintln!(
        "{with_focal} of {} cases kept a focal length",
        summary.cases
    );
}
