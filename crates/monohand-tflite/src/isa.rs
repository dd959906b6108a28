//! What both kinds of micro-kernels are chosen from, in one place: the CPU's features,
//! detected once per process ([`Cpu`]), and the level `MONOHAND_KERNEL` caps the kernels at,
//! read once per process ([`cap`]). The f32 kernels ([`crate::pointwise`]'s `Kernel`, which
//! [`crate::NhwcDepthwise`] and [`crate::NhwcConv`] use too) and the int8 ones
//! ([`crate::int8`]'s `Int8Kernel`) build their lists of supported kernels from [`Cpu`] and
//! pick one with [`choose`]. Their kernel values are still made only there, so holding one
//! still shows that the CPU has its features.
//!
//! `MONOHAND_KERNEL` names a [`Level`]: `portable`, `avx2`, `avxvnni`, `avx512`,
//! `avx512vnni` or `amx` (and `simd128`, the same level as `avx2`). Each kind of kernel then runs its
//! fastest kernel at or below that level which the CPU has: `avx2` runs the f32 AVX2 + FMA
//! kernel and the int8 AVX2 one, `avx512` the f32 AVX-512 kernel and the int8 AVX-VNNI one
//! where the CPU has it (else AVX2), `avx512vnni` the int8 AVX-512 VNNI one without AMX, `amx`
//! (or nothing) the fastest of each. An
//! unknown name caps nothing.

use std::sync::OnceLock;

/// `a·b + c`, lane by lane, for the WebAssembly kernels: in a module built with
/// `relaxed-simd`, `f32x4.relaxed_madd`, which the engine compiles to a fused multiply-add
/// where its CPU has one (V8 on x86-64 with FMA3, on ARM64) and to a product then a sum
/// elsewhere; with `simd128` alone, always a product then a sum (the portable loops' bits).
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
#[inline(always)]
pub(crate) fn wasm_madd(
    a: core::arch::wasm32::v128,
    b: core::arch::wasm32::v128,
    c: core::arch::wasm32::v128,
) -> core::arch::wasm32::v128 {
    use core::arch::wasm32::*;
    #[cfg(target_feature = "relaxed-simd")]
    {
        f32x4_relaxed_madd(a, b, c)
    }
    #[cfg(not(target_feature = "relaxed-simd"))]
    {
        f32x4_add(c, f32x4_mul(a, b))
    }
}

/// The mask of the first `n` (<= 16) lanes of an AVX-512 vector of f32 or i32: the
/// AVX-512 kernels' loads and stores of a tile's last, partial vector (f32 and int8 1x1
/// convolutions, the int8 quantizer).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn lanes(n: usize) -> u16 {
    if n >= 16 {
        0xffff
    } else {
        (1u16 << n) - 1
    }
}

/// The first `lanes` floats at `p` (4 or more: a whole vector), the other lanes 0: the
/// WebAssembly kernels' read of a tile's last, partial vector (a residual).
///
/// # Safety
/// `p` is valid for reading `lanes.min(4)` floats.
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
#[inline(always)]
pub(crate) unsafe fn wasm_load_lanes(p: *const f32, lanes: usize) -> core::arch::wasm32::v128 {
    use core::arch::wasm32::*;
    if lanes >= 4 {
        // SAFETY: 4 floats (the contract); WebAssembly loads need no alignment.
        return unsafe { v128_load(p as *const v128) };
    }
    let mut part = [0f32; 4];
    for (l, part) in part.iter_mut().enumerate().take(lanes) {
        // SAFETY: l < lanes floats (the contract).
        *part = unsafe { *p.add(l) };
    }
    // SAFETY: `part` holds 4 floats.
    unsafe { v128_load(part.as_ptr() as *const v128) }
}

