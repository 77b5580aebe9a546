//! Progress guard of the engine's clock loops: a model defect that leaves
//! every unit waiting for ever (a livelock, where tiles or requests still
//! move but no unit does its work, or a deadlock) stops the run with a
//! message naming each unit's state, instead of hanging.
//!
//! Every clock loop of the engine has one: the warps', the fallback
//! pass's and the final display read's (whose one "unit", `display`, is
//! busy in a cycle a read is issued or arrives: a DRAM backend that stops
//! answering is reported, not waited for).
//!
//! Rules:
//! 1. The engine reports every unit's tick of every cycle ([`Watchdog::note`]);
//!    a tick in state busy is progress.
//! 2. A warp's units hold a finite amount of work, so a correct model
//!    never goes long without progress: the longest honest wait is for
//!    DRAM, tile loads and write-backs queued behind each other (the
//!    fallback pass's last write-backs one after another, with one
//!    request outstanding at the slowest latency). The limit
//!    ([`limit_for`]) is 2²⁴ cycles or 1024 such requests,
//!    whichever is longer: a request is the DRAM latency plus a raw tile
//!    rounded up to whole bursts at the peak rate (at 8 cycles per byte
//!    with the `dramsim3` backend, whose rate the engine's knobs do not
//!    set).
//! 3. After a cycle with no progress for more than the limit,
//!    [`Watchdog::check`] panics: an internal error of the model, not of
//!    its input, reported with the units' last states and the engine's
//!    own details.
//!
//! Not a hardware unit: the hardware has no such guard; nothing of it is
//! timed or counted.

use crate::clock::Cycle;
use crate::config::{EngineConfig, tile_bytes};
use crate::units::{Tick, UnitState};

/// The limit of rule 2 for `cfg` (cycles).
pub fn limit_for(cfg: &EngineConfig) -> u64 {
    let bytes = tile_bytes(cfg).next_multiple_of(cfg.dram_burst_bytes.max(1));
    let transfer =
        if cfg.dram_backend == "ideal" { bytes.div_ceil(cfg.dram_peak_bytes_per_cycle.max(1)) } else { bytes * 8 };
    (1u64 << 24).max(1024 * (cfg.dram_latency_cycles + transfer))
}

/// The guard of one clock loop over `N` units.
pub struct Watchdog<const N: usize> {
    names: [&'static str; N],
    states: [UnitState; N],
    last_progress: Cycle,
    limit: u64,
}

impl<const N: usize> Watchdog<N> {
    /// A guard over the units `names` (in the order the engine reports
    /// them), with progress last seen at `now` and `limit` cycles allowed
    /// without it.
    pub fn new(names: [&'static str; N], now: Cycle, limit: u64) -> Self {
        Watchdog { names, states: [UnitState::Idle; N], last_progress: now, limit }
    }

    /// Rule 1: unit `k`'s tick at `now`; hands the tick back.
    #[inline(always)]
    pub fn note(&mut self, k: usize, now: Cycle, t: Tick) -> Tick {
        self.states[k] = t.state;
        if t.state == UnitState::Busy {
            self.last_progress = now;
        }
        t
    }

    /// Rule 3, after the cycle `now`: panic if no unit has made progress
    /// for more than the limit; `details` adds what the engine knows (the
    /// cache's state, the memory queues).
    #[inline(always)]
    pub fn check(&self, now: Cycle, details: impl FnOnce() -> String) {
        if now - self.last_progress > self.limit {
            self.stuck(now, details())
        }
    }

    #[cold]
    #[inline(never)]
    fn stuck(&self, now: Cycle, details: String) -> ! {
        let units: Vec<String> = self.names.iter().zip(&self.states).map(|(n, s)| format!("{n} {s:?}")).collect();
        panic!(
            "internal error in the cycle model: no unit made progress from cycle {} to {} (limit {} cycles); \
             last states: {}; {details}. This is a defect of the model, not of the input: please report it with \
             the trace and the configuration",
            self.last_progress.get(),
            now.get(),
            self.limit,
            units.join(", ")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::CACHE_BYTES_PER_SAMPLE;
    use crate::units::StallReason;

    fn tick(state: UnitState) -> Tick {
        Tick { state, moved: true }
    }

    #[test]
    fn progress_at_n_minus_1_allows_the_limit_and_no_cycle_more() {
        let mut w = Watchdog::new(["a", "b"], Cycle(0), 10);
        w.note(0, Cycle(5), tick(UnitState::Busy));
        w.note(1, Cycle(5), tick(UnitState::Stall(StallReason::Tile)));
        // Stalled ticks, even ones that moved something, are no progress.
        for n in 6..=15 {
            w.note(0, Cycle(n), tick(UnitState::Stall(StallReason::Tile)));
            w.note(1, Cycle(n), Tick::IDLE);
            w.check(Cycle(n), || unreachable!("within the limit"));
        }
        let r = std::panic::catch_unwind(|| w.check(Cycle(16), || "cache: 3 tiles".into()));
        let msg = *r.expect_err("one cycle past the limit").downcast::<String>().expect("a message");
        assert!(msg.contains("from cycle 5 to 16"), "{msg}");
        assert!(msg.contains("a Stall(Tile), b Idle"), "{msg}");
        assert!(msg.contains("cache: 3 tiles"), "{msg}");
        // Progress at N resets the count.
        w.note(1, Cycle(16), tick(UnitState::Busy));
        w.check(Cycle(26), || unreachable!("progress at 16"));
    }

    #[test]
    fn the_limit_covers_a_thousand_serial_tile_requests() {
        let cfg = EngineConfig::default();
        assert_eq!(limit_for(&cfg), 1 << 24);
        let tile = 256 * 256 * CACHE_BYTES_PER_SAMPLE;
        let slow = EngineConfig { tile_size: 256, dram_peak_bytes_per_cycle: 1, ..EngineConfig::default() };
        assert_eq!(limit_for(&slow), 1024 * (12 + tile));
        // The slowest latency, one request at a time: 1024 round trips.
        let far = EngineConfig { dram_latency_cycles: 1_000_000, dram_max_outstanding: 1, ..EngineConfig::default() };
        assert_eq!(limit_for(&far), 1024 * (1_000_000 + 8 * 8 * CACHE_BYTES_PER_SAMPLE / 16));
        // A burst larger than a tile: the whole burst moves.
        let burst = EngineConfig { tile_size: 4, dram_burst_bytes: 4096, dram_peak_bytes_per_cycle: 1, ..far };
        assert_eq!(limit_for(&burst), 1024 * (1_000_000 + 4096));
        let ds = EngineConfig { dram_backend: "dramsim3".into(), tile_size: 256, ..EngineConfig::default() };
        assert_eq!(limit_for(&ds), 1024 * (12 + 8 * tile));
    }
}
