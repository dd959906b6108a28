//! Bone-length (skeleton) JSON.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = monohand_io::skeleton::parse_bone_lengths(text, "bones.json");
    }
});
