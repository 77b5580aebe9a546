//! A-buffer packer unit: releases destination tiles behind the hole fill,
//! packs them to A-buffer format and writes them back (TR98 §10;
//! the format and the pixel packer are in `units::abuffer`).
//!
//! Job: take the tiles in the schedule's release order
//! ([`crate::schedule::release_order`]); when the hole fill has visited
//! enough samples for the next one, pack its pixels (lossy: the planes are
//! rewritten as the memory holds them), queue the write-back of its packed
//! bytes and free its cache slot.
//!
//! Ports: in, the hole fill's visit count; read/write, the tile's planes in
//! the destination cache; out, write-back requests to the memory port's
//! write queue.
//!
//! Throughput: `packer_pixels_per_cycle` pixels per clock (lanes): a tile
//! occupies the packer for ⌈(`tile_size` / `supersample`)² / lanes⌉
//! cycles, during which it is *busy*; its write-back is queued when the
//! release starts, to the tile's slot of the memory map
//! (`DestCache::tile_addr`).
//!
//! Rules:
//! 1. Tiles are released strictly in release order, each only once the
//!    hole fill has made the number of visits the order gives it.
//! 2. A release waits (stall `fifo_full`) while 8 or more writes are
//!    queued, and (stall `tile`) until the tile is resident; the packer's
//!    look-up is never counted as a destination-cache access.
//! 3. Waiting for the hole fill is not a stall: the packer is then *idle*
//!    (or busy finishing the previous tile).
//!
//! Not modelled: the packer's internal pipeline (a pixel's fragments are
//! merged in its one cycle), a write buffer beyond the memory port's queue.

use super::abuffer::{AbufferCounters, AbufferParams, round_trip_dest_pixels};
use super::dest_cache::DestCache;
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::clock::Cycle;
use crate::dest_frame::DestFrame;
use crate::mem::{Access, Client, MemPort, Req, Tag};

/// Writes queued beyond which the packer does not start a release.
pub const WRITE_QUEUE_LIMIT: usize = 8;

/// The packer's ports for one cycle.
pub struct PackerPorts<'a> {
    /// Samples the hole fill has visited so far in this pass.
    pub fill_visits: u64,
    /// The derived frame's planes (the cache contents).
    pub frame: &'a mut DestFrame,
    /// The destination cache.
    pub cache: &'a mut DestCache,
    /// The memory port (write-backs).
    pub port: &'a mut MemPort,
}

/// The packer's control for one warp.
pub struct PackerStage<'s> {
    releases: &'s [(u64, u32)],
    params: AbufferParams,
    /// Pixels packed per cycle.
    lanes: u32,
    next: usize,
    /// The cycle from which the packer is free.
    free_at: Cycle,
    evictions: u64,
    counters: AbufferCounters,
    activity: Activity,
}

impl<'s> PackerStage<'s> {
    /// A packer of `lanes` pixels per cycle releasing `releases` (visits
    /// needed, tile) in order with the A-buffer format `params`, free from
    /// `now`, accounted by `activity`.
    pub fn new(releases: &'s [(u64, u32)], params: AbufferParams, lanes: u32, now: Cycle, activity: Activity) -> Self {
        PackerStage {
            releases,
            params,
            lanes,
            next: 0,
            free_at: now,
            evictions: 0,
            counters: AbufferCounters::default(),
            activity,
        }
    }

    /// Every tile released and the last one packed.
    #[inline]
    pub fn is_done(&self, now: Cycle) -> bool {
        self.next >= self.releases.len() && now >= self.free_at
    }

    /// When the packer becomes free, if later than `now`.
    #[inline]
    pub fn next_event(&self, now: Cycle) -> Option<Cycle> {
        (self.free_at > now).then_some(self.free_at)
    }

    /// One cycle (rules 1–3).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut PackerPorts<'_>) -> Tick {
        let packing = now < self.free_at;
        let t = match self.releases.get(self.next) {
            Some(&(need, t)) if io.fill_visits >= need && !packing => {
                if io.port.writes_waiting() >= WRITE_QUEUE_LIMIT {
                    Tick::stall(StallReason::FifoFull)
                } else if io.cache.want(now, t, false, &[t], io.frame, io.port) {
                    self.release(now, t, io);
                    Tick::BUSY
                } else {
                    Tick::stall(StallReason::Tile)
                }
            }
            _ if packing => Tick { state: super::UnitState::Busy, moved: false },
            _ => Tick::IDLE,
        };
        self.activity.record(now, t)
    }

    fn release(&mut self, now: Cycle, t: u32, io: &mut PackerPorts<'_>) {
        let (tiles_x, ts, ss) = (io.cache.tiles().0, io.cache.tile_size(), self.params.ss);
        let (tx, ty) = (t % tiles_x, t / tiles_x);
        let (px0, py0) = (tx * ts / ss, ty * ts / ss);
        let side = ts / ss;
        let bytes =
            round_trip_dest_pixels(io.frame, px0, py0, px0 + side, py0 + side, &self.params, &mut self.counters);
        let addr = io.cache.tile_addr(t);
        io.port.write(Req { client: Client::TileWriteBack, access: Access::Write, addr, bytes, tag: Tag::Write });
        io.cache.release(t, bytes);
        self.evictions += 1;
        self.next += 1;
        self.free_at = now + u64::from((side * side).div_ceil(self.lanes));
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }

    /// Tiles released in this warp, and the packer's counters.
    pub fn counts(&self) -> (u64, &AbufferCounters) {
        (self.evictions, &self.counters)
    }
}
