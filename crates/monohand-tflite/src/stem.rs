//! A direct convolution for layers with few input channels: the networks' first layer.
//!
//! The first layer of every MediaPipe network is a small-kernel, strided convolution of the
//! RGB image (3x3 stride 2 to 24 channels in the landmark networks, 5x5 stride 2 to 32 in the
//! palm detectors). tract lowers it to a padded copy of the image, an im2col product with 27
//! or 75 columns and, for `RELU6`, two more passes over the output: about 2 of hand_landmark
//! lite's 9 ms for 8 million multiply-adds. This operator reads the image in place (the
//! padding is the taps it skips), keeps one output pixel's channels in registers over all
//! taps and applies bias and activation before its single store.

use tract_core::internal::*;

use crate::depthwise::axis_geometry;
use crate::pointwise::Activation;

/// Most input channels [`DirectConv`] takes (an image: 1, 3 or 4).
pub const DIRECT_CONV_MAX_INPUT_CHANNELS: usize = 4;

/// `KH x KW` convolution of a `[1, H, W, Cin]` f32 tensor with few input channels (at most
/// [`DIRECT_CONV_MAX_INPUT_CHANNELS`]), any stride, TFLite's padding rule (SAME: the extra
/// padding at the bottom/right), a bias per output channel and a fused activation.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct DirectConv {
    /// Weights `[KH, KW, Cin, Cout]` (TFLite's `[Cout, KH, KW, Cin]` transposed at load).
    kernel: Arc<Tensor>,
    /// Bias `[Cout]`.
    bias: Arc<Tensor>,
    /// Strides (y, x).
    strides: (usize, usize),
    /// TFLite SAME padding (else VALID).
    same: bool,
    /// Activation applied to the result.
    activation: Activation,
}

impl DirectConv {
    /// The operator for a TFLite `CONV_2D` kernel `[Cout, KH, KW, Cin]` and bias `[Cout]`.
    ///
    /// Errors if the shapes disagree or `Cin` is above [`DIRECT_CONV_MAX_INPUT_CHANNELS`].
    pub fn new(
        kernel: &Tensor,
        bias: &Tensor,
        strides: (usize, usize),
        same: bool,
        activation: Activation,
    ) -> TractResult<DirectConv> {
        let s = kernel.shape();
        ensure!(
            s.len() == 4,
            "direct conv kernel must be [Cout, KH, KW, Cin], got {s:?}"
        );
        let (cout, kh, kw, cin) = (s[0], s[1], s[2], s[3]);
        ensure!(
            (1..=DIRECT_CONV_MAX_INPUT_CHANNELS).contains(&cin) && cout > 0 && kh > 0 && kw > 0,
            "direct conv takes 1 to {DIRECT_CONV_MAX_INPUT_CHANNELS} input channels, kernel {s:?}"
        );
        ensure!(
            strides.0 > 0 && strides.1 > 0,
            "direct conv strides must be positive"
        );
        ensure!(
            bias.len() == cout,
            "direct conv bias has {} values for {cout} channels",
            bias.len()
        );
        let k = kernel.cast_to::<f32>()?;
        let k = k.try_as_plain_ram()?;
        let k = k.as_slice::<f32>()?;
        let mut packed = vec![0f32; k.len()];
        for o in 0..cout {
            for t in 0..kh * kw * cin {
                packed[t * cout + o] = k[o * kh * kw * cin + t];
            }
        }
        Ok(DirectConv {
            kernel: tensor1(&packed)
                .into_shape(&[kh, kw, cin, cout])?
                .into_arc_tensor(),
            bias: bias
                .cast_to::<f32>()?
                .into_owned()
                .into_shape(&[cout])?
                .into_arc_tensor(),
            strides,
            same,
            activation,
        })
    }

    fn dims(&self) -> (usize, usize, usize, usize) {
        let s = self.kernel.shape();
        (s[0], s[1], s[2], s[3])
    }

