//! Tile prefetch: the software-managed half of the destination cache
//! (TR98 §10: "both caches entirely software-managed"). The schedule,
//! computed before the warp, knows which lines may touch each destination
//! tile; this unit issues each tile's load a fixed distance ahead of the
//! sweep front, so that the compositor and the hole fill find their tiles
//! on chip instead of missing on them.
//!
//! Job: walk two lists in order, each of `(first line, tile)` sorted by
//! line: the warp's ([`crate::schedule::Schedule::first`]: the first
//! reference line whose kernels may write the tile) and the hole fill's
//! ([`crate::schedule::fill_first_lines`]: the first fill line that reads
//! or writes it). A tile is *due* once its front is within
//! `tile_prefetch_distance` lines of its first line; due tiles are loaded
//! in list order ([`super::dest_cache::DestCache::prefetch`]).
//!
//! Ports: in, kernel setup's line cursor (lines emitted) and the hole
//! fill's line cursor; out, prefetches into the destination cache (which
//! queues their reads with the memory port's prefetch requests).
//!
//! Throughput: one prefetch per cycle (one tag-store write port).
//!
//! Rules:
//! 1. Distance 0 turns the prefetch off: every tile is loaded on demand.
//! 2. A tile already in the cache or loaded in this warp is skipped (it
//!    costs no cycle).
//! 3. A prefetch takes a free slot or waits for one; it never spills.
//!    While it waits the lists do not advance (loads leave in order).
//! 4. Of the two lists, the due tile with the smaller first line goes
//!    first; ties go to the warp's list.
//!
//! Not modelled: the time to compute the lists (driver software, with the
//! schedule), the list memory (two entries of 8 bytes per tile).

use super::dest_cache::DestCache;
use super::tile_cache::TileState;
use crate::clock::Cycle;
use crate::dest_frame::DestFrame;
use crate::mem::MemPort;

/// The prefetch lists of one warp and their cursors.
pub struct TilePrefetch {
    /// `(first warp line, tile)` by line.
    warp: Vec<(u32, u32)>,
    /// `(first fill line, tile)` by line.
    fill: Vec<(u32, u32)>,
    next: [usize; 2],
    distance: u32,
}

/// The cursors the prefetch runs ahead of, this cycle.
#[derive(Clone, Copy, Debug)]
pub struct Fronts {
    /// Reference lines kernel setup has emitted.
    pub warp_lines: usize,
    /// Derived lines the hole fill has finished.
    pub fill_lines: usize,
}

impl TilePrefetch {
    /// The lists for tiles first touched by warp line `warp_first[t]` and
    /// fill line `fill_first[t]`, `distance` lines ahead (0: off).
    pub fn new(warp_first: &[Option<u32>], fill_first: &[Option<u32>], distance: u32) -> TilePrefetch {
        let list = |first: &[Option<u32>]| {
            let mut l: Vec<(u32, u32)> = if distance == 0 {
                Vec::new()
            } else {
                first.iter().enumerate().filter_map(|(t, f)| f.map(|l| (l, t as u32))).collect()
            };
            l.sort_unstable();
            l
        };
        TilePrefetch { warp: list(warp_first), fill: list(fill_first), next: [0, 0], distance }
    }

    /// The next due entry: (list, tile).
    #[inline]
    fn due(&self, fronts: Fronts) -> Option<(usize, u32)> {
        let d = self.distance as usize;
        let w = self.warp.get(self.next[0]).filter(|e| (e.0 as usize) <= fronts.warp_lines + d);
        let f = self.fill.get(self.next[1]).filter(|e| (e.0 as usize) <= fronts.fill_lines + d);
        match (w, f) {
            (Some(w), Some(f)) if f.0 < w.0 => Some((1, f.1)),
            (Some(w), _) => Some((0, w.1)),
            (None, Some(f)) => Some((1, f.1)),
            (None, None) => None,
        }
    }

    /// One cycle (rules 1–4): true if a prefetch was issued.
    #[inline]
    pub fn tick(
        &mut self,
        now: Cycle,
        fronts: Fronts,
        cache: &mut DestCache,
        frame: &mut DestFrame,
        port: &mut MemPort,
    ) -> bool {
        while let Some((list, t)) = self.due(fronts) {
            if cache.state(t) != TileState::Untouched {
                self.next[list] += 1;
                continue;
            }
            if !cache.prefetch(now, t, frame, port) {
                return false;
            }
            self.next[list] += 1;
            return true;
        }
        false
    }
}
