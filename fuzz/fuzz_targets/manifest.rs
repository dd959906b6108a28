//! The evaluation manifest (JSON Lines).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(ds) =
        monohand_eval::manifest::parse_manifest(data, "fuzz.jsonl", std::path::Path::new("/data"))
    {
        for f in &ds.frames {
            for h in 0..f.hands.len() {
                for v in 0..f.cameras.len() {
                    let _ = f.gt_keypoints(h, v);
                }
            }
        }
    }
});
