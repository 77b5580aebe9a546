//! The fallback pass's control (`units::fallback_fill`, [`FallbackStage`])
//! against a destination cache whose loads arrive when the test says.
//!
//! Doc rules checked: nothing to fill costs nothing (rule 1); runs inside
//! clean tiles are skipped at no cost and every sample of a dirty tile costs
//! a visit slot, `hole_fill_per_cycle` a cycle (rule 2); the cursor stalls on
//! `tile` until its tile is resident and, for an empty sample, until a clean
//! tap tile is (rule 4); a load arriving in cycle N is used at N and not at
//! N − 1; the dirty tile's changed pixels are re-packed one per clock and
//! written back at the new size, the clean tile dropped without a write,
//! a release waiting on `fifo_full` while 8 writes are queued (rule 5).
//!
//! The frame: 8x4 samples, one per pixel, in 4-sample tiles: tile 0
//! (columns 0–3) empty, tile 1 (columns 4–7) a real background, written
//! back by an earlier warp as 100 packed bytes each. The last warp's
//! epipole is at infinity along +x: its forward order runs from column 0,
//! so Mark's pass could not reach tile 0; the fallback runs from column 7
//! to 0, each column in the reverse of the forward order.

use crate::common::{TickLog, stall};
use glam::DVec3;
use postwarp_rtl::Epipole;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::mem::{Access, Client, MemPort, Req, Tag};
use postwarp_rtl::units::abuffer::{AbufferParams, FRAGMENT_BYTES, PIXEL_HEADER_BYTES};
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::fallback_fill::{FallbackPorts, FallbackStage};
use postwarp_rtl::units::hole_fill::HoleFillParams;
use postwarp_rtl::units::tile_cache::TileState;
use postwarp_rtl::units::{StallReason, Tick, UnitState};

const W: u32 = 8;
const H: u32 = 4;
const TILE: u32 = 4;
const TILE_BYTES: u64 = (TILE * TILE) as u64 * CACHE_BYTES_PER_SAMPLE;
const BACKGROUND: [f32; 3] = [0.25, 0.5, 0.75];
const STORED: u64 = 100;

struct Bench {
    frame: DestFrame,
    cache: DestCache,
    port: MemPort,
}

fn ab() -> AbufferParams {
    AbufferParams { ss: 1, abuffer_fragments: 3, slope_tol: 2.0, rel_tol: 0.01 }
}

impl Bench {
    fn new(empty_tile_0: bool) -> Bench {
        let mut frame = DestFrame::new(W, H);
        for y in 0..H {
            for x in 0..W {
                if x >= 4 || !empty_tile_0 {
                    let i = frame.index(x, y);
                    frame.real.set(i, true);
                    frame.samples[i].colour = BACKGROUND;
                    frame.samples[i].inv_z = 0.5;
                }
            }
        }
        let mut cache = DestCache::new(4 * TILE_BYTES, TILE, W, H);
        let mut port = MemPort::default();
        // The last warp wrote both tiles back.
        cache.begin_warp(0);
        for t in 0..2 {
            // First warp: cleared on chip, resident at once.
            let _ = cache.want(Cycle(0), t, true, &[t], &mut frame, &mut port);
            assert_eq!(cache.state(t), TileState::Resident);
            cache.release(t, STORED);
        }
        cache.begin_warp(1);
        Bench { frame, cache, port }
    }

    fn stage(&self, lanes: u32) -> Option<FallbackStage> {
        let p = HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 };
        let e = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
        FallbackStage::new(&self.frame, &e, p, lanes, ab(), &self.cache, Cycle(0), true)
    }

    fn tick(&mut self, s: &mut FallbackStage, now: Cycle) -> Tick {
        let Bench { frame, cache, port } = self;
        s.tick(now, &mut FallbackPorts { frame, cache, port })
    }

    /// Deliver tile `t`'s load at `now` (phase 1 of the cycle).
    fn arrive(&mut self, now: Cycle, t: u32) {
        assert_eq!(self.cache.state(t), TileState::Loading, "tile {t}");
        self.cache.arrived(now, t, true, &mut self.frame);
    }

    fn colour(&self, x: u32, y: u32) -> ([f32; 3], bool) {
        let i = self.frame.index(x, y);
        (self.frame.samples[i].colour, self.frame.hole[i])
    }
}

#[test]
fn a_frame_without_an_empty_sample_costs_nothing() {
    let b = Bench::new(false);
    assert!(b.stage(1).is_none());
}

