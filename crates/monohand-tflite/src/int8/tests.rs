//! The int8 1x1 convolution's tests: every kernel against the portable one, bit for bit, the
//! quantizer, the graph passes.

use super::*;
use crate::quantize::{code_depthwise_results, int8_input_ranges, quantize_pointwise};
use crate::split::testing::{differing_bits, Lcg};

const ACTS: [Activation; 3] = [Activation::None, Activation::Relu, Activation::Relu6];

/// The operator for `(rows, cin, cout)` with one of every epilogue.
struct Case {
    rows: usize,
    cin: usize,
    cout: usize,
    x: Vec<f32>,
    w: Vec<f32>,
    b: Vec<f32>,
    r: Vec<f32>,
    alpha: Vec<f32>,
}

impl Case {
    fn random(g: &mut Lcg, (rows, cin, cout): (usize, usize, usize)) -> Case {
        Case {
            rows,
            cin,
            cout,
            // Mostly one-sided, as after a RELU6 or a PRELU.
            x: g.vec(rows * cin, 3.0).iter().map(|v| v + 2.0).collect(),
            w: g.vec(cout * cin, 1.0),
            b: g.vec(cout, 2.0),
            r: g.vec(rows * cout, 4.0),
            alpha: g.vec(cout, 2.0),
        }
    }

    fn op(
        &self,
        quant: ActivationQuant,
        act: Activation,
        res: Option<Activation>,
        prelu: bool,
    ) -> PointwiseConvInt8 {
        let wt = Tensor::from_shape(&[self.cout, 1, 1, self.cin], &self.w).expect("w");
        let mut op = PointwiseConvInt8::new(&wt, &tensor1(&self.b), act, quant).expect("op");
        if let Some(ract) = res {
            op = op.with_residual(ract);
        }
        if prelu {
            op = op.with_prelu(&tensor1(&self.alpha)).expect("prelu");
        }
        op
    }

    fn run(&self, op: &PointwiseConvInt8, kernel: Int8Kernel) -> Vec<f32> {
        let mut out = vec![f32::NAN; self.rows * self.cout];
        let res = op.has_residual().then_some(&self.r[..]);
        op.compute_with(&self.x, res, &mut out, kernel, false)
            .expect("compute");
        out
    }
}

/// (rows, cin, cout): input channels off the group of 4 and the vector of 8, output
/// channels off the 8- and 16-channel vectors, the panels and the pairs of panels, row
/// counts off the tile heights (4, 6, 8), and inputs larger than one block of rows.
// Rows of 16 and more take AMX's tiles where the CPU has them: depths of a whole
// number of 64 codes, and not, and two panels with a narrow last one.
const SHAPES: [(usize, usize, usize); 18] = [
    (32, 64, 16),
    (48, 1152, 40),
    (20, 200, 33),
    (1, 1, 1),
    (5, 3, 7),
    (4, 4, 16),
    (6, 8, 16),
    (7, 17, 23),
    (13, 16, 24),
    (11, 33, 2),
    (25, 19, 36),
    (9, 40, 108),
    (12, 64, 9),
    (17, 12, 32),
    (19, 20, 48),
    (23, 8, 33),
    (3000, 24, 40),
    (700, 150, 17),
];