/// Writes the first `lanes` lanes of `v` to `p` (4 or more: the whole vector): the
/// WebAssembly kernels' store of a tile's last, partial vector.
///
/// # Safety
/// `p` is valid for writing `lanes.min(4)` floats.
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
#[inline(always)]
pub(crate) unsafe fn wasm_store_lanes(p: *mut f32, v: core::arch::wasm32::v128, lanes: usize) {
    use core::arch::wasm32::*;
    if lanes >= 4 {
        // SAFETY: 4 floats (the contract); WebAssembly stores need no alignment.
        unsafe { v128_store(p as *mut v128, v) };
        return;
    }
    let mut part = [0f32; 4];
    // SAFETY: `part` holds 4 floats.
    unsafe { v128_store(part.as_mut_ptr() as *mut v128, v) };
    for (l, &part) in part.iter().enumerate().take(lanes) {
        // SAFETY: l < lanes floats (the contract).
        unsafe { *p.add(l) = part };
    }
}

/// The instruction-set levels of the kernels, slowest first: the values `MONOHAND_KERNEL`
/// names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Level {
    /// Plain Rust (`portable`).
    Portable,
    /// AVX2 (`avx2`; the f32 kernels with FMA), and WebAssembly's 128-bit SIMD (`simd128`).
    Avx2,
    /// AVX2 with the VEX-coded `vpdpbusd` (`avxvnni`: Alder Lake and later, Zen 5).
    AvxVnni,
    /// AVX-512F + VL (`avx512`; the int8 kernels have none of their own at this level).
    Avx512,
    /// AVX-512 with VNNI's `vpdpbusd` on 512-bit registers (`avx512vnni`).
    Avx512Vnni,
    /// AVX-512 VNNI with AMX's int8 tile multiply (`amx`: Sapphire Rapids and later Xeons,
    /// where Linux grants the tile state; the f32 kernels have none of their own here).
    Amx,
}

impl Level {
    /// The level `name` stands for, if any.
    pub(crate) fn from_name(name: &str) -> Option<Level> {
        Some(match name {
            "portable" => Level::Portable,
            "avx2" | "simd128" => Level::Avx2,
            "avxvnni" => Level::AvxVnni,
            "avx512" => Level::Avx512,
            "avx512vnni" => Level::Avx512Vnni,
            "amx" => Level::Amx,
            _ => return None,
        })
    }
}

/// The level `MONOHAND_KERNEL` names (read once per process); `None` where it is unset or
/// names no level.
pub(crate) fn cap() -> Option<Level> {
    static CAP: OnceLock<Option<Level>> = OnceLock::new();
    *CAP.get_or_init(|| {
        std::env::var("MONOHAND_KERNEL")
            .ok()
            .as_deref()
            .and_then(Level::from_name)
    })
}

/// The last kernel of `supported` (slowest first) whose level is at most `cap`, or the
/// last one where `cap` is `None`; `fallback` where there is none.
pub(crate) fn choose<K: Copy>(
    supported: &[K],
    level: impl Fn(K) -> Level,
    cap: Option<Level>,
    fallback: K,
) -> K {
    supported
        .iter()
        .rev()
        .copied()
        .find(|&k| cap.is_none_or(|c| level(k) <= c))
        .unwrap_or(fallback)
}

/// The CPU features the kernels use, detected at run time once per process. Its fields are
/// private and set only by detection ([`Cpu::get`]): a feature reported here is one the CPU
/// has. (All false off x86-64, where no kernel asks for them: hence the `allow`s.)
#[derive(Debug, Clone, Copy, Default)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) struct Cpu {
    avx2: bool,
    fma: bool,
    avx512f: bool,
    avx512bw: bool,
    avx512vl: bool,
    avx512vnni: bool,
    avxvnni: bool,
}

#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
impl Cpu {
    /// This CPU's features (detected on the first call).
    pub(crate) fn get() -> Cpu {
        static CPU: OnceLock<Cpu> = OnceLock::new();
        *CPU.get_or_init(Cpu::detect)
    }

