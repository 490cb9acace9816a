//! Run-time choice of the wide-vector code paths.
//!
//! The hot kernels are written as plain loops over fixed-size arrays that the compiler
//! vectorises. Each has a portable instantiation (SSE2 on x86-64) and one compiled with AVX2
//! enabled, picked at run time. Both perform the same IEEE operations in the same order, so
//! results are identical on every CPU.

/// Whether this CPU runs the AVX2 instantiations of the kernels. Only AVX2 is enabled, not
/// FMA: fused multiply-adds round differently and would make results CPU-dependent.
#[inline]
pub(crate) fn wide_vectors_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
