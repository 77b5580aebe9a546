//! The warper's hardware units, one file each (`docs/units.md`), joined by
//! the engine (`crate::engine`).
//!
//! Each unit file holds the unit's datapath (pure functions of its inputs)
//! and its control (kernel setup's line computation, which the host may run
//! ahead on another thread, is in `line_kernels`): a `*Stage` struct that owns the unit's control state
//! (cursors, registers, counters) and exposes one clocked entry point,
//! `tick(now, ports) -> Tick`, where the ports struct names every wire the
//! unit reads or drives for that cycle. The engine owns the clock and the
//! wires; a unit sees time only through `now`.
//!
//! Accounting: every tick leaves the unit in one [`UnitState`], which holds
//! until the next tick that differs (the engine skips idle stretches
//! between ticks); each stage's [`Activity`] charges a state when it ends,
//! so `busy + stall + idle` equals the cycles the unit was ticked through,
//! and can record the runs of states for a timeline.

pub mod abuffer;
pub mod composite;
pub mod dest_cache;
pub mod display;
pub mod fallback_fill;
pub mod fetch;
pub mod hole_fill;
pub mod kernel_setup;
pub mod line_buffer;
pub mod line_kernels;
pub mod packer;
pub mod raster;
pub mod resolve;
pub mod tile_cache;
pub mod tile_manager;
pub mod tile_prefetch;
pub mod transform;

use crate::clock::Cycle;

/// Why a unit that had work did not move it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StallReason {
    /// Waiting for DRAM data (a source block still in flight).
    Dram,
    /// Waiting for a destination tile: not resident yet (its load in flight,
    /// or no cache slot free).
    Tile,
    /// Its output FIFO or queue is full (back-pressure from downstream).
    FifoFull,
    /// Waiting on an upstream dependency: the line buffer's next line, a
    /// tile not yet retired by the warp, or an item still in a FIFO's
    /// transit.
    Upstream,
}

impl StallReason {
    /// Every reason, in report order.
    pub const ALL: [StallReason; 4] =
        [StallReason::Dram, StallReason::Tile, StallReason::FifoFull, StallReason::Upstream];

    /// Position in [`StallReason::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Snake-case name, as used in stat names and `report.json`.
    pub const fn name(self) -> &'static str {
        match self {
            StallReason::Dram => "dram",
            StallReason::Tile => "tile",
            StallReason::FifoFull => "fifo_full",
            StallReason::Upstream => "upstream",
        }
    }
}

/// What a unit did in one cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum UnitState {
    /// It moved work.
    Busy,
    /// It had work but waited, for the reason given.
    Stall(StallReason),
    /// It had nothing to do.
    #[default]
    Idle,
}

/// The result of one tick: the unit's state, and whether anything moved
/// that another unit may see this cycle or the next (the engine skips
/// idle stretches only when no unit moved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tick {
    /// The unit's state in this cycle.
    pub state: UnitState,
    /// Some work moved (an item consumed or produced, a value written).
    pub moved: bool,
}

impl Tick {
    /// A tick that moved work.
    pub const BUSY: Tick = Tick { state: UnitState::Busy, moved: true };
    /// A tick with nothing to do.
    pub const IDLE: Tick = Tick { state: UnitState::Idle, moved: false };

    /// A stalled tick.
    pub const fn stall(reason: StallReason) -> Tick {
        Tick { state: UnitState::Stall(reason), moved: false }
    }
}

/// Busy, stalled and idle cycles of one unit, stalls split by reason
/// (cycles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitCycles {
    /// Cycles the unit moved work.
    pub busy: u64,
    /// Cycles it had work but waited (the sum of `stall_by_reason`).
    pub stall: u64,
    /// Cycles it had nothing to do.
    pub idle: u64,
    /// Stall cycles per [`StallReason`], in [`StallReason::ALL`] order.
    pub stall_by_reason: [u64; 4],
}

impl UnitCycles {
    /// Charge `span` cycles spent in `state`.
    #[inline]
    pub fn charge(&mut self, state: UnitState, span: u64) {
        match state {
            UnitState::Busy => self.busy += span,
            UnitState::Idle => self.idle += span,
            UnitState::Stall(r) => {
                self.stall += span;
                self.stall_by_reason[r.index()] += span;
            }
        }
    }

