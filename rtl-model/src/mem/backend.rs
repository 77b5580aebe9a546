//! DRAM backends: what times the requests the channel ([`super::Dram`])
//! accepts.
//!
//! Job: given a request accepted at a cycle (direction, address, bytes),
//! say when it completes. The channel keeps everything else (the one
//! command port, `max_outstanding`, tags, byte and latency counters), so
//! every backend is seen through the same interface by the engine.
//!
//! API ([`DramBackend`]): `tick(now)` once per engine cycle, `skip_to(now)`
//! over a stretch the backend allowed ([`DramBackend::next_event`]),
//! `accept(now, id, access, addr, bytes)` (the completion cycle if the
//! backend knows it at once), `pop_done(now)` (a finished request's id and
//! its completion cycle), `next_event()` ([`NextEvent`]), `counters()`
//! ([`BackendCounters`]). [`DramBackendFactory`] makes one backend per
//! frame (the engine runs every frame on a fresh, idle memory).
//!
//! Backends:
//! - [`IdealBackend`] (`dram_backend = "ideal"`, the default): the
//!   serialization model of `mem::dram` (fixed latency, one data bus at
//!   `peak_bytes_per_cycle`, completions in acceptance order), exactly the
//!   timing the model always had.
//! - External, cycle-accurate simulators live in the `postwarp` crate (this
//!   crate does no file I/O): `dram_backend = "dramsim3"` (`src/dram/`).
//!
//! Rules:
//! 1. `tick(now)` is called for consecutive cycles before any other call of
//!    that cycle; `skip_to(now)` replaces the ticks of the cycles after the
//!    last one up to `now` and is only called when [`DramBackend::next_event`]
//!    said nothing happens before `now` (`NextEvent::Idle`, or `At(t)` with
//!    `t >= now`). A backend that cannot predict its next completion
//!    returns [`NextEvent::EveryCycle`] while it has work: the engine then
//!    ticks every cycle. `skip_to` of a clocked backend must tick its clock
//!    as often as the skipped `tick`s would have (so skipping is exact,
//!    `tests/hw_skip_exact.rs`).
//! 2. Deterministic: the same calls give the same completions.
//! 3. Values never depend on the backend; only cycles do.
//!
//! Stats: [`BackendCounters`] (zero for the ideal backend).

use std::collections::VecDeque;
use std::sync::Arc;

use super::dram::{Access, DramConfig};
use crate::clock::Cycle;

/// When a backend's next completion is, as far as it knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NextEvent {
    /// Nothing outstanding: any stretch may be skipped.
    Idle,
    /// The next completion is at this cycle; nothing happens before.
    At(Cycle),
    /// Work outstanding, completion unknown: tick every cycle.
    EveryCycle,
}

/// Counters only a cycle-accurate backend has (all 0 for the ideal one).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BackendCounters {
    /// DRAM clock cycles simulated (DRAM cycles).
    pub dram_cycles: u64,
    /// Bytes the DRAM data bus could have moved in those cycles, every
    /// channel (bytes).
    pub peak_bytes: u64,
    /// Read transactions handed to the DRAM simulator (transactions).
    pub read_transactions: u64,
    /// Write transactions handed to the DRAM simulator (transactions).
    pub write_transactions: u64,
    /// Bytes of those transactions, at the simulator's transaction size
    /// (bytes).
    pub transaction_bytes: u64,
    /// Transactions to the row last opened in their bank (transactions).
    pub row_hits: u64,
    /// Transactions to a bank with no row opened yet (transactions).
    pub row_misses: u64,
    /// Transactions to a bank whose open row is another one (transactions).
    pub row_conflicts: u64,
}

impl BackendCounters {
    /// Add `o` to `self`.
    pub fn add(&mut self, o: &BackendCounters) {
        self.dram_cycles += o.dram_cycles;
        self.peak_bytes += o.peak_bytes;
        self.read_transactions += o.read_transactions;
        self.write_transactions += o.write_transactions;
        self.transaction_bytes += o.transaction_bytes;
        self.row_hits += o.row_hits;
        self.row_misses += o.row_misses;
        self.row_conflicts += o.row_conflicts;
    }
}

/// A DRAM timing model behind the channel (module doc for the rules).
pub trait DramBackend: Send {
    /// The `dram_backend` knob value that selects it.
    fn name(&self) -> &'static str;
    /// Advance to engine cycle `now` (rule 1).
    fn tick(&mut self, now: Cycle);
    /// Jump to `now` as if ticked every cycle in between (rule 1).
    fn skip_to(&mut self, now: Cycle);
    /// Take request `id` (ids increase by one per accepted request),
    /// accepted at `now`; its completion cycle if known now (then
    /// `pop_done` returns it from that cycle on).
    fn accept(&mut self, now: Cycle, id: u64, access: Access, addr: u64, bytes: u64) -> Option<Cycle>;
    /// A request finished by `now`, with the cycle it finished, if any.
    fn pop_done(&mut self, now: Cycle) -> Option<(u64, Cycle)>;
    /// The next event (rule 1).
    fn next_event(&self) -> NextEvent;
    /// Counters since the backend was made.
    fn counters(&self) -> BackendCounters {
        BackendCounters::default()
    }
}

