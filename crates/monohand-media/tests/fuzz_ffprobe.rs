//! Fuzzing of monohand-media's parser of outside input, ffprobe's JSON (see
//! docs/fuzzing.md): every mutated input must give `Ok` or `Err`, no panic, no allocation
//! over the harness limit, no hang. `MONOHAND_FUZZ_CASES` / `MONOHAND_FUZZ_SEED` as for the
//! other fuzz tests.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "../../monohand-io/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{cases, mutate_text, run, text, TrackingAlloc};
use monohand_media::video::parse_probe_json;

#[global_allocator]
static ALLOC: TrackingAlloc = TrackingAlloc;

/// Mutated inputs in a default `cargo test`.
const CI_CASES: usize = 3000;

#[test]
fn fuzz_ffprobe() {
    let seeds = vec![
        br#"{"programs": [], "streams": [{"codec_name": "h264", "width": 1920,
            "height": 1080, "r_frame_rate": "30000/1001", "avg_frame_rate": "30000/1001",
            "nb_frames": "300", "duration": "10.010000",
            "side_data_list": [{"side_data_type": "Display Matrix", "rotation": -90}]}],
            "format": {"duration": "10.010000", "nb_streams": 1}}"#
            .to_vec(),
        br#"{"streams": [{"width": 640, "height": 480, "r_frame_rate": "0/0",
            "tags": {"rotate": "180"}}]}"#
            .to_vec(),
        br#"{"streams": []}"#.to_vec(),
    ];
    run("ffprobe", &seeds, cases(CI_CASES), mutate_text, |input| {
        let info = parse_probe_json(&text(input), "fuzz.mp4")?;
        let _ = info.fps_or_default();
        Ok::<_, monohand_io::IoError>(())
    });
}
