//! Coding f32 values into activation codes ([`ActivationQuant`]) with an int8 kernel's own
//! quantizer (portable, AVX2, AVX-512 or WebAssembly: each gives the portable one's codes):
//! runs of values, and rows padded to whole groups of 4. Above the kernels, whose
//! quantizers it calls, and the codes (`quant.rs`), which the kernels take.

#[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
use super::wasm;
#[cfg(target_arch = "x86_64")]
use super::{avx2, avx512};
use super::{ActivationQuant, Int8Kernel, Isa};

/// Codes `x` into `q` (of the same length) with `quant` and the quantizer of the best int8
/// kernel: the codes a [`PointwiseConvInt8`](super::PointwiseConvInt8) with this input code makes of these values.
pub(crate) fn quantize_values(x: &[f32], q: &mut [u8], quant: ActivationQuant) {
    let n = x.len().min(q.len());
    quantize_run(&x[..n], &mut q[..n], quant, Int8Kernel::best());
}

/// Codes `x` (rows of `cin` f32) into `q` (rows of `kp` bytes, the `kp - cin` last ones 0).
pub(super) fn quantize_rows(
    x: &[f32],
    cin: usize,
    kp: usize,
    quant: ActivationQuant,
    q: &mut [u8],
    kernel: Int8Kernel,
) {
    if cin == kp {
        // No padding: the rows are one run of values in both.
        let n = x.len().min(q.len());
        quantize_run(&x[..n], &mut q[..n], quant, kernel);
        return;
    }
    for (x, q) in x.chunks_exact(cin).zip(q.chunks_exact_mut(kp)) {
        let (q, pad) = q.split_at_mut(cin);
        quantize_run(x, q, quant, kernel);
        pad.fill(0);
    }
}

/// Codes `x` into `q` (of the same length) with `kernel`'s quantizer.
pub(crate) fn quantize_run(x: &[f32], q: &mut [u8], quant: ActivationQuant, kernel: Int8Kernel) {
    match kernel.isa() {
        Isa::Portable => {
            for (q, &x) in q.iter_mut().zip(x) {
                *q = quant.quantize(x);
            }
        }
        // SAFETY: the CPU has AVX2 (an `Int8Kernel` of these ISAs is only made by run-time
        // detection, and AVX-VNNI's is made only where AVX2 is detected too); `x` and `q`
        // have the same length.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 | Isa::AvxVnni => unsafe { avx2::quantize(x, q, quant) },
        // SAFETY: the CPU has AVX-512F, BW and VL (as above); `x` and `q` have the same
        // length.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512Vnni | Isa::Amx => unsafe { avx512::quantize(x, q, quant) },
        #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
        Isa::RelaxedSimd => wasm::quantize(x, q, quant),
    }
}
