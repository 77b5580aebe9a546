//! What one derived frame looked like over time: the runs of every unit's
//! state, every DRAM request's lifetime, and the occupancy of the FIFOs,
//! the memory port and the destination cache.
//!
//! Job: record, while the engine runs a frame with recording on
//! (`Engine::record_timeline`), the raw material of a timeline view. The
//! `postwarp` crate writes it as a Chrome trace (`postwarp simulate
//! --timeline`, `docs/units.md`); this crate does no I/O.
//!
//! Rules:
//! 1. Unit runs tile the frame: for every unit, the runs are contiguous
//!    from cycle 0 to the frame's last cycle, consecutive runs differ in
//!    state, and the cycles of each state sum to the unit's counters in
//!    `FrameStats::units` (the display read at the end is an idle run).
//! 2. A request spans its acceptance cycle to its completion cycle.
//! 3. Occupancy is kept per window of [`OCCUPANCY_WINDOW`] cycles: the
//!    occupancy summed over the window's cycles (item-cycles) and its
//!    maximum; cycles the engine skipped count with the value they held.
//!
//! Not modelled: nothing (a recording; it changes no value and no cycle).

use crate::clock::Cycle;
use crate::mem::{Access, Client};
use crate::units::{Run, UnitState};

/// Cycles per occupancy window (rule 3).
pub const OCCUPANCY_WINDOW: u64 = 64;

/// One DRAM request's lifetime (rule 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RequestSpan {
    /// Who asked.
    pub client: Client,
    /// Read or write.
    pub access: Access,
    /// First byte's DRAM address (bytes).
    pub addr: u64,
    /// Bytes moved (rounded to bursts).
    pub bytes: u64,
    /// Cycle of acceptance.
    pub accepted: Cycle,
    /// Cycle from which it counts as completed.
    pub done: Cycle,
}

/// The occupancy of one queue, per window (rule 3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Occupancy {
    /// Track name (e.g. `kernel FIFO`).
    pub name: &'static str,
    /// Unit of the values (e.g. `kernels`, `tiles`).
    pub unit: &'static str,
    /// Capacity (same unit), for the reader's scale; `None` for a queue
    /// the model does not bound (the memory port's, `mem::port`).
    pub capacity: Option<u64>,
    /// Per window: occupancy summed over its cycles (unit-cycles).
    pub sum: Vec<u64>,
    /// Per window: largest occupancy.
    pub max: Vec<u64>,
}

impl Occupancy {
    /// An empty series.
    pub fn new(name: &'static str, unit: &'static str, capacity: Option<u64>) -> Occupancy {
        Occupancy { name, unit, capacity, sum: Vec::new(), max: Vec::new() }
    }

    /// The queue held `value` during cycles `from..from + span`.
    pub fn add(&mut self, from: Cycle, span: u64, value: u64) {
        let (mut at, mut left) = (from.get(), span);
        while left > 0 {
            let w = (at / OCCUPANCY_WINDOW) as usize;
            if self.sum.len() <= w {
                self.sum.resize(w + 1, 0);
                self.max.resize(w + 1, 0);
            }
            let take = left.min((w as u64 + 1) * OCCUPANCY_WINDOW - at);
            self.sum[w] += value * take;
            self.max[w] = self.max[w].max(value);
            at += take;
            left -= take;
        }
    }
}

/// The recording of one frame (module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Timeline {
    /// Cycles of the frame.
    pub cycles: u64,
    /// Per unit (in `frame_stats::UNITS` order), its runs (rule 1).
    pub units: Vec<Vec<Run>>,
    /// Every DRAM request, in acceptance order.
    pub requests: Vec<RequestSpan>,
    /// Occupancy series.
    pub occupancy: Vec<Occupancy>,
    /// Each reference warp's first cycle and the cycle after its last.
    pub warps: Vec<(Cycle, Cycle)>,
}

impl Timeline {
    /// An empty recording of `units` units and the given occupancy series.
    pub fn new(units: usize, occupancy: Vec<Occupancy>) -> Timeline {
        Timeline { cycles: 0, units: vec![Vec::new(); units], requests: Vec::new(), occupancy, warps: Vec::new() }
    }

    /// Append a unit's runs, merging a run that continues the last one's
    /// state (across a warp boundary).
    pub fn append_runs(&mut self, unit: usize, runs: Vec<Run>) {
        let track = &mut self.units[unit];
        for r in runs {
            match track.last_mut() {
                Some(last) if last.state == r.state && last.end == r.start => last.end = r.end,
                _ => track.push(r),
            }
        }
    }

    /// Close the frame at `end`: every unit idle from its last run on.
    pub fn close(&mut self, end: Cycle) {
        self.cycles = end.get();
        for u in 0..self.units.len() {
            let from = self.units[u].last().map_or(Cycle::ZERO, |r| r.end);
            if from < end {
                self.append_runs(u, vec![Run { state: UnitState::Idle, start: from, end }]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::StallReason;

    #[test]
    fn occupancy_spreads_a_span_over_its_windows() {
        let mut o = Occupancy::new("q", "items", Some(4));
        o.add(Cycle(60), 10, 3); // 4 cycles in window 0, 6 in window 1
        o.add(Cycle(70), 1, 1);
        assert_eq!(o.sum, vec![12, 19]);
        assert_eq!(o.max, vec![3, 3]);
    }

    #[test]
    fn runs_merge_across_warps_and_the_display_closes_them() {
        let mut t = Timeline::new(1, vec![]);
        let busy = |a, b| Run { state: UnitState::Busy, start: Cycle(a), end: Cycle(b) };
        t.append_runs(0, vec![busy(0, 5)]);
        t.append_runs(
            0,
            vec![busy(5, 7), Run { state: UnitState::Stall(StallReason::Tile), start: Cycle(7), end: Cycle(9) }],
        );
        t.close(Cycle(12));
        let r = &t.units[0];
        assert_eq!(r.len(), 3);
        assert_eq!((r[0].end, r[2].state, r[2].end), (Cycle(7), UnitState::Idle, Cycle(12)));
    }
}