#[test]
fn the_simd_kernels_give_the_portable_kernels_bits() {
    let kernels = Int8Kernel::supported();
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        let wanted = [
            (has!("avx2"), Isa::Avx2),
            (has!("avx2") && has!("avxvnni"), Isa::AvxVnni),
            (
                has!("avx512f") && has!("avx512bw") && has!("avx512vl") && has!("avx512vnni"),
                Isa::Avx512Vnni,
            ),
        ];
        for (detected, isa) in wanted {
            assert_eq!(kernels.iter().any(|k| k.isa() == isa), detected, "{isa:?}");
        }
        // The default is the last (fastest) one, unless `MONOHAND_KERNEL` caps it.
        if std::env::var_os("MONOHAND_KERNEL").is_none() {
            assert_eq!(Some(&Int8Kernel::best()), kernels.last());
        }
    }
    let mut g = Lcg(3);
    for shape in SHAPES {
        let c = Case::random(&mut g, shape);
        // A range narrower than the inputs', so that some are clamped.
        let quant = ActivationQuant::from_min_max(-0.5, 4.0);
        for act in ACTS {
            for res in [None, Some(Activation::None), Some(Activation::Relu6)] {
                for prelu in [false, true] {
                    let op = c.op(quant, act, res, prelu);
                    let want = c.run(&op, Int8Kernel::PORTABLE);
                    assert!(want.iter().all(|v| v.is_finite()));
                    for &k in &kernels {
                        let got = c.run(&op, k);
                        assert_eq!(
                            differing_bits(&got, &want),
                            0,
                            "{k:?} {shape:?} act {act:?} res {res:?} prelu {prelu}"
                        );
                    }
                }
            }
        }
    }
}

/// Every pair summed by `vpmaddubsw` at its extremes: codes 127 (and 0) against weights
/// of ±127, as many input channels as the deepest layer's and more: the sums are exact
/// (checked against i64 arithmetic) and the same in every kernel.
#[test]
fn extreme_codes_do_not_saturate() {
    for (rows, cin, cout) in [
        (5, 1152, 19),
        (6, 4, 16),
        (9, 2001, 8),
        (16, 1152, 19),
        (33, 2001, 8),
    ] {
        // Weights all ±1 (codes ±127), signs by a pattern; each channel's largest is 1.
        let w: Vec<f32> = (0..cout * cin)
            .map(|i| if (i * 7 + i / 3) % 5 < 3 { 1.0 } else { -1.0 })
            .collect();
        let wt = Tensor::from_shape(&[cout, cin], &w).expect("w");
        // Codes from 0 to 127: a zero point of 0 and a step of 1.
        let quant = ActivationQuant::new(1.0, 0).expect("quant");
        for x_code in [127.0f32, 0.0, 1e9] {
            let mut x = vec![x_code; rows * cin];
            // And a row of alternating extremes.
            for (k, v) in x[..cin].iter_mut().enumerate() {
                *v = if k % 2 == 0 { 127.0 } else { 0.0 };
            }
            let op =
                PointwiseConvInt8::new(&wt, &tensor1(&vec![0f32; cout]), Activation::None, quant)
                    .expect("op");
            let mut want = vec![f32::NAN; rows * cout];
            op.compute_with(&x, None, &mut want, Int8Kernel::PORTABLE, false)
                .expect("portable");
            for r in 0..rows {
                for o in 0..cout {
                    let exact: i64 = (0..cin)
                        .map(|k| {
                            let q = x[r * cin + k].clamp(0.0, 127.0) as i64;
                            q * (w[o * cin + k] as i64 * 127)
                        })
                        .sum();
                    // Scale 1 · 1/127 per unit of weight code: the sum in units of x·w.
                    let want_v = exact as f32 * (1.0 / 127.0);
                    let got = want[r * cout + o];
                    assert!(
                        (got - want_v).abs() <= 1e-6 * (1.0 + want_v.abs()),
                        "{rows}x{cin}->{cout} row {r} ch {o}: {got} vs {want_v}"
                    );
                }
            }
            for k in Int8Kernel::supported() {
                let mut got = vec![f32::NAN; rows * cout];
                op.compute_with(&x, None, &mut got, k, false)
                    .expect("kernel");
                assert_eq!(differing_bits(&got, &want), 0, "{k:?} {rows}x{cin}->{cout}");
            }
        }
    }
}

