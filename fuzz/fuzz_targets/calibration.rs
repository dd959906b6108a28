//! Calibration files: project JSON, WACV'18 JSON, OpenCV YAML and XML FileStorage, ROS
//! camera_info YAML, Kalibr camera chains.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = monohand_io::calibration::parse_calibrations(text, "fuzz");
    }
});
