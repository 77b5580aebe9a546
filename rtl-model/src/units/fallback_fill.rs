//! Fallback fill: the hole-fill unit's second mode, one pass after the last
//! reference warp over the samples no epipolar pass reached (knob
//! `fallback_fill`; the golden model's `fallback_fill.rs`, bit for bit).
//!
//! Job: Mark's fill propagates colour from the line *behind* a hole in the
//! forward order, so the strip along an image border that no reference saw
//! (a stereo pair's unseen side) has nothing behind it and stays empty. This
//! pass reads the finished frame back, runs the same datapath
//! ([`HoleFillUnit::new_fallback`]) over the reverse of the last warp's
//! forward order, fills the empty samples from the other side, and writes
//! back the pixels it changed.
//!
//! Ports:
//! - in: the tiles of the derived frame, through the destination cache
//!   (loads of their packed bytes, `Client::TileFill`);
//! - read/write: planes 1 and 5–9 of the samples it fills, planes 6–8 of up
//!   to five taps on the previous line of the pass's order;
//! - out: write-backs of the tiles it changed (`Client::TileWriteBack`).
//!
//! Throughput: `hole_fill_per_cycle` samples per cycle, as in the warps;
//! the write-back re-packs one pixel per clock.
//!
//! Rules:
//! 1. The pass runs only with `fallback_fill` on and only if the frame has
//!    an empty sample (a sample neither real nor hole-filled); otherwise it
//!    costs nothing. The tiles holding an empty sample are *dirty*: the
//!    packer flags them as it writes them back in the last warp (one bit per
//!    tile on chip; the model reads the flags off the frame).
//! 2. The cursor walks the lines of [`crate::traversal::reverse_lines`] in
//!    order. The runs of a line inside clean tiles hold nothing to fill and
//!    are skipped at no cost; every sample of a dirty tile costs a visit
//!    slot, whether it is filled or not.
//! 3. A tile's working planes 6–8 are set when it is first used in the pass
//!    ([`prepare_sample`]): a real or hole-filled sample is a source (valid,
//!    its plane-1 colour, distance 0), an empty one is not. Then the unit
//!    runs rules 2–6 of `units::hole_fill` in its fallback mode.
//! 4. The cursor stops (stall `tile`) until the sample's tile is resident,
//!    and, for an empty sample, every tile holding one of its taps — clean
//!    tiles too, which hold the sources. While it looks one up it pins the
//!    sample's tile and every tap tile looked up before (as the hole fill
//!    does), so a tap's miss never spills another tile the sample needs.
//! 5. Tiles leave in [`crate::schedule::release_order`] of the pass's lines,
//!    once the cursor has passed (visited or skipped) the samples the order
//!    gives them; tiles the pass never touched are passed over. A clean tile
//!    is dropped from the cache without a write. A dirty tile's *changed*
//!    pixels (those holding a sample the pass filled) are re-packed to
//!    A-buffer format, one pixel per clock (unit `abuffer`, busy), and the
//!    tile is written back at its new packed size; its other pixels stay as
//!    they were in memory (the golden model re-packs the same pixels,
//!    `round_trip_dest_where`). A release waits while 8 or more writes are
//!    queued (stall `fifo_full`) and until the tile is resident (`tile`).
//!
//! Accounting: the cursor is the `hole_fill` unit, the re-packing the
//! `abuffer` unit; the other units are idle through the pass.
//!
//! Not modelled: the line sequencer's search for the next dirty run (free);
//! the exact stored size of a changed pixel before the pass: the tile's new
//! size is its old packed size plus, per pixel that held an empty sample,
//! the difference between its packed size after the pass and that of its
//! samples as loaded packed again (the stored size, unless a second packing
//! groups a pixel's samples differently; at one sample per pixel always
//! exact).

