//! The JSON Lines input of `lift`, and what `lift` reads from each hand record.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(records) = monohand_io::jsonl::parse_jsonl(data, "fuzz.jsonl") {
        for r in &records {
            for h in &r.hands {
                let _ = h.keypoints();
                let _ = h.cues();
                let _ = h.joints_3d();
                let _ = h.pose.as_ref().map(|p| p.to_pose());
            }
        }
    }
});
