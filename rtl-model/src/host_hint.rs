//! Host-side hints: asking the host CPU to fetch memory the model is about
//! to read, and asking the allocator for blocks it hands out zeroed (the
//! binary's allocator, `postwarp::huge_pages`, maps those afresh on huge
//! pages). No model state; no value or cycle changes.

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

/// Types for which all-zero bytes are a valid value (the default one).
///
/// # Safety
/// Every field must accept the all-zero bit pattern (integers, floats,
/// arrays of them; no references, `NonZero`, enums without a zero variant).
pub unsafe trait Zeroable: Sized {}

/// `n` all-zero values in one block from the allocator's zeroed path.
/// `vec![T::default(); n]` of a struct writes every element through the
/// plain path instead, so the block neither gets huge pages nor skips the
/// memset (a frame's 1.2 M samples fault in 4 KiB at a time).
pub fn zeroed_vec<T: Zeroable>(n: usize) -> Vec<T> {
    let layout = std::alloc::Layout::array::<T>(n).expect("zeroed_vec: size overflows");
    if layout.size() == 0 {
        return Vec::new();
    }
    // SAFETY: the layout has a non-zero size.
    let ptr = unsafe { std::alloc::alloc_zeroed(layout) };
    if ptr.is_null() {
        std::alloc::handle_alloc_error(layout);
    }
    // SAFETY: `ptr` comes from the global allocator with the layout of `n`
    // values of `T` (so capacity `n` matches it), and all-zero bytes are
    // valid values of `T` (`Zeroable`), so all `n` are initialised.
    unsafe { Vec::from_raw_parts(ptr.cast::<T>(), n, n) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Default, PartialEq, Clone, Copy)]
    struct Pair {
        a: f32,
        b: u8,
    }
    // SAFETY: an f32 and a u8.
    unsafe impl Zeroable for Pair {}

    #[test]
    fn zeroed_vec_is_n_default_values() {
        assert_eq!(zeroed_vec::<Pair>(5), vec![Pair::default(); 5]);
        assert!(zeroed_vec::<Pair>(0).is_empty());
        let mut v = zeroed_vec::<Pair>(3);
        v.push(Pair { a: 1.0, b: 2 });
        assert_eq!(v.len(), 4);
    }
}
