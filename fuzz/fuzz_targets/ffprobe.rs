//! ffprobe's JSON output.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = monohand_media::video::parse_probe_json(text, "fuzz.mp4");
    }
});
