//! The f32 1x1 convolution's tests: every kernel against a naive reference and the portable
//! one's bits.

use super::*;
use crate::split::testing::Lcg;

fn clamp(y: f64, a: Activation) -> f64 {
    let (lo, hi) = a.bounds();
    y.max(lo as f64).min(hi as f64)
}

/// The epilogue written out naively, in f64.
#[allow(clippy::too_many_arguments)]
fn reference(
    x: &[f32],
    w: &[f32],
    b: &[f32],
    (rows, cin, cout): (usize, usize, usize),
    act: Activation,
    res: Option<(&[f32], Activation)>,
    alpha: Option<&[f32]>,
) -> Vec<f32> {
    let mut out = vec![0f32; rows * cout];
    for r in 0..rows {
        for o in 0..cout {
            let mut acc = b[o] as f64;
            for i in 0..cin {
                acc += x[r * cin + i] as f64 * w[o * cin + i] as f64;
            }
            let mut y = clamp(acc, act);
            if let Some((res, ract)) = res {
                y = clamp(y + res[r * cout + o] as f64, ract);
            }
            if let Some(al) = alpha {
                y = y.max(0.0) + al[o] as f64 * y.min(0.0);
            }
            out[r * cout + o] = y as f32;
        }
    }
    out
}

const ACTS: [Activation; 3] = [Activation::None, Activation::Relu, Activation::Relu6];

#[test]
fn every_kernel_and_epilogue_matches_a_naive_reference() {
    let mut g = Lcg(7);
    // (rows, cin, cout): channel counts off the panel and vector widths, row counts off
    // the tile height, and one input larger than a row block.
    let shapes = [
        (1, 1, 1),
        (5, 3, 7),
        (6, 8, 16),
        (7, 17, 23),
        (13, 16, 24),
        (11, 33, 2),
        (25, 19, 36),
        (9, 40, 108),
        (12, 64, 9),
        (700, 64, 40),
    ];
    for kernel in Kernel::available() {
        for &(rows, cin, cout) in &shapes {
            let x = g.vec(rows * cin, 4.0);
            let w = g.vec(cout * cin, 1.0);
            let b = g.vec(cout, 2.0);
            let r = g.vec(rows * cout, 4.0);
            let alpha = g.vec(cout, 0.5);
            let wt = Tensor::from_shape(&[cout, 1, 1, cin], &w).expect("w");
            let bt = tensor1(&b);
            for act in ACTS {
                let residuals = [None, Some(Activation::None), Some(Activation::Relu6)];
                for ract in residuals {
                    for prelu in [false, true] {
                        let mut op = PointwiseConv::new(&wt, &bt, act).expect("op");
                        if let Some(ract) = ract {
                            op = op.with_residual(ract);
                        }
                        if prelu {
                            op = op.with_prelu(&tensor1(&alpha)).expect("prelu");
                        }
                        let mut got = vec![f32::NAN; rows * cout];
                        op.compute(&x, ract.map(|_| &r[..]), &mut got, kernel, false)
                            .expect("compute");
                        let want = reference(
                            &x,
                            &w,
                            &b,
                            (rows, cin, cout),
                            act,
                            ract.map(|a| (&r[..], a)),
                            prelu.then_some(&alpha[..]),
                        );
                        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                            assert!(
                                (g - w).abs() <= 1e-4 * (1.0 + w.abs()),
                                "{kernel:?} {rows}x{cin}->{cout} act {act:?} res {ract:?} \
                                 prelu {prelu} at {k}: {g} vs {w}"
                            );
                        }
                    }
                }
            }
        }
    }
}