use super::abuffer::{
    AbufferCounters, AbufferParams, Packer, RAW_SAMPLE_BYTES, SampleIn, round_trip_dest_pixels, sample_in,
};
use super::dest_cache::DestCache;
use super::hole_fill::{FillOutcome, HoleFillCounters, HoleFillParams, HoleFillUnit};
use super::packer::WRITE_QUEUE_LIMIT;
use super::tile_cache::TileState;
use super::{Activity, Run, StallReason, Tick, UnitCycles, UnitState};
use crate::camera::Epipole;
use crate::clock::Cycle;
use crate::dest_frame::DestFrame;
use crate::mem::{Access, Client, MemPort, Req, Tag};
use crate::schedule::release_order;
use bitvec::vec::BitVec;

/// Rule 3: set sample `i`'s working planes 6–8 for the pass.
pub fn prepare_sample(f: &mut DestFrame, i: usize) {
    let source = f.real[i] || f.hole[i];
    f.fill_valid.set(i, source);
    f.samples[i].fill_colour = if source { f.samples[i].colour } else { [0.0; 3] };
    f.samples[i].fill_distance = 0;
}

/// True if sample `i` is empty (neither a surface nor hole fill).
fn empty(f: &DestFrame, i: usize) -> bool {
    !f.real[i] && !f.hole[i]
}

/// Counters of one pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FallbackCounters {
    /// Samples the cursor visited (those of dirty tiles; samples).
    pub visits: u64,
    /// Empty samples filled (samples).
    pub filled: u64,
    /// Empty samples with no counted tap, left empty (samples).
    pub unreached: u64,
    /// Dirty tiles re-packed and written back (tiles).
    pub tiles_written: u64,
    /// Display pixels re-packed: those holding a filled sample (pixels).
    pub pixels_changed: u64,
}

/// The pass's ports for one cycle.
pub struct FallbackPorts<'a> {
    /// The derived frame's planes (the cache contents).
    pub frame: &'a mut DestFrame,
    /// The destination cache.
    pub cache: &'a mut DestCache,
    /// The memory port (loads, spills, write-backs).
    pub port: &'a mut MemPort,
}

/// The fallback pass's control (rules 1–5).
pub struct FallbackStage {
    unit: HoleFillUnit,
    lanes: u32,
    ab: AbufferParams,
    /// Cursor: line, position in it.
    line: usize,
    pos: u32,
    /// Samples passed, visited or skipped (the release order's count).
    passed: u64,
    /// Rule 1, per tile.
    dirty: Vec<bool>,
    /// Rule 3 done, per tile.
    prepared: Vec<bool>,
    /// Per dirty tile: its packed size less that of its pixels holding an
    /// empty sample at the start (bytes).
    base_bytes: Vec<u64>,
    /// Pixels holding a sample the pass filled.
    changed: BitVec,
    releases: Vec<(u64, u32)>,
    next: usize,
    /// The re-packing is busy until this cycle.
    free_at: Cycle,
    fill_tile: Option<u32>,
    tap_retry: bool,
    counters: FallbackCounters,
    abuffer: AbufferCounters,
    fill_activity: Activity,
    pack_activity: Activity,
}

