//! Bounded FIFOs with a fixed latency: the wires between hardware units.
//!
//! Job: carry items from a producer unit to a consumer unit, with a bounded
//! number of slots (backpressure) and a fixed transit time (pipeline
//! registers on the path).
//!
//! API ([`Fifo`]): `new(capacity, latency)`; producer side `offer(now)`,
//! `push(now, item) -> Result<(), T>`, and `can_push(now)` for observers; consumer side `can_pop(now)`,
//! `peek(now)`, `pop(now)`; `len`, `is_empty`, `capacity`, `latency`, `held(k)`
//! (the k-th item, visible or not, for observers); counters
//! in [`FifoCounters`] (`counters()`).
//!
//! Timing rules:
//! - An item pushed at cycle N becomes visible to `peek`/`pop` at cycle
//!   N + latency and not before. Items leave in push order.
//! - `capacity` bounds the items *in the FIFO*, visible or still in transit:
//!   a slot is taken by `push` and freed by `pop`. `push` on a full FIFO
//!   refuses and hands the item back (`Err(item)`); the producer keeps it and
//!   retries on a later cycle.
//! - A slot freed by a `pop` is usable by a `push` in the same cycle, and an
//!   item pushed with latency 0 is visible in the same cycle after the push.
//!   What the other side sees within one cycle therefore depends on the
//!   order in which the engine ticks the two units; the engine's fixed phase
//!   order makes it deterministic. With consumers ticked before producers
//!   (downstream first), a FIFO of latency L sustains one item per cycle iff
//!   capacity ≥ L (with latency 0, the consumer sees the item on the next
//!   cycle); with producers first it needs capacity ≥ L + 1.
//! - There is no limit on pushes or pops per cycle: a unit that moves k items
//!   per clock enforces its own port width.
//! - Time never runs backwards: every call must pass a `now` at least as late
//!   as that of the latest `push` or `pop` (checked by a debug assertion).
//!
//! Stall counting: a *full cycle* is a cycle in which at least one `push` was
//! refused. It is counted once per cycle however many pushes that cycle
//! refused (several producers, or retries); `can_push` is a side-effect-free
//! query and counts nothing, so a producer that only asks and does not try is
//! not counted.
//!
//! The producer rule: a producer either calls `push` and keeps a refused
//! item for a later cycle, or — when it must not consume its own input
//! unless the FIFO takes the result (a unit with no output register, which
//! accepts an input only when its output is ready) — first calls `offer`,
//! which answers like `can_push` but counts a refusal as a refused push.
//! A `push` in the same cycle after an accepted `offer` cannot be refused;
//! the producer treats a refusal there as a bug. `can_push` is for
//! observers (tests, reports), never for a producer's decision.
//!
//! Throughput/latency: up to `capacity` items in flight; each takes exactly
//! `latency` cycles from push to visibility, plus any time it waits at the
//! head for the consumer.
//!
//! Not modelled: storage cost (area), read/write port conflicts, items of
//! different sizes, credit-return delay (a freed slot is reusable at once).

use crate::clock::Cycle;

/// Event counts of one [`Fifo`] since it was made (or last reset).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FifoCounters {
    /// Items accepted by `push` (items).
    pub pushes: u64,
    /// Items removed by `pop` (items).
    pub pops: u64,
    /// Cycles in which at least one `push` was refused because the FIFO was
    /// full (cycles).
    pub full_cycles: u64,
    /// Pushes refused because the FIFO was full, every attempt counted
    /// (attempts).
    pub refused_pushes: u64,
    /// Largest number of items held at once (items).
    pub peak_len: u64,
}

