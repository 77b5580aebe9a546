//! Destination cache controller: what happens when the compositor, the
//! hole fill or the packer asks for a destination tile.
//!
//! Job: answer "is tile `t` on chip?" for the units that read and write
//! the derived frame; on a miss take a slot in the tag store
//! ([`TileCache`]), spill a victim raw if the cache is full, and start the
//! tile's load; deliver arriving loads; remember each tile's packed size
//! as the packer last wrote it back.
//!
//! Ports: in, look-ups from the compositor, the hole fill and the packer
//! (`want`), load completions from the DRAM (`arrived`), releases from the
//! packer (`release`); out, load and spill requests to the memory port.
//!
//! Throughput: any number of look-ups per cycle (the model does not limit
//! the tag store's ports).
//!
//! Rules (tile cache rules 2–5, `units::tile_cache`):
//! 1. A compulsory miss in a frame's first warp clears the tile on chip: it
//!    is resident at once, no read. In a later warp it loads the tile's
//!    packed bytes as last written back (a tile never written back costs
//!    nothing and is resident at once); the cache-only planes 6–8 are reset
//!    as it arrives.
//! 2. A capacity miss reloads the raw tile (`tile_size² · 16 B`), planes
//!    unchanged.
//! 3. A spill writes the victim raw (`tile_size² · 16 B`) through the write
//!    queue.
//! 4. Loads on a miss queue as demand requests (the memory port's highest
//!    priority).
//! 5. The schedule's prefetch (`units::tile_prefetch`) starts a tile's
//!    load as rule 1 does, into a free slot only, and queues it with the
//!    prefetch requests (below demand loads and write-backs).
//!
//! 6. Addresses (`mem::layout`): packed loads and write-backs of tile `t`
//!    use slot `t` of `dest_tiles`; a spill writes and the reload after a
//!    capacity miss reads slot `t` of `dest_spill` ([`DestCache::place`]).
//!
//! 7. Reservation ([`DestCache::reserve`]): the tiles of the compositor's
//!    oldest waiting stamp (at most 4) are spilled by no one else's miss,
//!    on top of the tiles each look-up pins. Units look up their tiles
//!    side by side, each pinning only its own: without a reservation, two
//!    of them in a small cache could spill each other's tiles for ever.
//!    With it the oldest stamp always gets its tiles (the cache holds at
//!    least 8), so the compositor drains and every unit finishes.
//!
//! Not modelled: tag look-up latency, bank conflicts.

use super::tile_cache::{Lookup, TileCache, TileState};
use crate::clock::Cycle;
use crate::config::CACHE_BYTES_PER_SAMPLE;
use crate::dest_frame::DestFrame;
use crate::mem::{Access, Client, MemPort, Region, Req, Tag};

/// The destination cache: tags, the tile grid and the packed size of every
/// tile in memory.
pub struct DestCache {
    tags: TileCache,
    /// Packed bytes of each tile as last written back (0: never written).
    packed_bytes: Vec<u64>,
    tile_size: u32,
    /// Tiles per row and column.
    tiles: (u32, u32),
    /// Per derived column: its tile column.
    tile_x: Vec<u32>,
    /// Per derived row: the number of its tile row's first tile.
    tile_y: Vec<u32>,
    warp: usize,
    /// Tiles loaded in the current warp (tiles).
    loads: u64,
    /// The packed tiles in DRAM (`mem::layout`).
    packed: Region,
    /// The spill area in DRAM.
    spill: Region,
    /// Rule 7: the reserved tiles (count in `n_reserved`).
    reserved: [u32; 4],
    n_reserved: usize,
    /// Scratch: a miss's pins and the reserved tiles.
    pins: Vec<u32>,
}

