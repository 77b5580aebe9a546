//! The hole fill's control (`units::hole_fill`, [`HoleFillStage`], rule 7)
//! against its neighbours: the tile manager's retired bits and a
//! destination cache whose loads arrive when the test says.
//!
//! Doc rules checked: the cursor walks the pass's lines in order, up to
//! `hole_fill_per_cycle` samples a cycle, every visit costing a slot; it
//! stops at a sample whose tile is not retired (stall `upstream`) or not
//! resident (stall `tile`, the cache starting its load), or at a hole
//! whose tap tile is not resident (stall `tile`), but not for a tap tile
//! already released; the look-up of a tile is counted once when the
//! cursor enters it, a retry is not counted again.
//!
//! The frame: 8x4 samples (12x4 for the tap test) in 4-sample tiles, a
//! real background in columns 0 and 1, holes elsewhere; the derived
//! epipole at infinity along +x, so the pass visits column by column from
//! x = 0, each top to bottom, and a hole's taps are in the column before.

use crate::common::{TickLog, activity, stall};
use glam::DVec3;
use postwarp_rtl::Epipole;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::mem::MemPort;
use postwarp_rtl::traversal::Major;
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::hole_fill::{HoleFillParams, HoleFillPorts, HoleFillStage, HoleFillUnit};
use postwarp_rtl::units::tile_cache::TileState;
use postwarp_rtl::units::tile_manager::TileManager;
use postwarp_rtl::units::{StallReason, Tick, UnitState};

const H: u32 = 4;
const TILE: u32 = 4;
const TILE_BYTES: u64 = (TILE * TILE) as u64 * CACHE_BYTES_PER_SAMPLE;
const BACKGROUND: [f32; 3] = [0.25, 0.5, 0.75];

struct Bench {
    frame: DestFrame,
    cache: DestCache,
    port: MemPort,
    tiles: TileManager,
}

impl Bench {
    /// A `w x 4` frame, a cache of `slots` tiles in warp `warp` (every
    /// tile written back as 100 bytes in warp 0 when `warp` > 0), and the
    /// tile manager's retirement lines `retire` (one line in the schedule).
    fn new(w: u32, slots: u64, warp: usize, retire: &[Option<u32>]) -> Bench {
        let mut frame = DestFrame::new(w, H);
        for y in 0..H {
            for x in 0..2 {
                let i = frame.index(x, y);
                frame.real.set(i, true);
                frame.samples[i].colour = BACKGROUND;
            }
        }
        let mut b = Bench {
            frame,
            cache: DestCache::new(slots * TILE_BYTES, TILE, w, H),
            port: MemPort::default(),
            tiles: TileManager::new(1, retire),
        };
        b.cache.begin_warp(0);
        if warp > 0 {
            for t in 0..w / TILE {
                b.make_resident(Cycle(0), t);
                b.cache.release(t, 100);
            }
            b.cache.begin_warp(warp);
        }
        b
    }

    /// Bring tile `t` on chip before the test (as the compositor's look-up
    /// would).
    fn make_resident(&mut self, now: Cycle, t: u32) {
        let _ = self.cache.want(now, t, true, &[t], &mut self.frame, &mut self.port);
        if self.cache.state(t) == TileState::Loading {
            self.cache.arrived(now, t, true, &mut self.frame);
        }
        assert_eq!(self.cache.state(t), TileState::Resident);
    }

    fn tick(&mut self, s: &mut HoleFillStage, now: Cycle) -> Tick {
        let Bench { frame, cache, port, tiles } = self;
        s.tick(now, &mut HoleFillPorts { frame, cache, port, tiles })
    }

    fn accesses(&self) -> u64 {
        self.cache.tags().counters.accesses
    }

    /// Hole-fill distance and colour of `(x, y)`.
    fn fill(&self, x: u32, y: u32) -> (u8, [f32; 3]) {
        let i = self.frame.index(x, y);
        (self.frame.samples[i].fill_distance, self.frame.samples[i].fill_colour)
    }
}

