//! Reference fetch: reads a reference frame in A-buffer format from DRAM
//! through the software-managed source cache and expands its fragments to
//! super-samples, in the order of the schedule's fetch intervals
//! (`crate::schedule`).
//!
//! Job: stream the samples of each fetch interval to the transform unit;
//! keep the reference blocks they come from on chip.
//!
//! Ports: out, samples `(x, y, 1/Z, slopes)` to the transform unit;
//! memory, block reads ([`crate::mem::Client::ReferenceFetch`]).
//!
//! Throughput: up to `transform_throughput` samples per cycle while their
//! blocks are on chip; at most one block read a cycle (the memory port's).
//!
//! Rules:
//! 1. The reference is stored in blocks of `B x B` pixels,
//!    `B = tile_size / supersample`; a block's bytes are its fragments and
//!    headers in the A-buffer memory format (`units::abuffer`), read from
//!    the start of the block's slot in the reference's region of the
//!    memory map (`mem::layout`).
//! 2. The source cache holds whole blocks, up to `source_cache_bytes` of
//!    their actual (packed) size, replacing the least recently used. It
//!    holds at least the largest block a reference can pack to
//!    ([`crate::config::largest_block_bytes`]; `Engine::new` refuses a
//!    smaller cache), so the block being streamed from fits; an arriving
//!    block may still evict it (LRU), and it is then read again.
//! 3. Prefetch: when the fetch unit starts an interval it queues the reads
//!    of every block of that interval and of the next one that is neither
//!    on chip nor on its way ("software-managed": the schedule is known).
//! 4. A sample is streamed only when its block is on chip; samples with no
//!    surface have no fragment and cost no cycle.
//!
//! 5. Control ([`FetchStage`]): it streams the schedule's intervals in
//!    order, up to `transform_throughput` samples per cycle. It is *busy* in
//!    a cycle it pushed a sample, else *stalled* on `dram` (the next
//!    sample's block is not on chip) or `fifo_full` (the transform pipeline
//!    refused the sample), else *idle*. `source_cache.wait_cycles` counts
//!    every cycle in which it met an absent block, busy or not, including
//!    the cycles the engine skips while it waits.
//!
//! Not modelled: the expander's internal buffering (a fragment expands to
//! its covered samples with no delay), compression of the stream.

use super::transform::{InFlightSample, TransformStage};
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::clock::Cycle;
use crate::hw_reference::HwReference;
use crate::lru::Lru;
use crate::mem::{Access, Client, MemPort, Region, Req, Tag};
use crate::schedule::FetchInterval;
use crate::traversal::Major;

/// State of one reference block in the source cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockState {
    /// Not on chip.
    Absent,
    /// Read queued or in flight.
    Requested,
    /// On chip.
    Resident,
}

/// Event counts (units: counts).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SourceCacheCounters {
    /// Block reads (misses, including prefetches).
    pub block_reads: u64,
    /// Blocks evicted to make room.
    pub evictions: u64,
    /// Cycles the fetch unit waited for a block, cycles the engine
    /// skipped while it waited included.
    pub wait_cycles: u64,
}

/// The source cache's tags over a reference's block grid.
#[derive(Clone, Debug)]
pub struct SourceCache {
    /// Block side (pixels).
    pub block_pixels: u32,
    /// Super-samples per pixel per axis.
    pub ss: u32,
    /// Blocks per row and column.
    pub blocks: (u32, u32),
    capacity: u64,
    used: u64,
    state: Vec<BlockState>,
    bytes: Vec<u64>,
    /// Resident blocks in replacement order.
    lru: Lru,
    /// Per sample column: its block column (`x / side`).
    col_block: Vec<u32>,
    /// Per sample row: the number of its block row's first block.
    row_block: Vec<u32>,
    /// Counters.
    pub counters: SourceCacheCounters,
    /// The warp this cache serves (its number in the frame's warp order),
    /// carried by its read requests (`Tag::Block`).
    pub warp: u32,
    /// Where the reference's blocks are in DRAM (`mem::layout`; empty, at
    /// address 0, until [`SourceCache::place`]).
    region: Region,
}