#[test]
fn every_quantizer_codes_edge_values_alike() {
    let quant = ActivationQuant::from_min_max(-1.0, 3.0);
    let s = quant.scale();
    let z = quant.zero_point() as f32;
    // Ties on both sides, the range's ends and beyond, zeros, infinities and NaN.
    let mut x = vec![
        0.0,
        -0.0,
        0.5 * s,
        1.5 * s,
        2.5 * s,
        -0.5 * s,
        -1.5 * s,
        -z * s,
        (127.0 - z) * s,
        (127.0 - z + 0.5) * s,
        (-z - 0.5) * s,
        1e30,
        -1e30,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE,
    ];
    x.extend(Lcg(9).vec(61, 5.0));
    let cin = x.len();
    let kp = cin.div_ceil(KG) * KG;
    let mut want = vec![0xAAu8; kp];
    quantize_rows(&x, cin, kp, quant, &mut want, Int8Kernel::PORTABLE);
    assert!(want.iter().all(|&q| q <= ACTIVATION_QMAX));
    assert_eq!(want[0], quant.zero_point());
    assert_eq!(want[1], quant.zero_point());
    assert_eq!(want[11], ACTIVATION_QMAX);
    assert_eq!(want[12], 0);
    assert_eq!(want[15], 0, "NaN");
    assert!(want[cin..].iter().all(|&q| q == 0), "padding");
    for k in Int8Kernel::supported() {
        let mut got = vec![0x55u8; kp];
        quantize_rows(&x, cin, kp, quant, &mut got, k);
        assert_eq!(got, want, "{k:?}");
    }
    // Three rows of 76 channels (a multiple of 4: coded as one run of 228 values, the
    // vector quantizers' tails at the end only).
    let x3: Vec<f32> = [&x[..76], &x[1..77], &x[2..78]].concat();
    let mut want = vec![0xAAu8; x3.len()];
    quantize_rows(&x3, 76, 76, quant, &mut want, Int8Kernel::PORTABLE);
    for (r, row) in want.chunks_exact(76).enumerate() {
        for (q, &v) in row.iter().zip(&x[r..r + 76]) {
            assert_eq!(*q, quant.quantize(v));
        }
    }
    for k in Int8Kernel::supported() {
        let mut got = vec![0x55u8; x3.len()];
        quantize_rows(&x3, 76, 76, quant, &mut got, k);
        assert_eq!(got, want, "{k:?}, whole rows");
    }
}

#[test]
fn activation_codes_span_the_observed_range_and_code_zero_exactly() {
    let mut g = Lcg(21);
    for (lo, hi) in [
        (0.0, 6.0),
        (-1.3, 4.7),
        (-8.0, -2.0),
        (0.25, 0.5),
        (0.0, 0.0),
    ] {
        let values: Vec<f32> = g
            .vec(1000, 1.0)
            .iter()
            .map(|v| lo + (hi - lo) * (v + 1.0) / 2.0)
            .chain([lo, hi])
            .collect();
        let mut seen = MinMax::default();
        seen.observe(&values);
        seen.observe(&[f32::NAN, f32::INFINITY]);
        assert_eq!((seen.min, seen.max), (lo, hi));
        let q = seen.quant();
        assert_eq!(q.dequantize(q.quantize(0.0)), 0.0);
        for &v in &values {
            let back = q.dequantize(q.quantize(v));
            assert!(
                (back - v).abs() <= 0.5 * q.scale() * (1.0 + 1e-5),
                "[{lo}, {hi}]: {v} -> {back} (step {})",
                q.scale()
            );
        }
    }
}

