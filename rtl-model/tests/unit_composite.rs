//! The compositor's control (`units::composite`, [`CompositeStage`])
//! against its neighbours: a stamp FIFO the test fills at chosen cycles, a
//! destination cache whose loads arrive when the test says (the engine's
//! phase 1), the memory port, the frame and the tile manager.
//!
//! Doc rules checked (rule 5): stamps in order, up to `rects_per_cycle` a
//! cycle; a stamp proceeds only when every tile it touches is resident,
//! each looked up once per stamp however long it waits, the tiles pinned
//! against spills; a stamp waiting for a tile blocks the ones behind it
//! (stall `tile`); a stamp still in the FIFO's transit leaves it stalled
//! on `upstream`; a composited kernel is done in the tile manager. Rule 6
//! (the miss queue) and rule 7 (the oldest waiting stamp's tiles reserved
//! against other units' spills).

use crate::common::{TickLog, Warp, activity, config, plane, stall};
use glam::DVec3;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::fifo::Fifo;
use postwarp_rtl::mem::MemPort;
use postwarp_rtl::units::composite::{Candidate, CompositePorts, CompositeStage, Verdict};
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::raster::{Rect, Stamped};
use postwarp_rtl::units::tile_cache::TileState;
use postwarp_rtl::units::tile_manager::TileManager;
use postwarp_rtl::units::{StallReason, Tick, UnitState};

/// 8x8 samples in 4-sample tiles: tiles 0 1 / 2 3.
const N: u32 = 8;
const TILE: u32 = 4;
const TILE_BYTES: u64 = (TILE * TILE) as u64 * CACHE_BYTES_PER_SAMPLE;

fn warp() -> Warp {
    Warp::new(&plane(N, N, 5.0), DVec3::new(0.1, 0.0, 0.0), 0.0, config())
}

/// A stamp of `line` covering columns `x` and rows `y` (inclusive).
fn stamp(line: u32, x: (i32, i32), y: (i32, i32), r: f32) -> Stamped {
    let size = ((x.1 - x.0 + 1) as u32, (y.1 - y.0 + 1) as u32);
    Stamped {
        line,
        rect: Rect { x, y, size, over_limit: false },
        cand: Candidate { colour: [r, 0.5, 0.5], inv_z: 0.2, slopes: [0.0; 2], source: 0, fill_colour: [r, 0.0, 0.0] },
        sample: (3, 3),
        src_inv_z: 0.2,
        src_slopes: [0.0; 2],
        better: None,
        counted: false,
    }
}

/// The compositor's neighbours.
struct Bench {
    input: Fifo<Stamped>,
    frame: DestFrame,
    cache: DestCache,
    port: MemPort,
    tiles: TileManager,
}

impl Bench {
    /// A cache of `tiles` tiles in warp `warp` (tiles written back in
    /// warp 0 as `packed` bytes first, when `warp` > 0).
    fn new(tiles: u64, warp: usize, packed: u64) -> Bench {
        let mut b = Bench {
            input: Fifo::new(4, 1),
            frame: DestFrame::new(N, N),
            cache: DestCache::new(tiles * TILE_BYTES, TILE, N, N),
            port: MemPort::default(),
            tiles: TileManager::new(4, &[Some(0), Some(1), Some(2), Some(3)]),
        };
        b.cache.begin_warp(0);
        if warp > 0 {
            for t in 0..4 {
                b.make_resident(Cycle(0), t);
                b.cache.release(t, packed);
            }
            b.cache.begin_warp(warp);
        }
        b
    }

    /// Bring tile `t` on chip before the test (as an earlier unit's
    /// look-up would): resident from the next cycle.
    fn make_resident(&mut self, now: Cycle, t: u32) {
        let _ = self.cache.want(now, t, true, &[t], &mut self.frame, &mut self.port);
        if self.cache.state(t) == TileState::Loading {
            self.cache.arrived(now, t, true, &mut self.frame);
        }
        assert_eq!(self.cache.state(t), TileState::Resident);
    }

    fn tick(&mut self, c: &mut CompositeStage<'_>, now: Cycle) -> Tick {
        let Bench { input, frame, cache, port, tiles } = self;
        c.tick(now, &mut CompositePorts { input, frame, cache, port, tiles })
    }

