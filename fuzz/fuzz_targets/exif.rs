//! A photo with its EXIF focal length (seed it with JPEGs that carry EXIF).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = monohand_vision::image_io::decode_photo(data, "fuzz.jpg");
});
