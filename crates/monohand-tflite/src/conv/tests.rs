//! The stem's tests: every kernel against a naive reference, threads, tract's glue.

use super::*;

/// TFLite's convolution written out naively, in f64.
#[allow(clippy::too_many_arguments)]
pub(super) fn reference(
    x: &[f32],
    (h, w, cin): (usize, usize, usize),
    k: &[f32],
    (cout, kh, kw): (usize, usize, usize),
    b: &[f32],
    (sy, sx): (usize, usize),
    same: bool,
    act: Activation,
) -> Vec<f32> {
    let (oh, pt) = axis_geometry(h, kh, sy, same);
    let (ow, pl) = axis_geometry(w, kw, sx, same);
    let (lo, hi) = act.bounds();
    let mut out = vec![0f32; oh * ow * cout];
    for oy in 0..oh {
        for ox in 0..ow {
            for o in 0..cout {
                let mut acc = b[o] as f64;
                for ky in 0..kh {
                    for kx in 0..kw {
                        let iy = (oy * sy + ky) as isize - pt as isize;
                        let ix = (ox * sx + kx) as isize - pl as isize;
                        if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                            continue;
                        }
                        for c in 0..cin {
                            acc += x[(iy as usize * w + ix as usize) * cin + c] as f64
                                * k[((o * kh + ky) * kw + kx) * cin + c] as f64;
                        }
                    }
                }
                out[(oy * ow + ox) * cout + o] = acc.max(lo as f64).min(hi as f64) as f32;
            }
        }
    }
    out
}

#[test]
fn every_kernel_matches_a_naive_reference() {
    let mut seed = 5u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    // (h, w, cin, cout, kh, kw, stride, same): the landmark and palm stems (smaller
    // images), odd sizes where SAME pads one side only or both, VALID, and an image
    // wide enough that a band holds a single output row.
    let cases = [
        (16, 16, 3, 24, 3, 3, 2, true),
        (15, 13, 3, 24, 3, 3, 2, true),
        (12, 12, 3, 32, 5, 5, 2, true),
        (9, 10, 2, 7, 3, 3, 1, true),
        (9, 11, 3, 40, 3, 3, 2, false),
        (4, 700, 3, 16, 3, 3, 1, true),
        (3, 3, 1, 1, 3, 3, 2, true),
    ];
    for kernel in Kernel::supported() {
        for (h, w, cin, cout, kh, kw, s, same) in cases {
            let x: Vec<f32> = (0..h * w * cin).map(|_| next() * 3.0).collect();
            let k: Vec<f32> = (0..cout * kh * kw * cin).map(|_| next()).collect();
            let b: Vec<f32> = (0..cout).map(|_| next()).collect();
            for act in [Activation::None, Activation::Relu6] {
                let op = NhwcConv::new(
                    &Tensor::from_shape(&[cout, kh, kw, cin], &k).expect("k"),
                    &tensor1(&b),
                    (s, s),
                    same,
                    act,
                )
                .expect("op");
                let (oh, ow, _, _) = op.shape.geometry(h, w);
                let mut got = vec![f32::NAN; oh * ow * cout];
                op.compute(&x, (h, w), &mut got, kernel).expect("compute");
                let want = reference(&x, (h, w, cin), &k, (cout, kh, kw), &b, (s, s), same, act);
                for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                    assert!(
                        (g - w).abs() <= 1e-5 * (1.0 + w.abs()),
                        "{kernel:?} {h}x{w}x{cin} k{kh} s{s} same {same} {act:?} at {i}: \
                         {g} vs {w}"
                    );
                }
            }
        }
    }
}

#[test]
fn shared_between_threads_gives_the_same_bits() {
    // The landmark networks' stem (224x224x3, 3x3 stride 2, 24 channels) and a 5x5 one.
    for (h, k, cout) in [(224, 3, 24), (96, 5, 32)] {
        let cin = 3;
        let x: Vec<f32> = (0..h * h * cin)
            .map(|i| ((i * 37 % 255) as f32) / 255.0)
            .collect();
        let kv: Vec<f32> = (0..cout * k * k * cin)
            .map(|i| ((i * 13 % 17) as f32 - 8.0) / 8.0)
            .collect();
        let b: Vec<f32> = (0..cout).map(|i| i as f32 * 0.1 - 1.0).collect();
        let op = |split| {
            NhwcConv::new(
                &Tensor::from_shape(&[cout, k, k, cin], &kv).expect("k"),
                &tensor1(&b),
                (2, 2),
                true,
                Activation::Relu6,
            )
            .expect("op")
            .with_split(split)
        };
        let input = Tensor::from_shape(&[1, h, h, cin], &x).expect("x");
        crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
    }
}

#[test]
fn evaluates_as_a_tract_operator() {
    let (h, w, cin, cout) = (6, 5, 3, 8);
    let x: Vec<f32> = (0..h * w * cin).map(|i| (i % 7) as f32 - 3.0).collect();
    let k: Vec<f32> = (0..cout * 9 * cin).map(|i| (i % 5) as f32 * 0.25).collect();
    let b: Vec<f32> = (0..cout).map(|i| i as f32).collect();
    let op = NhwcConv::new(
        &Tensor::from_shape(&[cout, 3, 3, cin], &k).expect("k"),
        &tensor1(&b),
        (2, 2),
        true,
        Activation::Relu,
    )
    .expect("op");
    let out = op
        .eval_out_of_plan(tvec!(Tensor::from_shape(&[1, h, w, cin], &x)
            .expect("x")
            .into_tvalue()))
        .expect("eval")
        .expect("evaluates out of plan");
    assert_eq!(out[0].shape(), &[1, 3, 3, cout]);
    let got = out[0].try_as_plain_ram().expect("ram");
    let got = got.as_slice::<f32>().expect("f32");
    let want = reference(
        &x,
        (h, w, cin),
        &k,
        (cout, 3, 3),
        &b,
        (2, 2),
        true,
        Activation::Relu,
    );
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-4, "{g} vs {w}");
    }
}
