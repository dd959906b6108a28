//! The depthwise convolution's tests: the kernels against a naive reference and the portable
//! loop's bits.

use super::*;

/// Direct reference: TFLite semantics written out naively.
fn reference(
    x: &[f32],
    (h, w, c): (usize, usize, usize),
    k: &[f32],
    (kh, kw): (usize, usize),
    b: &[f32],
    s: usize,
    same: bool,
) -> (Vec<f32>, usize, usize) {
    let (oh, pt) = axis_geometry(h, kh, s, same);
    let (ow, pl) = axis_geometry(w, kw, s, same);
    let mut out = vec![0.0; oh * ow * c];
    for oy in 0..oh {
        for ox in 0..ow {
            for ch in 0..c {
                let mut acc = b[ch] as f64;
                for ky in 0..kh {
                    for kx in 0..kw {
                        let iy = (oy * s + ky) as isize - pt as isize;
                        let ix = (ox * s + kx) as isize - pl as isize;
                        if iy >= 0 && ix >= 0 && (iy as usize) < h && (ix as usize) < w {
                            acc += x[((iy as usize) * w + ix as usize) * c + ch] as f64
                                * k[(ky * kw + kx) * c + ch] as f64;
                        }
                    }
                }
                out[(oy * ow + ox) * c + ch] = acc as f32;
            }
        }
    }
    (out, oh, ow)
}

#[test]
fn matches_naive_reference_for_same_and_valid_strides_1_and_2() {
    // 5 channels: the scalar tail only; 45: a block of 32, one of 8 and a tail of 5.
    for c in [5, 45] {
        matches_naive_reference_with_channels(c);
    }
}

/// Fixed inputs (`n` values), weights (`nk`) and biases (`c`) for the kernels' tests.
fn data(n: usize, nk: usize, c: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let x = (0..n)
        .map(|i| ((i * 7919 % 1009) as f32 - 504.0) / 97.0)
        .collect();
    let k = (0..nk)
        .map(|i| ((i * 31 % 59) as f32 - 29.0) / 13.0)
        .collect();
    let b = (0..c).map(|i| i as f32 * 0.37 - 3.0).collect();
    (x, k, b)
}

/// A `k x k` "same" depthwise convolution of `c` channels with stride `s`, weights and
/// biases `(kernel, bias)` and a fused ReLU6 (the splitting and coding tests' layer).
fn relu6_square(
    k: usize,
    c: usize,
    s: usize,
    (kernel, bias): (&[f32], &[f32]),
    register_blocked: bool,
    split: bool,
) -> NhwcDepthwise {
    NhwcDepthwise {
        kernel: Tensor::from_shape(&[k, k, c], kernel)
            .expect("k")
            .into_arc_tensor(),
        bias: tensor1(bias).into_arc_tensor(),
        strides: (s, s),
        same: true,
        activation: Activation::Relu6,
        register_blocked,
        split,
    }
}

#[test]
fn shared_between_threads_gives_the_same_bits() {
    // The landmark networks' 112x112x24 3x3 layer, a 5x5 stride-2 one, and the portable
    // loop (not register-blocked).
    for (h, c, k, s, blocked) in [
        (112, 24, 3, 1, true),
        (56, 64, 5, 2, true),
        (56, 40, 3, 1, false),
    ] {
        let (x, kv, b) = data(h * h * c, k * k * c, c);
        let op = |split| relu6_square(k, c, s, (&kv, &b), blocked, split);
        let input = Tensor::from_shape(&[1, h, h, c], &x).expect("x");
        crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
    }
}

#[test]
fn coded_results_are_the_codes_of_the_f32_results() {
    // (h, c, k, stride, register-blocked): the landmark networks' 112x112x24 layer (one
    // output row per chunk), several rows per chunk, channels off the vectors and the
    // group of 4, the portable loop; a code range narrower than the results (clamped).
    for (h, c, k, s, blocked) in [
        (112, 24, 3, 1, true),
        (14, 480, 5, 1, true),
        (9, 37, 3, 2, true),
        (7, 5, 5, 1, true),
        (13, 40, 3, 1, false),
    ] {
        let (x, kv, b) = data(h * h * c, k * k * c, c);
        let conv = |split| relu6_square(k, c, s, (&kv, &b), blocked, split);
        let quant = ActivationQuant::from_min_max(0.0, 5.0);
        let input = Tensor::from_shape(&[1, h, h, c], &x).expect("x");
        let values = crate::split::testing::bits(&conv(false), std::slice::from_ref(&input));
        let want: Vec<u32> = values
            .iter()
            .map(|&v| quant.quantize(f32::from_bits(v)) as u32)
            .collect();
        let coded = |split| NhwcDepthwiseCodes::new(conv(split), quant);
        let got = crate::split::testing::bits(&coded(false), std::slice::from_ref(&input));
        assert_eq!(got, want, "h {h} c {c} k {k} s {s}");
        if h >= 56 {
            crate::split::testing::same_bits_split(&coded(true), &coded(false), &[input]);
        }
    }
}

