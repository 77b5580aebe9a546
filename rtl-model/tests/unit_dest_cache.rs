//! The destination cache controller (`units::dest_cache`, [`DestCache`])
//! against a memory port and a DRAM the test drains, as the compositor,
//! the hole fill and the packer use it.
//!
//! Doc rules checked: a compulsory miss in a frame's first warp clears the
//! tile on chip, resident at once with no read (rule 1); in a later warp
//! it loads the tile's packed bytes as last written back, a tile never
//! written back costing nothing, and the cache-only planes 6–8 are reset
//! as it arrives (rule 1); a capacity miss reloads the raw tile with the
//! planes unchanged (rule 2); a spill writes the victim raw through the
//! write queue (rule 3); loads queue as demand requests (rule 4); a load
//! wanted at cycle N makes the tile resident at exactly N + latency +
//! transfer, not a cycle before.

use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
use postwarp_rtl::dest_frame::DestFrame;
use postwarp_rtl::mem::{Client, Dram, DramConfig, MemPort, Tag};
use postwarp_rtl::units::dest_cache::DestCache;
use postwarp_rtl::units::tile_cache::TileState;

/// 8x4 samples in 4-sample tiles: tiles 0 and 1.
const TILE: u32 = 4;
const RAW: u64 = (TILE * TILE) as u64 * CACHE_BYTES_PER_SAMPLE;

/// Issue everything queued into a fresh DRAM; the tags and the bytes read
/// and written per client.
fn drain(port: &mut MemPort) -> (Vec<Tag>, [u64; 4], [u64; 4]) {
    let mut d: Dram<Tag> =
        Dram::new(DramConfig { peak_bytes_per_cycle: 1 << 16, latency_cycles: 0, burst_bytes: 1, max_outstanding: 64 });
    let mut tags = Vec::new();
    for c in 0..64 {
        d.tick(Cycle(c));
        while let Some((t, _)) = d.completed(Cycle(c)) {
            tags.push(t);
        }
        port.issue(&mut d, Cycle(c));
    }
    (tags, d.counters().client_bytes_read, d.counters().client_bytes_written)
}

fn real_frame() -> DestFrame {
    let mut f = DestFrame::new(8, 4);
    for i in 0..f.len() {
        f.real.set(i, i % 3 == 0);
        f.samples[i].colour = [i as f32 / 32.0, 0.5, 0.5];
        f.samples[i].fill_distance = 9;
    }
    f
}

#[test]
fn a_first_warp_miss_clears_the_tile_on_chip_without_a_read() {
    let mut f = real_frame();
    let mut c = DestCache::new(2 * RAW, TILE, 8, 4);
    let mut port = MemPort::default();
    c.begin_warp(0);
    assert!(!c.want(Cycle(3), 1, true, &[1], &mut f, &mut port), "a miss, answered as one");
    assert_eq!(c.state(1), TileState::Resident, "resident at once");
    assert!(port.is_empty(), "no memory read");
    assert_eq!(c.loads(), 1);
    assert!(c.want(Cycle(4), 1, true, &[1], &mut f, &mut port));
    // Planes 6-8 of tile 1 reset as it arrived; tile 0 untouched.
    let (inside, outside) = (f.index(5, 2), f.index(1, 2));
    assert_eq!((f.samples[inside].fill_distance, f.fill_valid[inside]), (0, f.real[inside]));
    assert_eq!(f.samples[outside].fill_distance, 9);
    let k = &c.tags().counters;
    assert_eq!((k.accesses, k.hits, k.misses_compulsory), (2, 1, 1));
}

#[test]
fn a_later_warp_loads_the_packed_bytes_as_demand_and_a_never_written_tile_costs_nothing() {
    let mut f = real_frame();
    let mut c = DestCache::new(2 * RAW, TILE, 8, 4);
    let mut port = MemPort::default();
    c.begin_warp(0);
    let _ = c.want(Cycle(0), 0, true, &[0], &mut f, &mut port);
    c.release(0, 37);
    // Tile 1 is never written back in warp 0 (a test shortcut: the packer
    // releases every tile).
    let _ = c.want(Cycle(0), 1, true, &[1], &mut f, &mut port);
    c.release(1, 0);
    assert_eq!(c.packed_bytes(), [37, 0]);
    c.begin_warp(1);
    assert!(!c.want(Cycle(10), 0, true, &[0], &mut f, &mut port));
    assert_eq!(c.state(0), TileState::Loading);
    assert!(!c.want(Cycle(10), 1, true, &[1], &mut f, &mut port));
    assert_eq!(c.state(1), TileState::Resident, "0 bytes: resident at once");
    let (tags, read, written) = drain(&mut port);
    assert_eq!(tags, [Tag::Tile { tile: 0, fresh: true }], "the 0-byte load never reaches the DRAM");
    assert_eq!((read[Client::TileFill.index()], written.iter().sum::<u64>()), (37, 0));
    // The load arrives: planes 6-8 reset.
    let i = f.index(2, 1);
    f.samples[i].fill_distance = 7;
    c.arrived(Cycle(20), 0, true, &mut f);
    assert_eq!((c.state(0), f.samples[i].fill_distance), (TileState::Resident, 0));
}

