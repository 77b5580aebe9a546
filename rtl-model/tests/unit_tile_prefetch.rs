//! The tile prefetch (`units::tile_prefetch`) against a destination cache:
//! a tile is loaded in the cycle its front comes within the distance of
//! its first line and not a cycle before (rules 1–4), one per cycle,
//! never into a full cache, and never twice.

use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::mem::MemPort;
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::tile_cache::TileState;
use postwarp_rtl::units::tile_prefetch::{Fronts, TilePrefetch};

/// 8x8 samples in 4-sample tiles: tiles 0 1 / 2 3, `slots` of them on chip,
/// in a frame's first warp (a load is a clear on chip: resident at once).
fn bench(slots: u64) -> (DestCache, DestFrame, MemPort) {
    let mut c = DestCache::new(slots * 16 * CACHE_BYTES_PER_SAMPLE, 4, 8, 8);
    c.begin_warp(0);
    (c, DestFrame::new(8, 8), MemPort::default())
}

fn fronts(warp_lines: usize, fill_lines: usize) -> Fronts {
    Fronts { warp_lines, fill_lines }
}

#[test]
fn a_tile_is_loaded_when_its_front_is_within_the_distance_not_before_one_per_cycle_never_twice() {
    let (mut c, mut f, mut port) = bench(8);
    let warp_first = [Some(5), Some(2), None, Some(9)];
    let fill_first = [Some(0), Some(3), Some(1), Some(4)];
    let mut p = TilePrefetch::new(&warp_first, &fill_first, 2);
    let mut tick =
        |p: &mut TilePrefetch, now: u64, fr: Fronts, c: &mut DestCache| p.tick(Cycle(now), fr, c, &mut f, &mut port);
    // Due at fronts (0, 0): tile 0 (fill line 0), tile 2 (fill line 1), tile 1
    // (warp line 2); the smaller first line goes first, one per cycle.
    for (now, t) in [(1, 0), (2, 2), (3, 1)] {
        assert!(tick(&mut p, now, fronts(0, 0), &mut c), "cycle {now}");
        assert_eq!(c.state(t), TileState::Resident, "tile {t} at cycle {now}");
    }
    assert_eq!(c.state(3), TileState::Untouched);
    assert!(!tick(&mut p, 4, fronts(0, 0), &mut c), "nothing else is due");
    // Tile 3: warp line 9 (due at warp front 7), fill line 4 (due at 2).
    assert!(!tick(&mut p, 5, fronts(6, 1), &mut c), "N - 1: tile 0's warp entry is skipped, tile 3 not yet due");
    assert_eq!(c.state(3), TileState::Untouched);
    assert!(tick(&mut p, 6, fronts(6, 2), &mut c), "N");
    assert_eq!(c.state(3), TileState::Resident);
    assert!(!tick(&mut p, 7, fronts(100, 100), &mut c), "every entry skipped: each tile loaded once");
    assert_eq!(c.tags().counters.prefetches, 4);
}

#[test]
fn a_prefetch_waits_for_a_free_slot_and_distance_zero_turns_it_off() {
    let (mut c, mut f, mut port) = bench(2);
    let first = [Some(0), Some(1), Some(2), Some(3)];
    let mut p = TilePrefetch::new(&first, &[None; 4], 1);
    assert!(p.tick(Cycle(1), fronts(5, 0), &mut c, &mut f, &mut port));
    assert!(p.tick(Cycle(2), fronts(5, 0), &mut c, &mut f, &mut port));
    assert!(!p.tick(Cycle(3), fronts(5, 0), &mut c, &mut f, &mut port), "full: it waits, no spill");
    assert_eq!((c.state(2), c.tags().counters.spills), (TileState::Untouched, 0));
    c.release(0, 10);
    assert!(p.tick(Cycle(4), fronts(5, 0), &mut c, &mut f, &mut port), "tile 2 once a slot is free");
    assert_eq!(c.state(2), TileState::Resident);
    let (mut c, mut f, mut port) = bench(8);
    let mut off = TilePrefetch::new(&first, &first, 0);
    assert!(!off.tick(Cycle(1), fronts(100, 100), &mut c, &mut f, &mut port));
    assert_eq!(c.tags().counters.prefetches, 0);
}