#[test]
fn loads_arriving_at_n_are_used_at_n_and_not_at_n_minus_1() {
    let mut b = Bench::new(true);
    let mut s = b.stage(1).expect("tile 0 is empty");
    let mut log = TickLog::new(Cycle(0));
    let q0 = b.port.queued();
    // Cycle 1: columns 7..4 (clean tile 1) skipped free; column 3 enters
    // tile 0, whose packed load is queued.
    let t = log.note(Cycle(1), b.tick(&mut s, Cycle(1)));
    assert_eq!(t.state, stall(StallReason::Tile));
    assert_eq!((s.counters().visits, b.port.queued()), (0, q0 + 1));
    let n = Cycle(10);
    for c in [2u64, 9] {
        let t = log.note(Cycle(c), b.tick(&mut s, Cycle(c)));
        assert_eq!(t.state, stall(StallReason::Tile), "cycle {c}: tile 0 loading");
        assert_eq!(s.counters().visits, 0);
    }
    b.arrive(n, 0);
    // (3, y) is empty; its taps (4, y ± 1) lie in clean tile 1: its load
    // is started now, and the cursor waits for it.
    let t = log.note(n, b.tick(&mut s, n));
    assert_eq!((t.state, s.counters().visits), (stall(StallReason::Tile), 0));
    assert_eq!(b.cache.state(1), TileState::Loading);
    let m = Cycle(20);
    let t = log.note(Cycle(19), b.tick(&mut s, Cycle(19)));
    assert_eq!((t.state, s.counters().visits), (stall(StallReason::Tile), 0), "cycle M - 1");
    b.arrive(m, 1);
    let t = log.note(m, b.tick(&mut s, m));
    assert_eq!((t.state, s.counters().visits), (UnitState::Busy, 1), "cycle M: the first sample");
    // The reverse order's first sample of column 3 is its bottom one.
    assert_eq!(b.colour(3, H - 1), (BACKGROUND, true));
    assert!(!b.colour(3, 0).1, "not yet visited");
    for c in 21..=35 {
        log.note(Cycle(c), b.tick(&mut s, Cycle(c)));
    }
    assert_eq!(s.counters().visits, 16, "one sample a cycle over tile 0");
    for x in 0..4 {
        for y in 0..H {
            assert_eq!(b.colour(x, y), (BACKGROUND, true), "({x}, {y})");
        }
    }
    log.check(Cycle(36), s.close(Cycle(36))[0].clone());
}

#[test]
fn the_dirty_tile_is_repacked_pixel_by_pixel_and_the_clean_one_dropped() {
    let mut b = Bench::new(true);
    let mut s = b.stage(16).expect("tile 0 is empty");
    b.tick(&mut s, Cycle(1));
    b.arrive(Cycle(2), 0);
    b.tick(&mut s, Cycle(2));
    b.arrive(Cycle(3), 1);
    // Cycle 3: all 16 samples of tile 0 (16 lanes); the releases follow at 4.
    assert_eq!(b.tick(&mut s, Cycle(3)).state, UnitState::Busy);
    assert_eq!(s.counters().visits, 16);
    // Eight writes already queued: the dirty tile's release waits.
    for _ in 0..8 {
        b.port.write(Req { client: Client::TileWriteBack, access: Access::Write, addr: 0, bytes: 1, tag: Tag::Write });
    }
    let writes = b.port.writes_waiting();
    b.tick(&mut s, Cycle(4));
    assert_eq!(b.cache.state(0), TileState::Resident, "the release waits on the write queue");
    assert_eq!(b.port.writes_waiting(), writes);
    // The queue drains (the loads were delivered by hand).
    b.port = MemPort::default();
    b.tick(&mut s, Cycle(5));
    // Release order: tile 1 (the taps' tile) and tile 0 both passed.
    assert_eq!(b.cache.state(0), TileState::Released);
    assert_eq!(b.cache.state(1), TileState::Released);
    assert_eq!(b.port.writes_waiting(), 1, "one write: the dirty tile; the clean one is dropped");
    // Tile 0: 16 pixels, each one fill fragment now (stored size 100 less
    // the 16 empty pixels' headers, plus 16 one-fragment pixels).
    let want = STORED - 16 * PIXEL_HEADER_BYTES + 16 * (PIXEL_HEADER_BYTES + FRAGMENT_BYTES);
    assert_eq!(b.cache.packed_bytes()[0], want);
    assert_eq!(b.cache.packed_bytes()[1], STORED, "the clean tile keeps its stored size");
    assert_eq!((s.counters().tiles_written, s.counters().pixels_changed), (1, 16));
    // One pixel per clock: busy through cycle 20, done at 21.
    assert!(!s.is_done(Cycle(20)));
    assert_eq!(s.next_event(Cycle(5)), Some(Cycle(21)));
    assert!(s.is_done(Cycle(21)));
    let [_, (pack, _)] = s.close(Cycle(21));
    assert_eq!(pack.busy, 16);
    assert_eq!(pack.stall_by_reason[StallReason::FifoFull.index()], 1);
}

#[test]
fn lanes_bound_the_visits_per_cycle_and_clean_runs_are_free() {
    let mut b = Bench::new(true);
    let mut s = b.stage(3).expect("tile 0 is empty");
    b.tick(&mut s, Cycle(1));
    b.arrive(Cycle(2), 0);
    b.tick(&mut s, Cycle(2));
    b.arrive(Cycle(3), 1);
    for c in 3..=8u64 {
        assert_eq!(b.tick(&mut s, Cycle(c)).state, UnitState::Busy, "cycle {c}");
        assert_eq!(s.counters().visits, (3 * (c - 2)).min(16), "cycle {c}");
    }
    assert_eq!(s.counters().filled, 16);
    assert_eq!(s.changed_pixels().count_ones(), 16);
}