/// Makes a fresh, idle backend for each frame.
pub type DramBackendFactory = Arc<dyn Fn() -> Box<dyn DramBackend> + Send + Sync>;

/// Today's model (`mem::dram` module doc, "Timing rules"): a request
/// starts its transfer `latency_cycles` after acceptance or when the bus is
/// free, whichever is later, and occupies the bus for its rounded bytes at
/// `peak_bytes_per_cycle`.
#[derive(Clone, Debug)]
pub struct IdealBackend {
    cfg: DramConfig,
    /// First free byte slot of the bus: cycle c carries the slots
    /// `[c * peak, (c + 1) * peak)`.
    bus_free_slot: u64,
    /// (id, completion cycle), in acceptance order.
    in_flight: VecDeque<(u64, Cycle)>,
}

impl IdealBackend {
    /// Idle, with the channel's knobs.
    pub fn new(cfg: DramConfig) -> IdealBackend {
        IdealBackend { cfg, bus_free_slot: 0, in_flight: VecDeque::with_capacity(cfg.max_outstanding) }
    }

    /// The first free byte slot of the bus (for tests of the schedule).
    pub fn bus_free_slot(&self) -> u64 {
        self.bus_free_slot
    }
}

impl DramBackend for IdealBackend {
    fn name(&self) -> &'static str {
        "ideal"
    }

    #[inline]
    fn tick(&mut self, _now: Cycle) {}

    #[inline]
    fn skip_to(&mut self, _now: Cycle) {}

    #[inline]
    fn accept(&mut self, now: Cycle, id: u64, _access: Access, _addr: u64, bytes: u64) -> Option<Cycle> {
        let peak = self.cfg.peak_bytes_per_cycle;
        let rounded = self.cfg.rounded(bytes);
        let start = self.bus_free_slot.max((now + self.cfg.latency_cycles).get() * peak);
        let end = start + rounded;
        let done = Cycle(end.div_ceil(peak));
        self.bus_free_slot = end;
        self.in_flight.push_back((id, done));
        Some(done)
    }

    #[inline]
    fn pop_done(&mut self, now: Cycle) -> Option<(u64, Cycle)> {
        let &(_, done) = self.in_flight.front()?;
        if done > now {
            return None;
        }
        self.in_flight.pop_front()
    }

    #[inline]
    fn next_event(&self) -> NextEvent {
        self.in_flight.front().map_or(NextEvent::Idle, |&(_, done)| NextEvent::At(done))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: DramConfig =
        DramConfig { peak_bytes_per_cycle: 16, latency_cycles: 10, burst_bytes: 32, max_outstanding: 8 };

    #[test]
    fn the_ideal_backend_serializes_the_bus_after_the_latency() {
        let mut b = IdealBackend::new(CFG);
        assert_eq!(b.next_event(), NextEvent::Idle);
        // 64 bytes: 4 cycles of bus after 10 of latency.
        assert_eq!(b.accept(Cycle(5), 0, Access::Read, 0, 64), Some(Cycle(19)));
        // Behind it on the bus: starts at 19, 33 bytes round to 64.
        assert_eq!(b.accept(Cycle(6), 1, Access::Write, 4096, 33), Some(Cycle(23)));
        assert_eq!(b.next_event(), NextEvent::At(Cycle(19)));
        assert_eq!(b.pop_done(Cycle(18)), None);
        assert_eq!(b.pop_done(Cycle(19)), Some((0, Cycle(19))));
        assert_eq!(b.pop_done(Cycle(30)), Some((1, Cycle(23))), "late polling gets the real completion cycle");
        assert_eq!(b.next_event(), NextEvent::Idle);
        assert_eq!(b.counters(), BackendCounters::default());
        assert_eq!(b.name(), "ideal");
    }

    #[test]
    fn backend_counters_add_field_by_field() {
        let one = BackendCounters {
            dram_cycles: 1,
            peak_bytes: 2,
            read_transactions: 3,
            write_transactions: 4,
            transaction_bytes: 5,
            row_hits: 6,
            row_misses: 7,
            row_conflicts: 8,
        };
        let mut s = one.clone();
        s.add(&one);
        assert_eq!(s.dram_cycles + s.peak_bytes + s.row_conflicts, 2 + 4 + 16);
        assert_eq!((s.read_transactions, s.write_transactions, s.transaction_bytes), (6, 8, 10));
        assert_eq!((s.row_hits, s.row_misses), (12, 14));
    }
}
