//! The memory map (`rtl-model/src/mem/layout.rs`, `docs/memory-layout.md`)
//! against the requests the engine makes: on frames of the bundled traces,
//! every request starts at a slot of a region its client may touch, moves
//! the size the layout gives for that slot, and the requests together are
//! exactly the bytes the DRAM counters count; regions of different clients
//! never overlap.

use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use postwarp_rtl::mem::layout::REGION_ALIGN;
use postwarp_rtl::mem::{Access, Client, MemoryLayout, RegionKind};
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Frames `frames` of `trace` under `cfg`, recording requests, with the
/// references each warped.
/// `cfg` takes the trace's super-sampling.
fn run(trace: &str, cfg: &mut EngineConfig, frames: &[usize]) -> Vec<(FrameOutput, Vec<HwReference>)> {
    let t = Trace::open(&root().join("traces").join(trace)).unwrap();
    cfg.supersample = t.display.supersample;
    let cfg = cfg.clone();
    let mut engine = Engine::new(cfg.clone()).unwrap();
    engine.record_requests(true);
    frames
        .iter()
        .map(|&k| {
            let refs: Vec<HwReference> = t.derived[k]
                .references
                .iter()
                .map(|&r| HwReference::new(&t.load_reference(r).unwrap().samples, &cfg))
                .collect();
            let out = engine.run_frame(&t.frame_commands(k), &refs.iter().collect::<Vec<_>>());
            (out, refs)
        })
        .collect()
}

/// What a frame's requests did, checked against the layout as they go.
#[derive(Default)]
struct Seen {
    bytes: HashMap<(Client, bool), u64>,
    spill_writes: u64,
    tile_writes: u64,
    reference_reads: u64,
    display_reads: Vec<(u64, u64)>,
}