/// The portable int8 result against the exact (f64) value of the f32 operator:
/// with `x̂ = s_x (q_x - z)` and `ŵ = s_w q_w`, `x·w - x̂·ŵ = x (w - ŵ) + ŵ (x - x̂)`, and
/// `|w - ŵ| <= s_w / 2`, `|x - x̂| <= s_x / 2` for inputs inside the coded range, so each
/// output before its epilogue is off by at most `Σ_k (|x_k| s_w + |ŵ_k| s_x) / 2` (plus
/// the f32 rounding of the epilogue). The clamps and the residual add do not widen it;
/// the PRELU multiplies it by at most `max(1, |α|)`.
#[test]
fn the_int8_result_is_within_the_quantization_error_of_the_f32_one() {
    let mut g = Lcg(17);
    let mut worst = 0f64;
    for shape in SHAPES {
        let c = Case::random(&mut g, shape);
        let mut seen = MinMax::default();
        seen.observe(&c.x);
        let quant = seen.quant();
        let (s_x, z) = (quant.scale() as f64, quant.zero_point() as f64);
        let wq: Vec<(Vec<i8>, f32)> = c.w.chunks_exact(c.cin).map(quantize_weights).collect();
        for act in ACTS {
            for res in [None, Some(Activation::Relu6)] {
                for prelu in [false, true] {
                    let op = c.op(quant, act, res, prelu);
                    let got = c.run(&op, Int8Kernel::PORTABLE);
                    for r in 0..c.rows {
                        for o in 0..c.cout {
                            let w = &c.w[o * c.cin..(o + 1) * c.cin];
                            let x = &c.x[r * c.cin..(r + 1) * c.cin];
                            let (wq, s_w) = (&wq[o].0, wq[o].1 as f64);
                            let (mut exact, mut bound, mut mag) = (c.b[o] as f64, 0.0, 0.0);
                            for k in 0..c.cin {
                                let (xv, wv) = (x[k] as f64, w[k] as f64);
                                exact += xv * wv;
                                let w_hat = s_w * wq[k] as f64;
                                bound += 0.5 * (xv.abs() * s_w + w_hat.abs() * s_x);
                                mag += xv.abs() * wv.abs();
                                // The coded input is the nearest code (no clamp here).
                                let x_hat = s_x * (quant.quantize(x[k]) as f64 - z);
                                assert!((x_hat - xv).abs() <= 0.5 * s_x * (1.0 + 1e-5));
                            }
                            let clamp = |y: f64, a: Activation| {
                                let (lo, hi) = a.bounds();
                                y.max(lo as f64).min(hi as f64)
                            };
                            let mut y = clamp(exact, act);
                            if let Some(ract) = res {
                                y = clamp(y + c.r[r * c.cout + o] as f64, ract);
                            }
                            let mut gain = 1.0;
                            if prelu {
                                let a = c.alpha[o] as f64;
                                y = y.max(0.0) + a * y.min(0.0);
                                gain = a.abs().max(1.0);
                            }
                            let slack = 1e-5 * (1.0 + mag + c.b[o].abs() as f64);
                            let err = (got[r * c.cout + o] as f64 - y).abs();
                            assert!(
                                err <= gain * bound + slack,
                                "{shape:?} act {act:?} res {res:?} prelu {prelu} \
                                 ({r}, {o}): {} vs {y}, bound {}",
                                got[r * c.cout + o],
                                gain * bound + slack
                            );
                            worst = worst.max(err / (gain * bound + slack));
                        }
                    }
                }
            }
        }
    }
    // The bound is a worst case; the errors of random data stay well inside it.
    assert!(worst < 0.8, "worst error {worst} of the bound");
}

#[test]
fn evaluates_as_a_tract_operator_with_a_residual() {
    let mut g = Lcg(11);
    let (h, w, cin, cout) = (3, 5, 10, 12);
    let c = Case::random(&mut g, (h * w, cin, cout));
    let quant = ActivationQuant::from_min_max(-1.0, 5.0);
    let op = c.op(quant, Activation::Relu, Some(Activation::None), true);
    let out = op
        .eval_out_of_plan(tvec!(
            Tensor::from_shape(&[1, h, w, cin], &c.x)
                .expect("x")
                .into_tvalue(),
            Tensor::from_shape(&[1, h, w, cout], &c.r)
                .expect("r")
                .into_tvalue()
        ))
        .expect("eval")
        .expect("evaluates out of plan");
    assert_eq!(out[0].shape(), &[1, h, w, cout]);
    let got = out[0].try_as_plain_ram().expect("ram");
    let got = got.as_slice::<f32>().expect("f32");
    let want = c.run(&op, Int8Kernel::PORTABLE);
    assert_eq!(differing_bits(got, &want), 0);
}

