//! The DRAM memory map of one derived frame: where each byte the warper
//! reads or writes lives (`docs/memory-layout.md`).
//!
//! Job: give every DRAM request its address. The map is computed from the
//! configuration and the frame's geometry alone (the derived frame's and
//! each reference's size in samples), so the same frame always gets the
//! same addresses; nothing is allocated at run time.
//!
//! Regions, in address order from 0, each starting on a
//! [`REGION_ALIGN`]-byte boundary:
//! 1. `reference[j]`, one per reference warp `j` of the frame (warp
//!    order): the reference in A-buffer format, one slot per source block
//!    of `B x B` pixels (`B = tile_size / supersample`, the fetch unit's
//!    block), blocks in row-major order. A slot holds the block's pixel
//!    headers (row-major) followed by their fragments, densely: a block of
//!    `n` bytes occupies the slot's first `n` bytes. Read by the fetch unit
//!    (`Client::ReferenceFetch`); written by the renderer (not modelled).
//! 2. `dest_tiles`: the derived frame in A-buffer format, one slot per
//!    destination tile (`tile_size` samples square, row-major), laid out as
//!    a reference block. Written by the packer and the fallback fill
//!    (`Client::TileWriteBack`, the tile's packed bytes), read back by the
//!    next warp's and the fallback pass's tile loads (`Client::TileFill`,
//!    the bytes last written) and by the display (`Client::Output`): the
//!    display reads the frame in place, there is no separate display
//!    buffer.
//! 3. `dest_spill`: one raw slot per destination tile (`tile_size² · 16 B`,
//!    the cache format). Written by the destination cache's spills
//!    (`Client::TileWriteBack`) and read by the reload after a capacity
//!    miss (`Client::TileFill`).
//!
//! Slot sizes are the worst case of what a unit moves: a packed block or
//! tile of `p` pixels is at most `p · (PIXEL_HEADER_BYTES + f ·
//! FRAGMENT_BYTES)` with `f = min(abuffer_fragments, supersample²)`
//! (raw: `p · supersample² · RAW_SAMPLE_BYTES`), rounded up to whole DRAM
//! bursts. Every slot therefore starts on a burst boundary, and a request
//! at a slot's start, rounded up to bursts by the DRAM
//! ([`super::DramConfig::rounded`]), stays inside its slot.
//!
//! Rules: a request's address is the start of its slot; its size is what
//! the unit moves (unchanged by the map). Regions never overlap.
//!
//! Not modelled: the renderer's and the display's own buffers beyond what
//! the warper touches; a frame-to-frame allocation (every frame's map
//! starts at address 0, so a trace of several frames reuses addresses).

use crate::config::{CACHE_BYTES_PER_SAMPLE, EngineConfig};
use crate::mem::{Access, Client};
use crate::units::abuffer::{FRAGMENT_BYTES, PIXEL_HEADER_BYTES, RAW_SAMPLE_BYTES};

/// Alignment of every region's base (bytes): a 4 KiB page, a multiple of
/// every allowed `dram_burst_bytes` (at most 4096, a power of two).
pub const REGION_ALIGN: u64 = 4096;

/// What a region holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RegionKind {
    /// The reference of warp `j` of the frame, in A-buffer format.
    Reference(u32),
    /// The derived frame's tiles in A-buffer format.
    DestTiles,
    /// The derived frame's tiles spilled raw.
    DestSpill,
}

/// One region of the map: `slots` slots of `slot_bytes` from `base`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// What it holds.
    pub kind: RegionKind,
    /// First byte (bytes; a multiple of [`REGION_ALIGN`]).
    pub base: u64,
    /// Bytes per slot (a multiple of the burst).
    pub slot_bytes: u64,
    /// Slots (source blocks or destination tiles).
    pub slots: u64,
}

impl Region {
    /// A region of no slots at address 0 (a unit not yet placed).
    pub const EMPTY: Region = Region { kind: RegionKind::DestTiles, base: 0, slot_bytes: 0, slots: 0 };

    /// Address of slot `i`'s first byte.
    #[inline]
    pub fn slot(&self, i: u32) -> u64 {
        debug_assert!(u64::from(i) < self.slots || self.slots == 0, "slot {i} of {}", self.slots);
        self.base + u64::from(i) * self.slot_bytes
    }

    /// Bytes the region spans.
    pub fn bytes(&self) -> u64 {
        self.slots * self.slot_bytes
    }

    /// One past the region's last byte.
    pub fn end(&self) -> u64 {
        self.base + self.bytes()
    }

    /// The slot holding byte `addr`, if it is in the region.
    pub fn slot_of(&self, addr: u64) -> Option<u64> {
        (addr >= self.base && addr < self.end()).then(|| (addr - self.base) / self.slot_bytes)
    }

    /// The region's name in `docs/memory-layout.md` (`reference[0]`,
    /// `dest_tiles`, `dest_spill`).
    pub fn name(&self) -> String {
        match self.kind {
            RegionKind::Reference(j) => format!("reference[{j}]"),
            RegionKind::DestTiles => "dest_tiles".into(),
            RegionKind::DestSpill => "dest_spill".into(),
        }
    }

