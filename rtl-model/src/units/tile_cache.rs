//! Destination tile cache: software-managed on-chip store of derived-frame
//! tiles (TR98 §10; `docs/warper-reference.md` §5).
//!
//! Job: hold the destination tiles the compositor and the hole-fill unit
//! work on; bring a tile in on first use in a warp and send it out when
//! the tile manager releases it; when full, spill a resident tile to make
//! room and count it.
//!
//! Ports: access (tile) from the compositor, the hole-fill unit and the
//! packer (release); load and write-back requests to DRAM through the
//! engine's memory port.
//!
//! Throughput: any number of look-ups a cycle (a tag store without ports
//! of its own: the units' rates bound it), one load or write issued a cycle
//! by the memory port. It holds no clock of its own: its timing is that of
//! the loads (`units::dest_cache`, tested in `tests/unit_dest_cache.rs`).
//!
//! Rules:
//! 1. Capacity is `dest_cache_bytes / (tile_size² · 16 B)` tiles
//!    ([`crate::config::CACHE_BYTES_PER_SAMPLE`]).
//! 2. An access to a resident tile is a hit. The first access to a tile in
//!    a warp is a *compulsory* (and *demand*) miss; an access to a tile
//!    spilled earlier in the same warp is a *capacity* miss. An access to a
//!    tile whose load is in flight waits (a *late* miss); its retries are
//!    not counted again.
//! 3. A compulsory miss loads the tile in A-buffer format (as the previous
//!    warp wrote it back); in a frame's first warp the tile is empty and is
//!    cleared on chip without a memory read. Either way the cache-only
//!    planes 6–8 are reset as the tile arrives.
//! 4. With every slot taken, a miss spills the least recently used resident
//!    tile that is not pinned by the access in progress: all its planes go
//!    out raw (`tile_size² · 16 B`) and come back raw on the capacity miss,
//!    so a spill never changes a value (packing to A-buffer format is lossy
//!    and happens only once per warp, on release).
//! 5. On release the tile is packed to A-buffer format and written back;
//!    its slot is free as soon as the write is queued.
//! 6. A *prefetch* ([`TileCache::prefetch`], issued by the schedule,
//!    `units::tile_prefetch`) takes a free slot for an untouched tile and
//!    starts its load as a compulsory miss would, without an access; it
//!    never spills, and leaves an eighth of the slots to misses (with
//!    fewer free it waits). An access that then finds
//!    the load still in flight waits (a *late* miss); one that finds a tile
//!    the schedule did not load is a *demand* miss.
//! 7. A miss that needs room first drops the newest prefetched tile not
//!    yet used and not pinned: it is clean (as loaded), so it goes without
//!    a write and is untouched again (its next access is a demand miss).
//!    Only with none does it spill by rule 4.
//!
//! Not modelled: tag lookup latency and bank conflicts (an access to a
//! resident tile costs nothing beyond the unit's cycle), write-buffer
//! capacity beyond the engine's queue.

use crate::clock::Cycle;
use crate::lru::Lru;

/// State of one tile within the current warp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileState {
    /// Not yet used in this warp.
    Untouched,
    /// A load is in flight.
    Loading,
    /// On chip.
    Resident,
    /// Spilled raw to memory (rule 4).
    Spilled,
    /// Released for this warp (packed and written back).
    Released,
}

/// What an access found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// Resident: go ahead.
    Hit,
    /// A load is in flight: wait.
    Wait,
    /// Compulsory miss: a slot was taken; the caller starts the load.
    Compulsory,
    /// Capacity miss: a slot was taken; the caller reloads the raw tile.
    Capacity,
    /// No slot free and nothing unpinned to spill: wait.
    Full,
}

/// Event counts (units: counts).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TileCacheCounters {
    /// Tile accesses (first look-up of each access; waits not recounted).
    pub accesses: u64,
    /// Accesses that found the tile resident.
    pub hits: u64,
    /// Tiles loaded for their first use in a warp, by the schedule's
    /// prefetch or on demand.
    pub misses_compulsory: u64,
    /// Accesses that found a tile the schedule had not loaded (untouched
    /// in this warp): loaded on demand.
    pub misses_demand: u64,
    /// Accesses that found the tile's load in flight (a late prefetch, or
    /// another unit's miss).
    pub misses_late: u64,
    /// Tiles the schedule loaded ahead of their first use.
    pub prefetches: u64,
    /// Prefetched tiles dropped unused to make room (clean: no write).
    pub prefetch_drops: u64,
    /// Use of a tile spilled earlier in the same warp.
    pub misses_capacity: u64,
    /// Tiles spilled raw to make room.
    pub spills: u64,
}