#[test]
fn a_float_operator_converts_and_a_model_is_calibrated_and_quantized() {
    let mut g = Lcg(29);
    let c = Case::random(&mut g, (6 * 7, 20, 24));
    let quant = ActivationQuant::from_min_max(0.0, 5.0);
    let wt = Tensor::from_shape(&[c.cout, c.cin], &c.w).expect("w");
    let f32op = crate::PointwiseConv::new(&wt, &tensor1(&c.b), Activation::Relu6)
        .expect("op")
        .with_residual(Activation::None)
        .with_prelu(&tensor1(&c.alpha))
        .expect("prelu");
    let want = c.op(quant, Activation::Relu6, Some(Activation::None), true);
    assert!(f32op.to_int8(quant).expect("to_int8") == want);

    // source -> 1x1 (RELU6) -> 1x1 (no activation): both calibrated and replaced.
    let mut model = TypedModel::default();
    let x = model
        .add_source("x", f32::fact([1, 6, 7, c.cin]))
        .expect("source");
    let first = crate::PointwiseConv::new(&wt, &tensor1(&c.b), Activation::Relu6)
        .expect("op")
        .with_split(false);
    let y = model.wire_node("first", first, &[x]).expect("first")[0];
    let w2 = Tensor::from_shape(&[5, c.cout], &g.vec(5 * c.cout, 1.0)).expect("w2");
    let second = crate::PointwiseConv::new(&w2, &tensor1(&[0.5f32; 5]), Activation::None)
        .expect("op")
        .with_split(false);
    let z = model.wire_node("second", second, &[y]).expect("second")[0];
    model.select_output_outlets(&[z]).expect("outputs");
    let input = Tensor::from_shape(&[1, 6, 7, c.cin], &c.x).expect("x");
    let ranges = int8_input_ranges(&model, &[tvec!(input.clone())]).expect("ranges");
    assert_eq!(ranges.len(), 2);
    let (lo, hi) =
        c.x.iter()
            .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    assert_eq!((ranges["first"].min, ranges["first"].max), (lo, hi));
    // The second reads RELU6 outputs.
    assert!(ranges["second"].min >= 0.0 && ranges["second"].max <= 6.0);
    let run = |m: &TypedModel| -> Vec<f32> {
        let out = m
            .clone()
            .into_runnable()
            .expect("plan")
            .run(tvec!(input.clone().into_tvalue()))
            .expect("run");
        let o = out[0].try_as_plain_ram().expect("ram");
        o.as_slice::<f32>().expect("f32").to_vec()
    };
    let reference = run(&model);
    let mut kept = model.clone();
    let n = quantize_pointwise(&mut kept, &ranges, |name, _| name == "first").expect("q");
    assert_eq!(n, 1);
    assert!(kept.node(1).op_as::<crate::PointwiseConv>().is_some());
    assert!(kept.node(2).op_as::<PointwiseConvInt8>().is_some());
    let mut all = model.clone();
    assert_eq!(
        quantize_pointwise(&mut all, &ranges, |_, _| false).expect("q"),
        2
    );
    let (half, full) = (run(&kept), run(&all));
    let scale = reference.iter().fold(0f32, |m, v| m.max(v.abs()));
    for ((r, h), f) in reference.iter().zip(&half).zip(&full) {
        // 7-bit activations over ranges of about 5 and 6 units, 20 and 24 terms.
        assert!((r - h).abs() <= 0.05 * scale, "{r} vs {h}");
        assert!((r - f).abs() <= 0.05 * scale, "{r} vs {f}");
    }
    assert!(half != reference && full != half);
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
        let c = Case::random(&mut g, (rows, cin, cout));
        let quant = ActivationQuant::from_min_max(-1.0, 5.0);
        let res = residual.then_some(Activation::None);
        let make = |split| {
            c.op(quant, Activation::Relu6, res, residual)
                .with_split(split)
        };
        let mut inputs = vec![Tensor::from_shape(&[1, rows, 1, cin], &c.x).expect("x")];
        if residual {
            inputs.push(Tensor::from_shape(&[1, rows, 1, cout], &c.r).expect("r"));
        }
        crate::split::testing::same_bits_split(&make(true), &make(false), &inputs);
    }
}

