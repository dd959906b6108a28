//! Fuzzing of monohand-media's reader of QuickTime metadata (`parse_quicktime_metadata`, see
//! docs/fuzzing.md): every mutated movie must give `Ok` or `Err`, no panic, no allocation
//! over the harness limit, no hang. Seeds: the fixtures of `tests/data/quicktime` (Apple's
//! layout written into small movies), mutated mostly in their `moov` box, where the boxes
//! the reader walks are. `MONOHAND_FUZZ_CASES` / `MONOHAND_FUZZ_SEED` as for the other fuzz
//! tests.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "../../monohand-io/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{cases, mutate_binary, run, seed_file, Regions, TrackingAlloc};
use monohand_media::video::parse_quicktime_metadata;
use std::io::Cursor;

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated movies in a default `cargo test`.
const CI_CASES: usize = 3000;

#[test]
fn fuzz_quicktime() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/quicktime");
    let seeds: Vec<Vec<u8>> = [
        "iphone_int.mov",
        "faststart_float.mov",
        "text_focal.mp4",
        "mdat64_float64.mov",
        "movie_keys_ffmpeg.mov",
    ]
    .iter()
    .map(|f| seed_file(dir.join(f)))
    .collect();
    // Mutations go to the movie box (the rest is ftyp and the media's bytes).
    let regions: Vec<Regions> = seeds
        .iter()
        .map(|s| {
            let moov = s.windows(4).position(|w| w == b"moov").unwrap() - 4;
            let end = moov + u32::from_be_bytes(s[moov..moov + 4].try_into().unwrap()) as usize;
            Regions(vec![(moov, end.min(s.len()))])
        })
        .collect();
    let mut with_focal = 0usize;
    let summary = run(
        "quicktime",
        &seeds,
        cases(CI_CASES),
        |rng, seeds| mutate_binary(rng, seeds, &regions),
        |movie| {
            let meta = parse_quicktime_metadata(Cursor::new(movie))?;
            let cam = meta.camera();
            if let Some(Ok(_)) = cam.focal_35mm_mm() {
                with_focal += 1;
            }
            let _ = cam.describe();
            Ok::<_, monohand_media::video::QuickTimeError>(())
        },
    );
    // Some mutations must leave the focal length readable, or the harness would not be
    // reaching the reader's decoding.
    assert!(
        with_focal > summary.cases / 20,
        "{with_focal} of {} cases kept a focal length",
        summary.cases
    );
    eprintln!(
        "{with_focal} of {} cases kept a focal length ({} refused)",
        summary.cases, summary.rejected
    );
}