    fn written(&self, x: u32, y: u32) -> bool {
        self.frame.real[self.frame.index(x, y)]
    }
}

#[test]
fn a_stamp_pushed_at_p_is_composited_at_p_plus_1_and_not_before() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 0, activity(Cycle(0)));
    let mut b = Bench::new(4, 0, 0);
    b.make_resident(Cycle(0), 0);
    b.tiles.kernel_issued(0);
    let p = Cycle(5);
    b.input.push(p, stamp(0, (1, 2), (1, 2), 0.7)).unwrap();
    let t = b.tick(&mut c, p);
    assert_eq!(t.state, stall(StallReason::Upstream), "the stamp is in the FIFO's transit");
    assert!(!b.written(1, 1), "written at P");
    assert!(!b.tiles.tick(1), "the kernel is in flight");
    let t = b.tick(&mut c, p + 1);
    assert_eq!((t.state, t.moved), (UnitState::Busy, true));
    for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
        assert!(b.written(x, y), "({x}, {y}) not written at P + 1");
        assert_eq!(b.frame.samples[b.frame.index(x, y)].colour, [0.7, 0.5, 0.5]);
    }
    assert!(!b.written(0, 0) && !b.written(3, 1));
    assert_eq!(c.verdicts()[Verdict::Filled as usize], 4);
    assert!(b.tiles.tick(1) && b.tiles.is_retired(0), "the composited kernel is done");
    assert_eq!(b.tick(&mut c, p + 2).state, UnitState::Idle);
}

#[test]
fn a_stamp_waits_on_its_tile_until_the_load_arrives_counted_once_and_blocks_the_next() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 2, 0, activity(Cycle(0)));
    // Warp 1: every tile was written back as 100 bytes in warp 0.
    let mut b = Bench::new(4, 1, 100);
    b.make_resident(Cycle(0), 3);
    let queued = b.port.queued();
    let accesses = b.cache.tags().counters.accesses;
    b.tiles.kernel_issued(0);
    b.tiles.kernel_issued(3);
    b.input.push(Cycle(0), stamp(0, (0, 1), (0, 1), 0.6)).unwrap(); // tile 0
    b.input.push(Cycle(0), stamp(3, (5, 6), (5, 6), 0.8)).unwrap(); // tile 3, resident
    let mut log = TickLog::new(Cycle(0));
    let arrival = Cycle(30);
    for now in [1u64, 2, 3, 10, 29].map(Cycle) {
        let t = log.note(now, b.tick(&mut c, now));
        assert_eq!(t.state, stall(StallReason::Tile), "{now}: tile 0 is loading");
        assert!(!b.written(0, 0) && !b.written(5, 5), "{now}: nothing composited, in order");
        assert_eq!(b.port.queued(), queued + 1, "{now}: one load, started by the first look-up");
        assert_eq!(b.cache.tags().counters.accesses, accesses + 1, "{now}: the look-up counted once");
    }
    assert_eq!(b.cache.state(0), TileState::Loading);
    // Phase 1 of cycle N delivers the load; both stamps go at N (2 lanes).
    b.cache.arrived(arrival, 0, true, &mut b.frame);
    let t = log.note(arrival, b.tick(&mut c, arrival));
    assert_eq!(t.state, UnitState::Busy);
    assert!(b.written(0, 0) && b.written(1, 1) && b.written(5, 5) && b.written(6, 6));
    assert_eq!(b.cache.tags().counters.accesses, accesses + 2, "the retry not counted, tile 3's hit counted");
    assert_eq!(c.verdicts()[Verdict::Filled as usize], 8);
    assert_eq!(log.note(arrival + 1, b.tick(&mut c, arrival + 1)).state, UnitState::Idle);
    log.check(Cycle(40), c.close(Cycle(40)));
}

