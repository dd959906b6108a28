//! The kernel type, in a module of its own so that nothing else can make one.

#[cfg(target_arch = "x86_64")]
use crate::isa::Cpu;
use crate::isa::Level;

/// The instruction set of a micro-kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// Plain Rust, any CPU.
    Portable,
    /// `std::arch` AVX2 + FMA intrinsics.
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
    /// `std::arch` AVX-512F + VL intrinsics.
    #[cfg(target_arch = "x86_64")]
    Avx512,
    /// `core::arch::wasm32` 128-bit SIMD, in a module built with `simd128` (a
    /// WebAssembly engine either runs such a module or refuses to load it, so there is
    /// nothing to detect at run time).
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    Simd128,
}

/// A micro-kernel that this CPU runs. Its field is private: a `Kernel` is made only by
/// run-time detection ([`Kernel::supported`], [`Kernel::best`]), or is the portable one,
/// so holding one shows that the CPU has the features of its [`Isa`] — what the
/// `unsafe` calls of the intrinsics behind it rely on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Kernel(Isa);

impl Kernel {
    /// The portable kernel (any CPU).
    pub(crate) const PORTABLE: Kernel = Kernel(Isa::Portable);

    /// Its instruction set (which the CPU has).
    pub(crate) fn isa(self) -> Isa {
        self.0
    }

    /// The name of its level in `MONOHAND_KERNEL` (which the measurements print).
    #[cfg(test)]
    pub(crate) fn name(self) -> &'static str {
        match self.0 {
            Isa::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2Fma => "avx2",
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => "avx512",
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Isa::Simd128 => "simd128",
        }
    }

    /// Its instruction-set level (what `MONOHAND_KERNEL` caps).
    pub(crate) fn level(self) -> Level {
        match self.0 {
            Isa::Portable => Level::Portable,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2Fma => Level::Avx2,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => Level::Avx512,
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Isa::Simd128 => Level::Avx2,
        }
    }

    /// Every kernel this CPU runs, slowest first (detected at run time, [`Cpu`]).
    pub(crate) fn supported() -> Vec<Kernel> {
        #[allow(unused_mut)]
        let mut v = vec![Kernel::PORTABLE];
        #[cfg(target_arch = "x86_64")]
        {
            let cpu = Cpu::get();
            if cpu.avx2_fma() {
                v.push(Kernel(Isa::Avx2Fma));
            }
            if cpu.avx512f_vl() {
                v.push(Kernel(Isa::Avx512));
            }
        }
        #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
        v.push(Kernel(Isa::Simd128));
        v
    }

    /// The fastest kernel this CPU runs at or below the level `MONOHAND_KERNEL` names
    /// (decided once per process; see [`crate::isa`]).
    pub(crate) fn best() -> Kernel {
        static BEST: std::sync::OnceLock<Kernel> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| {
            crate::isa::choose(
                &Kernel::supported(),
                Kernel::level,
                crate::isa::cap(),
                Kernel::PORTABLE,
            )
        })
    }
}