/// The cache's tag state.
#[derive(Clone, Debug)]
pub struct TileCache {
    capacity: usize,
    state: Vec<TileState>,
    /// Resident tiles in replacement order.
    lru: Lru,
    /// Tiles holding a slot: resident or loading.
    held: usize,
    /// Most tiles held at once since the warp began.
    peak: usize,
    /// Prefetched tiles, newest last (rule 7; entries go stale once used).
    prefetched: Vec<u32>,
    /// Per tile: accessed since it arrived in this warp.
    used: Vec<bool>,
    /// Counters since the cache was made.
    pub counters: TileCacheCounters,
}

impl TileCache {
    /// A cache of `capacity` tiles over a grid of `tiles` tiles.
    pub fn new(capacity: usize, tiles: usize) -> TileCache {
        TileCache {
            capacity,
            state: vec![TileState::Untouched; tiles],
            lru: Lru::new(tiles),
            held: 0,
            peak: 0,
            prefetched: Vec::new(),
            used: vec![false; tiles],
            counters: TileCacheCounters::default(),
        }
    }

    /// Capacity (tiles).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Tiles holding a slot now.
    pub fn occupancy(&self) -> usize {
        self.held
    }

    /// Most tiles held at once (resident or loading) since the warp began.
    pub fn peak(&self) -> usize {
        self.peak
    }

    /// Start a new warp: every tile untouched (the cache is empty between
    /// warps: the previous warp released every tile).
    pub fn begin_warp(&mut self) {
        debug_assert_eq!(self.held, 0, "tiles still held at a warp boundary");
        self.state.fill(TileState::Untouched);
        self.lru.clear();
        self.prefetched.clear();
        self.used.fill(false);
        self.peak = 0;
    }

    /// State of tile `t`.
    #[inline]
    pub fn state(&self, t: u32) -> TileState {
        self.state[t as usize]
    }

    /// [`TileCache::access`] when tile `t` is resident (a hit, counted if
    /// `counted`): true. Otherwise false, and nothing changes.
    #[inline]
    pub fn hit(&mut self, t: u32, now: Cycle, counted: bool) -> bool {
        let ti = t as usize;
        if self.state[ti] != TileState::Resident {
            return false;
        }
        self.used[ti] = true;
        self.lru.touch(t, now.get());
        if counted {
            self.counters.accesses += 1;
            self.counters.hits += 1;
        }
        true
    }

    /// Look tile `t` up at time `now` (rule 2). `counted` is false for a
    /// retry of an access already counted. On a miss that needs room, the
    /// spilled tile is returned for the caller to write out (rule 4);
    /// `pinned` tiles are never spilled.
    #[inline]
    pub fn access(&mut self, t: u32, now: Cycle, counted: bool, pinned: &[u32]) -> (Lookup, Option<u32>) {
        let ti = t as usize;
        let st = self.state[ti];
        let lookup = match st {
            TileState::Resident => {
                self.used[ti] = true;
                self.lru.touch(t, now.get());
                Lookup::Hit
            }
            TileState::Loading => {
                if counted {
                    self.counters.accesses += 1;
                    self.counters.misses_late += 1;
                }
                Lookup::Wait
            }
            TileState::Untouched | TileState::Spilled => {
                let mut spilled = None;
                if self.held >= self.capacity && !self.drop_unused(pinned) {
                    match self.victim(pinned) {
                        Some(v) => {
                            self.spill(v);
                            spilled = Some(v);
                        }
                        None => return (Lookup::Full, None),
                    }
                }
                self.held += 1;
                self.peak = self.peak.max(self.held);
                self.state[ti] = TileState::Loading;
                if counted {
                    self.counters.accesses += 1;
                    if st == TileState::Untouched {
                        self.counters.misses_compulsory += 1;
                        self.counters.misses_demand += 1;
                    } else {
                        self.counters.misses_capacity += 1;
                    }
                }
                let l = if st == TileState::Untouched { Lookup::Compulsory } else { Lookup::Capacity };
                return (l, spilled);
            }
            TileState::Released => panic!("tile {t} used after its release in this warp"),
        };
        if counted && lookup == Lookup::Hit {
            self.counters.accesses += 1;
            self.counters.hits += 1;
        }
        (lookup, None)
    }