impl SourceCache {
    /// A cache of `capacity` bytes over a reference of `w x h` samples in
    /// blocks of `block_pixels` pixels whose packed sizes are
    /// `bytes(block_x, block_y)`.
    pub fn new(capacity: u64, w: u32, h: u32, ss: u32, block_pixels: u32, bytes: impl Fn(u32, u32) -> u64) -> Self {
        let side = block_pixels * ss;
        let blocks = (w.div_ceil(side), h.div_ceil(side));
        let n = (blocks.0 * blocks.1) as usize;
        let mut b = Vec::with_capacity(n);
        for by in 0..blocks.1 {
            for bx in 0..blocks.0 {
                b.push(bytes(bx, by));
            }
        }
        SourceCache {
            block_pixels,
            ss,
            blocks,
            capacity,
            used: 0,
            state: vec![BlockState::Absent; n],
            bytes: b,
            lru: Lru::new(n),
            col_block: (0..w).map(|x| x / side).collect(),
            row_block: (0..h).map(|y| y / side * blocks.0).collect(),
            counters: SourceCacheCounters::default(),
            warp: 0,
            region: Region::EMPTY,
        }
    }

    /// The block holding sample `(x, y)`.
    #[inline]
    pub fn block_of(&self, x: u32, y: u32) -> u32 {
        self.row_block[y as usize] + self.col_block[x as usize]
    }

    /// Put the reference's blocks at `region` of the memory map.
    pub fn place(&mut self, region: Region) {
        self.region = region;
    }

    /// DRAM address of block `b` (bytes).
    #[inline]
    pub fn addr(&self, b: u32) -> u64 {
        self.region.slot(b)
    }

    /// Packed bytes of block `b`.
    #[inline]
    pub fn bytes(&self, b: u32) -> u64 {
        self.bytes[b as usize]
    }

    /// State of block `b`.
    #[inline]
    pub fn state(&self, b: u32) -> BlockState {
        self.state[b as usize]
    }

    /// Blocks of an interval, in streaming order, without repeats.
    pub fn blocks_of(&self, iv: &FetchInterval, mut f: impl FnMut(u32)) {
        let side = self.block_pixels * self.ss;
        let (a, b) = (iv.lo / side, iv.hi / side);
        let mut each = |k: u32| match iv.major {
            Major::Row => f((iv.line / side) * self.blocks.0 + k),
            Major::Column => f(k * self.blocks.0 + iv.line / side),
        };
        if iv.step > 0 {
            (a..=b).for_each(&mut each);
        } else {
            (a..=b).rev().for_each(&mut each);
        }
    }

    /// Mark block `b` requested (rule 3): the caller queues the read.
    /// Returns false if it is already on chip or on its way.
    #[inline]
    pub fn request(&mut self, b: u32) -> bool {
        if self.state[b as usize] != BlockState::Absent {
            return false;
        }
        self.state[b as usize] = BlockState::Requested;
        self.counters.block_reads += 1;
        true
    }

    /// Block `b` has arrived at `now`: make room (rule 2) and keep it.
    pub fn arrived(&mut self, b: u32, now: Cycle) {
        let now = now.get();
        let need = self.bytes[b as usize];
        debug_assert!(need <= self.capacity, "block {b} of {need} bytes in a cache of {}", self.capacity);
        while self.used + need > self.capacity
            && let Some(v) = self.lru.victim(|_| true)
        {
            self.lru.remove(v);
            self.used -= self.bytes[v as usize];
            self.state[v as usize] = BlockState::Absent;
            self.counters.evictions += 1;
        }
        self.used += need;
        self.state[b as usize] = BlockState::Resident;
        self.lru.insert(b, now);
    }

    /// Read sample data from block `b` at `now`: true if on chip.
    #[inline]
    pub fn touch(&mut self, b: u32, now: Cycle) -> bool {
        if self.state[b as usize] == BlockState::Resident {
            self.lru.touch(b, now.get());
            true
        } else {
            false
        }
    }
}

/// The fetch unit's ports for one cycle.
pub struct FetchPorts<'a> {
    /// The transform pipeline it feeds.
    pub transform: &'a mut TransformStage,
    /// The memory port (block reads).
    pub port: &'a mut MemPort,
}

/// The fetch unit's control for one warp (rule 5).
pub struct FetchStage<'s> {
    plan: &'s [FetchInterval],
    reference: &'s HwReference,
    /// The source cache.
    pub cache: SourceCache,
    lanes: usize,
    /// Interval being streamed, and the position in it.
    interval: usize,
    pos: u32,
    /// Intervals whose blocks are queued (rule 3).
    prefetched: usize,
    /// Since when the fetch unit has met an absent block in every tick.
    waiting_since: Option<Cycle>,
    activity: Activity,
}

