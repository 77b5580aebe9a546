//! Row-buffer hits, counted from the addresses DRAMsim3 is given: the
//! binding exposes no DRAMsim3 statistics, so the backend keeps its own
//! count (`docs/memory.md`).
//!
//! Rule: every bank keeps the row of the last transaction handed to
//! DRAMsim3 for it open (an open-page policy, `row_buf_policy =
//! OPEN_PAGE` in every shipped ini). A transaction is a *hit* if its row is
//! the bank's open one, a *miss* if the bank has none open yet, a
//! *conflict* otherwise. Counted in the order transactions enter DRAMsim3,
//! not in the order its scheduler issues them, and ignoring refresh (which
//! closes rows): an estimate of DRAMsim3's own `num_read_row_hits`.

use super::ini::Geometry;
use std::collections::HashMap;

/// What one transaction found in its bank.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowOutcome {
    /// Its row was open.
    Hit,
    /// No row was open in the bank.
    Miss,
    /// Another row was open.
    Conflict,
}

/// The open row of every bank touched so far.
#[derive(Clone, Debug)]
pub struct RowTracker {
    geometry: Geometry,
    open: HashMap<u64, u64>,
}

impl RowTracker {
    /// Every bank closed.
    pub fn new(geometry: Geometry) -> RowTracker {
        RowTracker { geometry, open: HashMap::new() }
    }

    /// A transaction at byte address `addr`: what it found, and its row is
    /// open afterwards.
    pub fn access(&mut self, addr: u64) -> RowOutcome {
        let l = self.geometry.decode(addr);
        match self.open.insert(l.bank, l.row) {
            None => RowOutcome::Miss,
            Some(r) if r == l.row => RowOutcome::Hit,
            Some(_) => RowOutcome::Conflict,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dram::ini::Ini;

    #[test]
    fn a_sequential_stream_hits_the_open_row_and_the_mapping_decides_how_often() {
        let ini = Ini::load("DDR4_8Gb_x8_3200").unwrap();
        let count = |mapping: &str| {
            let mut t = RowTracker::new(Geometry::of(&ini, mapping).unwrap());
            let mut n = [0u32; 3];
            for i in 0..4096u64 {
                n[t.access(i * 64) as usize] += 1;
            }
            n
        };
        // Columns lowest (rochrababgco): 128 transactions per row, 16 banks
        // then 2 ranks; 4096 transactions = 1 row in each of 32 banks.
        assert_eq!(count("rochrababgco"), [4096 - 32, 32, 0]);
        // Rows lowest (chrabgbacoro): every transaction a new row of one bank.
        let [hits, misses, conflicts] = count("chrabgbacoro");
        assert_eq!((hits, misses), (0, 1));
        assert_eq!(conflicts, 4095);
        let mut t = RowTracker::new(Geometry::of(&ini, "").unwrap());
        assert_eq!(t.access(0), RowOutcome::Miss);
        assert_eq!(t.access(0), RowOutcome::Hit, "all-zero addresses: one row");
    }
}