    /// Rule 6: take a free slot for untouched tile `t` and mark its load in
    /// flight; false (nothing changes) if `t` is not untouched or no slot
    /// is free.
    #[inline]
    pub fn prefetch(&mut self, t: u32) -> bool {
        let ti = t as usize;
        if self.state[ti] != TileState::Untouched || self.held + self.capacity / 8 >= self.capacity {
            return false;
        }
        self.prefetched.push(t);
        self.used[ti] = false;
        self.held += 1;
        self.peak = self.peak.max(self.held);
        self.state[ti] = TileState::Loading;
        self.counters.prefetches += 1;
        self.counters.misses_compulsory += 1;
        true
    }

    /// A load of tile `t` has arrived.
    #[inline]
    pub fn loaded(&mut self, t: u32, now: Cycle) {
        debug_assert_eq!(self.state[t as usize], TileState::Loading);
        self.state[t as usize] = TileState::Resident;
        self.lru.insert(t, now.get());
    }

    /// Release tile `t` (rule 5): it must be resident.
    pub fn release(&mut self, t: u32) {
        debug_assert_eq!(self.state[t as usize], TileState::Resident);
        self.remove_resident(t);
        self.state[t as usize] = TileState::Released;
    }

    fn remove_resident(&mut self, t: u32) {
        if self.lru.contains(t) {
            self.lru.remove(t);
        }
        self.held -= 1;
    }

    /// The unpinned resident tile least recently used (ties: lowest number).
    fn victim(&mut self, pinned: &[u32]) -> Option<u32> {
        self.lru.victim(|t| !pinned.contains(&t))
    }

    /// Rule 7: drop the newest prefetched tile not used yet (resident,
    /// unpinned); false if there is none. Entries found used or no longer
    /// resident leave the list as they are met; a pinned one stays and the
    /// search goes on to older ones, past which a load still in flight
    /// stays listed too (it may arrive unused and be dropped later).
    fn drop_unused(&mut self, pinned: &[u32]) -> bool {
        let mut k = self.prefetched.len();
        let mut passed_pinned = false;
        while k > 0 {
            k -= 1;
            let t = self.prefetched[k];
            let ti = t as usize;
            if passed_pinned && self.state[ti] == TileState::Loading {
                continue;
            }
            if self.state[ti] != TileState::Resident || self.used[ti] {
                self.prefetched.remove(k);
                continue;
            }
            if pinned.contains(&t) {
                passed_pinned = true;
                continue;
            }
            self.prefetched.remove(k);
            self.remove_resident(t);
            self.state[ti] = TileState::Untouched;
            self.counters.prefetch_drops += 1;
            return true;
        }
        false
    }