impl FallbackStage {
    /// The pass over `f` after the last warp, whose derived-image epipole is
    /// `epipole`, with `hole`'s knobs, `lanes` samples per cycle, the
    /// A-buffer format `ab` and `cache`'s tiles; `None` if there is nothing
    /// to fill (rule 1). Both activities start at `now`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        f: &DestFrame,
        epipole: &Epipole,
        hole: HoleFillParams,
        lanes: u32,
        ab: AbufferParams,
        cache: &DestCache,
        now: Cycle,
        record: bool,
    ) -> Option<FallbackStage> {
        let (tw, th) = cache.tiles();
        let mut dirty = vec![false; (tw * th) as usize];
        let mut any = false;
        for i in (0..f.len()).filter(|&i| empty(f, i)) {
            let (x, y) = (i as u32 % f.width, i as u32 / f.width);
            dirty[cache.tile_of(x, y) as usize] = true;
            any = true;
        }
        if !any {
            return None;
        }
        let unit = HoleFillUnit::new_fallback(f.width, f.height, epipole, hole);
        let releases =
            release_order(unit.lines(), (f.width, f.height), cache.tile_size(), &HoleFillUnit::tap_offsets(&hole));
        let n = dirty.len();
        Some(FallbackStage {
            unit,
            lanes,
            ab,
            line: 0,
            pos: 0,
            passed: 0,
            dirty,
            prepared: vec![false; n],
            base_bytes: vec![0; n],
            changed: BitVec::repeat(false, (f.width / ab.ss * (f.height / ab.ss)) as usize),
            releases,
            next: 0,
            free_at: now,
            fill_tile: None,
            tap_retry: false,
            counters: FallbackCounters::default(),
            abuffer: AbufferCounters::default(),
            fill_activity: Activity::starting(now, record),
            pack_activity: Activity::starting(now, record),
        })
    }

    /// The pass in the fixed mode of the hole-fill unit
    /// ([`HoleFillUnit::with_fixed`]).
    pub fn with_fixed(mut self, fixed: Option<(crate::qformat::QFormat, crate::qformat::QFormat)>) -> FallbackStage {
        self.unit = self.unit.with_fixed(fixed);
        self
    }

    /// Fixed mode: values the pass saturated (counts).
    pub fn saturations(&self) -> u64 {
        self.unit.counters().saturations
    }

    /// Every sample passed, every tile released and the last one packed.
    pub fn is_done(&self, now: Cycle) -> bool {
        self.line >= self.unit.lines().len() && self.next >= self.releases.len() && now >= self.free_at
    }

    /// When the re-packing becomes free, if later than `now`.
    pub fn next_event(&self, now: Cycle) -> Option<Cycle> {
        (self.free_at > now).then_some(self.free_at)
    }

    /// The counters so far (the datapath's: filled and unreached).
    pub fn counters(&self) -> FallbackCounters {
        let c: &HoleFillCounters = self.unit.counters();
        FallbackCounters { filled: c.filled, unreached: c.unreached, ..self.counters }
    }

    /// The re-packing's A-buffer counters.
    pub fn abuffer_counters(&self) -> &AbufferCounters {
        &self.abuffer
    }

    /// Display pixels holding a sample the pass filled.
    pub fn changed_pixels(&self) -> &BitVec {
        &self.changed
    }

    /// Rule 3 for tile `t` (resident) once; a dirty tile's base size too.
    fn prepare(&mut self, t: u32, f: &mut DestFrame, cache: &DestCache) {
        if std::mem::replace(&mut self.prepared[t as usize], true) {
            return;
        }
        let (x0, y0, x1, y1) = tile_rect(t, cache, f);
        for y in y0..y1 {
            for x in x0..x1 {
                prepare_sample(f, f.index(x, y));
            }
        }
        if self.dirty[t as usize] {
            let mut base = cache.packed_bytes()[t as usize];
            for (px, py) in pixels_with_empty(f, (x0, y0, x1, y1), self.ab.ss) {
                base -= pixel_bytes(f, px, py, &self.ab);
            }
            self.base_bytes[t as usize] = base;
        }
    }

    /// One cycle: the write-back (rule 5), then the cursor (rules 2–4).
    pub fn tick(&mut self, now: Cycle, io: &mut FallbackPorts<'_>) -> Tick {
        let pack = self.pack_tick(now, io);
        self.pack_activity.record(now, pack);
        let fill = self.fill_tick(now, io);
        self.fill_activity.record(now, fill);
        // Either half's work is the pass's progress (the engine's
        // watchdog sees this state).
        let state = if pack.state == UnitState::Busy { UnitState::Busy } else { fill.state };
        Tick { state, moved: pack.moved || fill.moved }
    }

    fn pack_tick(&mut self, now: Cycle, io: &mut FallbackPorts<'_>) -> Tick {
        if now < self.free_at {
            return Tick { state: UnitState::Busy, moved: false };
        }
        let mut moved = false;
        while let Some(&(need, t)) = self.releases.get(self.next) {
            if self.passed < need {
                break;
            }
            if io.cache.state(t) == TileState::Untouched {
                self.next += 1;
                continue;
            }
            if self.dirty[t as usize] && io.port.writes_waiting() >= WRITE_QUEUE_LIMIT {
                return Tick::stall(StallReason::FifoFull);
            }
            if !io.cache.want(now, t, false, &[t], io.frame, io.port) {
                return Tick::stall(StallReason::Tile);
            }
            self.next += 1;
            moved = true;
            if !self.dirty[t as usize] {
                let bytes = io.cache.packed_bytes()[t as usize];
                io.cache.release(t, bytes);
                continue;
            }
            let rect = tile_rect(t, io.cache, io.frame);
            let ss = self.ab.ss;
            let mut bytes = self.base_bytes[t as usize];
            let mut packed = 0u64;
            for (px, py) in pixels_with_empty_at_start(rect, ss, &self.changed, io.frame) {
                let k = (py * (io.frame.width / ss) + px) as usize;
                if self.changed[k] {
                    bytes += round_trip_dest_pixels(io.frame, px, py, px + 1, py + 1, &self.ab, &mut self.abuffer);
                    packed += 1;
                } else {
                    bytes += pixel_bytes(io.frame, px, py, &self.ab);
                }
            }
            io.port.write(Req {
                client: Client::TileWriteBack,
                access: Access::Write,
                addr: io.cache.tile_addr(t),
                bytes,
                tag: Tag::Write,
            });
            io.cache.release(t, bytes);
            self.counters.tiles_written += 1;
            self.counters.pixels_changed += packed;
            self.free_at = now + packed.max(1);
            return Tick::BUSY;
        }
        if moved { Tick { state: UnitState::Idle, moved: true } } else { Tick::IDLE }
    }

    fn fill_tick(&mut self, now: Cycle, io: &mut FallbackPorts<'_>) -> Tick {
        let mut did = 0;
        let mut moved = false;
        let (dw, dh) = (io.frame.width, io.frame.height);
        let n_lines = self.unit.lines().len();
        while did < self.lanes && self.line < n_lines {
            let line = self.unit.lines()[self.line];
            let (x, y) = line.at(if line.step > 0 { line.lo + self.pos } else { line.hi - self.pos });
            let t = io.cache.tile_of(x, y);
            if !self.dirty[t as usize] {
                // Rule 2: skip the run inside this clean tile.
                self.step();
                moved = true;
                continue;
            }
            let entering = self.fill_tile != Some(t);
            self.fill_tile = Some(t);
            if !io.cache.want(now, t, entering, &[t], io.frame, io.port) {
                return self.stalled(did, moved, StallReason::Tile);
            }
            self.prepare(t, io.frame, io.cache);
            let hole = !io.frame.fill_valid[io.frame.index(x, y)];
            if hole {
                let mut ready = true;
                // The sample's own tile first, then its tap tiles: all of
                // them pinned while any is looked up (as in the hole fill).
                let (mut seen, mut n_seen) = ([u32::MAX; 9], 1);
                seen[0] = t;
                for (tx, ty) in HoleFillUnit::tap_positions(&line, x, y, &self.unit.params()) {
                    if tx < 0 || ty < 0 || tx >= dw as i64 || ty >= dh as i64 {
                        continue;
                    }
                    let tt = io.cache.tile_of(tx as u32, ty as u32);
                    if seen[..n_seen].contains(&tt) {
                        continue;
                    }
                    if n_seen < seen.len() {
                        seen[n_seen] = tt;
                        n_seen += 1;
                    }
                    // A retry of the same sample's taps is not counted again.
                    if io.cache.want(now, tt, !self.tap_retry, &seen[..n_seen], io.frame, io.port) {
                        self.prepare(tt, io.frame, io.cache);
                    } else {
                        ready = false;
                    }
                }
                if !ready {
                    self.tap_retry = true;
                    return self.stalled(did, moved, StallReason::Tile);
                }
                self.tap_retry = false;
            }
            let outcome = self.unit.fill_sample(io.frame, &line, x, y);
            if hole && matches!(outcome, FillOutcome::Filled { .. }) {
                let ss = self.ab.ss;
                self.changed.set(((y / ss) * (dw / ss) + x / ss) as usize, true);
            }
            self.counters.visits += 1;
            did += 1;
            moved = true;
            self.step();
        }
        if did > 0 {
            Tick::BUSY
        } else if self.line < n_lines {
            Tick::stall(StallReason::Upstream)
        } else {
            Tick { state: UnitState::Idle, moved }
        }
    }

    fn stalled(&self, did: u32, moved: bool, r: StallReason) -> Tick {
        if did > 0 { Tick::BUSY } else { Tick { state: UnitState::Stall(r), moved } }
    }

    /// Move the cursor one sample on.
    fn step(&mut self) {
        self.passed += 1;
        self.pos += 1;
        if self.pos == self.unit.lines()[self.line].len() {
            self.line += 1;
            self.pos = 0;
        }
    }

    /// End the pass at `now`: the `hole_fill` and `abuffer` cycles and
    /// (when recording) their runs of states.
    pub fn close(&mut self, now: Cycle) -> [(UnitCycles, Vec<Run>); 2] {
        self.fill_activity.close(now);
        self.pack_activity.close(now);
        [
            (self.fill_activity.cycles(), self.fill_activity.take_runs()),
            (self.pack_activity.cycles(), self.pack_activity.take_runs()),
        ]
    }
}

