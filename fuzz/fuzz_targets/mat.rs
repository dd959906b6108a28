//! MATLAB v5 .mat files, then the STB labels read from them.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mat) = monohand_eval::mat::MatFile::from_bytes(data, "fuzz.mat") {
        for a in &mat.arrays {
            let _ = a.get(&[1, 2, 3]);
        }
        if let Ok(seq) = monohand_eval::stb::StbSequence::from_mat(&mat, "fuzz.mat") {
            let _ = seq.frames.first().map(|f| f.bone_lengths());
        }
    }
});
