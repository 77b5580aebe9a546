//! Host-side hints: asking the host CPU to fetch memory the model is about
//! to read. No model state; no value or cycle changes.

/// Ask the host CPU to bring the cache line at `p` into its caches (a
/// no-op on hosts other than x86-64).
#[inline(always)]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch is a hint that never faults, whatever `p` is.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p as *const i8) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