/// A bounded FIFO whose items become visible a fixed number of cycles after
/// they are pushed. See the module documentation for the timing rules.
#[derive(Clone, Debug)]
pub struct Fifo<T> {
    capacity: usize,
    latency: u64,
    /// Items with the cycle at which each becomes visible, oldest first.
    items: Ring<(Cycle, T)>,
    counters: FifoCounters,
    /// The cycle of the last refused push, so a full cycle counts once.
    last_refused: Option<Cycle>,
    /// The latest `now` seen, to catch time running backwards (kept in
    /// debug builds only, where the check runs).
    last_now: Cycle,
}

impl<T: Copy> Fifo<T> {
    /// A FIFO of `capacity` slots (items, at least 1) and `latency` cycles
    /// from push to visibility (0 allowed: visible in the same cycle).
    ///
    /// # Panics
    /// If `capacity` is 0.
    pub fn new(capacity: usize, latency: u64) -> Fifo<T> {
        assert!(capacity > 0, "Fifo capacity must be at least 1");
        Fifo {
            capacity,
            latency,
            items: Ring::new(capacity),
            counters: FifoCounters::default(),
            last_refused: None,
            last_now: Cycle::ZERO,
        }
    }

    /// Number of slots (items).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Cycles from push to visibility.
    pub fn latency(&self) -> u64 {
        self.latency
    }

    /// Items held, visible or in transit.
    #[inline]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True if no item is held (visible or in transit).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Event counts so far.
    pub fn counters(&self) -> FifoCounters {
        self.counters
    }

    /// Zero the counters (e.g. at a frame boundary); the contents stay and
    /// `peak_len` restarts from the current length.
    pub fn reset_counters(&mut self) {
        self.counters = FifoCounters { peak_len: self.items.len() as u64, ..FifoCounters::default() };
        self.last_refused = None;
    }

    /// True if a `push` at `now` would be accepted. Counts nothing.
    #[inline]
    pub fn can_push(&self, now: Cycle) -> bool {
        self.check_time(now);
        self.items.len() < self.capacity
    }

    /// True if a `push` at `now` would be accepted; false counts as a
    /// refused push (and the cycle as a full cycle), as a refused `push`
    /// does (module doc, the producer rule).
    #[inline]
    pub fn offer(&mut self, now: Cycle) -> bool {
        self.observe(now);
        if self.items.len() < self.capacity {
            return true;
        }
        self.refuse(now);
        false
    }

    #[inline(never)]
    fn refuse(&mut self, now: Cycle) {
        self.counters.refused_pushes += 1;
        if self.last_refused != Some(now) {
            self.counters.full_cycles += 1;
            self.last_refused = Some(now);
        }
    }

    /// Push `item` at `now`; it becomes visible at `now + latency`. On a full
    /// FIFO the item is handed back and the cycle counts as a full cycle.
    #[inline]
    pub fn push(&mut self, now: Cycle, item: T) -> Result<(), T> {
        self.observe(now);
        if self.items.len() >= self.capacity {
            self.refuse(now);
            return Err(item);
        }
        self.items.push_back((now + self.latency, item));
        self.counters.pushes += 1;
        self.counters.peak_len = self.counters.peak_len.max(self.items.len() as u64);
        Ok(())
    }

    /// True if the oldest item is visible at `now`.
    #[inline]
    pub fn can_pop(&self, now: Cycle) -> bool {
        self.check_time(now);
        self.items.front().is_some_and(|&(ready, _)| ready <= now)
    }

    /// The oldest item, if it is visible at `now`.
    #[inline]
    pub fn peek(&self, now: Cycle) -> Option<&T> {
        self.check_time(now);
        match self.items.front() {
            Some((ready, item)) if *ready <= now => Some(item),
            _ => None,
        }
    }

    /// Remove and return the oldest item, if it is visible at `now`.
    #[inline]
    pub fn pop(&mut self, now: Cycle) -> Option<T> {
        self.observe(now);
        if !self.can_pop(now) {
            return None;
        }
        self.counters.pops += 1;
        self.items.pop_front().map(|(_, item)| item)
    }

