//! The warper's hardware units, one file each (`docs/units.md`), joined by
//! the engine (`crate::engine`).
//!
//! Each unit file holds the unit's datapath (pure functions of its inputs)
//! and its control: a `*Stage` struct that owns the unit's control state
//! (cursors, registers, counters) and exposes one clocked entry point,
//! `tick(now, ports) -> Tick`, where the ports struct names every wire the
//! unit reads or drives for that cycle. The engine owns the clock and the
//! wires; a unit sees time only through `now`.
//!
//! Accounting: every tick leaves the unit in one [`UnitState`]; the engine
//! then calls the stage's `charge(span)` with the number of cycles that
//! state lasted (1, or the span of an idle stretch the engine skipped), so
//! `busy + stall + idle` equals the cycles the unit was ticked through.

pub mod abuffer;
pub mod composite;
pub mod dest_cache;
pub mod display;
pub mod fetch;
pub mod hole_fill;
pub mod kernel_setup;
pub mod line_buffer;
pub mod packer;
pub mod raster;
pub mod resolve;
pub mod tile_cache;
pub mod tile_manager;
pub mod transform;

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

/// The accounting half of a stage: the state of its last tick and the
/// cycles charged so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Activity {
    /// State of the last tick.
    pub state: UnitState,
    /// Cycles charged.
    pub cycles: UnitCycles,
}

impl Activity {
    /// Record a tick's state and pass the tick on.
    #[inline]
    pub fn record(&mut self, t: Tick) -> Tick {
        self.state = t.state;
        t
    }

    /// Charge `span` cycles to the state of the last tick.
    #[inline]
    pub fn charge(&mut self, span: u64) {
        self.cycles.charge(self.state, span);
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
}