impl DestCache {
    /// A cache of `capacity_bytes` over a `width x height`-sample derived
    /// frame of `tile_size`-sample tiles.
    pub fn new(capacity_bytes: u64, tile_size: u32, width: u32, height: u32) -> DestCache {
        let tiles = (width.div_ceil(tile_size), height.div_ceil(tile_size));
        let n = (tiles.0 * tiles.1) as usize;
        let cap = (capacity_bytes / (tile_size as u64 * tile_size as u64 * CACHE_BYTES_PER_SAMPLE)) as usize;
        DestCache {
            tags: TileCache::new(cap, n),
            packed_bytes: vec![0; n],
            tile_size,
            tiles,
            tile_x: (0..width).map(|x| x / tile_size).collect(),
            tile_y: (0..height).map(|y| y / tile_size * tiles.0).collect(),
            warp: 0,
            loads: 0,
            packed: Region::EMPTY,
            spill: Region::EMPTY,
            reserved: [0; 4],
            n_reserved: 0,
            pins: Vec::new(),
        }
    }

    /// Rule 7: reserve `tiles` (at most 4) against other units' spills,
    /// replacing the reservation before; an empty slice clears it.
    #[inline]
    pub fn reserve(&mut self, tiles: &[u32]) {
        self.n_reserved = tiles.len();
        self.reserved[..tiles.len()].copy_from_slice(tiles);
    }

    /// The reserved tiles (rule 7).
    pub fn reserved(&self) -> &[u32] {
        &self.reserved[..self.n_reserved]
    }

    /// Put the frame's packed tiles at `packed` and its spill area at
    /// `spill` of the memory map (both at address 0 until placed).
    pub fn place(&mut self, packed: Region, spill: Region) {
        self.packed = packed;
        self.spill = spill;
    }

    /// DRAM address of tile `t` in A-buffer format (bytes; rule 6).
    #[inline]
    pub fn tile_addr(&self, t: u32) -> u64 {
        self.packed.slot(t)
    }

    /// DRAM address of tile `t`'s raw spill slot (bytes; rule 6).
    #[inline]
    pub fn spill_addr(&self, t: u32) -> u64 {
        self.spill.slot(t)
    }

    /// Start warp number `warp` of the frame (the cache is empty).
    pub fn begin_warp(&mut self, warp: usize) {
        self.warp = warp;
        self.loads = 0;
        self.n_reserved = 0;
        self.tags.begin_warp();
    }

    /// The tag store (counters, occupancy).
    pub fn tags(&self) -> &TileCache {
        &self.tags
    }

    /// Tiles per row and column.
    pub fn tiles(&self) -> (u32, u32) {
        self.tiles
    }

    /// Tile side (samples).
    pub fn tile_size(&self) -> u32 {
        self.tile_size
    }

    /// Tiles loaded in the current warp.
    pub fn loads(&self) -> u64 {
        self.loads
    }

    /// Packed bytes of every tile as last written back, in tile order.
    pub fn packed_bytes(&self) -> &[u64] {
        &self.packed_bytes
    }

    /// The tile holding derived sample `(x, y)`.
    #[inline(always)]
    pub fn tile_of(&self, x: u32, y: u32) -> u32 {
        self.tile_y[y as usize] + self.tile_x[x as usize]
    }

    /// The tile column of derived column `x`.
    #[inline(always)]
    pub fn tile_col(&self, x: u32) -> u32 {
        self.tile_x[x as usize]
    }

    /// The number of the first tile of derived row `y`'s tile row.
    #[inline(always)]
    pub fn tile_row_base(&self, y: u32) -> u32 {
        self.tile_y[y as usize]
    }

    /// State of tile `t` in this warp.
    #[inline]
    pub fn state(&self, t: u32) -> TileState {
        self.tags.state(t)
    }

    fn raw_tile_bytes(&self) -> u64 {
        self.tile_size as u64 * self.tile_size as u64 * CACHE_BYTES_PER_SAMPLE
    }