    /// The oldest item, visible or still in transit.
    #[inline]
    pub fn oldest(&self) -> Option<&T> {
        self.items.front().map(|(_, item)| item)
    }

    /// The `k`-th oldest item, visible or not (`None` past the last): for
    /// observers such as a host-side prefetch; it changes nothing.
    #[inline]
    pub fn held(&self, k: usize) -> Option<&T> {
        (k < self.items.len()).then(|| &self.items.get(k).1)
    }

    /// The oldest item, visible or not, for in-place updates by the
    /// consumer that will pop it (e.g. marking a retry).
    #[inline]
    pub fn oldest_mut(&mut self) -> Option<&mut T> {
        self.items.front_mut().map(|(_, item)| item)
    }

    /// The cycle at which the oldest item becomes (or became) visible.
    #[inline]
    pub fn next_visible(&self) -> Option<Cycle> {
        self.items.front().map(|&(ready, _)| ready)
    }

    /// The first cycle after `now` at which an item still in transit
    /// becomes visible (items become visible in push order), if any: the
    /// FIFO's next event when its consumer is blocked on what it already
    /// sees.
    #[inline]
    pub fn next_visible_after(&self, now: Cycle) -> Option<Cycle> {
        (0..self.items.len()).map(|i| self.items.get(i).0).find(|&ready| ready > now)
    }

    /// Debug check that `now` is not before the latest push or pop.
    #[inline(always)]
    fn check_time(&self, now: Cycle) {
        debug_assert!(now >= self.last_now, "Fifo used at cycle {now} after cycle {}", self.last_now);
    }

    /// Check `now` and record it as the latest time seen.
    #[inline(always)]
    fn observe(&mut self, now: Cycle) {
        self.check_time(now);
        if cfg!(debug_assertions) {
            self.last_now = now;
        }
    }
}

/// A fixed-capacity ring buffer of `Copy` items (the FIFO's storage; slots
/// are written as they are first needed, so no item value is invented).
/// It holds at most `cap` items in a power-of-two number of slots, so that
/// positions wrap with a mask.
#[derive(Clone, Debug)]
struct Ring<E> {
    buf: Vec<E>,
    /// Slots − 1 (slots: `cap` rounded up to a power of two).
    mask: usize,
    head: usize,
    len: usize,
}

