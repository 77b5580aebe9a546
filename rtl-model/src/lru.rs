//! Least-recently-used replacement order of a cache's resident entries:
//! a use costs one store, a victim costs a few heap operations.
//!
//! Job: find the replacement victim of the source and destination caches —
//! the least recently used resident entry, ties to the lowest id, among
//! those the caller allows — without scanning the resident entries.
//!
//! API: [`Lru::new`] over ids `0..n`; `insert(id, now)`, `touch(id, now)`,
//! `remove(id)`, `victim(keep)`, `clear`.
//!
//! Rules:
//! 1. An entry's last use is the time of its last `insert` or `touch`;
//!    times never decrease.
//! 2. The victim is the resident entry with the smallest `(last use, id)`
//!    for which `keep` holds.
//! 3. Bookkeeping: a min-heap holds one entry `(use, id)` per resident id,
//!    with `use` at most its true last use (a touch only raises the true
//!    one). Popping an entry whose use is out of date pushes it back with
//!    the true use; the first popped entry that is up to date is therefore
//!    the smallest true key. Entries of removed ids are dropped when
//!    popped.
//!
//! Not modelled: the hardware's own replacement logic (this is the
//! model's bookkeeping of the rule the caches document).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The replacement order (module doc).
#[derive(Clone, Debug)]
pub struct Lru {
    last_use: Vec<u64>,
    resident: Vec<bool>,
    heap: BinaryHeap<Reverse<(u64, u32)>>,
    held: Vec<(u64, u32)>,
}

impl Lru {
    /// No resident entry, over ids `0..n`.
    pub fn new(n: usize) -> Lru {
        Lru { last_use: vec![0; n], resident: vec![false; n], heap: BinaryHeap::new(), held: Vec::new() }
    }

    /// Make `id` resident, used at `now`.
    pub fn insert(&mut self, id: u32, now: u64) {
        debug_assert!(!self.resident[id as usize], "{id} inserted twice");
        self.resident[id as usize] = true;
        self.last_use[id as usize] = now;
        self.heap.push(Reverse((now, id)));
    }

    /// A use of resident `id` at `now`.
    #[inline(always)]
    pub fn touch(&mut self, id: u32, now: u64) {
        debug_assert!(self.resident[id as usize] && self.last_use[id as usize] <= now);
        self.last_use[id as usize] = now;
    }

    /// `id` is no longer resident.
    pub fn remove(&mut self, id: u32) {
        self.resident[id as usize] = false;
    }

    /// True if `id` is resident.
    pub fn contains(&self, id: u32) -> bool {
        self.resident[id as usize]
    }

    /// Forget every entry.
    pub fn clear(&mut self) {
        for Reverse((_, id)) in self.heap.drain() {
            self.resident[id as usize] = false;
        }
    }

    /// The least recently used resident entry that `keep` allows (rule 2);
    /// it stays resident until the caller removes it.
    pub fn victim(&mut self, keep: impl Fn(u32) -> bool) -> Option<u32> {
        let mut found = None;
        while let Some(Reverse((u, id))) = self.heap.pop() {
            let i = id as usize;
            if !self.resident[i] {
                continue;
            }
            if u != self.last_use[i] {
                self.heap.push(Reverse((self.last_use[i], id)));
                continue;
            }
            self.held.push((u, id));
            if keep(id) {
                found = Some(id);
                break;
            }
        }
        for e in self.held.drain(..) {
            self.heap.push(Reverse(e));
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn the_victim_is_the_smallest_last_use_then_id_under_random_use() {
        let mut l = Lru::new(24);
        let mut uses: BTreeMap<u32, u64> = BTreeMap::new();
        let mut seed = 12345u64;
        let mut now = 0u64;
        for _ in 0..20000 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let id = ((seed >> 33) % 24) as u32;
            if (seed >> 20) % 3 == 0 {
                now += 1;
            }
            match ((seed >> 40) % 5, l.contains(id)) {
                (0, true) => {
                    l.remove(id);
                    uses.remove(&id);
                }
                (1, _) => {
                    let pinned = (seed >> 50) as u32 % 24;
                    let want = uses.iter().map(|(&i, &u)| (u, i)).filter(|&(_, i)| i != pinned).min().map(|p| p.1);
                    assert_eq!(l.victim(|i| i != pinned), want);
                }
                (_, true) => {
                    l.touch(id, now);
                    uses.insert(id, now);
                }
                (_, false) => {
                    l.insert(id, now);
                    uses.insert(id, now);
                }
            }
        }
        l.clear();
        assert_eq!(l.victim(|_| true), None);
    }
}
