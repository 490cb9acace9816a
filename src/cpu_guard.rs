//! The instruction-set guard the `vadscope` binary runs first: it refuses to start, with a
//! message that says how to rebuild, on an x86-64 CPU that lacks an extension the build was
//! compiled for. It lives in the library (built with the same target features as the
//! binary) so that its tests run with the library's and the binary needs no test harness.
//!
//! `.cargo/config.toml` builds for the CPU of the machine that compiles (`target-cpu=native`):
//! AVX2 and FMA on any x86-64 CPU of the last decade, AVX-512 where the CPU has it. A binary
//! copied to a CPU without one of those extensions would die of SIGILL somewhere inside the
//! first hot loop. The features are read with CPUID directly: `is_x86_feature_detected!`
//! answers `true` at compile time for every feature the build enables, so it cannot tell.

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
        "this vadscope was built for another CPU (`target-cpu=native` in .cargo/config.toml \
         builds for the machine that compiles), and this CPU lacks {}; rebuild it on this \
         machine with `cargo build --release`, or for any x86-64 CPU with \
         `RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release` (the scenario generator \
         then runs 10-20 % slower)",
        missing.join(", ")
    )
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{__cpuid, __cpuid_count};

    /// Each extension the compiler or a dependency's compile-time dispatch may use: its
    /// name, whether the build uses it, whether the CPU (and, for the AVX families, the
    /// operating system) provides it.
    pub fn required() -> Vec<(&'static str, bool, bool)> {
        // Leaves above the reported maximum are not queried.
        let (max_leaf, max_ext) = (__cpuid(0).eax, __cpuid(0x8000_0000).eax);
        let leaf1 = __cpuid(1);
        let leaf7 = if max_leaf >= 7 {
            __cpuid_count(7, 0)
        } else {
            empty_leaf()
        };
        let leaf7_1 = if max_leaf >= 7 && leaf7.eax >= 1 {
            __cpuid_count(7, 1)
        } else {
            empty_leaf()
        };
        let ext1 = if max_ext >= 0x8000_0001 {
            __cpuid(0x8000_0001)
        } else {
            empty_leaf()
        };
        let bit = |reg: u32, n: u32| reg & (1 << n) != 0;
        let c1 = leaf1.ecx;
        let xcr0 = if bit(c1, 27) { extended_state() } else { 0 };
        // XCR0: SSE and AVX state (bits 1, 2); AVX-512 opmask and upper ZMM state (5-7).
        let avx = bit(c1, 28) && xcr0 & 0b110 == 0b110;
        let avx512 = avx && xcr0 & 0b1110_0000 == 0b1110_0000;
        let (b7, c7, d7, a7_1) = (leaf7.ebx, leaf7.ecx, leaf7.edx, leaf7_1.eax);
        // The name is the `target_feature` name, whose `cfg!` says whether the build uses it.
        macro_rules! row {
            ($name:literal, $present:expr) => {
                ($name, cfg!(target_feature = $name), $present)
            };
        }
        vec![
            row!("sse3", bit(c1, 0)),
            row!("pclmulqdq", bit(c1, 1)),
            row!("ssse3", bit(c1, 9)),
            row!("sse4.1", bit(c1, 19)),
            row!("sse4.2", bit(c1, 20)),
            row!("popcnt", bit(c1, 23)),
            row!("aes", bit(c1, 25)),
            row!("adx", bit(b7, 19)),
            row!("sha", bit(b7, 29)),
            row!("avx", avx),
            row!("avx2", avx && bit(b7, 5)),
            row!("fma", avx && bit(c1, 12)),
            row!("f16c", avx && bit(c1, 29)),
            row!("bmi1", bit(b7, 3)),
            row!("bmi2", bit(b7, 8)),
            row!("lzcnt", bit(ext1.ecx, 5)),
            row!("movbe", bit(c1, 22)),
            row!("avxvnni", avx && bit(a7_1, 4)),
            row!("gfni", bit(c7, 8)),
            row!("vaes", avx && bit(c7, 9)),
            row!("vpclmulqdq", avx && bit(c7, 10)),
            row!("avx512f", avx512 && bit(b7, 16)),
            row!("avx512dq", avx512 && bit(b7, 17)),
            row!("avx512ifma", avx512 && bit(b7, 21)),
            row!("avx512cd", avx512 && bit(b7, 28)),
            row!("avx512bw", avx512 && bit(b7, 30)),
            row!("avx512vl", avx512 && bit(b7, 31)),
            row!("avx512vbmi", avx512 && bit(c7, 1)),
            row!("avx512vbmi2", avx512 && bit(c7, 6)),
            row!("avx512vnni", avx512 && bit(c7, 11)),
            row!("avx512bitalg", avx512 && bit(c7, 12)),
            row!("avx512vpopcntdq", avx512 && bit(c7, 14)),
            row!("avx512fp16", avx512 && bit(d7, 23)),
            row!("avx512bf16", avx512 && bit(a7_1, 5)),
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

    /// The register states the operating system saves on a context switch (XCR0); only
    /// asked once CPUID reports OSXSAVE.
    fn extended_state() -> u64 {
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
        (u64::from(hi) << 32) | u64::from(lo)
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
        assert!(message.contains("cargo build --release`"), "{message}");
        assert!(message.contains("target-cpu=x86-64\""), "{message}");
    }
}