    /// A look-up of tile `t` at `now`: true if it is resident. `counted` is
    /// false for a retry already counted; `pinned` tiles are not spilled.
    /// A miss starts the load (rules 1–4).
    #[inline]
    pub fn want(
        &mut self,
        now: Cycle,
        t: u32,
        counted: bool,
        pinned: &[u32],
        f: &mut DestFrame,
        port: &mut MemPort,
    ) -> bool {
        self.tags.hit(t, now, counted) || self.miss(now, t, counted, pinned, f, port)
    }

    #[inline(never)]
    fn miss(
        &mut self,
        now: Cycle,
        t: u32,
        counted: bool,
        pinned: &[u32],
        f: &mut DestFrame,
        port: &mut MemPort,
    ) -> bool {
        let (lookup, spilled) = if self.n_reserved == 0 {
            self.tags.access(t, now, counted, pinned)
        } else {
            self.pins.clear();
            self.pins.extend_from_slice(pinned);
            self.pins.extend_from_slice(&self.reserved[..self.n_reserved]);
            self.tags.access(t, now, counted, &self.pins)
        };
        if let Some(v) = spilled {
            let (addr, bytes) = (self.spill_addr(v), self.raw_tile_bytes());
            port.write(Req { client: Client::TileWriteBack, access: Access::Write, addr, bytes, tag: Tag::Write });
        }
        match lookup {
            Lookup::Hit => true,
            Lookup::Wait | Lookup::Full => false,
            Lookup::Compulsory => {
                self.start_fresh_load(now, t, f, port, true);
                false
            }
            Lookup::Capacity => {
                self.loads += 1;
                let bytes = self.raw_tile_bytes();
                port.demand(Req {
                    client: Client::TileFill,
                    access: Access::Read,
                    addr: self.spill_addr(t),
                    bytes,
                    tag: Tag::Tile { tile: t, fresh: false },
                });
                false
            }
        }
    }

    /// Rule 5: the schedule's prefetch of untouched tile `t`, queued with
    /// the prefetch requests; false if it is not untouched or no slot is
    /// free (nothing changes).
    pub fn prefetch(&mut self, now: Cycle, t: u32, f: &mut DestFrame, port: &mut MemPort) -> bool {
        if !self.tags.prefetch(t) {
            return false;
        }
        self.start_fresh_load(now, t, f, port, false);
        true
    }

    /// Rule 1: the load of a tile's first use in this warp, on `demand` (the
    /// demand queue) or prefetched (the prefetch queue).
    fn start_fresh_load(&mut self, now: Cycle, t: u32, f: &mut DestFrame, port: &mut MemPort, demand: bool) {
        self.loads += 1;
        if self.warp == 0 {
            // First warp: the tile is empty, cleared on chip.
            self.arrived(now, t, true, f);
            return;
        }
        let bytes = self.packed_bytes[t as usize];
        let req = Req {
            client: Client::TileFill,
            access: Access::Read,
            addr: self.tile_addr(t),
            bytes,
            tag: Tag::Tile { tile: t, fresh: true },
        };
        if demand {
            port.demand(req);
        } else {
            port.prefetch(req);
        }
        if bytes == 0 {
            self.arrived(now, t, true, f);
        }
    }

    /// Tile `t`'s load arrived at `now`; a compulsory (`fresh`) load resets
    /// the cache-only planes of its samples.
    pub fn arrived(&mut self, now: Cycle, t: u32, fresh: bool, f: &mut DestFrame) {
        self.tags.loaded(t, now);
        if fresh {
            let ts = self.tile_size;
            let (tx, ty) = (t % self.tiles.0, t / self.tiles.0);
            let (x0, x1) = (tx * ts, ((tx + 1) * ts).min(f.width));
            for y in ty * ts..((ty + 1) * ts).min(f.height) {
                f.begin_warp_run(f.index(x0, y)..f.index(x0, y) + (x1 - x0) as usize);
            }
        }
    }

    /// The packer released tile `t`, written back as `bytes` packed bytes.
    pub fn release(&mut self, t: u32, bytes: u64) {
        self.packed_bytes[t as usize] = bytes;
        self.tags.release(t);
    }
}
