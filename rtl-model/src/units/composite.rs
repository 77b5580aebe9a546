//! Compositor: read-modify-write of a candidate sample into the destination
//! tile cache (TR98 §8; `docs/warper-reference.md` §4).
//!
//! Job: decide whether a rasterized candidate replaces the stored sample,
//! and write planes 1–5, 9 and the hole-fill planes 6–8.
//!
//! Ports: in, covered sample addresses with the flat candidate from the
//! rasterizer; read/write, the destination tile cache (the tile must be
//! resident: the engine stalls the compositor on a tile miss).
//!
//! Throughput: one rectangle (up to `kernel_limit²` samples, one stamp)
//! per cycle per rasterizer lane; the read-modify-write is pipelined.
//!
//! Rules, per derived sample:
//! 1. A candidate always beats an empty or hole-fill sample.
//! 2. With `tol = slope_tol·max(|∇c|₁, |∇s|₁) + rel_tol·max(1/Zc, 1/Zs)`,
//!    if `|1/Zc − 1/Zs| > tol` the larger 1/Z wins.
//! 3. Within `tol`: from the same reference the stored sample stays; from
//!    another, the candidate wins unless its better-reference mask has the
//!    stored sample's reference bit set.
//! 4. A write stores colour, 1/Z, slopes and source, clears the hole flag
//!    and weight, and sets the hole-fill colour (the candidate's fill
//!    colour: its own or its forward-edge neighbour's), valid, distance 0.
//!
//! 5. Control ([`CompositeStage`]): each cycle it takes up to
//!    `rects_per_cycle` stamps from the stamp FIFO, in order. A stamp
//!    proceeds only when every tile it touches (at most 4, since
//!    `kernel_limit` ≤ `tile_size`) is resident; it looks them all up, each
//!    counted once per stamp however long it waits, and pins them against
//!    spills. A stamp waiting for a tile blocks the stamps behind it
//!    (stall `tile`); a stamp still in the FIFO's transit leaves it stalled
//!    on `upstream`. The better-reference mask is computed (by the
//!    transform unit, on request) only when rule 3 needs it.
//!
//! 6. Miss queue (`composite_miss_queue` stamps; 0 = rule 5's in-order
//!    blocking): a stamp whose tiles are not all resident leaves the FIFO
//!    for the queue while it has room, and the stamps behind it go on. A
//!    stamp that shares a tile with a queued stamp is never composited
//!    before it (it queues behind it, or waits in the FIFO): stamps that
//!    share no tile write disjoint samples, so the order among stamps
//!    that may overlap is the FIFO's and every value is what in-order
//!    compositing gives. Each cycle the queue is served first, oldest
//!    first, then the FIFO, `rects_per_cycle` stamps in all.
//!
//! 7. The oldest waiting stamp (the miss queue's first, else a FIFO head
//!    blocked on a tile) reserves its tiles in the destination cache
//!    (`dest_cache` rule 7), set at the end of each cycle and moved on at
//!    once when the queue's first stamp is drawn: no other look-up spills
//!    them, so it always gets them and the compositor drains, whatever
//!    the hole fill and the packer look up beside it. With no stamp
//!    waiting the reservation is cleared.
//!
//! Not modelled: bank conflicts inside the cache (one stamp per cycle).

use super::dest_cache::DestCache;
use super::raster::Stamped;
use super::tile_manager::TileManager;
use super::transform::TransformUnit;
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::bits;
use crate::clock::Cycle;
use crate::dest_frame::{DestFrame, DestSample};
use crate::fifo::Fifo;
use crate::mem::MemPort;

/// A rasterized candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Derived 1/Z (flat over the rectangle).
    pub inv_z: f32,
    /// Derived slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// Reference number in the frame's warp order.
    pub source: u8,
    /// Colour for the hole-fill plane.
    pub fill_colour: [f32; 3],
}

/// What one composite did (in report order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Written over an empty or hole-fill sample (rule 1).
    Filled,
    /// Won the depth test (rule 2).
    Nearer,
    /// Won the same-surface arbitration (rule 3).
    Better,
    /// Lost.
    Lost,
}