/// Samples `x0..x1, y0..y1` of tile `t`, clipped to the frame.
fn tile_rect(t: u32, cache: &DestCache, f: &DestFrame) -> (u32, u32, u32, u32) {
    let ts = cache.tile_size();
    let (tx, ty) = (t % cache.tiles().0, t / cache.tiles().0);
    (tx * ts, ty * ts, ((tx + 1) * ts).min(f.width), ((ty + 1) * ts).min(f.height))
}

/// Display pixels of the sample rectangle holding an empty sample now.
fn pixels_with_empty(f: &DestFrame, (x0, y0, x1, y1): (u32, u32, u32, u32), ss: u32) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for py in y0 / ss..y1 / ss {
        for px in x0 / ss..x1 / ss {
            let any = (0..ss * ss).any(|k| empty(f, f.index(px * ss + k % ss, py * ss + k / ss)));
            if any {
                out.push((px, py));
            }
        }
    }
    out
}

/// Display pixels of the sample rectangle that held an empty sample when
/// the pass began: those holding one now or a sample the pass filled.
fn pixels_with_empty_at_start(
    (x0, y0, x1, y1): (u32, u32, u32, u32),
    ss: u32,
    changed: &BitVec,
    f: &DestFrame,
) -> Vec<(u32, u32)> {
    let pw = f.width / ss;
    let mut out = Vec::new();
    for py in y0 / ss..y1 / ss {
        for px in x0 / ss..x1 / ss {
            let now_empty = (0..ss * ss).any(|k| empty(f, f.index(px * ss + k % ss, py * ss + k / ss)));
            if now_empty || changed[(py * pw + px) as usize] {
                out.push((px, py));
            }
        }
    }
    out
}

/// Packed size of pixel `(px, py)` as its samples stand (bytes).
fn pixel_bytes(f: &DestFrame, px: u32, py: u32, p: &AbufferParams) -> u64 {
    let ss = p.ss;
    if p.abuffer_fragments == 0 {
        return (ss * ss) as u64 * RAW_SAMPLE_BYTES;
    }
    let samples: Vec<Option<SampleIn>> =
        (0..ss * ss).map(|k| sample_in(f, f.index(px * ss + k % ss, py * ss + k / ss))).collect();
    Packer::new().pack_pixel(&samples, p, &mut AbufferCounters::default()).bytes()
}
