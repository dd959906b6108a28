//! The .tflite flatbuffer importer.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = monohand_tflite::list_operators(data);
    let _ = monohand_tflite::import(data);
});