/// Check every request of `out` against the frame's layout (module doc);
/// `what` names the case in messages.
fn check_frame(out: &FrameOutput, refs: &[HwReference], cfg: &EngineConfig, what: &str) -> Seen {
    let burst = cfg.dram_burst_bytes;
    let round = |b: u64| b.div_ceil(burst) * burst;
    // The layout is a function of the configuration and the geometry.
    let sizes: Vec<_> = refs.iter().map(|r| (r.width, r.height)).collect();
    let layout = MemoryLayout::new(cfg, (out.frame.width, out.frame.height), &sizes);
    assert_eq!(out.layout, layout, "{what}: the engine's map is not the one its geometry gives");
    // Regions: aligned, in order, disjoint.
    for w in layout.regions.windows(2) {
        assert!(w[0].end() <= w[1].base, "{what}: {} overlaps {}", w[0].name(), w[1].name());
    }
    for r in &layout.regions {
        assert_eq!(r.base % REGION_ALIGN, 0, "{what}: {} unaligned", r.name());
        assert_eq!(r.slot_bytes % burst, 0, "{what}: {} slots not whole bursts", r.name());
    }
    let side = cfg.tile_size / cfg.supersample;
    let raw_tile = round(u64::from(cfg.tile_size).pow(2) * 16);
    let mut seen = Seen::default();
    // Per slot of dest_tiles / dest_spill: the bytes last written there.
    let mut tiles: HashMap<u64, u64> = HashMap::new();
    let mut spilled: HashSet<u64> = HashSet::new();
    let mut reloaded = Vec::new();
    let mut by_client: HashMap<Client, Vec<(u64, u64)>> = HashMap::new();
    assert!(!out.requests.is_empty(), "{what}: no request recorded");
    for (i, q) in out.requests.iter().enumerate() {
        let at = format!("{what}: request {i} ({:?} {:?} {} B at {:#x})", q.client, q.access, q.bytes, q.addr);
        let region = layout.region_of(q.addr).unwrap_or_else(|| panic!("{at}: outside every region"));
        assert!(region.clients().contains(&(q.client, q.access)), "{at}: not a client of {}", region.name());
        assert_eq!((q.addr - region.base) % region.slot_bytes, 0, "{at}: not at a slot's start in {}", region.name());
        let slot = region.slot_of(q.addr).unwrap();
        assert!(q.bytes > 0 && q.bytes <= region.slot_bytes, "{at}: larger than its slot ({} B)", region.slot_bytes);
        assert_eq!(q.bytes % burst, 0, "{at}: not whole bursts");
        match (region.kind, q.access) {
            (RegionKind::Reference(j), _) => {
                let r = &refs[j as usize];
                let bx_n = r.width.div_ceil(cfg.tile_size) as u64;
                let (bx, by) = ((slot % bx_n) as u32, (slot / bx_n) as u32);
                let want = r.packed.bytes_in_pixels(bx * side, by * side, (bx + 1) * side, (by + 1) * side);
                assert_eq!(q.bytes, round(want), "{at}: block ({bx}, {by}) of reference {j} holds {want} B");
                seen.reference_reads += 1;
            }
            (RegionKind::DestTiles, Access::Write) => {
                tiles.insert(slot, q.bytes);
                seen.tile_writes += 1;
            }
            (RegionKind::DestTiles, Access::Read) => {
                // A load reads what the packer last wrote there.
                assert_eq!(tiles.get(&slot), Some(&q.bytes), "{at}: tile {slot} was last written at another size");
                if q.client == Client::Output {
                    seen.display_reads.push((slot, q.bytes));
                }
            }
            (RegionKind::DestSpill, Access::Write) => {
                assert_eq!(q.bytes, raw_tile, "{at}: a spill moves a raw tile");
                spilled.insert(slot);
                seen.spill_writes += 1;
            }
            (RegionKind::DestSpill, Access::Read) => {
                assert_eq!(q.bytes, raw_tile, "{at}: a reload moves a raw tile");
                // The spill's write may still wait in the memory port's
                // write queue, below demand reads (on room's small-cache
                // frames 0 and 1, 16 and 7 reloads reach the DRAM first):
                // checked at the end.
                reloaded.push(slot);
            }
        }
        *seen.bytes.entry((q.client, q.access == Access::Write)).or_default() += q.bytes;
        by_client.entry(q.client).or_default().push((q.addr, q.addr + q.bytes));
    }
    for slot in reloaded {
        assert!(spilled.contains(&slot), "{what}: tile {slot} reloaded from the spill area but never spilled");
    }
    // The requests are exactly the bytes the DRAM counted, client by client.
    let d = &out.stats.dram;
    assert_eq!(out.requests.len() as u64, d.requests, "{what}: requests recorded vs counted");
    for c in Client::ALL {
        let got = |w| seen.bytes.get(&(c, w)).copied().unwrap_or(0);
        assert_eq!(got(false), d.client_bytes_read[c.index()], "{what}: {c:?} bytes read");
        assert_eq!(got(true), d.client_bytes_written[c.index()], "{what}: {c:?} bytes written");
    }
    // Counts as the units count them.
    assert_eq!(seen.reference_reads, out.stats.source_cache.block_reads, "{what}: block reads");
    assert_eq!(seen.spill_writes, out.stats.dest_cache.spills, "{what}: spills");
    assert_eq!(
        seen.tile_writes,
        out.stats.tile_evictions.iter().sum::<u64>() + out.stats.fallback_tiles_written,
        "{what}: packed write-backs"
    );
    // The display reads every tile written, once, at its final size, in tile order.
    let mut written: Vec<(u64, u64)> = tiles.into_iter().collect();
    written.sort_unstable();
    assert_eq!(seen.display_reads, written, "{what}: the display's reads are not the frame as written");
    // The reference fetch's bytes lie apart from every other client's.
    let ranges = |c: Client| by_client.get(&c).cloned().unwrap_or_default();
    let refs_ranges = ranges(Client::ReferenceFetch);
    for c in [Client::TileFill, Client::TileWriteBack, Client::Output] {
        for &(a0, a1) in &ranges(c) {
            assert!(
                refs_ranges.iter().all(|&(b0, b1)| a1 <= b0 || b1 <= a0),
                "{what}: {c:?} touches [{a0:#x}, {a1:#x}) inside the references"
            );
        }
    }
    seen
}

#[test]
fn the_requests_of_room_frames_cover_the_layout_exactly() {
    let small = EngineConfig { dest_cache_bytes: 16 * 1024, source_cache_bytes: 8 * 1024, ..EngineConfig::default() };
    for (name, mut cfg) in [("default", EngineConfig::default()), ("small-cache", small)] {
        let mut spills = 0;
        for (k, (out, refs)) in run("room", &mut cfg, &[0, 1]).iter().enumerate() {
            assert!(refs.len() >= 2, "room frame {k}: expected several warps");
            let seen = check_frame(out, refs, &cfg, &format!("room frame {k} {name}"));
            assert!(!seen.display_reads.is_empty());
            spills += seen.spill_writes;
        }
        assert_eq!(spills > 0, name == "small-cache", "{name}: spills exercised where expected");
    }
}

#[test]
fn the_fallback_fill_writes_its_tiles_in_place() {
    let mut cfg = EngineConfig::default();
    let frames = run("motorcycle", &mut cfg, &[0]);
    let (out, refs) = &frames[0];
    assert!(out.stats.fallback_tiles_written > 0, "motorcycle exercises the fallback fill");
    check_frame(out, refs, &cfg, "motorcycle frame 0");
}

#[test]
fn a_raw_frame_buffer_uses_raw_slots() {
    let mut cfg = EngineConfig { abuffer_fragments: 0, ..EngineConfig::default() };
    let frames = run("room", &mut cfg, &[0]);
    let (out, refs) = &frames[0];
    assert_eq!(out.layout.dest_tiles().slot_bytes, out.layout.dest_spill().slot_bytes);
    check_frame(out, refs, &cfg, "room frame 0 raw");
}
