//! The instruction-set guard: refuses to start, with a message that says how to rebuild, on
//! an x86-64 CPU that lacks an extension the build was compiled for.
//!
//! `.cargo/config.toml` builds for `x86-64-v3` (AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE).
//! Without this check such a binary dies of SIGILL somewhere inside the first hot loop. The
//! features are read with CPUID directly: `is_x86_feature_detected!` answers `true` at
//! compile time for every feature the build enables, so it cannot tell.

/// The extensions this build requires that the CPU lacks, by their `target_feature` names;
/// empty when it may run (always on other architectures).
pub fn missing_extensions() -> Vec<&'static str> {
    #[cfg(target_arch = "x86_64")]
    {
        missing_of(&x86::required())
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec::new()
    }
}

#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
/// The names of `(name, compiled in, present)` rows that the build uses and the CPU lacks.
fn missing_of(extensions: &[(&'static str, bool, bool)]) -> Vec<&'static str> {
    extensions
        .iter()
        .filter(|&&(_, compiled_in, present)| compiled_in && !present)
        .map(|&(name, _, _)| name)
        .collect()
}

/// The message for a CPU that lacks `missing`.
pub fn refusal(missing: &[&str]) -> String {
    format!(
        "this vadscope was built for x86-64-v3, but this CPU lacks {}; rebuild it for \
         the baseline with `RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release` \
         (the scenario generator then runs 5-10 % slower)",
        missing.join(", ")
    )
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{__cpuid, __cpuid_count};

    /// Each x86-64-v3 extension: its name, whether the build uses it, whether the CPU (and,
    /// for the AVX family, the operating system) provides it.
    pub fn required() -> [(&'static str, bool, bool); 8] {
        // Leaves above the reported maximum are not queried.
        let (max_leaf, max_ext) = (__cpuid(0).eax, __cpuid(0x8000_0000).eax);
        let leaf1 = __cpuid(1);
        let leaf7 = if max_leaf >= 7 {
            __cpuid_count(7, 0)
        } else {
            empty_leaf()
        };
        let ext1 = if max_ext >= 0x8000_0001 {
            __cpuid(0x8000_0001)
        } else {
            empty_leaf()
        };
        let bit = |reg: u32, n: u32| reg & (1 << n) != 0;
        let os_saves_ymm = bit(leaf1.ecx, 27) && ymm_state_enabled();
        let avx = bit(leaf1.ecx, 28) && os_saves_ymm;
        [
            ("avx", cfg!(target_feature = "avx"), avx),
            (
                "avx2",
                cfg!(target_feature = "avx2"),
                avx && bit(leaf7.ebx, 5),
            ),
            (
                "fma",
                cfg!(target_feature = "fma"),
                avx && bit(leaf1.ecx, 12),
            ),
            (
                "f16c",
                cfg!(target_feature = "f16c"),
                avx && bit(leaf1.ecx, 29),
            ),
            ("bmi1", cfg!(target_feature = "bmi1"), bit(leaf7.ebx, 3)),
            ("bmi2", cfg!(target_feature = "bmi2"), bit(leaf7.ebx, 8)),
            ("lzcnt", cfg!(target_feature = "lzcnt"), bit(ext1.ecx, 5)),
            ("movbe", cfg!(target_feature = "movbe"), bit(leaf1.ecx, 22)),
        ]
    }

    fn empty_leaf() -> std::arch::x86_64::CpuidResult {
        std::arch::x86_64::CpuidResult {
            eax: 0,
            ebx: 0,
            ecx: 0,
            edx: 0,
        }
    }

    /// Whether the operating system saves the SSE and AVX registers on a context switch
    /// (XCR0 bits 1 and 2); only asked once CPUID reports OSXSAVE.
    fn ymm_state_enabled() -> bool {
        let (lo, hi): (u32, u32);
        // SAFETY: XGETBV is available when CPUID.1:ECX.OSXSAVE is set, which the caller
        // checks first; it reads a register and touches no memory.
        unsafe {
            std::arch::asm!(
                "xgetbv",
                in("ecx") 0u32,
                out("eax") lo,
                out("edx") hi,
                options(nomem, nostack, preserves_flags),
            );
        }
        let xcr0 = (u64::from(hi) << 32) | u64::from(lo);
        xcr0 & 0b110 == 0b110
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_machine_that_built_this_can_run_it() {
        // Tests run on the build machine, which therefore has every extension compiled in.
        assert_eq!(missing_extensions(), Vec::<&str>::new());
    }

    #[test]
    fn only_extensions_the_build_uses_are_required() {
        let rows = [
            ("avx2", true, false),
            ("fma", true, true),
            ("f16c", false, false),
            ("bmi2", true, false),
        ];
        assert_eq!(missing_of(&rows), ["avx2", "bmi2"]);
    }

    #[test]
    fn the_refusal_names_what_is_missing_and_how_to_rebuild() {
        let message = refusal(&["avx2", "fma"]);
        assert!(message.contains("avx2, fma"), "{message}");
        assert!(message.contains("target-cpu=x86-64\""), "{message}");
    }
}