    /// The clients and directions that touch the region (rules above).
    pub fn clients(&self) -> &'static [(Client, Access)] {
        match self.kind {
            RegionKind::Reference(_) => &[(Client::ReferenceFetch, Access::Read)],
            RegionKind::DestTiles => &[
                (Client::TileWriteBack, Access::Write),
                (Client::TileFill, Access::Read),
                (Client::Output, Access::Read),
            ],
            RegionKind::DestSpill => &[(Client::TileWriteBack, Access::Write), (Client::TileFill, Access::Read)],
        }
    }
}

/// The memory map of one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryLayout {
    /// The regions in address order: the references in warp order, then
    /// `dest_tiles`, then `dest_spill`.
    pub regions: Vec<Region>,
}

/// Worst-case bytes of `pixels` pixels in the configuration's memory
/// format (bytes): headers plus `min(abuffer_fragments, supersample²)`
/// fragments each, or raw samples.
pub fn max_packed_bytes(cfg: &EngineConfig, pixels: u64) -> u64 {
    let samples = u64::from(cfg.supersample * cfg.supersample);
    if cfg.abuffer_fragments == 0 {
        return pixels * samples * RAW_SAMPLE_BYTES;
    }
    pixels * (PIXEL_HEADER_BYTES + u64::from(cfg.abuffer_fragments).min(samples) * FRAGMENT_BYTES)
}

impl MemoryLayout {
    /// The map of a frame of `derived` samples (width, height) warped from
    /// references of `references[j]` samples, in warp order, under `cfg`.
    pub fn new(cfg: &EngineConfig, derived: (u32, u32), references: &[(u32, u32)]) -> MemoryLayout {
        let burst = cfg.dram_burst_bytes;
        let round = |b: u64| b.div_ceil(burst) * burst;
        let ts = cfg.tile_size;
        // A reference block and a packed destination tile cover the same
        // pixels: one slot size for both.
        let packed_slot = round(crate::config::largest_block_bytes(cfg));
        let grid = |(w, h): (u32, u32)| u64::from(w.div_ceil(ts)) * u64::from(h.div_ceil(ts));
        let mut regions = Vec::with_capacity(references.len() + 2);
        let mut next = 0;
        let mut push = |kind, slot_bytes, slots| {
            let r = Region { kind, base: next, slot_bytes, slots };
            next = r.end().div_ceil(REGION_ALIGN) * REGION_ALIGN;
            regions.push(r);
        };
        for (j, &size) in references.iter().enumerate() {
            push(RegionKind::Reference(j as u32), packed_slot, grid(size));
        }
        push(RegionKind::DestTiles, packed_slot, grid(derived));
        push(RegionKind::DestSpill, round(u64::from(ts).pow(2) * CACHE_BYTES_PER_SAMPLE), grid(derived));
        MemoryLayout { regions }
    }

    /// The region of reference warp `j`.
    ///
    /// # Panics
    /// If the frame has no warp `j`.
    pub fn reference(&self, j: usize) -> &Region {
        let r = &self.regions[j];
        assert_eq!(r.kind, RegionKind::Reference(j as u32), "no reference warp {j}");
        r
    }

    /// The derived frame's packed tiles.
    pub fn dest_tiles(&self) -> &Region {
        &self.regions[self.regions.len() - 2]
    }

    /// The derived frame's spill area.
    pub fn dest_spill(&self) -> &Region {
        &self.regions[self.regions.len() - 1]
    }

    /// The region holding byte `addr`.
    pub fn region_of(&self, addr: u64) -> Option<&Region> {
        self.regions.iter().find(|r| r.slot_of(addr).is_some())
    }

    /// One past the last byte of the map.
    pub fn end(&self) -> u64 {
        self.regions.last().map_or(0, Region::end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_are_aligned_ordered_and_disjoint() {
        let cfg = EngineConfig::preset("mark1998").unwrap();
        let m = MemoryLayout::new(&cfg, (1280, 960), &[(1400, 1000), (1400, 1000)]);
        assert_eq!(m.regions.len(), 4);
        for w in m.regions.windows(2) {
            assert!(w[0].end() <= w[1].base, "{:?} overlaps {:?}", w[0], w[1]);
        }
        for r in &m.regions {
            assert_eq!(r.base % REGION_ALIGN, 0);
            assert_eq!(r.slot_bytes % cfg.dram_burst_bytes, 0);
        }
        // 8-sample tiles at 2x2: 4x4 pixels of 1 + 3 · 16 bytes = 784, 25 bursts of 32.
        assert_eq!(m.dest_tiles().slot_bytes, 800);
        assert_eq!(m.dest_spill().slot_bytes, 8 * 8 * 16);
        assert_eq!(m.dest_tiles().slots, 160 * 120);
        assert_eq!(m.reference(1).slots, 175 * 125);
        assert_eq!(m.region_of(m.dest_spill().slot(3)).map(|r| r.kind), Some(RegionKind::DestSpill));
        assert_eq!(m.region_of(m.end()), None);
    }

    #[test]
    fn raw_slots_hold_every_sample() {
        let cfg = EngineConfig { abuffer_fragments: 0, ..EngineConfig::preset("mark1998").unwrap() };
        let m = MemoryLayout::new(&cfg, (16, 16), &[]);
        assert_eq!(m.dest_tiles().slot_bytes, m.dest_spill().slot_bytes);
    }
}
