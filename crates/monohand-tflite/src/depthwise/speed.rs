//! Timings of the depthwise kernels on the landmark network's shapes (ignored: run by hand).

use super::*;
use crate::pointwise::{Isa, Kernel};

/// Microseconds per call of each SIMD kernel the CPU runs, side by side, on the
/// hand-landmark lite shapes and three of palm_detection_full's (best of 7):
/// `cargo test --release -p monohand-tflite depthwise::speed -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a test"]
fn landmark_shapes() {
    // (h, w, c, k, stride) of the input.
    let shapes = [
        (112, 112, 24, 3, 1),
        (112, 112, 64, 3, 2),
        (56, 56, 96, 3, 1),
        (56, 56, 96, 3, 2),
        (28, 28, 144, 5, 2),
        (14, 14, 288, 5, 1),
        (14, 14, 384, 3, 1),
        (7, 7, 672, 5, 1),
        // palm_detection_full's.
        (96, 96, 32, 5, 1),
        (48, 48, 64, 5, 1),
        (24, 24, 128, 5, 1),
    ];
    for (h, w, c, kh, s) in shapes {
        let g = square_geometry(h, w, c, kh, s, true);
        let (oh, ow) = (g.oh, g.ow);
        let x = vec![0.5f32; h * w * c];
        let k = vec![0.25f32; kh * kh * c];
        let b = vec![0.1f32; c];
        let mut out = vec![0f32; oh * ow * c];
        let mut line = format!("{h:>4}x{w:<4}x{c:>4} k{kh} s{s}:");
        for kernel in Kernel::supported() {
            let n = (2e7 / (oh * ow * c * kh * kh) as f64).max(3.0) as usize;
            let mut best = f64::MAX;
            for _ in 0..7 {
                let t = std::time::Instant::now();
                for _ in 0..n {
                    match kernel.isa() {
                        Isa::Portable => continue,
                        // SAFETY: the CPU has the kernel's features (`supported`); the
                        // buffers have the geometry's sizes, all of its rows.
                        Isa::Avx2Fma => unsafe { avx2::run(&g, &x, &k, &b, &mut out, (0.0, 6.0)) },
                        // SAFETY: as above.
                        Isa::Avx512 => unsafe { avx512::run(&g, &x, &k, &b, &mut out, (0.0, 6.0)) },
                    }
                }
                best = best.min(t.elapsed().as_secs_f64() / n as f64);
            }
            if kernel != Kernel::PORTABLE {
                line += &format!("  {}: {:7.1} us", kernel.name(), best * 1e6);
            }
        }
        println!("{line}");
    }
}