impl<E: Copy> Ring<E> {
    fn new(cap: usize) -> Ring<E> {
        let slots = cap.next_power_of_two();
        Ring { buf: Vec::with_capacity(slots), mask: slots - 1, head: 0, len: 0 }
    }

    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }

    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.len == 0
    }

    #[inline(always)]
    fn wrap(&self, i: usize) -> usize {
        i & self.mask
    }

    /// Append; the caller keeps `len < cap`.
    #[inline(always)]
    fn push_back(&mut self, e: E) {
        debug_assert!(self.len <= self.mask);
        let at = self.wrap(self.head + self.len);
        if at == self.buf.len() {
            self.buf.push(e);
        } else {
            self.buf[at] = e;
        }
        self.len += 1;
    }

    /// The `i`-th item from the front (`i < len`).
    #[inline(always)]
    fn get(&self, i: usize) -> &E {
        &self.buf[self.wrap(self.head + i)]
    }

    #[inline(always)]
    fn front(&self) -> Option<&E> {
        (self.len > 0).then(|| &self.buf[self.head])
    }

    #[inline(always)]
    fn front_mut(&mut self) -> Option<&mut E> {
        (self.len > 0).then(|| &mut self.buf[self.head])
    }

    #[inline(always)]
    fn pop_front(&mut self) -> Option<E> {
        if self.len == 0 {
            return None;
        }
        let e = self.buf[self.head];
        self.head = self.wrap(self.head + 1);
        self.len -= 1;
        Some(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: Cycle = Cycle(100);

    #[test]
    fn an_item_pushed_at_n_is_not_visible_at_n_plus_latency_minus_1() {
        for latency in 1..6 {
            let mut f = Fifo::new(4, latency);
            f.push(N, 7u32).unwrap();
            for t in N.get()..N.get() + latency {
                assert!(!f.can_pop(Cycle(t)), "latency {latency}: visible at {t}");
                assert_eq!(f.peek(Cycle(t)), None);
                assert_eq!(f.pop(Cycle(t)), None);
            }
            assert_eq!(f.len(), 1);
        }
    }

    #[test]
    fn held_items_are_seen_in_order_across_the_wrap_of_a_non_power_of_two_capacity() {
        // Capacity 3 in 4 slots: push and pop past the wrap several times.
        let mut f = Fifo::new(3, 2);
        let mut next = 0u32;
        for round in 0..10u64 {
            let now = N + 10 * round;
            while f.push(now, next).is_ok() {
                next += 1;
            }
            assert_eq!(f.len(), 3, "capacity holds");
            let first = next - 3;
            for k in 0..3 {
                assert_eq!(f.held(k), Some(&(first + k as u32)), "round {round}, item {k}");
            }
            assert_eq!(f.held(3), None);
            assert_eq!(f.pop(now + 2), Some(first));
            assert_eq!(f.pop(now + 2), Some(first + 1));
        }
    }

    #[test]
    fn an_item_pushed_at_n_is_visible_at_n_plus_latency() {
        for latency in 1..6 {
            let mut f = Fifo::new(4, latency);
            f.push(N, 7u32).unwrap();
            let t = N + latency;
            assert!(f.can_pop(t));
            assert_eq!(f.peek(t), Some(&7));
            assert_eq!(f.pop(t), Some(7));
            assert!(f.is_empty());
        }
    }

    #[test]
    fn an_item_stays_visible_until_popped() {
        let mut f = Fifo::new(2, 3);
        f.push(N, 'a').unwrap();
        assert_eq!(f.pop(N + 50), Some('a'));
    }

    #[test]
    fn latency_zero_is_visible_in_the_same_cycle_after_the_push() {
        let mut f = Fifo::new(2, 0);
        assert!(!f.can_pop(N));
        f.push(N, 1u8).unwrap();
        assert!(f.can_pop(N));
        assert_eq!(f.pop(N), Some(1));
    }

    #[test]
    fn the_next_event_is_the_first_item_still_in_transit() {
        let mut f: Fifo<u32> = Fifo::new(4, 3);
        assert_eq!(f.next_visible_after(Cycle(0)), None);
        f.push(Cycle(0), 1).unwrap();
        f.push(Cycle(2), 2).unwrap();
        // Item 1 visible from cycle 3 (blocked head), item 2 from cycle 5.
        assert_eq!(f.next_visible(), Some(Cycle(3)));
        assert_eq!(f.next_visible_after(Cycle(2)), Some(Cycle(3)));
        assert_eq!(f.next_visible_after(Cycle(3)), Some(Cycle(5)));
        assert_eq!(f.next_visible_after(Cycle(5)), None);
    }

    #[test]
    fn items_leave_in_push_order() {
        let mut f = Fifo::new(8, 2);
        for (i, v) in (0..8u32).enumerate() {
            f.push(N + i as u64 / 3, v).unwrap();
        }
        let out: Vec<u32> = std::iter::from_fn(|| f.pop(N + 10)).collect();
        assert_eq!(out, (0..8).collect::<Vec<_>>());
    }

    #[test]
    fn a_visible_item_behind_a_hidden_head_is_not_popped() {
        // Both pushed in order; the younger one cannot overtake the older.
        let mut f = Fifo::new(4, 2);
        f.push(N, 1).unwrap();
        f.push(N + 1, 2).unwrap();
        assert_eq!(f.pop(N + 1), None);
        assert_eq!(f.pop(N + 2), Some(1));
        assert_eq!(f.pop(N + 2), None);
        assert_eq!(f.pop(N + 3), Some(2));
    }

    #[test]
    fn a_full_fifo_refuses_and_returns_the_item() {
        let mut f = Fifo::new(2, 1);
        f.push(N, 1).unwrap();
        f.push(N, 2).unwrap();
        assert!(!f.can_push(N));
        assert_eq!(f.push(N, 3), Err(3));
        assert_eq!(f.len(), 2);
        // Items in transit hold their slots too: still full at N + 1.
        assert_eq!(f.push(N + 1, 3), Err(3));
        // A pop frees a slot for a push in the same cycle.
        assert_eq!(f.pop(N + 1), Some(1));
        assert!(f.can_push(N + 1));
        f.push(N + 1, 3).unwrap();
        assert_eq!(f.pop(N + 2), Some(2));
        assert_eq!(f.pop(N + 2), Some(3));
    }

    #[test]
    fn full_cycles_count_each_refused_cycle_once() {
        let mut f = Fifo::new(1, 1);
        f.push(N, 0).unwrap();
        // Three refusals in one cycle, one in the next; can_push counts nothing.
        assert!(!f.can_push(N));
        for _ in 0..3 {
            assert!(f.push(N, 1).is_err());
        }
        assert!(!f.can_push(N + 1));
        assert!(f.push(N + 1, 1).is_err());
        assert_eq!(f.pop(N + 1), Some(0));
        f.push(N + 1, 1).unwrap();
        let c = f.counters();
        assert_eq!(c, FifoCounters { pushes: 2, pops: 1, full_cycles: 2, refused_pushes: 4, peak_len: 1 });
        f.reset_counters();
        assert_eq!(f.counters(), FifoCounters { peak_len: 1, ..FifoCounters::default() });
    }

    #[test]
    fn a_refused_offer_counts_like_a_refused_push() {
        let mut f = Fifo::new(1, 1);
        assert!(f.offer(N));
        f.push(N, 0).unwrap();
        assert!(!f.offer(N));
        assert!(!f.offer(N));
        assert!(f.push(N + 1, 1).is_err());
        let c = f.counters();
        assert_eq!((c.refused_pushes, c.full_cycles, c.pushes), (3, 2, 1));
        assert_eq!(f.pop(N + 1), Some(0));
        assert!(f.offer(N + 1));
    }

    /// Consumer ticked before producer in each cycle (downstream first).
    fn run_downstream_first(capacity: usize, latency: u64, cycles: u64) -> (u64, u64) {
        let mut f = Fifo::new(capacity, latency);
        let mut next = 0u64;
        let mut received = 0u64;
        for t in 0..cycles {
            let now = Cycle(t);
            if let Some(v) = f.pop(now) {
                assert_eq!(v, received);
                received += 1;
            }
            if f.push(now, next).is_ok() {
                next += 1;
            }
        }
        (received, f.counters().full_cycles)
    }

    #[test]
    fn capacity_equal_to_latency_sustains_one_item_per_cycle_downstream_first() {
        for latency in 1..5 {
            let (received, full) = run_downstream_first(latency as usize, latency, 100);
            assert_eq!(received, 100 - latency, "latency {latency}");
            assert_eq!(full, 0, "latency {latency}");
        }
    }

    #[test]
    fn capacity_below_latency_limits_throughput() {
        // Capacity 2, latency 4: at most 2 items per 4 cycles.
        let (received, full) = run_downstream_first(2, 4, 400);
        assert!(received <= 200, "{received}");
        assert!(received >= 198, "{received}");
        assert!(full > 0);
    }

    #[test]
    #[should_panic(expected = "capacity")]
    fn capacity_zero_is_rejected() {
        let _ = Fifo::<u8>::new(0, 1);
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "after cycle")]
    fn time_running_backwards_is_caught_in_debug_builds() {
        let mut f = Fifo::new(1, 1);
        f.push(N, 0).unwrap();
        let _ = f.pop(N - 1);
    }
}