/// Composite candidate `c` into sample `i`; `better()` yields the
/// candidate's better-reference mask, read only by rule 3.
#[inline]
pub fn composite(
    f: &mut DestFrame,
    i: usize,
    c: &Candidate,
    better: impl FnOnce() -> u32,
    slope_tol: f64,
    rel_tol: f64,
) -> Verdict {
    let verdict = if !bits::get(&f.real, i) {
        Verdict::Filled
    } else {
        let d = &f.samples[i];
        let (s, ss) = (d.inv_z, d.slopes);
        let l1 = |v: [f32; 2]| (v[0].abs() + v[1].abs()) as f64;
        let tol = slope_tol * l1(c.slopes).max(l1(ss)) + rel_tol * (c.inv_z.max(s)) as f64;
        let diff = c.inv_z as f64 - s as f64;
        if diff.abs() > tol {
            if diff > 0.0 { Verdict::Nearer } else { Verdict::Lost }
        } else if d.source != c.source && better() & (1 << d.source) == 0 {
            Verdict::Better
        } else {
            Verdict::Lost
        }
    };
    if verdict != Verdict::Lost {
        f.samples[i] = DestSample {
            colour: c.colour,
            inv_z: c.inv_z,
            slopes: c.slopes,
            fill_colour: c.fill_colour,
            fill_weight: 0.0,
            source: c.source,
            fill_distance: 0,
        };
        bits::put(&mut f.hole, i, false);
        bits::put(&mut f.real, i, true);
        bits::put(&mut f.fill_valid, i, true);
    }
    verdict
}

/// The compositor's ports for one cycle.
pub struct CompositePorts<'a> {
    /// The stamp FIFO from the rasterizer.
    pub input: &'a mut Fifo<Stamped>,
    /// The derived frame's planes (the cache contents).
    pub frame: &'a mut DestFrame,
    /// The destination cache.
    pub cache: &'a mut DestCache,
    /// The memory port (loads and spills the cache starts).
    pub port: &'a mut MemPort,
    /// The tile manager (a composited kernel is done).
    pub tiles: &'a mut TileManager,
}

/// The destination tiles a stamp touches (at most 4, rule 5: at most two
/// per axis), row by row, in a fixed array with their count. Built in
/// registers: writing the array element by element and reading it back
/// whole stalled the host's store forwarding on every stamp.
#[inline]
fn stamp_tiles(c: &DestCache, job: &Stamped) -> ([u32; 4], usize) {
    let (tx0, tx1) = (c.tile_col(job.rect.x.0 as u32), c.tile_col(job.rect.x.1 as u32));
    let (ty0, ty1) = (c.tile_row_base(job.rect.y.0 as u32), c.tile_row_base(job.rect.y.1 as u32));
    let row = c.tiles().0;
    debug_assert!(tx1 <= tx0 + 1 && ty1 <= ty0 + row, "a stamp spans at most two tiles per axis");
    let t = ty0 + tx0;
    const NONE: u32 = u32::MAX;
    match (tx1 > tx0, ty1 > ty0) {
        (false, false) => ([t, NONE, NONE, NONE], 1),
        (true, false) => ([t, t + 1, NONE, NONE], 2),
        (false, true) => ([t, t + row, NONE, NONE], 2),
        (true, true) => ([t, t + 1, t + row, t + row + 1], 4),
    }
}

/// Host speed only: ask the host CPU to fetch the planes of the rows of
/// the stamps in `input` from the `from`-th held on (the engine calls it
/// after the rasterizer's tick, with the count held before it, so each
/// stamp is fetched once, as it enters). No value or timing depends on it.
#[inline]
pub fn prefetch_stamps(input: &Fifo<Stamped>, from: usize, frame: &DestFrame) {
    for k in from..input.len() {
        let Some(job) = input.held(k) else { break };
        let x = job.rect.x.0.max(0) as u32;
        let n = (job.rect.x.1 as i64 + 1 - x as i64).max(0) as usize;
        for row in job.rect.y.0.max(0)..job.rect.y.1 + 1 {
            // The row's first sample with its flag words, then the rest
            // of the row's samples (a row of 44-byte samples spans up to
            // three host cache lines).
            let i = frame.index(x, row as u32);
            frame.prefetch(i);
            frame.prefetch_run(i + 1..i + n);
        }
    }
}