#[test]
fn coded_rows_give_the_bits_of_coding_the_values() {
    let mut g = Lcg(41);
    // Input channels a multiple of 4 (the coded rows' condition), with rows below and
    // above the split threshold and over one block of rows.
    let shapes = SHAPES
        .iter()
        .copied()
        .filter(|s| s.1 % KG == 0)
        .chain([(3136, 24, 144), (49, 192, 40)]);
    for shape in shapes {
        let c = Case::random(&mut g, shape);
        let quant = ActivationQuant::from_min_max(-0.5, 4.0);
        let codes: Vec<u8> = c.x.iter().map(|&v| quant.quantize(v)).collect();
        for (res, prelu) in [(None, false), (Some(Activation::Relu6), true)] {
            let op = c.op(quant, Activation::Relu6, res, prelu);
            let coded = op.clone().with_coded_input().expect("coded");
            assert!(coded.has_coded_input() && !op.has_coded_input());
            let r = res.map(|_| &c.r[..]);
            for k in Int8Kernel::supported() {
                let want = c.run(&op, k);
                let mut got = vec![f32::NAN; want.len()];
                coded
                    .compute_with(&codes[..], r, &mut got, k, false)
                    .expect("coded");
                assert_eq!(differing_bits(&got, &want), 0, "{k:?} {shape:?}");
            }
        }
    }
    // As a tract operator, in one piece and shared between threads (by rows, by
    // channels).
    for (rows, cin, cout) in [(3136, 24, 144), (49, 192, 1152)] {
        let c = Case::random(&mut g, (rows, cin, cout));
        let quant = ActivationQuant::from_min_max(-1.0, 5.0);
        let codes: Vec<u8> = c.x.iter().map(|&v| quant.quantize(v)).collect();
        let op = |split| {
            c.op(quant, Activation::Relu6, None, false)
                .with_split(split)
        };
        let coded = |split| op(split).with_coded_input().expect("coded");
        let x = Tensor::from_shape(&[1, rows, 1, cin], &c.x).expect("x");
        let q = Tensor::from_shape(&[1, rows, 1, cin], &codes).expect("codes");
        let want = crate::split::testing::bits(&op(false), &[x]);
        let got = crate::split::testing::bits(&coded(false), std::slice::from_ref(&q));
        assert_eq!(got, want);
        crate::split::testing::same_bits_split(&coded(true), &coded(false), &[q]);
    }
    // Not without whole groups of 4 channels.
    let c = Case::random(&mut g, (4, 6, 8));
    let op = c.op(
        ActivationQuant::from_min_max(0.0, 1.0),
        Activation::None,
        None,
        false,
    );
    assert!(op.with_coded_input().is_err());
}

/// `source -> depthwise (RELU6) -> 1x1`, and a second depthwise whose result is read by
/// two 1x1 convolutions (so not coded), in f32.
fn depthwise_model(g: &mut Lcg, c: usize) -> TypedModel {
    let (h, k) = (9, 3);
    let dw = |g: &mut Lcg| crate::NhwcDepthwise {
        kernel: Tensor::from_shape(&[k, k, c], &g.vec(k * k * c, 1.0))
            .expect("k")
            .into_arc_tensor(),
        bias: tensor1(&g.vec(c, 1.0)).into_arc_tensor(),
        strides: (1, 1),
        same: true,
        activation: Activation::Relu6,
        register_blocked: true,
        split: false,
    };
    let pw = |g: &mut Lcg, cout: usize| {
        let w = Tensor::from_shape(&[cout, c], &g.vec(cout * c, 1.0)).expect("w");
        crate::PointwiseConv::new(&w, &tensor1(&g.vec(cout, 1.0)), Activation::None)
            .expect("op")
            .with_split(false)
    };
    let mut model = TypedModel::default();
    let x = model.add_source("x", f32::fact([1, h, h, c])).expect("x");
    let d1 = model.wire_node("dw1", dw(g), &[x]).expect("dw1")[0];
    let p1 = model.wire_node("pw1", pw(g, c), &[d1]).expect("pw1")[0];
    let d2 = model.wire_node("dw2", dw(g), &[p1]).expect("dw2")[0];
    let a = model.wire_node("pw2", pw(g, 8), &[d2]).expect("pw2")[0];
    let b = model.wire_node("pw3", pw(g, 8), &[d2]).expect("pw3")[0];
    model.select_output_outlets(&[a, b]).expect("outputs");
    model
}