fn matches_naive_reference_with_channels(c: usize) {
    let (h, w) = (7, 6);
    let x: Vec<f32> = (0..h * w * c)
        .map(|i| ((i * 37 % 101) as f32 - 50.0) / 25.0)
        .collect();
    let (mut below, mut above) = (false, false);
    for ((kh, kw, s, same), activation) in [
        (3, 3, 1, true),
        (5, 5, 2, true),
        (3, 3, 2, false),
        (1, 1, 1, true),
    ]
    .into_iter()
    .flat_map(|g| [Activation::None, Activation::Relu, Activation::Relu6].map(|a| (g, a)))
    {
        let k: Vec<f32> = (0..kh * kw * c)
            .map(|i| ((i * 13 % 17) as f32 - 8.0) / 8.0)
            .collect();
        let b: Vec<f32> = (0..c).map(|i| i as f32 * 0.1).collect();
        let op = NhwcDepthwise {
            kernel: Tensor::from_shape(&[kh, kw, c], &k)
                .expect("k")
                .into_arc_tensor(),
            bias: Tensor::from_shape(&[c], &b).expect("b").into_arc_tensor(),
            strides: (s, s),
            same,
            activation,
            register_blocked: true,
            split: true,
        };
        let input = Tensor::from_shape(&[1, h, w, c], &x).expect("x");
        let out = op
            .eval_out_of_plan(tvec!(input.into_tvalue()))
            .expect("eval")
            .expect("evaluates out of plan");
        let (want, oh, ow) = reference(&x, (h, w, c), &k, (kh, kw), &b, s, same);
        assert_eq!(out[0].shape(), &[1, oh, ow, c]);
        let got = out[0].try_as_plain_ram().expect("ram");
        let got = got.as_slice::<f32>().expect("f32");
        let (low, high) = match activation {
            Activation::None => (f32::NEG_INFINITY, f32::INFINITY),
            Activation::Relu => (0.0, f32::INFINITY),
            Activation::Relu6 => (0.0, 6.0),
        };
        below |= want.iter().any(|&v| v < 0.0);
        above |= want.iter().any(|&v| v > 6.0);
        for (g, w) in got.iter().zip(&want) {
            let w = w.max(low).min(high);
            assert!(
                (g - w).abs() < 1e-5,
                "k{kh} s{s} same {same} {activation:?}: {g} vs {w}"
            );
        }
    }
    // The references reach past both bounds, so each clamp is exercised.
    assert!(below && above);
}

/// `(h, w, c, k, stride, same)` of the register-blocked kernels' tests: channel counts
/// that cover AVX2's blocks of 32 and 8 and its scalar tail, AVX-512's blocks of 64 and
/// its last blocks of 1, 2 and 3 vectors with and without a masked last vector and of 4
/// with one, and `simd128`'s blocks of 32 and 4 and its tail.
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "wasm32", target_feature = "simd128")
))]
/// (h, w, c, k, stride, same), the last five wide enough for the AVX-512 kernel's runs
/// of 4 (16 and 32 channels) and 2 (40 and 64) pixels, with single pixels after them.
const BLOCK_SHAPES: [(usize, usize, usize, usize, usize, bool); 16] = [
    (9, 8, 72, 3, 1, true),
    (10, 11, 45, 5, 2, true),
    (8, 8, 40, 3, 2, false),
    (7, 9, 100, 3, 1, true),
    (6, 5, 3, 5, 1, true),
    (9, 9, 24, 3, 1, true),
    (6, 7, 96, 3, 2, true),
    (5, 5, 16, 3, 1, false),
    (6, 6, 48, 5, 1, true),
    (7, 6, 56, 3, 1, true),
    (6, 7, 120, 5, 2, true),
    (7, 14, 32, 5, 1, true),
    (6, 21, 24, 3, 2, true),
    (5, 13, 16, 3, 1, false),
    (5, 12, 64, 5, 1, true),
    (4, 15, 40, 5, 2, false),
];