/// A stamp waiting in the miss queue for a tile, with its tiles.
struct Waiting {
    job: Stamped,
    tiles: [u32; 4],
    n: usize,
}

impl Waiting {
    /// The stamp's tiles.
    fn tiles(&self) -> &[u32] {
        &self.tiles[..self.n]
    }

    fn shares_a_tile(&self, tiles: &[u32]) -> bool {
        self.tiles().iter().any(|t| tiles.contains(t))
    }
}

/// The compositor's control for one warp (rules 5 and 6).
pub struct CompositeStage<'s> {
    tu: &'s TransformUnit,
    slope_tol: f64,
    rel_tol: f64,
    lanes: usize,
    /// Miss-queue entries (`composite_miss_queue`).
    queue_cap: usize,
    /// The miss queue, oldest first.
    queue: Vec<Waiting>,
    verdicts: [u64; 4],
    /// Stamps that went ahead of an older stamp in the miss queue.
    bypasses: u64,
    activity: Activity,
}

impl<'s> CompositeStage<'s> {
    /// A compositor with the Z tolerances `slope_tol`, `rel_tol`, `lanes`
    /// stamps per cycle and a miss queue of `miss_queue` stamps, for the
    /// warp by `tu`, accounted by `activity`.
    pub fn new(
        tu: &'s TransformUnit,
        slope_tol: f64,
        rel_tol: f64,
        lanes: u32,
        miss_queue: u32,
        activity: Activity,
    ) -> Self {
        CompositeStage {
            tu,
            slope_tol,
            rel_tol,
            lanes: lanes as usize,
            queue_cap: miss_queue as usize,
            queue: Vec::with_capacity(miss_queue as usize),
            verdicts: [0; 4],
            bypasses: 0,
            activity,
        }
    }

    /// No stamp waits in the miss queue.
    #[inline]
    pub fn is_idle(&self) -> bool {
        self.queue.is_empty()
    }

    /// Look up a stamp's tiles (counted once per stamp); true if all are
    /// resident.
    #[inline]
    fn ready(now: Cycle, tiles: &[u32], counted: bool, io: &mut CompositePorts<'_>) -> bool {
        let mut ready = true;
        for &t in tiles {
            ready &= io.cache.want(now, t, counted, tiles, io.frame, io.port);
        }
        ready
    }

    /// Rule 7: reserve the miss queue's first stamp's tiles, or clear the
    /// reservation when none is queued.
    #[inline]
    fn reserve_oldest(&self, cache: &mut DestCache) {
        cache.reserve(self.queue.first().map_or(&[], Waiting::tiles));
    }

    /// Composite one stamp whose tiles are resident.
    #[inline]
    fn draw(&mut self, mut job: Stamped, io: &mut CompositePorts<'_>) {
        let (sx, sy) = job.sample;
        let (src_inv_z, src_slopes) = (job.src_inv_z, job.src_slopes);
        let tu = self.tu;
        let f = &mut *io.frame;
        job.rect.for_each(|x, y| {
            let i = f.index(x, y);
            let better = &mut job.better;
            let v = composite(
                f,
                i,
                &job.cand,
                || *better.get_or_insert_with(|| tu.better_mask(sx as f64, sy as f64, src_inv_z, src_slopes)),
                self.slope_tol,
                self.rel_tol,
            );
            self.verdicts[v as usize] += 1;
        });
        io.tiles.kernel_done(job.line);
    }