#[test]
fn a_spill_writes_the_victim_raw_and_its_capacity_miss_reloads_it_raw_planes_unchanged() {
    let mut f = real_frame();
    // One slot.
    let mut c = DestCache::new(RAW, TILE, 8, 4);
    let mut port = MemPort::default();
    c.begin_warp(0);
    let _ = c.want(Cycle(0), 0, true, &[0], &mut f, &mut port);
    let i = f.index(1, 1);
    f.samples[i].fill_distance = 5;
    f.samples[i].colour = [0.9; 3];
    let _ = c.want(Cycle(1), 1, true, &[1], &mut f, &mut port);
    assert_eq!((c.state(0), c.state(1)), (TileState::Spilled, TileState::Resident));
    assert_eq!(port.writes_waiting(), 1);
    c.release(1, 50);
    assert!(!c.want(Cycle(2), 0, true, &[0], &mut f, &mut port), "a capacity miss");
    assert_eq!(c.state(0), TileState::Loading);
    let (tags, read, written) = drain(&mut port);
    // The demand reload goes before the older spill (rule 4: demand first).
    assert_eq!(tags, [Tag::Tile { tile: 0, fresh: false }, Tag::Write]);
    assert_eq!(read[Client::TileFill.index()], RAW);
    assert_eq!(written[Client::TileWriteBack.index()], RAW);
    c.arrived(Cycle(3), 0, false, &mut f);
    assert_eq!((f.samples[i].fill_distance, f.samples[i].colour), (5, [0.9; 3]), "a raw reload changes no plane");
    let k = &c.tags().counters;
    assert_eq!((k.misses_compulsory, k.misses_capacity, k.spills), (2, 1, 1));
}

#[test]
fn a_load_wanted_at_n_is_resident_at_n_plus_latency_plus_transfer_and_not_a_cycle_before() {
    const LATENCY: u64 = 9;
    const BYTES: u64 = 37;
    let mut f = real_frame();
    let mut c = DestCache::new(2 * RAW, TILE, 8, 4);
    let mut port = MemPort::default();
    c.begin_warp(0);
    let _ = c.want(Cycle(0), 0, true, &[0], &mut f, &mut port);
    c.release(0, BYTES);
    c.begin_warp(1);
    // 8 bytes a cycle: 37 bytes are 5 cycles of bus time.
    let mut d: Dram<Tag> =
        Dram::new(DramConfig { peak_bytes_per_cycle: 8, latency_cycles: LATENCY, burst_bytes: 1, max_outstanding: 8 });
    let n = 5u64;
    let transfer = BYTES.div_ceil(8);
    let mut resident_at = None;
    for t in n..n + LATENCY + transfer + 4 {
        // The engine's order: DRAM tick, completions delivered, then the
        // port issues and the units ask.
        d.tick(Cycle(t));
        while let Some((tag, _)) = d.completed(Cycle(t)) {
            if let Tag::Tile { tile, fresh } = tag {
                c.arrived(Cycle(t), tile, fresh, &mut f);
            }
        }
        port.issue(&mut d, Cycle(t));
        let hit = c.want(Cycle(t), 0, true, &[0], &mut f, &mut port);
        if hit && resident_at.is_none() {
            resident_at = Some(t);
        }
        if t == n {
            assert!(!hit, "a miss at N");
            assert_eq!(c.state(0), TileState::Loading);
            // The port has taken no request yet this cycle: the load goes
            // out in the cycle it was queued.
            port.issue(&mut d, Cycle(t));
        }
    }
    assert_eq!(resident_at, Some(n + LATENCY + transfer), "resident exactly when the load completes");
    assert_eq!(c.loads(), 1, "one load in this warp, the retries while loading not counted");
}