/// The `simd128` kernel sums as the portable one (a product, then a sum, in the same
/// order): the same bits. (Run by `scripts/web-test.sh` under Node's WASI.) With
/// `relaxed-simd` its sums may be fused, as the AVX2 and AVX-512 kernels' are, and it is
/// held to the naive reference as they are (`every_kernel_and_epilogue_...`).
#[cfg(all(
    target_arch = "wasm32",
    target_feature = "simd128",
    not(target_feature = "relaxed-simd")
))]
#[test]
fn the_simd128_kernel_gives_the_portable_kernels_bits() {
    let mut g = Lcg(11);
    let simd = Kernel::best();
    assert_eq!(simd.isa(), Isa::Simd128);
    for (rows, cin, cout) in [(7, 17, 23), (13, 16, 24), (25, 19, 36), (300, 64, 40)] {
        let x = g.vec(rows * cin, 4.0);
        let w = g.vec(cout * cin, 1.0);
        let r = g.vec(rows * cout, 4.0);
        let wt = Tensor::from_shape(&[cout, 1, 1, cin], &w).expect("w");
        let op = PointwiseConv::new(&wt, &tensor1(&g.vec(cout, 2.0)), Activation::Relu6)
            .expect("op")
            .with_residual(Activation::None)
            .with_prelu(&tensor1(&g.vec(cout, 0.5)))
            .expect("prelu");
        let mut want = vec![f32::NAN; rows * cout];
        let mut got = vec![f32::NAN; rows * cout];
        op.compute(&x, Some(&r), &mut want, Kernel::PORTABLE, false)
            .expect("portable");
        op.compute(&x, Some(&r), &mut got, simd, false)
            .expect("simd128");
        let differ = crate::split::testing::differing_bits(&got, &want);
        assert_eq!(differ, 0, "{rows}x{cin}->{cout}");
    }
}

#[test]
fn shared_between_threads_by_rows_or_channels_gives_the_same_bits() {
    let mut g = Lcg(5);
    // (rows, cin, cout): by rows (56x56x24 to 144, with a residual and PRELU), by
    // channels (7x7x192 to 1152, 14x14x112 to 672).
    for (rows, cin, cout, residual) in [
        (3136, 24, 144, true),
        (49, 192, 1152, false),
        (196, 112, 672, true),
    ] {
        let wt = Tensor::from_shape(&[cout, cin], &g.vec(cout * cin, 0.5)).expect("w");
        let (bias, alpha) = (tensor1(&g.vec(cout, 1.0)), tensor1(&g.vec(cout, 1.0)));
        let make = |split| {
            let op = PointwiseConv::new(&wt, &bias, Activation::Relu6)
                .expect("op")
                .with_split(split);
            match residual {
                true => op
                    .with_residual(Activation::None)
                    .with_prelu(&alpha)
                    .expect("prelu"),
                false => op,
            }
        };
        let mut inputs =
            vec![Tensor::from_shape(&[1, rows, 1, cin], &g.vec(rows * cin, 2.0)).expect("x")];
        if residual {
            inputs.push(
                Tensor::from_shape(&[1, rows, 1, cout], &g.vec(rows * cout, 2.0)).expect("r"),
            );
        }
        crate::split::testing::same_bits_split(&make(true), &make(false), &inputs);
    }
}

#[test]
fn evaluates_as_a_tract_operator_with_a_residual() {
    let mut g = Lcg(11);
    let (h, w, cin, cout) = (3, 5, 10, 12);
    let x = g.vec(h * w * cin, 1.0);
    let k = g.vec(cout * cin, 1.0);
    let b = g.vec(cout, 1.0);
    let r = g.vec(h * w * cout, 1.0);
    let op = PointwiseConv::new(
        &Tensor::from_shape(&[cout, cin], &k).expect("k"),
        &tensor1(&b),
        Activation::Relu,
    )
    .expect("op")
    .with_residual(Activation::None);
    let out = op
        .eval_out_of_plan(tvec!(
            Tensor::from_shape(&[1, h, w, cin], &x)
                .expect("x")
                .into_tvalue(),
            Tensor::from_shape(&[1, h, w, cout], &r)
                .expect("r")
                .into_tvalue()
        ))
        .expect("eval")
        .expect("evaluates out of plan");
    assert_eq!(out[0].shape(), &[1, h, w, cout]);
    let got = out[0].try_as_plain_ram().expect("ram");
    let got = got.as_slice::<f32>().expect("f32");
    let want = reference(
        &x,
        &k,
        &b,
        (h * w, cin, cout),
        Activation::Relu,
        Some((&r, Activation::None)),
        None,
    );
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-5, "{g} vs {w}");
    }
}
