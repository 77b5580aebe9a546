//! The memory allocator of the `postwarp` binary, its benches and examples:
//! the system allocator, except that on Linux every zeroed block of at
//! least [`HUGE`] bytes (the per-sample planes) is its own anonymous
//! mapping, aligned to [`HUGE`] and offered to the kernel for transparent
//! huge pages (`madvise(MADV_HUGEPAGE)`).
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
//! 1. Only zeroed blocks of at least [`HUGE`] bytes (`vec![0; n]`, the
//!    planes) get huge pages; every other block comes from
//!    `std::alloc::System` unchanged, and so do all blocks on other
//!    systems. Non-zeroed large blocks stay with the system allocator
//!    because it reuses freed memory without clearing it: mapping those
//!    afresh made the kernel clear every per-frame buffer of a multi-frame
//!    `simulate` again (`clear_page_erms`, a sixth of its busy time).
//! 2. A huge-page block is `mmap`ed with room to align it, the unaligned
//!    head and tail are unmapped at once, and the kept range (the size
//!    rounded up to whole 4 KiB pages) is advised. Fresh anonymous pages
//!    are zero, so it costs no memset.
//! 3. Every huge-page block is registered (at most [`REGISTERED`] at
//!    once; beyond that, zeroed blocks come from the system allocator
//!    too); freeing a registered block unmaps it, any other block goes to
//!    the system allocator.
//! 4. A failed mapping returns null (the caller's allocation error), never
//!    panics; a refused `madvise` leaves ordinary pages (it is advice).
//! 5. Values never depend on the allocator: output bytes are the same with
//!    it or without it.
//! 6. With glibc, before the first block, the system allocator's mmap
//!    threshold is fixed at [`MMAP_THRESHOLD`] (`mallopt`): every other
//!    block of at least that size is mapped on its own and unmapped when
//!    freed. glibc's default threshold slides up to each freed mapping's
//!    size (up to 32 MiB), after which such blocks come from per-thread
//!    arenas that keep what is freed: a `simulate` that loads, warps and
//!    drops references one at a time then held 325 MB at its peak instead
//!    of 281 MB, with no gain in time (`docs/performance.md`).
//!
//! Not modelled: explicit (hugetlbfs) pages, NUMA placement.

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes get huge-page mappings (2 MiB, the
/// x86-64 and common AArch64 huge-page size).
pub const HUGE: usize = 2 << 20;

/// Rule 6: other blocks of at least this many bytes are mapped on their
/// own (1 MiB).
pub const MMAP_THRESHOLD: usize = 1 << 20;

/// Huge-page blocks live at once, at most (rule 3).
pub const REGISTERED: usize = 1024;

/// The allocator (module doc). Install it in a binary with
/// `#[global_allocator] static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;`.
pub struct HugePageAlloc;

#[cfg(target_os = "linux")]
mod large {
    use super::{HUGE, REGISTERED};
    use std::sync::Mutex;
    const PAGE: usize = 4096;

    /// Rule 3: the addresses of the live huge-page blocks.
    struct Registry {
        addrs: [usize; REGISTERED],
        n: usize,
    }

    static LIVE: Mutex<Registry> = Mutex::new(Registry { addrs: [0; REGISTERED], n: 0 });

    fn live() -> std::sync::MutexGuard<'static, Registry> {
        // Nothing panics while the lock is held: a poisoned lock still
        // holds consistent entries.
        LIVE.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Rules 2 and 3: a registered, zeroed, `HUGE`-aligned block of `size`
    /// bytes, or null (full registry or failed mapping: the caller uses
    /// the system allocator).
    pub fn alloc_registered(size: usize) -> *mut u8 {
        let mut r = live();
        if r.n == REGISTERED {
            return std::ptr::null_mut();
        }
        let p = alloc(size);
        if !p.is_null() {
            let n = r.n;
            r.addrs[n] = p as usize;
            r.n += 1;
        }
        p
    }

    /// True if `p` is a live huge-page block; it is then unregistered and
    /// unmapped.
    ///
    /// # Safety
    /// If registered, `p` came from [`alloc_registered`] with this `size`.
    pub unsafe fn free_if_registered(p: *mut u8, size: usize) -> bool {
        let mut r = live();
        let n = r.n;
        let Some(i) = r.addrs[..n].iter().position(|&a| a == p as usize) else { return false };
        r.addrs.swap(i, n - 1);
        r.n -= 1;
        drop(r);
        // SAFETY: forwarded contract.
        unsafe { free(p, size) };
        true
    }

    /// True if `p` is a live huge-page block.
    pub fn is_registered(p: *mut u8) -> bool {
        let r = live();
        r.addrs[..r.n].contains(&(p as usize))
    }

    fn mapped_len(size: usize) -> usize {
        size.div_ceil(PAGE) * PAGE
    }

    /// Rule 2: a zeroed, `HUGE`-aligned mapping of `size` bytes, or null.
    fn alloc(size: usize) -> *mut u8 {
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
    unsafe fn free(p: *mut u8, size: usize) {
        // SAFETY: the caller's contract: `p .. p + mapped_len(size)` is
        // exactly the range `alloc` kept.
        unsafe { libc::munmap(p as *mut libc::c_void, mapped_len(size)) };
    }
}

#[inline]
fn is_large(layout: &Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= HUGE && layout.align() <= HUGE
}

/// Rule 6, once per process (an atomic load after the first call).
#[inline]
fn fix_mmap_threshold() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        // SAFETY: `mallopt` only sets a parameter of the C allocator; it
        // is called before this allocator hands out its first block.
        ONCE.call_once(|| unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD as libc::c_int);
        });
    }
}

// SAFETY: every block is either System's (rule 1) or a registered
// mapping of `large::alloc_registered` (rules 2 and 3); `dealloc` and
// `realloc` look the address up in the registry, so each block is freed by
// the allocator that made it. Huge-page blocks are aligned to HUGE, which
// `is_large` checks is at least the layout's alignment.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        fix_mmap_threshold();
        // SAFETY: forwarded contract (rule 1: never a huge-page block).
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        fix_mmap_threshold();
        #[cfg(target_os = "linux")]
        if is_large(&layout) {
            let p = large::alloc_registered(layout.size());
            if !p.is_null() {
                return p;
            }
        }
        // SAFETY: forwarded contract.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: a registered block came from `alloc_registered` with this
        // layout's size (the caller passes the layout it allocated with).
        #[cfg(target_os = "linux")]
        if is_large(&layout) && unsafe { large::free_if_registered(ptr, layout.size()) } {
            return;
        }
        // SAFETY: forwarded contract; not a registered block, so System's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        #[cfg(target_os = "linux")]
        if is_large(&layout) && large::is_registered(ptr) {
            // A huge-page block grows or shrinks into a System block (a
            // reallocation is not zeroed, rule 1).
            // SAFETY: `new_size` forms a valid layout with the old
            // alignment (the caller's contract); the contents are copied
            // and the old block freed by the allocator that made it.
            unsafe {
                let new = Layout::from_size_align_unchecked(new_size, layout.align());
                let p = System.alloc(new);
                if !p.is_null() {
                    std::ptr::copy_nonoverlapping(ptr, p, layout.size().min(new_size));
                    self.dealloc(ptr, layout);
                }
                return p;
            }
        }
        // SAFETY: forwarded contract; both blocks are System's.
        unsafe { System.realloc(ptr, layout, new_size) }
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
