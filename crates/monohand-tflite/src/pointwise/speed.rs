//! Timings of the f32 kernels on the landmark network's shapes (ignored: run by hand).

use super::*;

/// GFLOP/s of the dispatched kernel (`MONOHAND_KERNEL=portable|avx2|avx512` forces one)
/// on the hand-landmark (full) and some palm shapes:
/// `cargo test --release -p monohand-tflite pointwise::speed -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a test"]
fn landmark_shapes() {
    let shapes = [
        (12544, 24, 16),
        (12544, 16, 64),
        (3136, 64, 24),
        (3136, 24, 144),
        (3136, 144, 24),
        (784, 144, 40),
        (784, 40, 240),
        (784, 240, 40),
        (196, 240, 80),
        (196, 80, 480),
        (196, 480, 80),
        (196, 112, 672),
        (196, 672, 112),
        (49, 192, 1152),
        (49, 1152, 192),
        (576, 128, 128),
        (144, 256, 256),
        (9216, 32, 32),
    ];
    let kernel = Kernel::best();
    for (rows, cin, cout) in shapes {
        let x = vec![0.5f32; rows * cin];
        let w = Tensor::zero::<f32>(&[cout, cin]).expect("w");
        let b = Tensor::zero::<f32>(&[cout]).expect("b");
        let op = PointwiseConv::new(&w, &b, Activation::Relu6).expect("op");
        let mut out = vec![0f32; rows * cout];
        let n = (1e9 / (rows * cin * cout) as f64).max(3.0) as usize;
        let mut best = f64::MAX;
        for _ in 0..7 {
            let t = std::time::Instant::now();
            for _ in 0..n {
                op.compute(&x, None, &mut out, kernel, false).expect("run");
            }
            best = best.min(t.elapsed().as_secs_f64() / n as f64);
        }
        let gflops = 2.0 * (rows * cin * cout) as f64 / best / 1e9;
        println!(
            "{rows:>6} x {cin:>5} -> {cout:>5}: {:8.3} ms {gflops:6.1} GFLOP/s",
            best * 1e3
        );
    }
}