#[test]
fn depthwise_results_read_only_by_an_int8_1x1_are_coded_with_the_same_bits() {
    let mut g = Lcg(43);
    let c = 24;
    let model = depthwise_model(&mut g, c);
    let input = Tensor::from_shape(&[1, 9, 9, c], &g.vec(81 * c, 3.0)).expect("x");
    let ranges = int8_input_ranges(&model, &[tvec!(input.clone())]).expect("ranges");
    assert_eq!(ranges.len(), 3);
    // Each 1x1 layer in int8 coding its own input (no coded results).
    let mut plain = model.clone();
    for id in 0..plain.nodes().len() {
        let node = plain.node(id);
        if let Some(op) = node.op_as::<crate::PointwiseConv>() {
            let int8 = op.to_int8(ranges[&node.name].quant()).expect("int8");
            plain.node_mut(id).op = Box::new(int8);
        }
    }
    let mut coded = model.clone();
    assert_eq!(
        quantize_pointwise(&mut coded, &ranges, |_, _| false).expect("q"),
        3
    );
    let op_name = |m: &TypedModel, name: &str| {
        let id = m.node_by_name(name).expect("node").id;
        m.node(id).op().name().to_string()
    };
    assert_eq!(op_name(&coded, "dw1"), "MonohandNhwcDepthwiseCodes");
    assert_eq!(op_name(&coded, "dw2"), "MonohandNhwcDepthwise");
    for (name, is_coded) in [("pw1", true), ("pw2", false), ("pw3", false)] {
        let id = coded.node_by_name(name).expect("node").id;
        let op = coded.node(id).op_as::<PointwiseConvInt8>().expect("int8");
        assert_eq!(op.has_coded_input(), is_coded, "{name}");
    }
    assert_eq!(code_depthwise_results(&mut coded).expect("again"), 0);
    let run = |m: TypedModel| -> Vec<Vec<u32>> {
        let out = m
            .into_optimized()
            .expect("optimised")
            .into_runnable()
            .expect("plan")
            .run(tvec!(input.clone().into_tvalue()))
            .expect("run");
        out.iter()
            .map(|o| {
                let o = o.try_as_plain_ram().expect("ram");
                let v = o.as_slice::<f32>().expect("f32");
                v.iter().map(|v| v.to_bits()).collect()
            })
            .collect()
    };
    assert_eq!(run(coded), run(plain));
}

#[test]
fn rejects_inconsistent_buffers_and_codes() {
    assert!(ActivationQuant::new(0.0, 0).is_err());
    assert!(ActivationQuant::new(f32::NAN, 0).is_err());
    assert!(ActivationQuant::new(1.0, 128).is_err());
    let op = PointwiseConvInt8::new(
        &Tensor::from_shape(&[2, 3], &[1f32; 6]).expect("w"),
        &tensor1(&[0f32; 2]),
        Activation::None,
        ActivationQuant::from_min_max(0.0, 1.0),
    )
    .expect("op");
    let mut out = vec![0f32; 4];
    assert!(op.compute(&[0.5; 6], None, &mut out).is_ok());
    assert!(op.compute(&[0.5; 5], None, &mut out).is_err());
    assert!(op.compute(&[0.5; 6], Some(&[0.0; 4]), &mut out).is_err());
    assert!(PointwiseConvInt8::new(
        &Tensor::from_shape(&[2, 3], &[1f32; 6]).expect("w"),
        &tensor1(&[0f32; 3]),
        Activation::None,
        ActivationQuant::from_min_max(0.0, 1.0),
    )
    .is_err());
}
