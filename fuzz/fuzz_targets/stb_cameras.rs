//! STB's camera_params.json.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = monohand_eval::stb::stb_cameras_from_str(text, "camera_params.json");
    }
});
