//! Least-recently-used order of a cache's resident entries, in O(1) per
//! use.
//!
//! Job: keep the resident entries of a cache (source blocks, destination
//! tiles) ordered by `(last use, id)`, so that the replacement victim — the
//! least recently used entry, ties to the lowest id — is found without a
//! scan.
//!
//! API: [`Lru::new`] over ids `0..n`; `insert(id, now)`, `touch(id, now)`,
//! `remove(id)`, `contains`, `oldest_where(pred)`, `len`.
//!
//! Rules:
//! 1. Times passed are non-decreasing (the engine's clock); an entry's
//!    last use is the time of its last `insert` or `touch`.
//! 2. The order is exactly ascending `(last use, id)`: a use at the current
//!    time goes after every entry used earlier and after the entries used
//!    at the same time with a lower id.
//!
//! Not modelled: the hardware's own replacement logic (this is the model's
//! bookkeeping of the rule the cache documents).

const NIL: u32 = u32::MAX;

/// An intrusive doubly linked list of resident ids in LRU order.
#[derive(Clone, Debug)]
pub struct Lru {
    prev: Vec<u32>,
    next: Vec<u32>,
    last_use: Vec<u64>,
    resident: Vec<bool>,
    head: u32,
    tail: u32,
    len: usize,
}

impl Lru {
    /// An empty order over ids `0..n`.
    pub fn new(n: usize) -> Lru {
        Lru {
            prev: vec![NIL; n],
            next: vec![NIL; n],
            last_use: vec![0; n],
            resident: vec![false; n],
            head: NIL,
            tail: NIL,
            len: 0,
        }
    }

    /// Resident entries.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No entry is resident.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True if `id` is resident.
    #[inline]
    pub fn contains(&self, id: u32) -> bool {
        self.resident[id as usize]
    }

    /// Make `id` resident, used at `now` (rule 2).
    pub fn insert(&mut self, id: u32, now: u64) {
        debug_assert!(!self.resident[id as usize], "{id} inserted twice");
        self.resident[id as usize] = true;
        self.last_use[id as usize] = now;
        self.len += 1;
        self.link_at_time(id, now);
    }

    /// Record a use of resident `id` at `now`.
    #[inline]
    pub fn touch(&mut self, id: u32, now: u64) {
        let i = id as usize;
        debug_assert!(self.resident[i]);
        if self.last_use[i] == now {
            // Already among the entries of this time, in id order.
            return;
        }
        debug_assert!(self.last_use[i] <= now, "time ran backwards");
        self.unlink(id);
        self.last_use[i] = now;
        self.link_at_time(id, now);
    }

    /// Remove resident `id`.
    pub fn remove(&mut self, id: u32) {
        debug_assert!(self.resident[id as usize], "{id} removed but not resident");
        self.unlink(id);
        self.resident[id as usize] = false;
        self.len -= 1;
    }

    /// The least recently used resident entry for which `pred` holds.
    pub fn oldest_where(&self, mut pred: impl FnMut(u32) -> bool) -> Option<u32> {
        let mut k = self.head;
        while k != NIL {
            if pred(k) {
                return Some(k);
            }
            k = self.next[k as usize];
        }
        None
    }

    /// Link `id` (used at `now`, the latest time) into place: after every
    /// entry used earlier, and after those used at `now` with a lower id.
    fn link_at_time(&mut self, id: u32, now: u64) {
        let mut after = self.tail;
        while after != NIL && self.last_use[after as usize] == now && after > id {
            after = self.prev[after as usize];
        }
        let before = if after == NIL { self.head } else { self.next[after as usize] };
        self.prev[id as usize] = after;
        self.next[id as usize] = before;
        if after == NIL {
            self.head = id;
        } else {
            self.next[after as usize] = id;
        }
        if before == NIL {
            self.tail = id;
        } else {
            self.prev[before as usize] = id;
        }
    }

    fn unlink(&mut self, id: u32) {
        let (p, n) = (self.prev[id as usize], self.next[id as usize]);
        if p == NIL {
            self.head = n;
        } else {
            self.next[p as usize] = n;
        }
        if n == NIL {
            self.tail = p;
        } else {
            self.prev[n as usize] = p;
        }
        self.prev[id as usize] = NIL;
        self.next[id as usize] = NIL;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// The order a plain map of last uses gives.
    fn reference_order(uses: &BTreeMap<u32, u64>) -> Vec<u32> {
        let mut v: Vec<(u64, u32)> = uses.iter().map(|(&id, &u)| (u, id)).collect();
        v.sort_unstable();
        v.into_iter().map(|(_, id)| id).collect()
    }

    fn order(l: &Lru) -> Vec<u32> {
        let mut out = vec![];
        let mut k = l.head;
        while k != NIL {
            out.push(k);
            k = l.next[k as usize];
        }
        out
    }

    #[test]
    fn the_order_is_ascending_last_use_then_id_under_random_use() {
        let mut l = Lru::new(16);
        let mut uses = BTreeMap::new();
        let mut seed = 12345u64;
        let mut now = 0u64;
        for _ in 0..5000 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let id = ((seed >> 33) % 16) as u32;
            if (seed >> 20) % 3 == 0 {
                now += 1;
            }
            match ((seed >> 40) % 4, l.contains(id)) {
                (0, true) => {
                    l.remove(id);
                    uses.remove(&id);
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
            assert_eq!(order(&l), reference_order(&uses));
            assert_eq!(l.len(), uses.len());
        }
        let oldest_odd = l.oldest_where(|id| id % 2 == 1);
        assert_eq!(oldest_odd, reference_order(&uses).into_iter().find(|id| id % 2 == 1));
    }
}