    fn spill(&mut self, t: u32) {
        self.remove_resident(t);
        self.state[t as usize] = TileState::Spilled;
        self.counters.spills += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prefetch_takes_a_free_slot_never_spills_and_turns_the_first_access_into_a_hit_or_a_late_miss() {
        let mut c = TileCache::new(2, 4);
        assert!(c.prefetch(0) && c.prefetch(1));
        assert!(!c.prefetch(2), "full: a prefetch waits, it does not spill");
        assert!(!c.prefetch(0), "already in flight");
        assert_eq!(c.access(0, Cycle(1), true, &[]), (Lookup::Wait, None), "late");
        c.loaded(0, Cycle(2));
        c.loaded(1, Cycle(2));
        assert_eq!(c.access(0, Cycle(3), true, &[]).0, Lookup::Hit);
        // A demand miss drops the unused prefetched tile 1 (clean: no write,
        // untouched again) rather than spill the used tile 0.
        assert_eq!(c.access(3, Cycle(4), true, &[]), (Lookup::Compulsory, None));
        assert_eq!((c.state(1), c.state(0)), (TileState::Untouched, TileState::Resident));
        c.loaded(3, Cycle(5));
        // With no unused prefetch left, a miss spills by LRU.
        assert_eq!(c.access(2, Cycle(6), true, &[]), (Lookup::Compulsory, Some(0)));
        let k = &c.counters;
        assert_eq!((k.accesses, k.hits, k.misses_late, k.misses_demand), (4, 1, 1, 2));
        assert_eq!((k.prefetches, k.prefetch_drops, k.misses_compulsory, k.spills), (2, 1, 4, 1));
        assert_eq!(c.peak(), 2);
    }

    #[test]
    fn a_miss_drops_an_older_unused_prefetch_when_the_newest_is_pinned() {
        let mut c = TileCache::new(3, 5);
        assert!(c.prefetch(0) && c.prefetch(1) && c.prefetch(2));
        for t in 0..3 {
            c.loaded(t, Cycle(1));
        }
        // Tile 2 (the newest prefetch) is pinned by the access in progress:
        // the miss drops tile 1, the newest unpinned one, and spills nothing.
        assert_eq!(c.access(3, Cycle(2), true, &[2]), (Lookup::Compulsory, None));
        assert_eq!(
            (c.state(0), c.state(1), c.state(2)),
            (TileState::Resident, TileState::Untouched, TileState::Resident)
        );
        c.loaded(3, Cycle(3));
        // Tiles 2 and 0 still unused and pinned: with no unused prefetch
        // left to drop, the miss spills the least recently used unpinned tile.
        assert_eq!(c.access(4, Cycle(4), true, &[0, 2]), (Lookup::Compulsory, Some(3)));
        let k = &c.counters;
        assert_eq!((k.prefetch_drops, k.spills), (1, 1));
    }

    #[test]
    fn a_prefetch_still_loading_below_a_pinned_one_can_be_dropped_once_it_arrives() {
        let mut c = TileCache::new(3, 5);
        assert!(c.prefetch(0) && c.prefetch(1) && c.prefetch(2));
        c.loaded(2, Cycle(1));
        // Tile 2 pinned, tiles 0 and 1 still loading: nothing to drop or spill.
        assert_eq!(c.access(3, Cycle(2), true, &[2]), (Lookup::Full, None));
        // Tile 1 arrives unused: the retry drops it rather than spill.
        c.loaded(1, Cycle(3));
        assert_eq!(c.access(3, Cycle(4), false, &[2]), (Lookup::Compulsory, None));
        assert_eq!(c.state(1), TileState::Untouched);
        let k = &c.counters;
        assert_eq!((k.prefetch_drops, k.spills), (1, 0));
    }

    #[test]
    fn compulsory_then_hits_then_capacity_after_a_spill() {
        let mut c = TileCache::new(2, 4);
        assert_eq!(c.access(0, Cycle(0), true, &[]), (Lookup::Compulsory, None));
        assert_eq!(c.access(0, Cycle(1), true, &[]), (Lookup::Wait, None));
        c.loaded(0, Cycle(1));
        assert_eq!(c.access(0, Cycle(2), true, &[]).0, Lookup::Hit);
        assert_eq!(c.access(1, Cycle(3), true, &[]).0, Lookup::Compulsory);
        c.loaded(1, Cycle(3));
        // Full: tile 0 is least recently used and is spilled for tile 2.
        assert_eq!(c.access(2, Cycle(4), true, &[]), (Lookup::Compulsory, Some(0)));
        c.loaded(2, Cycle(5));
        assert_eq!(c.access(0, Cycle(6), true, &[1, 2]), (Lookup::Full, None));
        assert_eq!(c.access(0, Cycle(7), true, &[]), (Lookup::Capacity, Some(1)));
        let k = &c.counters;
        assert_eq!((k.accesses, k.hits, k.misses_compulsory, k.misses_capacity, k.spills), (6, 1, 3, 1, 2));
        assert_eq!((k.misses_demand, k.misses_late, k.prefetches), (3, 1, 0));
        c.loaded(0, Cycle(8));
        c.release(0);
        c.release(2);
        assert_eq!(c.occupancy(), 0);
    }
}
