//! Single-bit reads and writes of a [`BitVec`] by word and mask.
//!
//! Job: the per-sample flag planes (`DestFrame::real`, `hole`,
//! `fill_valid`) are `BitVec`s in bitvec's default layout (`usize`
//! words, least significant bit first, the vector starting at bit 0 of its
//! first word). The crate's indexing goes through bit-pointer proxies that
//! cost tens of instructions per access in the units' inner loops; these
//! two functions read and write the same bit of the same word directly.
//!
//! Rules: `i < v.len()` (checked in debug builds; in release a word index
//! past the storage still panics through the slice's bounds check). The
//! values are exactly what `v[i]` and `v.set(i, b)` read and write
//! (tested against them).
//!
//! Throughput/latency and not modelled: not applicable (host code).

use bitvec::vec::BitVec;

const WORD: usize = usize::BITS as usize;

/// `v[i]`.
#[inline(always)]
pub fn get(v: &BitVec, i: usize) -> bool {
    debug_assert!(i < v.len(), "bit {i} of {}", v.len());
    v.as_raw_slice()[i / WORD] >> (i % WORD) & 1 != 0
}

/// `v.set(i, b)`.
#[inline(always)]
pub fn put(v: &mut BitVec, i: usize, b: bool) {
    debug_assert!(i < v.len(), "bit {i} of {}", v.len());
    let w = &mut v.as_raw_mut_slice()[i / WORD];
    let m = 1usize << (i % WORD);
    *w = if b { *w | m } else { *w & !m };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_writes_the_bits_the_crate_indexes() {
        let mut a = BitVec::repeat(false, 200);
        let mut b = a.clone();
        for (step, i) in (0..200).step_by(7).chain([63, 64, 127, 128, 199]).enumerate() {
            let on = step % 3 != 0;
            a.set(i, on);
            put(&mut b, i, on);
            assert_eq!(a, b, "after setting bit {i}");
        }
        for i in 0..200 {
            assert_eq!(get(&b, i), a[i], "bit {i}");
        }
        put(&mut b, 64, false);
        assert!(!b[64] && !get(&b, 64));
    }
}