    #[cfg(target_arch = "x86_64")]
    fn detect() -> Cpu {
        use std::arch::is_x86_feature_detected as has;
        Cpu {
            avx2: has!("avx2"),
            fma: has!("fma"),
            avx512f: has!("avx512f"),
            avx512bw: has!("avx512bw"),
            avx512vl: has!("avx512vl"),
            avx512vnni: has!("avx512vnni"),
            avxvnni: has!("avxvnni"),
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn detect() -> Cpu {
        Cpu::default()
    }

    /// AVX2.
    pub(crate) fn avx2(self) -> bool {
        self.avx2
    }

    /// AVX2 and FMA.
    pub(crate) fn avx2_fma(self) -> bool {
        self.avx2 && self.fma
    }

    /// AVX-512F and AVX-512VL.
    pub(crate) fn avx512f_vl(self) -> bool {
        self.avx512f && self.avx512vl
    }

    /// AVX2 and AVX-VNNI (the VEX-coded 256-bit `vpdpbusd`).
    pub(crate) fn avx_vnni(self) -> bool {
        self.avx2 && self.avxvnni
    }

    /// AVX-512F, BW, VL and VNNI.
    pub(crate) fn avx512_vnni(self) -> bool {
        self.avx512f && self.avx512bw && self.avx512vl && self.avx512vnni
    }

    /// AMX's int8 tile multiply (`tdpbusd`) usable by this process, besides AVX-512 VNNI
    /// (whose kernel does a tile's epilogue and the rows AMX's 16-row tiles leave). The
    /// check is tract's own, which its AMX matrix products use: CPUID, then (on Linux, once
    /// per process) `arch_prctl(ARCH_REQ_XCOMP_PERM, XFEATURE_XTILEDATA)`, without which an
    /// AMX instruction is a SIGILL; elsewhere false.
    pub(crate) fn amx_int8(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            self.avx512_vnni() && tract_core::tract_linalg::x86_64::amx::has_amx_int8()
        }
        #[cfg(not(target_arch = "x86_64"))]
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_levels_and_choice() {
        assert_eq!(Level::from_name("portable"), Some(Level::Portable));
        assert_eq!(Level::from_name("simd128"), Some(Level::Avx2));
        assert_eq!(Level::from_name("avx512vnni"), Some(Level::Avx512Vnni));
        assert_eq!(Level::from_name("amx"), Some(Level::Amx));
        assert!(Level::Avx512Vnni < Level::Amx);
        assert_eq!(Level::from_name("sse2"), None);
        assert!(Level::Avx2 < Level::AvxVnni && Level::AvxVnni < Level::Avx512);
        let levels = [
            Level::Portable,
            Level::Avx2,
            Level::AvxVnni,
            Level::Avx512Vnni,
        ];
        let pick = |cap| choose(&[0, 1, 2, 3], |k: usize| levels[k], cap, 9);
        assert_eq!(pick(None), 3);
        assert_eq!(pick(Some(Level::Avx512Vnni)), 3);
        assert_eq!(pick(Some(Level::Avx512)), 2);
        assert_eq!(pick(Some(Level::Avx2)), 1);
        assert_eq!(pick(Some(Level::Portable)), 0);
        assert_eq!(choose(&[2], |k: usize| levels[k], Some(Level::Avx2), 9), 9);
    }

    #[test]
    fn detection_matches_std() {
        let cpu = Cpu::get();
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            assert_eq!(cpu.avx2_fma(), has!("avx2") && has!("fma"));
            assert_eq!(cpu.avx512f_vl(), has!("avx512f") && has!("avx512vl"));
            assert_eq!(cpu.avx_vnni(), has!("avx2") && has!("avxvnni"));
            assert_eq!(cpu.avx512_vnni(), has!("avx512vnni") && has!("avx512bw"));
        }
        #[cfg(not(target_arch = "x86_64"))]
        assert!(!cpu.avx2() && !cpu.avx512_vnni());
    }
}