#[test]
fn the_tiles_of_a_stamp_are_pinned_against_spills_and_it_goes_once_all_are_resident() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 0, activity(Cycle(0)));
    // Two slots; tile 2 was used by the hole fill (phase 4) in this cycle.
    let mut b = Bench::new(2, 0, 0);
    let now = Cycle(5);
    b.make_resident(now, 2);
    // Tiles 0 and 1: tile 0 takes the free slot, tile 1 needs a victim.
    // Tiles 0 and 2 were last used in the same cycle; the lower number
    // would go on a tie, but tile 0 is pinned by the stamp.
    b.tiles.kernel_issued(0);
    b.input.push(Cycle(0), stamp(0, (2, 5), (1, 2), 0.4)).unwrap();
    let t = b.tick(&mut c, now);
    assert_eq!(t.state, stall(StallReason::Tile), "both tiles missed in this cycle");
    assert_eq!(b.cache.state(2), TileState::Spilled, "the unpinned tile is spilled");
    assert_eq!((b.cache.state(0), b.cache.state(1)), (TileState::Resident, TileState::Resident));
    assert_eq!(b.port.writes_waiting(), 1, "the spill's raw write");
    assert!(!b.written(2, 1));
    assert_eq!(b.tick(&mut c, now + 1).state, UnitState::Busy);
    assert!(b.written(2, 1) && b.written(5, 2));
}

#[test]
fn a_stamp_over_four_tiles_looks_each_up_once() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 0, activity(Cycle(0)));
    let mut b = Bench::new(4, 0, 0);
    for t in 0..4 {
        b.make_resident(Cycle(0), t);
    }
    let k = b.cache.tags().counters.clone();
    b.tiles.kernel_issued(0);
    b.input.push(Cycle(0), stamp(0, (2, 5), (3, 4), 0.4)).unwrap();
    assert_eq!(b.tick(&mut c, Cycle(1)).state, UnitState::Busy);
    let k2 = &b.cache.tags().counters;
    assert_eq!((k2.accesses - k.accesses, k2.hits - k.hits), (4, 4));
    assert_eq!(c.verdicts()[Verdict::Filled as usize], 8);
}

/// Rule 6: with a miss queue, a stamp waiting for its tile steps aside and
/// the next stamp, on a resident tile, goes at once; a stamp sharing the
/// waiting stamp's tile never passes it; the queued stamp goes in the cycle
/// its load arrives, not before.
#[test]
fn the_miss_queue_lets_the_compositor_proceed_past_a_missing_tile_but_never_past_a_shared_one() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 2, activity(Cycle(0)));
    let mut b = Bench::new(4, 1, 100);
    b.make_resident(Cycle(0), 3);
    for l in [0, 3, 0] {
        b.tiles.kernel_issued(l);
    }
    b.input.push(Cycle(0), stamp(0, (0, 1), (0, 1), 0.6)).unwrap(); // tile 0, loading
    b.input.push(Cycle(0), stamp(3, (5, 6), (5, 6), 0.8)).unwrap(); // tile 3, resident
    b.input.push(Cycle(0), stamp(0, (1, 2), (1, 2), 0.9)).unwrap(); // tile 0 again: overlaps the first
    let mut log = TickLog::new(Cycle(0));
    // Cycle 1: the first stamp misses and moves to the queue (no lane used).
    let t = log.note(Cycle(1), b.tick(&mut c, Cycle(1)));
    assert_eq!(t.state, UnitState::Busy, "the tile-3 stamp went in the same cycle");
    assert!(b.written(5, 5) && !b.written(0, 0), "past the missing tile");
    assert_eq!(c.bypasses(), 1);
    assert_eq!(b.cache.reserved(), &[0], "rule 7: the queued stamp's tile");
    // Cycle 2: the third stamp shares tile 0: it queues behind the first.
    let t = log.note(Cycle(2), b.tick(&mut c, Cycle(2)));
    assert_eq!(t.state, stall(StallReason::Tile));
    assert!(!b.written(1, 1) && !b.written(2, 2) && !c.is_idle());
    let arrival = Cycle(20);
    for now in [Cycle(3), arrival - 1] {
        assert_eq!(log.note(now, b.tick(&mut c, now)).state, stall(StallReason::Tile), "{now}");
    }
    b.cache.arrived(arrival, 0, true, &mut b.frame);
    assert_eq!(log.note(arrival, b.tick(&mut c, arrival)).state, UnitState::Busy);
    // One lane: the older stamp first; (1, 1) holds its colour until the
    // overlapping one goes a cycle later, in FIFO order.
    assert_eq!(b.frame.samples[b.frame.index(1, 1)].colour, [0.6, 0.5, 0.5]);
    assert_eq!(log.note(arrival + 1, b.tick(&mut c, arrival + 1)).state, UnitState::Busy);
    assert_eq!(b.frame.samples[b.frame.index(2, 2)].colour, [0.9, 0.5, 0.5]);
    assert_eq!(
        b.frame.samples[b.frame.index(1, 1)].colour[0],
        0.6,
        "same reference, within tolerance: the stored stays"
    );
    assert!(c.is_idle());
    assert_eq!(b.cache.reserved(), &[] as &[u32], "no stamp waits");
    assert_eq!(log.note(arrival + 2, b.tick(&mut c, arrival + 2)).state, UnitState::Idle);
    log.check(Cycle(30), c.close(Cycle(30)));
    // Without a queue the same stamps go strictly in order.
    let mut c0 = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 0, activity(Cycle(0)));
    let mut b0 = Bench::new(4, 1, 100);
    b0.make_resident(Cycle(0), 3);
    b0.tiles.kernel_issued(0);
    b0.tiles.kernel_issued(3);
    b0.input.push(Cycle(0), stamp(0, (0, 1), (0, 1), 0.6)).unwrap();
    b0.input.push(Cycle(0), stamp(3, (5, 6), (5, 6), 0.8)).unwrap();
    assert_eq!(b0.tick(&mut c0, Cycle(1)).state, stall(StallReason::Tile));
    assert!(!b0.written(5, 5), "blocked behind the missing tile");
}