fn stage(w: u32, lanes: u32) -> HoleFillStage {
    let p = HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 };
    let unit = HoleFillUnit::new(w, H, &Epipole { h: DVec3::new(1.0, 0.0, 0.0) }, p);
    assert!(unit.lines().iter().enumerate().all(|(k, l)| l.major == Major::Column && l.line == k as u32));
    HoleFillStage::new(unit, lanes, activity(Cycle(0)))
}

#[test]
fn a_tile_retired_in_cycle_n_minus_1_is_visited_at_n_and_not_before() {
    // Tile 0 retired from the start; tile 1 once the schedule's line 0
    // completes.
    let mut b = Bench::new(8, 2, 0, &[None, Some(0)]);
    b.make_resident(Cycle(0), 0);
    b.make_resident(Cycle(0), 1);
    let mut s = stage(8, 1);
    let mut log = TickLog::new(Cycle(0));
    let a0 = b.accesses();
    for c in 1..=16 {
        assert_eq!(log.note(Cycle(c), b.tick(&mut s, Cycle(c))).state, UnitState::Busy, "cycle {c}");
    }
    assert_eq!(s.visits(), 16, "tile 0: one sample a cycle");
    assert_eq!(b.accesses() - a0, 1, "one look-up counted on entering tile 0");
    assert_eq!(b.fill(3, 2), (2, BACKGROUND), "holes filled from the background, distance 1 per column");
    let n = Cycle(25);
    for c in [17, 18, 24] {
        let t = log.note(Cycle(c), b.tick(&mut s, Cycle(c)));
        assert_eq!(t.state, stall(StallReason::Upstream), "cycle {c}: tile 1 not retired");
        assert_eq!(s.visits(), 16);
    }
    // Phase 7 of cycle N - 1, after the hole fill: the tile retires.
    assert!(b.tiles.tick(1) && b.tiles.is_retired(1));
    let t = log.note(n, b.tick(&mut s, n));
    assert_eq!((t.state, s.visits()), (UnitState::Busy, 17), "tile 1's first sample at N");
    assert_eq!(b.fill(4, 0), (3, BACKGROUND));
    log.check(Cycle(40), s.close(Cycle(40)));
}

#[test]
fn a_tile_not_resident_stalls_it_on_tile_until_its_load_arrives_counted_once() {
    let mut b = Bench::new(8, 2, 1, &[None, None]);
    let mut s = stage(8, 1);
    let mut log = TickLog::new(Cycle(0));
    let (a0, q0) = (b.accesses(), b.port.queued());
    let n = Cycle(20);
    for c in [1u64, 2, 5, 19] {
        let t = log.note(Cycle(c), b.tick(&mut s, Cycle(c)));
        assert_eq!(t.state, stall(StallReason::Tile), "cycle {c}: tile 0 loading");
        assert_eq!(s.visits(), 0);
        assert_eq!(b.port.queued(), q0 + 1, "cycle {c}: one load queued by the first look-up");
        assert_eq!(b.accesses(), a0 + 1, "cycle {c}: the look-up counted once");
    }
    // Phase 1 of cycle N: the load arrives (planes 6-8 reset).
    b.cache.arrived(n, 0, true, &mut b.frame);
    let t = log.note(n, b.tick(&mut s, n));
    assert_eq!((t.state, s.visits(), b.accesses()), (UnitState::Busy, 1, a0 + 1));
    log.check(Cycle(21), s.close(Cycle(21)));
}

