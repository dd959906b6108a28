//! A movie's QuickTime metadata (seed it with crates/monohand-media/tests/data/quicktime).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(meta) = monohand_media::video::parse_quicktime_metadata(std::io::Cursor::new(data))
    {
        let _ = meta.camera().describe();
    }
});