    fn geometry(&self, h: usize, w: usize) -> Geometry {
        let (kh, kw, cin, cout) = self.dims();
        let (oh, pt) = axis_geometry(h, kh, self.strides.0, self.same);
        let (ow, pl) = axis_geometry(w, kw, self.strides.1, self.same);
        Geometry {
            h,
            w,
            cin,
            cout,
            kh,
            kw,
            sy: self.strides.0,
            sx: self.strides.1,
            pt,
            pl,
            oh,
            ow,
        }
    }
}

impl Op for DirectConv {
    fn name(&self) -> StaticName {
        "MonohandDirectConv".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        let (kh, kw, cin, cout) = self.dims();
        Ok(vec![format!(
            "{kh}x{kw} stride {:?}, {cin} -> {cout} channels, {}, {:?}",
            self.strides,
            if self.same { "SAME" } else { "VALID" },
            self.activation
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for DirectConv {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let shape = input.shape();
        ensure!(
            shape.len() == 4 && shape[0] == 1,
            "direct conv expects [1, H, W, C], got {shape:?}"
        );
        let g = self.geometry(shape[1], shape[2]);
        ensure!(
            shape[3] == g.cin,
            "direct conv kernel takes {} channels, input has {}",
            g.cin,
            shape[3]
        );
        let mut output = Tensor::zero::<f32>(&[1, g.oh, g.ow, g.cout])?;
        {
            let src = input.try_as_plain_ram()?;
            let src = src.as_slice::<f32>()?;
            let k = self.kernel.try_as_plain_ram()?;
            let k = k.as_slice::<f32>()?;
            let b = self.bias.try_as_plain_ram()?;
            let b = b.as_slice::<f32>()?;
            let mut dst = output.try_as_plain_ram_mut()?;
            let dst = dst.as_slice_mut::<f32>()?;
            run(&g, src, k, b, dst, self.activation.bounds(), Kernel::best());
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

impl TypedOp for DirectConv {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = inputs[0]
            .shape
            .as_concrete()
            .context("direct conv needs a concrete input shape")?;
        ensure!(shape.len() == 4, "direct conv expects rank 4");
        let g = self.geometry(shape[1], shape[2]);
        Ok(tvec!(f32::fact([shape[0], g.oh, g.ow, g.cout])))
    }
}

/// Sizes of one evaluation.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    h: usize,
    w: usize,
    cin: usize,
    cout: usize,
    kh: usize,
    kw: usize,
    sy: usize,
    sx: usize,
    pt: usize,
    pl: usize,
    oh: usize,
    ow: usize,
}

impl Geometry {
    /// The taps `[start, end)` of a kernel axis that fall inside the input, for the output
    /// position `o` (`stride`, leading padding `pad`, input size `n`, kernel size `k`).
    #[inline]
    fn taps(o: usize, stride: usize, pad: usize, n: usize, k: usize) -> (usize, usize) {
        let first = (o * stride) as isize - pad as isize;
        let start = (-first).max(0) as usize;
        let end = (n as isize - first).clamp(0, k as isize) as usize;
        (start.min(end), end)
    }
}

/// Which loop runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kernel {
    /// Plain Rust (multiply, then add), any CPU.
    Portable,
    /// The same loop compiled for AVX2 with fused multiply-adds.
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
}

impl Kernel {
    fn best() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            return Kernel::Avx2Fma;
        }
        Kernel::Portable
    }
}

fn run(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    bounds: (f32, f32),
    kernel: Kernel,
) {
    match kernel {
        Kernel::Portable => dispatch::<false>(g, src, k, b, dst, bounds),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Kernel::best` chose this kernel only on a CPU with AVX2 and FMA.
        Kernel::Avx2Fma => unsafe { dispatch_avx2_fma(g, src, k, b, dst, bounds) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn dispatch_avx2_fma(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    bounds: (f32, f32),
) {
    dispatch::<true>(g, src, k, b, dst, bounds)
}

/// The output channel counts with a loop unrolled for them (the networks' 16, 24 and 32),
/// then any count.
#[inline(always)]
fn dispatch<const FMA: bool>(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    bounds: (f32, f32),
) {
    match g.cout {
        16 => conv::<FMA, 16>(g, src, k, b, dst, bounds),
        24 => conv::<FMA, 24>(g, src, k, b, dst, bounds),
        32 => conv::<FMA, 32>(g, src, k, b, dst, bounds),
        _ => conv_any::<FMA>(g, src, k, b, dst, bounds),
    }
}

/// One output pixel's `C` channels summed in registers over every tap inside the image.
///
/// The taps are summed in tract's im2col order (input channel, then kernel row, then
/// column) from zero, and the bias is added after them, as tract's product does: the
/// outputs are the same bits as tract's `Conv` (the padding's taps add exact zeros there).
/// (Two or four pixels side by side, for independent chains of multiply-adds, measured
/// slower: the CPU already overlaps consecutive pixels' sums.)
#[inline(always)]
fn conv<const FMA: bool, const C: usize>(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    (lo, hi): (f32, f32),
) {
    let Ok(bias) = <&[f32; C]>::try_from(b) else {
        return;
    };
    for (oy, row) in dst.chunks_exact_mut(g.ow * C).enumerate().take(g.oh) {
        for (ox, out) in row.chunks_exact_mut(C).enumerate() {
            let mut acc = [0f32; C];
            pixel::<FMA>(g, src, k, oy, ox, &mut acc);
            for ((o, a), b) in out.iter_mut().zip(acc).zip(bias) {
                *o = (a + b).max(lo).min(hi);
            }
        }
    }
}

/// [`conv`] for any channel count, summing into the output row.
#[inline(always)]
fn conv_any<const FMA: bool>(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    b: &[f32],
    dst: &mut [f32],
    (lo, hi): (f32, f32),
) {
    for (oy, row) in dst.chunks_exact_mut(g.ow * g.cout).enumerate().take(g.oh) {
        for (ox, out) in row.chunks_exact_mut(g.cout).enumerate() {
            out.fill(0.0);
            pixel::<FMA>(g, src, k, oy, ox, out);
            for (o, b) in out.iter_mut().zip(b) {
                *o = (*o + b).max(lo).min(hi);
            }
        }
    }
}

/// Adds the taps of output pixel `(oy, ox)` that fall inside the image to `acc`
/// (`Cout` values).
#[inline(always)]
fn pixel<const FMA: bool>(
    g: &Geometry,
    src: &[f32],
    k: &[f32],
    oy: usize,
    ox: usize,
    acc: &mut [f32],
) {
    let c = acc.len();
    let (ky0, ky1) = Geometry::taps(oy, g.sy, g.pt, g.h, g.kh);
    let (kx0, kx1) = Geometry::taps(ox, g.sx, g.pl, g.w, g.kw);
    for ci in 0..g.cin {
        for ky in ky0..ky1 {
            // In range: the taps start where the padding ends.
            let line = (oy * g.sy + ky - g.pt) * g.w;
            for kx in kx0..kx1 {
                let x = src[(line + ox * g.sx + kx - g.pl) * g.cin + ci];
                let t = (ky * g.kw + kx) * g.cin + ci;
                let w = &k[t * c..(t + 1) * c];
                for (a, &w) in acc.iter_mut().zip(w) {
                    *a = if FMA { x.mul_add(w, *a) } else { *a + x * w };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

    use super::*;

    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        }
        fn vec(&mut self, n: usize) -> Vec<f32> {
            (0..n).map(|_| self.next()).collect()
        }
    }

    /// A plain convolution in f64 from TFLite's `[Cout, KH, KW, Cin]` kernel, with the
    /// padding made explicit: what the operator must compute.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        x: &[f32],
        (h, w, cin): (usize, usize, usize),
        k: &[f32],
        (cout, kh, kw): (usize, usize, usize),
        b: &[f32],
        (sy, sx): (usize, usize),
        same: bool,
        act: Activation,
    ) -> (usize, usize, Vec<f64>) {
        let (oh, pt) = axis_geometry(h, kh, sy, same);
        let (ow, pl) = axis_geometry(w, kw, sx, same);
        let (lo, hi) = act.bounds();
        let mut out = vec![0.0; oh * ow * cout];
        for oy in 0..oh {
            for ox in 0..ow {
                for o in 0..cout {
                    let mut s = b[o] as f64;
                    for ky in 0..kh {
                        for kx in 0..kw {
                            let iy = (oy * sy + ky) as isize - pt as isize;
                            let ix = (ox * sx + kx) as isize - pl as isize;
                            if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                                continue;
                            }
                            for c in 0..cin {
                                s += x[(iy as usize * w + ix as usize) * cin + c] as f64
                                    * k[((o * kh + ky) * kw + kx) * cin + c] as f64;
                            }
                        }
                    }
                    out[(oy * ow + ox) * cout + o] = s.clamp(lo as f64, hi as f64);
                }
            }
        }
        (oh, ow, out)
    }

    /// One shape: input `(h, w, cin)`, `cout` channels, kernel `(size, stride)`.
    fn check(
        (h, w, cin): (usize, usize, usize),
        cout: usize,
        (kk, stride): (usize, usize),
        same: bool,
        act: Activation,
    ) {
        let mut rng = Lcg(h as u64 * 1000 + cout as u64 * 10 + kk as u64);
        let x = rng.vec(h * w * cin);
        let k = rng.vec(cout * kk * kk * cin);
        let b = rng.vec(cout);
        let (oh, ow, want) = reference(
            &x,
            (h, w, cin),
            &k,
            (cout, kk, kk),
            &b,
            (stride, stride),
            same,
            act,
        );
        let kernel = tensor1(&k).into_shape(&[cout, kk, kk, cin]).unwrap();
        let op = DirectConv::new(&kernel, &tensor1(&b), (stride, stride), same, act).unwrap();
        let g = op.geometry(h, w);
        assert_eq!((g.oh, g.ow), (oh, ow));
        let kp = op.kernel.try_as_plain_ram().unwrap();
        let kp = kp.as_slice::<f32>().unwrap();
        let mut kernels = vec![Kernel::Portable];
        if Kernel::best() != Kernel::Portable {
            kernels.push(Kernel::best());
        }
        for kernel in kernels {
            let mut got = vec![f32::NAN; oh * ow * cout];
            run(&g, &x, kp, &b, &mut got, act.bounds(), kernel);
            for (i, (&g, &r)) in got.iter().zip(&want).enumerate() {
                assert!(
                    (g as f64 - r).abs() < 1e-5 * (1.0 + r.abs()),
                    "{kernel:?} {h}x{w}x{cin} -> {cout}, {kk}x{kk}/{stride} same={same} {act:?}: element {i}: {g} against {r}"
                );
            }
        }
    }

    #[test]
    fn matches_a_plain_convolution_for_the_networks_stems_and_odd_shapes() {
        // The landmark networks' stem, the palm detectors', then other channel counts,
        // kernels, strides, VALID padding and inputs smaller than the kernel.
        check((224, 224, 3), 24, (3, 2), true, Activation::Relu6);
        check((192, 192, 3), 32, (5, 2), true, Activation::None);
        check((17, 13, 3), 16, (3, 2), true, Activation::Relu);
        check((17, 13, 1), 7, (3, 1), true, Activation::None);
        check((9, 10, 4), 24, (3, 2), false, Activation::Relu6);
        check((8, 8, 3), 32, (5, 3), false, Activation::None);
        check((2, 3, 2), 5, (5, 2), true, Activation::Relu);
    }

    #[test]
    fn refuses_what_it_cannot_compute() {
        let k = Tensor::zero::<f32>(&[8, 3, 3, 5]).unwrap();
        assert!(DirectConv::new(
            &k,
            &Tensor::zero::<f32>(&[8]).unwrap(),
            (2, 2),
            true,
            Activation::None
        )
        .is_err());
        let k = Tensor::zero::<f32>(&[8, 3, 3, 3]).unwrap();
        assert!(DirectConv::new(
            &k,
            &Tensor::zero::<f32>(&[7]).unwrap(),
            (2, 2),
            true,
            Activation::None
        )
        .is_err());
        assert!(DirectConv::new(
            &k,
            &Tensor::zero::<f32>(&[8]).unwrap(),
            (0, 2),
            true,
            Activation::None
        )
        .is_err());
    }
}
