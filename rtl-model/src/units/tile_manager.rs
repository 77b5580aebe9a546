//! Tile manager, run-time half: which destination tiles the warp can no
//! longer write (retired), from the schedule's retirement lines and the
//! kernels still in flight.
//!
//! Job: count, per schedule line, the kernels emitted by kernel setup and
//! not yet finished (composited, or dropped as an empty stamp by the
//! rasterizer); a line is *complete* once kernel setup has moved past it
//! and its count is 0, lines completing in schedule order; a tile is
//! *retired* once every line up to its retirement line
//! ([`crate::schedule::Schedule::retire`]) is complete. The hole fill
//! waits on retirement.
//!
//! Ports: in, `kernel_issued(line)` from kernel setup, `kernel_done(line)`
//! from the rasterizer and the compositor, kernel setup's line cursor
//! each cycle; out, the retired bit of every tile (`is_retired`).
//!
//! Throughput: any number of lines and tiles per cycle (counters and a
//! sorted list; the model does not limit it).
//!
//! Rules:
//! 1. Tiles no line can touch are retired from the start of the warp.
//! 2. A kernel counts against its line from its emission to its end; the
//!    counts never go negative.
//!
//! Not modelled: the counters' width, the cost of sorting the retirement
//! list (software, with the schedule).

use bitvec::vec::BitVec;

/// The retirement tracker of one warp (module doc).
pub struct TileManager {
    /// Kernels in flight per schedule line.
    in_flight: Vec<u32>,
    /// Lines complete (a prefix of the schedule).
    complete: usize,
    /// `(retirement line, tile)`, by line.
    order: Vec<(u32, u32)>,
    next: usize,
    retired: BitVec,
}

impl TileManager {
    /// The tracker for a schedule of `lines` lines whose tiles retire after
    /// `retire[t]` (`None`: no line can touch the tile).
    pub fn new(lines: usize, retire: &[Option<u32>]) -> TileManager {
        let mut order: Vec<(u32, u32)> = Vec::new();
        let mut retired: BitVec = BitVec::repeat(false, retire.len());
        for (t, rl) in retire.iter().enumerate() {
            match rl {
                None => retired.set(t, true),
                Some(l) => order.push((*l, t as u32)),
            }
        }
        order.sort_unstable();
        TileManager { in_flight: vec![0; lines], complete: 0, order, next: 0, retired }
    }

    /// Kernel setup emitted a kernel of `line`.
    #[inline]
    pub fn kernel_issued(&mut self, line: usize) {
        self.in_flight[line] += 1;
    }

    /// A kernel of `line` is done (composited, or an empty stamp).
    #[inline]
    pub fn kernel_done(&mut self, line: u32) {
        self.in_flight[line as usize] -= 1;
    }

    /// Tile `t` can no longer be written in this warp.
    #[inline]
    pub fn is_retired(&self, t: u32) -> bool {
        self.retired[t as usize]
    }

    /// Advance after kernel setup's tick: it has moved past `emitted`
    /// lines. True if a tile retired.
    #[inline]
    pub fn tick(&mut self, emitted: usize) -> bool {
        while self.complete < emitted && self.in_flight[self.complete] == 0 {
            self.complete += 1;
        }
        let mut moved = false;
        while self.next < self.order.len() && (self.order[self.next].0 as usize) < self.complete {
            self.retired.set(self.order[self.next].1 as usize, true);
            self.next += 1;
            moved = true;
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_retires_once_its_last_line_is_complete_and_not_before() {
        // Tile 0: last line 1; tile 1: never touched; tile 2: last line 0.
        let mut m = TileManager::new(3, &[Some(1), None, Some(0)]);
        assert!(m.is_retired(1) && !m.is_retired(0) && !m.is_retired(2));
        m.kernel_issued(0);
        assert!(!m.tick(1), "line 0 has a kernel in flight");
        m.kernel_done(0);
        assert!(m.tick(1));
        assert!(m.is_retired(2) && !m.is_retired(0));
        m.kernel_issued(1);
        assert!(!m.tick(2));
        m.kernel_done(1);
        assert!(m.tick(2) && m.is_retired(0));
        assert!(!m.tick(3), "nothing left to retire");
    }
}
