//! Timings of the stems (ignored: run by hand).

use super::*;
use crate::int8::Int8Kernel;

/// Microseconds per call of the stems in f32 ([`NhwcConv`]) and int8 ([`NhwcConvInt8`]),
/// one thread, side by side (best of 9 rounds, the two alternating):
/// `cargo test --release -p monohand-tflite conv::speed -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a test"]
fn stems() {
    // (input size, kernel, Cout, activation): the landmark networks' and the palm
    // detectors' first layers.
    for (size, k, cout, act) in [
        (224, 3, 24, Activation::Relu6),
        (192, 5, 32, Activation::None),
    ] {
        let w: Vec<f32> = (0..cout * k * k * 3)
            .map(|i| ((i * 37 % 101) as f32 - 50.0) / 200.0)
            .collect();
        let w = Tensor::from_shape(&[cout, k, k, 3], &w).expect("w");
        let b = Tensor::from_shape(&[cout], &vec![0.1f32; cout]).expect("b");
        let f32_conv = NhwcConv::new(&w, &b, (2, 2), true, act)
            .expect("conv")
            .with_split(false);
        let quant = ActivationQuant::from_min_max(0.0, 1.0);
        let int8 = f32_conv.to_int8(quant).expect("int8");
        let x: Vec<f32> = (0..size * size * 3)
            .map(|i| (i * 7919 % 256) as f32 / 255.0)
            .collect();
        let (oh, ow, _, _) = f32_conv.shape.geometry(size, size);
        let mut out = vec![0f32; oh * ow * cout];
        let (mut a, mut q) = (f64::MAX, f64::MAX);
        for _ in 0..9 {
            let t = std::time::Instant::now();
            for _ in 0..20 {
                f32_conv
                    .compute(&x, (size, size), &mut out, Kernel::best())
                    .expect("f32");
            }
            a = a.min(t.elapsed().as_secs_f64() / 20.0);
            let t = std::time::Instant::now();
            for _ in 0..20 {
                int8.compute(&x, (size, size), &mut out, Int8Kernel::best())
                    .expect("int8");
            }
            q = q.min(t.elapsed().as_secs_f64() / 20.0);
        }
        println!(
            "{size}x{size}x3 k{k} -> {cout}: f32 {:7.1} us, int8 {:7.1} us ({})",
            a * 1e6,
            q * 1e6,
            Int8Kernel::best().name()
        );
    }
}