    /// One cycle (rules 5 and 6).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut CompositePorts<'_>) -> Tick {
        let mut did = 0;
        let mut waiting_tile = false;
        // Rule 6: queued stamps whose tiles have arrived, oldest first; one
        // that shares a tile with an older queued stamp keeps its place.
        let mut k = 0;
        while k < self.queue.len() && did < self.lanes {
            let tiles = self.queue[k].tiles();
            if self.queue[..k].iter().any(|o| o.shares_a_tile(tiles)) || !Self::ready(now, tiles, false, io) {
                k += 1;
                continue;
            }
            if k > 0 {
                self.bypasses += 1;
            }
            let w = self.queue.remove(k);
            if k == 0 {
                // Rule 7: the next oldest is protected from here on.
                self.reserve_oldest(io.cache);
            }
            self.draw(w.job, io);
            did += 1;
        }
        while did < self.lanes {
            let Some(job) = io.input.peek(now) else { break };
            let (tiles, n) = stamp_tiles(io.cache, job);
            let counted = !job.counted;
            let behind = self.queue.iter().any(|w| w.shares_a_tile(&tiles[..n]));
            let ready = Self::ready(now, &tiles[..n], counted, io);
            if ready && !behind {
                let job = io.input.pop(now).expect("peeked");
                if !self.queue.is_empty() {
                    self.bypasses += 1;
                }
                self.draw(job, io);
                did += 1;
            } else if self.queue.len() < self.queue_cap {
                let mut job = io.input.pop(now).expect("peeked");
                job.counted = true;
                self.queue.push(Waiting { job, tiles, n });
            } else {
                if let Some(j) = io.input.oldest_mut() {
                    j.counted = true;
                }
                if self.queue.is_empty() {
                    io.cache.reserve(&tiles[..n]);
                }
                waiting_tile = true;
                break;
            }
        }
        // Rule 7: the oldest waiting stamp's tiles are reserved (a blocked
        // FIFO head with nothing queued reserved its own above).
        if !(self.queue.is_empty() && waiting_tile) {
            self.reserve_oldest(io.cache);
        }
        waiting_tile |= did == 0 && !self.queue.is_empty();
        let t = if did > 0 {
            Tick::BUSY
        } else if io.input.is_empty() && self.queue.is_empty() {
            Tick::IDLE
        } else if waiting_tile {
            Tick::stall(StallReason::Tile)
        } else {
            Tick::stall(StallReason::Upstream)
        };
        self.activity.record(now, t)
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }

    /// Verdicts in this warp, in [`Verdict`] order (samples).
    pub fn verdicts(&self) -> [u64; 4] {
        self.verdicts
    }

    /// Stamps composited ahead of an older stamp waiting in the miss
    /// queue, in this warp.
    pub fn bypasses(&self) -> u64 {
        self.bypasses
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(inv_z: f32, source: u8, r: f32) -> Candidate {
        Candidate { colour: [r, 0.0, 0.0], inv_z, slopes: [0.0; 2], source, fill_colour: [r, 0.0, 0.0] }
    }

    #[test]
    fn z_test_then_same_surface_arbitration() {
        let mut f = DestFrame::new(1, 1);
        f.hole.set(0, true);
        assert_eq!(composite(&mut f, 0, &cand(0.1, 0, 1.0), || 0, 2.0, 0.01), Verdict::Filled);
        assert!(f.real[0] && !f.hole[0]);
        assert_eq!(composite(&mut f, 0, &cand(0.05, 0, 0.5), || 0, 2.0, 0.01), Verdict::Lost);
        assert_eq!(composite(&mut f, 0, &cand(0.2, 0, 0.7), || 0, 2.0, 0.01), Verdict::Nearer);
        assert_eq!(composite(&mut f, 0, &cand(0.2, 0, 0.9), || 0, 2.0, 0.01), Verdict::Lost, "same source keeps");
        assert_eq!(composite(&mut f, 0, &cand(0.2, 1, 0.9), || 0b1, 2.0, 0.01), Verdict::Lost, "stored ref better");
        assert_eq!(composite(&mut f, 0, &cand(0.2, 1, 0.9), || 0, 2.0, 0.01), Verdict::Better);
        assert_eq!(f.samples[0].colour[0], 0.9);
    }
}
