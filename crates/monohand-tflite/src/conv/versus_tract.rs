//! The stem against tract's own `Conv`, bit for bit, and the int8 stem against its reference.

use super::*;
use crate::int8::Int8Kernel;
use tract_core::ops::cnn::{Conv, KernelFormat, PaddingSpec, PoolSpec};
use tract_core::ops::nn::DataFormat;

/// tract's `Conv` (as the importer wired it before this operator) on `x`.
#[allow(clippy::too_many_arguments)]
fn tract_conv(
    x: &[f32],
    (h, w, cin): (usize, usize, usize),
    k: &[f32],
    (cout, kh): (usize, usize),
    b: &[f32],
    s: usize,
    same: bool,
) -> Vec<f32> {
    let mut m = TypedModel::default();
    let xi = m
        .add_source("x", f32::fact([1, h, w, cin]))
        .expect("source");
    let kt = Tensor::from_shape(&[cout, kh, kh, cin], k).expect("k");
    let kt = m.add_const("k", kt).expect("k");
    let bt = m.add_const("b", tensor1(b)).expect("b");
    let op = Conv {
        pool_spec: PoolSpec {
            data_format: DataFormat::NHWC,
            kernel_shape: tvec!(kh, kh),
            padding: if same {
                PaddingSpec::SameUpper
            } else {
                PaddingSpec::Valid
            },
            strides: Some(tvec!(s, s)),
            dilations: Some(tvec!(1, 1)),
            input_channels: cin,
            output_channels: cout,
        },
        kernel_fmt: KernelFormat::OHWI,
        group: 1,
        q_params: None,
    };
    let y = m.wire_node("conv", op, &[xi, kt, bt]).expect("wire");
    m.select_output_outlets(&y).expect("outputs");
    let plan = m
        .into_optimized()
        .expect("optimise")
        .into_runnable()
        .expect("plan");
    let x = Tensor::from_shape(&[1, h, w, cin], x).expect("x");
    let r = plan.run(tvec!(x.into_tvalue())).expect("run");
    let r = r[0].try_as_plain_ram().expect("ram");
    r.as_slice::<f32>().expect("f32").to_vec()
}

/// On the stems' shapes (landmark 3x3, palm and face 5x5, stride 2, 3 -> 24/32
/// channels; smaller images) the operator gives tract's bits with every vectorised
/// kernel, so swapping it in moves no keypoint.
#[test]
fn gives_the_bits_of_tracts_conv() {
    for kernel in Kernel::supported() {
        if kernel == Kernel::PORTABLE {
            // tract's own kernels use FMA where the CPU has it; the portable product
            // multiplies and adds.
            continue;
        }
        for (h, w, cin, cout, kh, s, same) in [
            (32, 32, 3, 24, 3, 2, true),
            (31, 29, 3, 24, 3, 2, true),
            (24, 24, 3, 32, 5, 2, true),
            (17, 19, 3, 24, 5, 2, false),
        ] {
            let x: Vec<f32> = (0..h * w * cin)
                .map(|i| ((i * 7919 % 1009) as f32 - 504.0) / 97.0)
                .collect();
            let k: Vec<f32> = (0..cout * kh * kh * cin)
                .map(|i| ((i * 31 % 59) as f32 - 29.0) / 13.0)
                .collect();
            let b: Vec<f32> = (0..cout).map(|i| i as f32 * 0.37 - 3.0).collect();
            let want = tract_conv(&x, (h, w, cin), &k, (cout, kh), &b, s, same);
            let op = NhwcConv::new(
                &Tensor::from_shape(&[cout, kh, kh, cin], &k).expect("k"),
                &tensor1(&b),
                (s, s),
                same,
                Activation::None,
            )
            .expect("op");
            let mut got = vec![f32::NAN; want.len()];
            op.compute(&x, (h, w), &mut got, kernel).expect("compute");
            let differ = crate::split::testing::differing_bits(&got, &want);
            assert_eq!(differ, 0, "{kernel:?} {h}x{w}x{cin} k{kh} s{s} same {same}");
        }
    }
}

/// The int8 stem written out naively: the image coded with `quant` (zero-point codes in
/// the padding), each window's codes in OHWI order, the int8 weights and epilogue of
/// the same `PointwiseConvInt8` on those rows with the portable kernel.
fn int8_reference(op: &NhwcConvInt8, x: &[f32], (h, w): (usize, usize)) -> Vec<f32> {
    let (oh, ow, pt, pl) = op.shape.geometry(h, w);
    let (kh, kw, cin) = (op.shape.kh, op.shape.kw, op.shape.cin);
    let kp = op.product.input_channels();
    let mut cols = vec![op.input_quant().zero_point(); oh * ow * kp];
    for oy in 0..oh {
        for ox in 0..ow {
            for ky in 0..kh {
                for kx in 0..kw {
                    let iy = (oy * op.shape.strides.0 + ky) as isize - pt as isize;
                    let ix = (ox * op.shape.strides.1 + kx) as isize - pl as isize;
                    if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                        continue;
                    }
                    for c in 0..cin {
                        let v = x[(iy as usize * w + ix as usize) * cin + c];
                        cols[(oy * ow + ox) * kp + (ky * kw + kx) * cin + c] =
                            op.input_quant().quantize(v);
                    }
                }
            }
        }
    }
    let mut out = vec![0f32; oh * ow * op.product.output_channels()];
    op.product
        .compute_with(&cols[..], None, &mut out, Int8Kernel::PORTABLE, false)
        .expect("product");
    out
}

