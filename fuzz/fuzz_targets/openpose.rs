//! OpenPose JSON frame files.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = monohand_io::openpose::parse_openpose(text, "f_keypoints.json");
    }
});