/// Rule 7: a stamp blocked on a tile reserves all its tiles at the end of
/// the cycle, so another unit's miss in the next cycle cannot spill the
/// one already resident (in a two-tile cache that miss finds no victim and
/// waits); once the stamp is composited the reservation is gone and the
/// same miss spills. Without it, the hole fill and the compositor could
/// spill each other's tiles for ever in a small cache.
#[test]
fn a_waiting_stamp_reserves_its_tiles_against_other_units_misses_until_it_goes() {
    let w = warp();
    let mut c = CompositeStage::new(&w.tu, w.cfg.slope_tol, w.cfg.rel_tol, 1, 0, activity(Cycle(0)));
    // Warp 1 (loads take time), two slots; tile 1 on chip.
    let mut b = Bench::new(2, 1, 100);
    b.make_resident(Cycle(0), 1);
    b.tiles.kernel_issued(0);
    b.input.push(Cycle(0), stamp(0, (2, 5), (1, 2), 0.4)).unwrap(); // tiles 0 and 1
    assert_eq!(b.cache.reserved(), &[] as &[u32]);
    assert_eq!(b.tick(&mut c, Cycle(1)).state, stall(StallReason::Tile), "tile 0 is loading");
    assert_eq!(b.cache.reserved(), &[0, 1], "reserved at the end of cycle N");
    // Cycle N + 1: another unit (pinning only its own tile) misses on tile 2.
    let writes = b.port.writes_waiting();
    assert!(!b.cache.want(Cycle(2), 2, true, &[2], &mut b.frame, &mut b.port));
    assert_eq!(b.cache.state(1), TileState::Resident, "the reserved tile stays");
    assert_eq!(b.cache.state(2), TileState::Untouched, "no slot: the miss waits");
    assert_eq!(b.port.writes_waiting(), writes, "nothing spilled");
    let arrival = Cycle(20);
    b.cache.arrived(arrival, 0, true, &mut b.frame);
    assert_eq!(b.tick(&mut c, arrival).state, UnitState::Busy);
    assert!(b.written(2, 1) && b.written(5, 2));
    assert_eq!(b.cache.reserved(), &[] as &[u32], "cleared once no stamp waits");
    assert!(!b.cache.want(arrival + 1, 2, true, &[2], &mut b.frame, &mut b.port));
    assert_eq!(b.cache.state(2), TileState::Loading);
    assert_eq!(b.port.writes_waiting(), writes + 1, "now the miss spills a victim");
}