impl<'s> FetchStage<'s> {
    /// Stream `plan` from `reference` through `cache`, `lanes` samples per
    /// cycle, accounted by `activity`.
    pub fn new(
        plan: &'s [FetchInterval],
        reference: &'s HwReference,
        cache: SourceCache,
        lanes: u32,
        activity: Activity,
    ) -> Self {
        FetchStage {
            plan,
            reference,
            cache,
            lanes: lanes as usize,
            interval: 0,
            pos: 0,
            prefetched: 0,
            waiting_since: None,
            activity,
        }
    }

    /// The interval being streamed (= intervals fully pushed).
    #[inline]
    pub fn interval(&self) -> usize {
        self.interval
    }

    /// Every interval has been pushed.
    #[inline]
    pub fn is_done(&self) -> bool {
        self.interval >= self.plan.len()
    }

    fn queue_block(cache: &mut SourceCache, port: &mut MemPort, b: u32) {
        if cache.request(b) {
            port.prefetch(Req {
                client: Client::ReferenceFetch,
                access: Access::Read,
                addr: cache.addr(b),
                bytes: cache.bytes(b),
                tag: Tag::Block { block: b, warp: cache.warp },
            });
        }
    }

    /// One cycle (rules 3–5).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut FetchPorts<'_>) -> Tick {
        let r = self.reference;
        let mut pushed = 0;
        let mut stalled = None;
        let mut block_wait = false;
        while self.interval < self.plan.len() {
            while self.prefetched < (self.interval + 2).min(self.plan.len()) {
                let iv = self.plan[self.prefetched];
                let (cache, port) = (&mut self.cache, &mut *io.port);
                let mut list = Vec::new();
                cache.blocks_of(&iv, |b| list.push(b));
                for b in list {
                    Self::queue_block(cache, port, b);
                }
                self.prefetched += 1;
            }
            let iv = self.plan[self.interval];
            if self.pos == iv.len() {
                self.interval += 1;
                self.pos = 0;
                continue;
            }
            if pushed == self.lanes {
                break;
            }
            let (x, y) = iv.at(self.pos);
            let i = r.grid.index(x, y);
            if !r.valid_at(i) {
                self.pos += 1;
                continue;
            }
            let b = self.cache.block_of(x, y);
            if !self.cache.touch(b, now) {
                if self.cache.state(b) == BlockState::Absent {
                    Self::queue_block(&mut self.cache, io.port, b);
                }
                block_wait = true;
                stalled = Some(StallReason::Dram);
                break;
            }
            let s = InFlightSample { grid_index: i as u32, interval: self.interval as u32 };
            if io.transform.accept(now, s).is_err() {
                stalled = Some(StallReason::FifoFull);
                break;
            }
            pushed += 1;
            self.pos += 1;
        }
        // Rule 5: wait cycles run from the first tick that meets an absent
        // block to the first that does not.
        match (block_wait, self.waiting_since) {
            (true, None) => self.waiting_since = Some(now),
            (false, Some(since)) => {
                self.cache.counters.wait_cycles += now - since;
                self.waiting_since = None;
            }
            _ => {}
        }
        let t = match (pushed, stalled) {
            (1.., _) => Tick::BUSY,
            (0, Some(r)) => Tick::stall(r),
            (0, None) => Tick::IDLE,
        };
        self.activity.record(now, t)
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        if let Some(since) = self.waiting_since.take() {
            self.cache.counters.wait_cycles += now - since;
        }
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lru_by_bytes_and_block_walk() {
        // 32x8 samples, ss 2, 4-pixel blocks: 8-sample blocks, 4x1 grid.
        let mut c = SourceCache::new(250, 32, 8, 2, 4, |bx, _| 100 + bx as u64);
        assert_eq!(c.blocks, (4, 1));
        let iv = FetchInterval { major: Major::Row, line: 3, lo: 5, hi: 20, step: -1 };
        let mut seen = vec![];
        c.blocks_of(&iv, |b| seen.push(b));
        assert_eq!(seen, vec![2, 1, 0]);
        assert!(c.request(0) && !c.request(0));
        c.arrived(0, Cycle(1));
        assert!(c.request(1));
        c.arrived(1, Cycle(2));
        assert!(c.touch(0, Cycle(3)));
        assert!(c.request(2));
        c.arrived(2, Cycle(4)); // 100 + 101 + 102 > 250: block 1 (LRU) goes
        assert_eq!((c.state(1), c.state(0), c.counters.evictions), (BlockState::Absent, BlockState::Resident, 1));
    }
}
