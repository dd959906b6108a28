//! Timings of the int8 kernels on the landmark network's shapes (ignored: run by hand).

use super::*;
use crate::pointwise::{Kernel, PointwiseConv};

/// Times `f` (best of 5 rounds of enough calls for about 2·10⁸ multiply-adds, a few
/// milliseconds), in seconds per call.
fn time(work: usize, mut f: impl FnMut()) -> f64 {
    let n = (2e8 / work as f64).max(3.0) as usize;
    let mut best = f64::MAX;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        for _ in 0..n {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / n as f64);
    }
    best
}

/// The f32 and the int8 1x1 convolution on hand_landmark_full's 1x1 shapes, one
/// thread, hot caches: the dispatched f32 kernel (`MONOHAND_KERNEL` caps it) against
/// every int8 kernel this CPU runs but the portable one, interleaved (per shape, `ROUNDS`
/// rounds over all kernels, the best time of each kept):
/// `cargo test --release -p monohand-tflite int8::speed -- --ignored --nocapture`.
/// The int8 times include quantizing the f32 input; all write f32 outputs.
#[test]
#[ignore = "a measurement, not a test"]
fn landmark_shapes() {
    const ROUNDS: usize = 4;
    // (rows, cin, cout, how many such layers in hand_landmark_full), from
    // `PER_NODE=1 cargo run --release -p monohand-tflite --example profile_ops`.
    let shapes = SHAPES_LANDMARK_FULL;
    let k32 = Kernel::best();
    let k8: Vec<Int8Kernel> = Int8Kernel::supported()
        .into_iter()
        .filter(|&k| k != Int8Kernel::PORTABLE)
        .collect();
    let mut names = vec![format!("f32 {}", k32.name())];
    names.extend(k8.iter().map(|k| format!("int8 {}", k.name())));
    println!("ms per call (GMAC/s), speedup against f32 in []");
    println!(
        "{:>24} | {}",
        "rows x cin -> cout (n)",
        names
            .iter()
            .map(|n| format!("{n:>24}"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    let mut totals = vec![0.0; names.len()];
    for &(rows, cin, cout, count) in shapes {
        let mut g = 1u64;
        let mut next = || {
            g = g
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((g >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let x: Vec<f32> = (0..rows * cin).map(|_| 3.0 * next() + 3.0).collect();
        let w: Vec<f32> = (0..cout * cin).map(|_| next()).collect();
        let w = Tensor::from_shape(&[cout, cin], &w).expect("w");
        let b = Tensor::zero::<f32>(&[cout]).expect("b");
        let f32op = PointwiseConv::new(&w, &b, Activation::Relu6).expect("op");
        let q = ActivationQuant::from_min_max(0.0, 6.0);
        let i8op = PointwiseConvInt8::new(&w, &b, Activation::Relu6, q).expect("op");
        let mut out = vec![0f32; rows * cout];
        let work = rows * cin * cout;
        let mut best = vec![f64::MAX; names.len()];
        for _ in 0..ROUNDS {
            best[0] = best[0].min(time(work, || {
                f32op.compute(&x, None, &mut out, k32, false).expect("f32");
            }));
            for (b, &k) in best[1..].iter_mut().zip(&k8) {
                *b = b.min(time(work, || {
                    i8op.compute_with(&x, None, &mut out, k, false)
                        .expect("int8");
                }));
            }
        }
        for (t, b) in totals.iter_mut().zip(&best) {
            *t += b * count as f64;
        }
        let cells: Vec<String> = best
            .iter()
            .map(|&t| {
                format!(
                    "{:7.3} ({:5.1}) [{:4.2}]",
                    t * 1e3,
                    work as f64 / t / 1e9,
                    best[0] / t
                )
            })
            .collect();
        println!(
            "{:>24} | {}",
            format!("{rows} x {cin} -> {cout} ({count})"),
            cells.join(" | ")
        );
    }
    let cells: Vec<String> = totals
        .iter()
        .map(|&t| format!("{:>15.3} [{:4.2}]", t * 1e3, totals[0] / t))
        .collect();
    println!("{:>24} | {}", "all 30 layers", cells.join(" | "));
}

/// hand_landmark_full's 30 1x1 convolutions: (rows, cin, cout, count).
const SHAPES_LANDMARK_FULL: &[(usize, usize, usize, usize)] = &[
    (12544, 24, 16, 1),
    (12544, 16, 64, 1),
    (3136, 64, 24, 1),
    (3136, 24, 144, 2),
    (3136, 144, 24, 1),
    (784, 144, 40, 1),
    (784, 40, 240, 2),
    (784, 240, 40, 1),
    (196, 240, 80, 1),
    (196, 80, 480, 3),
    (196, 480, 80, 2),
    (196, 480, 112, 1),
    (196, 112, 672, 3),
    (196, 672, 112, 2),
    (49, 672, 192, 1),
    (49, 192, 1152, 4),
    (49, 1152, 192, 3),
];