#[test]
fn a_hole_waits_on_tile_for_a_tap_tile_that_is_not_resident() {
    // 12x4: tiles 0, 1, 2; two slots.
    let mut b = Bench::new(12, 2, 0, &[None, None, None]);
    b.make_resident(Cycle(0), 0);
    let mut s = stage(12, 1);
    for c in 1..=16 {
        b.tick(&mut s, Cycle(c));
    }
    assert_eq!(s.visits(), 16);
    // Other units use tiles 1 and 2 in cycle 16: tile 0, least recently
    // used (a tie at cycle 16, lower number), is spilled.
    b.make_resident(Cycle(16), 1);
    b.make_resident(Cycle(16), 2);
    assert_eq!(b.cache.state(0), TileState::Spilled);
    let a0 = b.accesses();
    // (4, 0) is a hole whose taps (3, 0) and (3, 1) are in tile 0.
    let n = Cycle(30);
    for c in [17u64, 18, 29] {
        let t = b.tick(&mut s, Cycle(c));
        assert_eq!(t.state, stall(StallReason::Tile), "cycle {c}: a tap tile is loading");
        assert_eq!(s.visits(), 16);
    }
    assert_eq!(b.cache.state(0), TileState::Loading, "the tap tile's reload was started");
    assert_eq!(b.accesses() - a0, 2, "entering tile 1, then tile 0's capacity miss; retries not counted");
    b.cache.arrived(n, 0, false, &mut b.frame);
    assert_eq!(b.tick(&mut s, n).state, UnitState::Busy);
    assert_eq!(s.visits(), 17);
    assert_eq!(b.fill(4, 0), (3, BACKGROUND), "filled from the reloaded taps");
}

#[test]
fn a_released_tap_tile_is_not_waited_for() {
    let mut b = Bench::new(8, 2, 0, &[None, None]);
    b.make_resident(Cycle(0), 0);
    b.make_resident(Cycle(0), 1);
    let mut s = stage(8, 1);
    for c in 1..=16 {
        b.tick(&mut s, Cycle(c));
    }
    b.cache.release(0, 64);
    let a0 = b.accesses();
    for c in 17..=20 {
        assert_eq!(b.tick(&mut s, Cycle(c)).state, UnitState::Busy, "cycle {c}");
    }
    assert_eq!(s.visits(), 20);
    assert_eq!(b.accesses() - a0, 1, "only tile 1 on entry: the released tap tile is not looked up");
    assert_eq!(b.fill(4, 3), (3, BACKGROUND));
}

#[test]
fn lanes_bound_each_cycle_and_every_visit_costs_a_slot() {
    let mut b = Bench::new(8, 2, 0, &[None, None]);
    b.make_resident(Cycle(0), 0);
    b.make_resident(Cycle(0), 1);
    let mut s = stage(8, 3);
    let mut log = TickLog::new(Cycle(0));
    for c in 1..=11u64 {
        assert!(!s.is_done());
        assert_eq!(log.note(Cycle(c), b.tick(&mut s, Cycle(c))).state, UnitState::Busy);
        assert_eq!(s.visits(), (3 * c).min(32), "cycle {c}: 3 visits a cycle, surfaces and holes alike");
    }
    assert!(s.is_done());
    assert_eq!(log.note(Cycle(12), b.tick(&mut s, Cycle(12))).state, UnitState::Idle);
    let k = s.unit().counters();
    assert_eq!((k.visited, k.filled, k.unreached), (32, 24, 0));
    log.check(Cycle(20), s.close(Cycle(20)));
}

/// A hole whose taps lie in one other tile looks that tile up once (rule
/// 7, `docs/stats.md`: a tile holding a hole's tap is one access), not
/// once per tap position as the model once did.
#[test]
fn a_hole_counts_one_access_per_tap_tile() {
    let mut b = Bench::new(8, 2, 0, &[None, None]);
    b.make_resident(Cycle(0), 0);
    b.make_resident(Cycle(0), 1);
    let mut s = stage(8, 1);
    for c in 1..=16 {
        b.tick(&mut s, Cycle(c));
    }
    let a0 = b.accesses();
    // Column 4: four holes, their taps all in column 3 (tile 0).
    for c in 17..=20 {
        assert_eq!(b.tick(&mut s, Cycle(c)).state, UnitState::Busy);
    }
    assert_eq!(b.accesses() - a0, 1 + 4, "tile 1 on entry, then tile 0 once per hole");
}
