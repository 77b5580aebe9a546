//! The memory allocator of the `postwarp` binary, its benches and examples:
//! the system allocator, except that on Linux every block of at least
//! [`HUGE`] bytes is its own anonymous mapping, aligned to [`HUGE`] and
//! offered to the kernel for transparent huge pages
//! (`madvise(MADV_HUGEPAGE)`).
//!
//! Why: both engines keep per-sample planes of whole frames (a 640x480
//! frame at 2x2 samples: ten planes of 1.2 M samples, about 50 MB) and
//! reach them in the warp's order, which moves between rows at every
//! stamp; with 4 KiB pages nearly every such access needs a page walk, and
//! every new frame's planes fault in 4 KiB at a time. Most Linux systems
//! give huge pages only where asked (`/sys/kernel/mm/transparent_hugepage/
//! enabled` = `madvise`). Measured on the `cargo bench --bench simulate`
//! frame: `docs/performance.md`.
//!
//! Rules:
//! 1. Blocks below [`HUGE`], and every block on other systems, come from
//!    `std::alloc::System` unchanged.
//! 2. A large block is `mmap`ed with room to align it, the unaligned head
//!    and tail are unmapped at once, and the kept range (the size rounded
//!    up to whole 4 KiB pages) is advised; freeing unmaps it. Fresh
//!    anonymous pages are zero, so a zeroed large block costs no memset.
//! 3. A failed mapping returns null (the caller's allocation error), never
//!    panics; a refused `madvise` leaves ordinary pages (it is advice).
//! 4. Values never depend on the allocator: output bytes are the same with
//!    it or without it.
//!
//! Not modelled: explicit (hugetlbfs) pages, NUMA placement.

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes get huge-page mappings (2 MiB, the
/// x86-64 and common AArch64 huge-page size).
pub const HUGE: usize = 2 << 20;

/// The allocator (module doc). Install it in a binary with
/// `#[global_allocator] static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;`.
pub struct HugePageAlloc;

#[cfg(target_os = "linux")]
mod large {
    use super::HUGE;
    const PAGE: usize = 4096;

    fn mapped_len(size: usize) -> usize {
        size.div_ceil(PAGE) * PAGE
    }

    /// Rule 2: a zeroed, `HUGE`-aligned mapping of `size` bytes, or null.
    pub fn alloc(size: usize) -> *mut u8 {
        let len = mapped_len(size);
        let Some(span) = len.checked_add(HUGE) else { return std::ptr::null_mut() };
        // SAFETY: an anonymous private mapping at an address of the
        // kernel's choice touches no existing memory.
        let raw = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                span,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if raw == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let start = raw as usize;
        let aligned = start.next_multiple_of(HUGE);
        let (head, tail) = (aligned - start, start + span - (aligned + len));
        // SAFETY: the head and tail lie inside the mapping just made and
        // are not handed out; the kept range is advised, which changes no
        // contents.
        unsafe {
            if head > 0 {
                libc::munmap(raw, head);
            }
            if tail > 0 {
                libc::munmap((aligned + len) as *mut libc::c_void, tail);
            }
            libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
        }
        aligned as *mut u8
    }

    /// Free a block of [`alloc`].
    ///
    /// # Safety
    /// `p` came from [`alloc`] with the same `size`.
    pub unsafe fn free(p: *mut u8, size: usize) {
        // SAFETY: the caller's contract: `p .. p + mapped_len(size)` is
        // exactly the range `alloc` kept.
        unsafe { libc::munmap(p as *mut libc::c_void, mapped_len(size)) };
    }
}

#[inline]
fn is_large(layout: &Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= HUGE && layout.align() <= HUGE
}

// SAFETY: every block is either System's (rule 1) or a mapping of
// `large::alloc` (rule 2), chosen by `is_large` of the layout, which the
// caller passes unchanged to `dealloc`, so each block is freed by the
// allocator that made it; large blocks are aligned to HUGE, which is at
// least the layout's alignment.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        #[cfg(target_os = "linux")]
        if is_large(&layout) {
            return large::alloc(layout.size());
        }
        // SAFETY: forwarded contract.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        #[cfg(target_os = "linux")]
        if is_large(&layout) {
            // Fresh anonymous pages are zero (rule 2).
            return large::alloc(layout.size());
        }
        // SAFETY: forwarded contract.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        #[cfg(target_os = "linux")]
        if is_large(&layout) {
            // SAFETY: `is_large` chose `large::alloc` for this layout.
            unsafe { large::free(ptr, layout.size()) };
            return;
        }
        // SAFETY: forwarded contract.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller guarantees `new_size` forms a valid layout
        // with the old alignment.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        if !is_large(&layout) && !is_large(&new) {
            // SAFETY: forwarded contract; both blocks are System's.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        // SAFETY: a new block from this allocator, the contents copied,
        // the old block freed by the allocator that made it.
        unsafe {
            let p = self.alloc(new);
            if !p.is_null() {
                std::ptr::copy_nonoverlapping(ptr, p, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
            p
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_blocks_are_aligned_zeroed_and_keep_their_contents_through_realloc() {
        let a = HugePageAlloc;
        let layout = Layout::from_size_align(HUGE + 12_345, 8).unwrap();
        // SAFETY: a non-zero layout; every block is freed with its layout.
        unsafe {
            let p = a.alloc_zeroed(layout);
            assert!(!p.is_null());
            if cfg!(target_os = "linux") {
                assert_eq!(p as usize % HUGE, 0, "large blocks start on a huge-page boundary");
            }
            let s = std::slice::from_raw_parts_mut(p, layout.size());
            assert!(s.iter().all(|&b| b == 0));
            s[0] = 7;
            s[layout.size() - 1] = 9;
            // Shrink below the threshold and grow back: the prefix survives.
            let q = a.realloc(p, layout, 100);
            assert_eq!((*q, *q.add(99)), (7, 0));
            let small = Layout::from_size_align(100, 8).unwrap();
            let r = a.realloc(q, small, 3 * HUGE);
            assert_eq!(*r, 7);
            a.dealloc(r, Layout::from_size_align(3 * HUGE, 8).unwrap());
            let tiny = a.alloc(small);
            assert!(!tiny.is_null());
            a.dealloc(tiny, small);
        }
    }
}
