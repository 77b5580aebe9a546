//! The A-buffer packer's control (`units::packer`, [`PackerStage`])
//! against its neighbours: the hole fill's visit count set by the test,
//! the memory port's write queue, and a destination cache whose loads
//! arrive when the test says.
//!
//! Doc rules checked: tiles leave strictly in release order, each once the
//! hole fill has made the visits the order gives it (rule 1), in the cycle
//! it has and not before; a tile occupies the packer (busy) for
//! (`tile_size` / `supersample`)² cycles, its write-back queued when the
//! release starts; a release waits on `fifo_full` while 8 or more writes
//! are queued and on `tile` until the tile is resident, the packer's
//! look-up never counted (rule 2); waiting for the hole fill is idle, or
//! busy finishing the previous tile (rule 3).

use crate::common::{TickLog, activity, config, stall};
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::hw_reference::abuffer_params;
use postwarp_rtl::mem::{Access, Client, Dram, DramConfig, MemPort, Req, Tag};
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::packer::{PackerPorts, PackerStage, WRITE_QUEUE_LIMIT};
use postwarp_rtl::units::tile_cache::TileState;
use postwarp_rtl::units::{StallReason, Tick, UnitState};

/// 8x4 samples, one per pixel, 4-sample tiles: 2 tiles of 16 pixels.
const W: u32 = 8;
const H: u32 = 4;
const TILE: u32 = 4;
const PACK_CYCLES: u64 = 16;
const RELEASES: [(u64, u32); 2] = [(4, 0), (8, 1)];

struct Bench {
    frame: DestFrame,
    cache: DestCache,
    port: MemPort,
}

impl Bench {
    /// Warp `warp`; with `resident`, both tiles on chip.
    fn new(warp: usize, resident: bool) -> Bench {
        let mut frame = DestFrame::new(W, H);
        for x in 0..W {
            let i = frame.index(x, 1);
            frame.real.set(i, true);
            frame.samples[i].colour = [0.5, 0.25, x as f32 / 8.0];
            frame.samples[i].inv_z = 0.2;
        }
        let cache = DestCache::new(2 * (TILE * TILE) as u64 * CACHE_BYTES_PER_SAMPLE, TILE, W, H);
        let mut b = Bench { frame, cache, port: MemPort::default() };
        b.cache.begin_warp(0);
        if warp > 0 {
            for t in 0..2 {
                b.make_resident(t);
                b.cache.release(t, 100);
            }
            b.cache.begin_warp(warp);
        }
        if resident {
            for t in 0..2 {
                b.make_resident(t);
            }
        }
        b
    }

    fn make_resident(&mut self, t: u32) {
        let _ = self.cache.want(Cycle(0), t, true, &[t], &mut self.frame, &mut self.port);
        if self.cache.state(t) == TileState::Loading {
            self.cache.arrived(Cycle(0), t, true, &mut self.frame);
        }
        assert_eq!(self.cache.state(t), TileState::Resident);
    }

    fn tick(&mut self, p: &mut PackerStage<'_>, now: Cycle, fill_visits: u64) -> Tick {
        let Bench { frame, cache, port } = self;
        p.tick(now, &mut PackerPorts { fill_visits, frame, cache, port })
    }
}

fn packer(now: Cycle) -> PackerStage<'static> {
    PackerStage::new(&RELEASES, abuffer_params(&config()), 1, now, activity(now))
}

#[test]
fn a_tile_leaves_in_the_cycle_the_fill_has_made_its_visits_and_occupies_the_packer_for_its_pixels() {
    let mut b = Bench::new(0, true);
    let mut p = packer(Cycle(0));
    let mut log = TickLog::new(Cycle(0));
    for c in 1..=3u64 {
        assert_eq!(log.note(Cycle(c), b.tick(&mut p, Cycle(c), c)).state, UnitState::Idle, "waiting is idle");
        assert_eq!((b.port.writes_waiting(), b.cache.state(0)), (0, TileState::Resident), "cycle {c}");
    }
    // The hole fill's 4th visit is seen at N.
    let n = Cycle(4);
    let t = log.note(n, b.tick(&mut p, n, 4));
    assert_eq!((t.state, t.moved), (UnitState::Busy, true));
    assert_eq!((b.port.writes_waiting(), b.cache.state(0)), (1, TileState::Released), "queued as the release starts");
    assert_eq!(p.next_event(n), Some(n + PACK_CYCLES));
    // Tile 1 is due (8 visits) but the packer is busy with tile 0's pixels.
    for c in [n + 1, n + (PACK_CYCLES - 1)] {
        let t = log.note(c, b.tick(&mut p, c, 8));
        assert_eq!((t.state, t.moved), (UnitState::Busy, false), "{c}: packing");
        assert_eq!((b.port.writes_waiting(), b.cache.state(1)), (1, TileState::Resident));
    }
    let t = log.note(n + PACK_CYCLES, b.tick(&mut p, n + PACK_CYCLES, 8));
    assert_eq!((t.state, t.moved, b.port.writes_waiting()), (UnitState::Busy, true, 2));
    assert_eq!(b.cache.state(1), TileState::Released);
    let end = n + 2 * PACK_CYCLES;
    assert!(!p.is_done(end - 1) && p.is_done(end));
    assert_eq!(log.note(end, b.tick(&mut p, end, 8)).state, UnitState::Idle);
    assert_eq!(p.counts().0, 2);
    log.check(end + 5, p.close(end + 5));
    // The write-backs carry the tiles' packed sizes, as the cache keeps them.
    let packed = b.cache.packed_bytes().to_vec();
    assert!(packed.iter().all(|&v| v > 0));
    let mut dram: Dram<Tag> =
        Dram::new(DramConfig { peak_bytes_per_cycle: 1 << 16, latency_cycles: 0, burst_bytes: 1, max_outstanding: 8 });
    for c in 0..4 {
        dram.tick(Cycle(c));
        while dram.completed(Cycle(c)).is_some() {}
        b.port.issue(&mut dram, Cycle(c));
    }
    let d = dram.counters();
    assert_eq!(d.client_bytes_written[Client::TileWriteBack.index()], packed.iter().sum::<u64>());
    assert_eq!(d.requests, 2);
}