    /// Add another unit's (or another warp's) cycles.
    pub fn add(&mut self, o: &UnitCycles) {
        self.busy += o.busy;
        self.stall += o.stall;
        self.idle += o.idle;
        for (a, b) in self.stall_by_reason.iter_mut().zip(o.stall_by_reason) {
            *a += b;
        }
    }

    /// Every cycle charged (busy + stall + idle).
    pub fn total(&self) -> u64 {
        self.busy + self.stall + self.idle
    }
}

/// A run of one state: cycles `start..end` (end exclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// The state.
    pub state: UnitState,
    /// First cycle of the run.
    pub start: Cycle,
    /// First cycle after it.
    pub end: Cycle,
}

/// The accounting half of a stage: the state of its last tick, since when
/// it has held, the cycles charged to earlier states, and (when recording)
/// the runs of states for a timeline.
///
/// A state is charged when it ends (the next tick with another state, or
/// [`Activity::close`]): with the engine skipping idle stretches, a state
/// lasts until the next tick that differs, so every cycle from the
/// stage's start is charged to exactly one state.
#[derive(Clone, Debug)]
pub struct Activity {
    state: UnitState,
    since: Cycle,
    cycles: UnitCycles,
    runs: Option<Vec<Run>>,
}

impl Activity {
    /// A stage starting at `now` (idle until its first tick), recording
    /// its runs if `record`.
    pub fn starting(now: Cycle, record: bool) -> Activity {
        Activity { state: UnitState::Idle, since: now, cycles: UnitCycles::default(), runs: record.then(Vec::new) }
    }

    /// Record a tick's state at `now` and pass the tick on.
    #[inline(always)]
    pub fn record(&mut self, now: Cycle, t: Tick) -> Tick {
        if t.state != self.state {
            self.switch(now, t.state);
        }
        t
    }

    #[inline(never)]
    fn switch(&mut self, now: Cycle, state: UnitState) {
        let span = now - self.since;
        if span > 0 {
            self.cycles.charge(self.state, span);
            if let Some(runs) = &mut self.runs {
                runs.push(Run { state: self.state, start: self.since, end: now });
            }
        }
        self.state = state;
        self.since = now;
    }

    /// End the stage at `now`: charge the current state up to it.
    pub fn close(&mut self, now: Cycle) {
        let state = self.state;
        self.switch(now, state);
    }

    /// State of the last tick.
    pub fn state(&self) -> UnitState {
        self.state
    }

    /// Cycles charged so far (the current state up to its last switch).
    pub fn cycles(&self) -> UnitCycles {
        self.cycles
    }

    /// The recorded runs (empty unless recording).
    pub fn take_runs(&mut self) -> Vec<Run> {
        self.runs.take().unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charges_split_stalls_by_reason_and_sum_to_the_total() {
        let mut c = UnitCycles::default();
        c.charge(UnitState::Busy, 3);
        c.charge(UnitState::Stall(StallReason::Tile), 4);
        c.charge(UnitState::Stall(StallReason::Dram), 5);
        c.charge(UnitState::Idle, 6);
        assert_eq!((c.busy, c.stall, c.idle, c.stall_by_reason), (3, 9, 6, [5, 4, 0, 0]));
        assert_eq!(c.total(), 18);
        let mut d = c;
        d.add(&c);
        assert_eq!(d.total(), 36);
        assert_eq!(d.stall_by_reason.iter().sum::<u64>(), d.stall);
    }

    #[test]
    fn activity_charges_each_state_until_the_next_change_and_records_runs() {
        let mut a = Activity::starting(Cycle(10), true);
        a.record(Cycle(10), Tick::BUSY);
        a.record(Cycle(11), Tick::BUSY);
        a.record(Cycle(12), Tick::stall(StallReason::Dram));
        // Cycles 13..20 skipped by the engine: the stall lasts.
        a.record(Cycle(20), Tick::IDLE);
        a.close(Cycle(25));
        let c = a.cycles();
        assert_eq!((c.busy, c.stall, c.idle, c.stall_by_reason[0]), (2, 8, 5, 8));
        assert_eq!(c.total(), 15);
        let runs = a.take_runs();
        assert_eq!(runs.len(), 3);
        assert_eq!((runs[1].start, runs[1].end), (Cycle(12), Cycle(20)));
        assert!(runs.windows(2).all(|w| w[0].end == w[1].start));
    }
}
