//! The kernel type, in a module of its own so that nothing else can make one.

#[cfg(target_arch = "x86_64")]
use crate::isa::Cpu;
use crate::isa::Level;

/// The instruction set of an int8 micro-kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// Plain Rust, any CPU: the reference.
    Portable,
    /// `std::arch` AVX2 intrinsics (`vpmaddubsw`, `vpmaddwd`).
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// AVX2 with AVX-VNNI's VEX-coded 256-bit `vpdpbusd`.
    #[cfg(target_arch = "x86_64")]
    AvxVnni,
    /// AVX-512F + BW + VL with AVX-512 VNNI's 512-bit `vpdpbusd`.
    #[cfg(target_arch = "x86_64")]
    Avx512Vnni,
    /// AMX's `tdpbusd` on tiles of 16 rows, with the AVX-512 VNNI kernel's epilogue
    /// and for the rows left over.
    #[cfg(target_arch = "x86_64")]
    Amx,
    /// WebAssembly's relaxed SIMD, `i32x4.relaxed_dot_i8x16_i7x16_add_s`, in a module
    /// built with `relaxed-simd` (an engine either runs such a module or refuses to
    /// load it: nothing to detect at run time).
    #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
    RelaxedSimd,
}

/// An int8 micro-kernel that this CPU runs. Its field is private: one is made only by
/// run-time detection ([`Int8Kernel::supported`], [`Int8Kernel::best`], from
/// [`Cpu`](crate::isa::Cpu)) or is the portable one, so holding one shows that the CPU
/// has the features of its [`Isa`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Int8Kernel(Isa);

impl Int8Kernel {
    /// The portable kernel (any CPU).
    pub(crate) const PORTABLE: Int8Kernel = Int8Kernel(Isa::Portable);

    /// Its instruction set (which the CPU has).
    pub(crate) fn isa(self) -> Isa {
        self.0
    }

    /// Its name (that of its level in `MONOHAND_KERNEL`).
    pub(crate) fn name(self) -> &'static str {
        match self.0 {
            Isa::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => "avx2",
            #[cfg(target_arch = "x86_64")]
            Isa::AvxVnni => "avxvnni",
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512Vnni => "avx512vnni",
            #[cfg(target_arch = "x86_64")]
            Isa::Amx => "amx",
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            Isa::RelaxedSimd => "relaxed-simd",
        }
    }

    /// Its instruction-set level (what `MONOHAND_KERNEL` caps).
    pub(crate) fn level(self) -> Level {
        match self.0 {
            Isa::Portable => Level::Portable,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => Level::Avx2,
            #[cfg(target_arch = "x86_64")]
            Isa::AvxVnni => Level::AvxVnni,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512Vnni => Level::Avx512Vnni,
            #[cfg(target_arch = "x86_64")]
            Isa::Amx => Level::Amx,
            #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
            Isa::RelaxedSimd => Level::Avx2,
        }
    }

    /// Every int8 kernel this CPU runs, slowest first (detected at run time).
    pub(crate) fn supported() -> Vec<Int8Kernel> {
        #[allow(unused_mut)]
        let mut v = vec![Int8Kernel::PORTABLE];
        #[cfg(target_arch = "x86_64")]
        {
            let cpu = Cpu::get();
            if cpu.avx2() {
                v.push(Int8Kernel(Isa::Avx2));
            }
            if cpu.avx_vnni() {
                v.push(Int8Kernel(Isa::AvxVnni));
            }
            if cpu.avx512_vnni() {
                v.push(Int8Kernel(Isa::Avx512Vnni));
            }
            if cpu.amx_int8() {
                v.push(Int8Kernel(Isa::Amx));
            }
        }
        #[cfg(all(target_arch = "wasm32", target_feature = "relaxed-simd"))]
        v.push(Int8Kernel(Isa::RelaxedSimd));
        v
    }

    /// The fastest kernel this CPU runs at or below the level `MONOHAND_KERNEL` names
    /// (decided once per process; see [`crate::isa`]).
    pub(crate) fn best() -> Int8Kernel {
        static BEST: std::sync::OnceLock<Int8Kernel> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| {
            crate::isa::choose(
                &Int8Kernel::supported(),
                Int8Kernel::level,
                crate::isa::cap(),
                Int8Kernel::PORTABLE,
            )
        })
    }
}