/// The `simd128` kernel sums in the portable loop's order, a product then a sum per tap
/// as the portable loop does on WebAssembly: its results are the same bits. Built with
/// `relaxed-simd`, each tap's product and sum is fused or not as the engine decides, the
/// same way for every tap: the bits of the fused portable loop or of the plain one. (Run
/// by `scripts/web-test.sh` under Node's WASI.)
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
#[test]
fn the_simd128_kernel_is_bit_identical_to_the_portable_loop() {
    for (h, w, c, kh, s, same) in BLOCK_SHAPES {
        let (x, k, b) = data(h * w * c, kh * kh * c, c);
        let g = square_geometry(h, w, c, kh, s, same);
        let (oh, ow) = (g.oh, g.ow);
        for act in [(f32::NEG_INFINITY, f32::INFINITY), (0.0, 6.0)] {
            let mut portable = vec![0.0; oh * ow * c];
            kernel::<false>(&g, &x, &k, &b, &mut portable, act);
            let mut fast = vec![f32::NAN; oh * ow * c];
            // SAFETY: the buffers have the geometry's sizes, all of its rows
            // (`square_geometry`).
            unsafe { wasm::run(&g, &x, &k, &b, &mut fast, act) };
            let mut differ = crate::split::testing::differing_bits(&fast, &portable);
            if cfg!(target_feature = "relaxed-simd") && differ != 0 {
                // The engine fused the blocks' taps; the last 1-3 channels (after the
                // blocks of 4) are the portable loop's, a product then a sum.
                let mut fused = vec![0.0; oh * ow * c];
                kernel::<true>(&g, &x, &k, &b, &mut fused, act);
                let blocks = c / 4 * 4;
                for (i, (p, f)) in portable.iter_mut().zip(&fused).enumerate() {
                    if i % c < blocks {
                        *p = *f;
                    }
                }
                differ = crate::split::testing::differing_bits(&fast, &portable);
            }
            assert_eq!(differ, 0, "{h}x{w}x{c} k{kh} s{s} same {same} {act:?}");
        }
    }
}

/// The AVX2 and AVX-512 kernels sum in the portable loop's order with the same fused
/// multiply-adds: their results are the same bits. The channel counts cover AVX2's blocks
/// of 32 and 8 and its scalar tail, and AVX-512's blocks of 64 and its last blocks of 1,
/// 2 and 3 vectors with and without a masked last vector, and of 4 with one.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_simd_kernels_are_bit_identical_to_the_portable_loop() {
    use crate::pointwise::{Isa, Kernel};
    let kernels = Kernel::supported();
    if !kernels.iter().any(|k| k.isa() == Isa::Avx2Fma) {
        eprintln!("no AVX2 + FMA on this CPU: only the portable loop runs here");
        return;
    }
    for (h, w, c, kh, s, same) in BLOCK_SHAPES {
        let (x, k, b) = data(h * w * c, kh * kh * c, c);
        let g = square_geometry(h, w, c, kh, s, same);
        let (oh, ow) = (g.oh, g.ow);
        for act in [(f32::NEG_INFINITY, f32::INFINITY), (0.0, 6.0)] {
            let mut portable = vec![0.0; oh * ow * c];
            // SAFETY: AVX2 and FMA were detected (`Kernel::supported` has `Avx2Fma`).
            unsafe { avx2::run_avx2_fma(&g, &x, &k, &b, &mut portable, act) };
            for &kernel in &kernels {
                let mut fast = vec![f32::NAN; oh * ow * c];
                match kernel.isa() {
                    Isa::Portable => continue,
                    // SAFETY: the CPU has the kernel's features (`supported`); the
                    // buffers have the geometry's sizes, all of its rows (`square_geometry`).
                    Isa::Avx2Fma => unsafe { avx2::run(&g, &x, &k, &b, &mut fast, act) },
                    // SAFETY: as above.
                    Isa::Avx512 => unsafe { avx512::run(&g, &x, &k, &b, &mut fast, act) },
                }
                let differ = crate::split::testing::differing_bits(&fast, &portable);
                assert_eq!(
                    differ, 0,
                    "{kernel:?} {h}x{w}x{c} k{kh} s{s} same {same} {act:?}"
                );
            }
        }
    }
}