#[test]
fn eight_queued_writes_stall_a_release_on_fifo_full_until_one_issues() {
    let mut b = Bench::new(0, true);
    for _ in 0..WRITE_QUEUE_LIMIT {
        b.port.write(Req { client: Client::TileWriteBack, access: Access::Write, addr: 0, bytes: 64, tag: Tag::Write });
    }
    let mut dram: Dram<Tag> =
        Dram::new(DramConfig { peak_bytes_per_cycle: 64, latency_cycles: 0, burst_bytes: 32, max_outstanding: 8 });
    let mut p = packer(Cycle(0));
    let mut log = TickLog::new(Cycle(0));
    let n = Cycle(6);
    for c in 0..=n.get() {
        let now = Cycle(c);
        dram.tick(now);
        while dram.completed(now).is_some() {}
        // Phase 2: the memory port issues from cycle N on.
        if now >= n {
            assert!(b.port.issue(&mut dram, now));
        }
        let t = log.note(now, b.tick(&mut p, now, 100));
        if now < n {
            assert_eq!(t.state, stall(StallReason::FifoFull), "{now}: 8 writes queued");
            assert_eq!(b.cache.state(0), TileState::Resident);
        } else {
            assert_eq!(t.state, UnitState::Busy, "7 writes queued: the release starts");
            assert_eq!((b.port.writes_waiting(), b.cache.state(0)), (WRITE_QUEUE_LIMIT, TileState::Released));
        }
    }
    log.check(n + 1, p.close(n + 1));
}

#[test]
fn a_tile_not_resident_stalls_the_releases_in_order_on_tile_and_the_look_up_is_not_counted() {
    let mut b = Bench::new(1, false);
    b.make_resident(1);
    let mut p = packer(Cycle(0));
    let mut log = TickLog::new(Cycle(0));
    let (k0, q0) = (b.cache.tags().counters.clone(), b.port.queued());
    let n = Cycle(12);
    for c in [1u64, 2, 7, 11] {
        let t = log.note(Cycle(c), b.tick(&mut p, Cycle(c), 100));
        assert_eq!(t.state, stall(StallReason::Tile), "cycle {c}: tile 0 loading");
        assert_eq!(b.port.queued(), q0 + 1, "cycle {c}: its load, queued once");
        assert_eq!(b.cache.state(1), TileState::Resident, "cycle {c}: tile 1, due and resident, waits its turn");
    }
    assert_eq!(b.cache.state(0), TileState::Loading);
    b.cache.arrived(n, 0, true, &mut b.frame);
    assert_eq!(log.note(n, b.tick(&mut p, n, 100)).state, UnitState::Busy);
    assert_eq!((b.cache.state(0), b.cache.state(1)), (TileState::Released, TileState::Resident));
    assert_eq!(b.cache.tags().counters, k0, "the packer's look-ups are never counted");
    log.check(n + 3, p.close(n + 3));
}

#[test]
fn with_lanes_a_tile_occupies_the_packer_for_its_pixels_divided_by_the_lanes_rounded_up() {
    for lanes in [2u32, 3, 8] {
        let mut b = Bench::new(0, true);
        let mut p = PackerStage::new(&RELEASES, abuffer_params(&config()), lanes, Cycle(0), activity(Cycle(0)));
        let n = Cycle(4);
        assert!(b.tick(&mut p, n, 8).moved);
        let busy = PACK_CYCLES.div_ceil(lanes as u64);
        assert_eq!(p.next_event(n), Some(n + busy), "{lanes} lanes");
        // Tile 1 is due at once: it leaves at N + busy, not a cycle before.
        assert!(!b.tick(&mut p, n + (busy - 1), 8).moved);
        assert_eq!(b.cache.state(1), TileState::Resident);
        assert!(b.tick(&mut p, n + busy, 8).moved);
        assert_eq!(b.cache.state(1), TileState::Released, "{lanes} lanes");
    }
}