#[test]
fn the_int8_stem_gives_the_reference_bits_with_every_kernel_and_is_near_f32() {
    let mut seed = 11u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    // (h, w, cin, cout, k, stride, same): the landmark and palm stems on smaller
    // images (windows inside and across every border), odd sizes, VALID, a stride of
    // 1, channels whose windows are no multiple of 4 codes, and a band of one row.
    let cases = [
        (16, 16, 3, 24, 3, 2, true),
        (15, 13, 3, 24, 3, 2, true),
        (12, 12, 3, 32, 5, 2, true),
        (11, 9, 3, 32, 5, 2, false),
        (9, 10, 2, 7, 3, 1, true),
        (6, 700, 3, 24, 3, 2, true),
    ];
    for (h, w, cin, cout, k, s, same) in cases {
        let x: Vec<f32> = (0..h * w * cin).map(|_| next()).collect();
        let wv: Vec<f32> = (0..cout * k * k * cin).map(|_| next() - 0.5).collect();
        let bv: Vec<f32> = (0..cout).map(|_| next() - 0.5).collect();
        let weights = Tensor::from_shape(&[cout, k, k, cin], &wv).expect("w");
        let bias = Tensor::from_shape(&[cout], &bv).expect("b");
        let conv = NhwcConv::new(&weights, &bias, (s, s), same, Activation::Relu6)
            .expect("conv")
            .with_split(false);
        let op = conv
            .to_int8(ActivationQuant::from_min_max(0.0, 1.0))
            .expect("int8");
        let want = int8_reference(&op, &x, (h, w));
        let (oh, ow, _, _) = op.shape.geometry(h, w);
        for kernel in Int8Kernel::supported() {
            let mut got = vec![f32::NAN; oh * ow * cout];
            op.compute(&x, (h, w), &mut got, kernel).expect("compute");
            let differ = crate::split::testing::differing_bits(&got, &want);
            assert_eq!(differ, 0, "{kernel:?} {h}x{w}x{cin} k{k} s{s} same {same}");
        }
        // And it is the f32 convolution, up to the codes' rounding: each of the
        // `k·k·cin` inputs off by at most half a step (1/254) and each weight by half of
        // its channel's step.
        let exact = super::tests::reference(
            &x,
            (h, w, cin),
            &wv,
            (cout, k, k),
            &bv,
            (s, s),
            same,
            Activation::Relu6,
        );
        let taps = (k * k * cin) as f32;
        let worst = exact
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(
            worst < taps * (0.5 / 127.0 * 0.5 + 0.5 / 127.0 * 0.5),
            "{worst}"
        );
    }
}

#[test]
fn the_int8_stem_shared_between_threads_gives_the_same_bits() {
    let (h, w, cin, cout) = (96, 96, 3, 24);
    let x: Vec<f32> = (0..h * w * cin)
        .map(|i| (i * 7919 % 256) as f32 / 255.0)
        .collect();
    let wv: Vec<f32> = (0..cout * 27)
        .map(|i| ((i * 37 % 101) as f32 - 50.0) / 200.0)
        .collect();
    let weights = Tensor::from_shape(&[cout, 3, 3, cin], &wv).expect("w");
    let bias = Tensor::from_shape(&[cout], &vec![0.1f32; cout]).expect("b");
    let quant = ActivationQuant::from_min_max(0.0, 1.0);
    let op = |split| {
        NhwcConv::new(&weights, &bias, (2, 2), true, Activation::Relu6)
            .expect("conv")
            .with_split(split)
            .to_int8(quant)
            .expect("int8")
    };
    let input = Tensor::from_shape(&[1, h, w, cin], &x).expect("x");
    crate::split::testing::same_bits_split(&op(true), &op(false), &[input]);
}

#[test]
fn the_int8_stem_refuses_a_malformed_input() {
    let weights = Tensor::from_shape(&[4, 3, 3, 3], &[0.5f32; 108]).expect("w");
    let bias = Tensor::from_shape(&[4], &[0f32; 4]).expect("b");
    let op = NhwcConv::new(&weights, &bias, (2, 2), true, Activation::None)
        .expect("conv")
        .to_int8(ActivationQuant::from_min_max(0.0, 1.0))
        .expect("int8");
    let wrong = Tensor::zero::<f32>(&[1, 8, 8, 4]).expect("x");
    assert!(op.eval_out_of_plan(tvec!(wrong.into_tvalue())).is_err());
    let mut out = vec![0f32; 3];
    assert!(op
        .compute(&[0.0; 10], (8, 8), &mut out, Int8Kernel::best())
        .is_err());
}
