//! The engine: owns the clock and runs one derived frame through the
//! warper's units, cycle by cycle.
//!
//! Flow per derived frame: for each reference in warp order, the tile
//! manager computes the schedule (`crate::schedule`); then
//! fetch → transform → kernel setup → raster → composite write the
//! destination tiles, the hole-fill unit follows the sweep front over
//! retired tiles, and the A-buffer packer writes released tiles back. After
//! the last warp the display reads the frame (`Client::Output`) and
//! resolves it (`units::resolve`).
//!
//! Phase order within a cycle (downstream first, so a FIFO of latency L
//! sustains its rate with L slots per lane):
//! 1. DRAM tick; completions delivered (source blocks, tiles).
//! 2. Memory port: at most one request issued, by priority demand tile
//!    loads > write-backs and spills > source prefetch > display reads.
//! 3. A-buffer packer: release the next tile whose fill is complete.
//! 4. Hole fill: up to `hole_fill_per_cycle` samples in fill order.
//! 5. Composite: up to `rects_per_cycle` stamps whose tiles are resident.
//! 6. Raster: up to `rects_per_cycle` kernels into stamps.
//! 7. Kernel setup: absorb up to `transform_throughput` transformed
//!    samples, then emit up to as many kernels of ready lines.
//! 8. Fetch: push up to `transform_throughput` samples into the transform
//!    pipeline (a FIFO of latency `transform_latency`).
//!
//! Per-unit accounting: each cycle a unit is *busy* (moved work), *stalled*
//! (had work but waited on memory, a full FIFO or an upstream dependency)
//! or *idle* (nothing to do).
//!
//! Skipping: a cycle in which nothing moved and nothing arrived is followed
//! by a jump to the next event (a DRAM completion, a FIFO item becoming
//! visible, the packer finishing); the skipped cycles are added to each
//! unit's state of that cycle, so cycle counts stay exact while idle time
//! costs no host time.
//!
//! Rules:
//! 1. Warps run one after another: a warp starts when the previous one has
//!    released every tile and queued every write.
//! 2. The values computed (warp, kernels, composite, hole fill, A-buffer)
//!    do not depend on timing; only when they are computed does.
//!
//! Not modelled: overlap of consecutive warps or frames, the schedule's
//! computation time (driver software), clock gating.

use crate::camera::Epipole;
use crate::clock::Cycle;
use crate::cmd::FrameCommands;
use crate::config::{CACHE_BYTES_PER_SAMPLE, EngineConfig};
use crate::dest_frame::DestFrame;
use crate::fifo::Fifo;
use crate::mem::{Access, Client, Dram};
use crate::sample_image::SampleImage;
use crate::schedule::{CoarseDepth, Schedule, release_order};
use crate::traversal::{Major, reverse_lines};
use crate::units::abuffer::{self, AbufferCounters, AbufferParams, PackedReference};
use crate::units::composite::{Candidate, Verdict, composite};
use crate::units::fetch::{BlockState, SourceCache};
use crate::units::hole_fill::{FillOutcome, HoleFillParams, HoleFillUnit};
use crate::units::kernel_setup::{Group, backward_step, bounding_box, corners, group, one_surface};
use crate::units::raster::{Stamp, stamp};
use crate::units::resolve::resolve;
use crate::units::tile_cache::{Lookup, TileCache, TileState};
use crate::units::transform::{TransformUnit, Warped};
use bitvec::vec::BitVec;
use glam::DVec2;
use std::collections::VecDeque;

pub use crate::frame_stats::{FrameStats, RECT_HIST_MAX, UNITS, UnitCycles};
const FETCH: usize = 0;
const TRANSFORM: usize = 1;
const KERNEL: usize = 2;
const RASTER: usize = 3;
const COMPOSITE: usize = 4;
const HOLE_FILL: usize = 5;
const ABUFFER: usize = 6;

/// A reference frame as it sits in memory, with the host-side expansion
/// the fetch unit streams (unpacking is deterministic; the model does it
/// once per reference and charges the reads per block).
#[derive(Clone, Debug)]
pub struct HwReference {
    /// The reference in A-buffer format.
    pub packed: PackedReference,
    /// Its samples as the fetch unit expands them.
    pub samples: SampleImage,
    /// 1/Z of every sample (0 without a surface).
    pub inv_z: Vec<f64>,
    /// Coarse depth map for the schedule.
    pub depth: CoarseDepth,
    /// Packer counters of the conversion (reference frames).
    pub counters: AbufferCounters,
    /// What the units read of each sample, packed in one record, twice
    /// (host-speed copies; they change no value): row-major for the
    /// row-major sheets and column-major for the others, so that a sheet
    /// streams its records in address order.
    rows: Vec<RefSample>,
    cols: Vec<RefSample>,
    /// The layout of `valid_tiles` (and of the engine's per-sample bits).
    grid: Grid,
    /// `valid`, one word per 8x8 tile of [`Grid`].
    valid_tiles: Vec<u64>,
}

/// Host layout of per-sample bits: 8x8-sample tiles in row-major tile
/// order, each tile row-major (one 64-bit word per tile), so that rows and
/// columns both walk few words.
#[derive(Clone, Copy, Debug)]
struct Grid {
    tiles_x: usize,
    tiles_y: usize,
}

impl Grid {
    fn new(w: u32, h: u32) -> Grid {
        Grid { tiles_x: w.div_ceil(8) as usize, tiles_y: h.div_ceil(8) as usize }
    }

    fn len(&self) -> usize {
        self.tiles_x * self.tiles_y * 64
    }

    #[inline(always)]
    fn index(&self, x: u32, y: u32) -> usize {
        (((y >> 3) as usize * self.tiles_x + (x >> 3) as usize) << 6) | ((y & 7) << 3 | (x & 7)) as usize
    }
}

/// What the units read of one reference sample (valid samples only).
#[derive(Clone, Copy, Debug, Default)]
struct RefSample {
    inv_z: f64,
    slopes: [f32; 2],
    colour: [f32; 3],
    z: f32,
}

impl HwReference {
    #[inline(always)]
    fn valid_at(&self, gi: usize) -> bool {
        self.valid_tiles[gi >> 6] >> (gi & 63) & 1 != 0
    }

    /// The record of sample `(x, y)`, from the copy laid out along `major`.
    #[inline(always)]
    fn rec(&self, major: Major, x: u32, y: u32) -> &RefSample {
        match major {
            Major::Row => &self.rows[y as usize * self.samples.width as usize + x as usize],
            Major::Column => &self.cols[x as usize * self.samples.height as usize + y as usize],
        }
    }
}

fn abuffer_params(cfg: &EngineConfig) -> AbufferParams {
    AbufferParams {
        ss: cfg.supersample,
        max_fragments: cfg.max_fragments,
        slope_tol: cfg.slope_tol,
        rel_tol: cfg.rel_tol,
    }
}

impl HwReference {
    /// Pack a rendered reference into A-buffer format (the renderer's
    /// output, or the warper's conversion on first use; not charged here).
    pub fn new(img: &SampleImage, cfg: &EngineConfig) -> HwReference {
        let mut counters = AbufferCounters::default();
        let packed = abuffer::pack_reference(img, &abuffer_params(cfg), &mut counters);
        let samples = packed.unpack();
        let inv_z: Vec<f64> =
            (0..samples.len()).map(|i| if samples.valid[i] { 1.0 / samples.z[i] as f64 } else { 0.0 }).collect();
        let depth = CoarseDepth::new(&samples);
        let (w, h) = (samples.width as usize, samples.height as usize);
        let grid = Grid::new(samples.width, samples.height);
        let mut rows = vec![RefSample::default(); w * h];
        let mut cols = vec![RefSample::default(); w * h];
        let mut valid_tiles = vec![0u64; grid.len() / 64];
        for i in samples.valid.iter_ones() {
            let (x, y) = (i % w, i / w);
            let gi = grid.index(x as u32, y as u32);
            valid_tiles[gi >> 6] |= 1 << (gi & 63);
            let rec = RefSample {
                inv_z: inv_z[i],
                slopes: samples.inv_z_slopes[i],
                colour: samples.colour[i],
                z: samples.z[i],
            };
            rows[i] = rec;
            cols[x * h + y] = rec;
        }
        HwReference { packed, samples, inv_z, depth, counters, rows, cols, grid, valid_tiles }
    }
}

/// The hardware model's output for one derived frame.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    /// Final per-sample planes.
    pub frame: DestFrame,
    /// Resolved display pixels (linear RGB).
    pub pixels: Vec<[f32; 3]>,
    /// Pixels whose samples all hold real surfaces.
    pub covered: BitVec,
    /// Counters.
    pub stats: FrameStats,
}

const TAG_BLOCK: u64 = 1 << 56;
const TAG_TILE: u64 = 2 << 56;
const TAG_WRITE: u64 = 3 << 56;
const TAG_OUTPUT: u64 = 4 << 56;
const TAG_MASK: u64 = 0xff << 56;

#[derive(Clone, Copy, Debug)]
struct Req {
    client: Client,
    access: Access,
    bytes: u64,
    tag: u64,
}

/// Memory requests waiting for the single command port (phase 2).
#[derive(Default)]
struct Port {
    demand: VecDeque<Req>,
    writes: VecDeque<Req>,
    prefetch: VecDeque<Req>,
    output: VecDeque<Req>,
}

impl Port {
    fn is_empty(&self) -> bool {
        self.demand.is_empty() && self.writes.is_empty() && self.prefetch.is_empty() && self.output.is_empty()
    }

    /// Issue at most one request; true if one was accepted.
    #[inline]
    fn issue(&mut self, dram: &mut Dram, now: Cycle) -> bool {
        if self.is_empty() {
            return false;
        }
        for q in [&mut self.demand, &mut self.writes, &mut self.prefetch, &mut self.output] {
            if let Some(r) = q.front() {
                if r.bytes == 0 {
                    q.pop_front();
                    continue;
                }
                return match dram.request(now, r.client, r.access, r.bytes, r.tag) {
                    Ok(()) => {
                        q.pop_front();
                        true
                    }
                    Err(_) => false,
                };
            }
        }
        false
    }
}

/// Unit state of one cycle.
#[derive(Clone, Copy, PartialEq, Eq)]
enum State {
    Busy = 0,
    Stall = 1,
    Idle = 2,
}

/// Host-side scratch reused across warps.
///
/// The transform unit's outputs and kernel setup's 2x2 group verdicts are
/// pure functions of the reference samples, so the host computes them
/// when first read and keeps them in two small direct-mapped caches of
/// four lines of the current sheet (the window kernel setup and the
/// rasterizer read), tagged with the position and the warp number; a miss
/// recomputes the same value. Which samples the transform unit has
/// streamed in this warp is kept as one bit per sample, so that a read
/// before the transform is still caught.
#[derive(Default)]
struct Scratch {
    warps: Vec<WarpEntry>,
    groups: Vec<GroupEntry>,
    /// Entries per ring line (the longer image side).
    stride: usize,
    /// Per sample ([`Grid`] order): streamed by the transform unit in
    /// this warp.
    transformed: Vec<u64>,
    warp_no: u32,
}

/// A cached transform of sample `(x, y)` in warp `warp` (`some`: not
/// culled).
#[derive(Clone, Copy)]
struct WarpEntry {
    x: u32,
    y: u32,
    warp: u32,
    some: bool,
    w: Warped,
}

/// A cached verdict of the 2x2 group at `(x, y)` in warp `warp`.
#[derive(Clone, Copy)]
struct GroupEntry {
    x: u32,
    y: u32,
    warp: u32,
    g: Group,
}

impl Scratch {
    /// Ready the caches for a warp of a `w x h` reference (grid `grid`).
    fn begin_warp(&mut self, w: u32, h: u32, grid: &Grid) {
        let stride = w.max(h) as usize;
        if self.stride < stride {
            self.stride = stride;
            let none = Warped { pos: DVec2::ZERO, inv_z: 0.0, e: 0.0 };
            self.warps = vec![WarpEntry { x: 0, y: 0, warp: 0, some: false, w: none }; 4 * stride];
            self.groups = vec![GroupEntry { x: 0, y: 0, warp: 0, g: Group::Missing }; 4 * stride];
        }
        self.transformed.clear();
        self.transformed.resize(grid.len() / 64, 0);
        self.warp_no += 1;
    }

    /// Ring slot of position `(x, y)` when the current line runs along
    /// `major`.
    #[inline(always)]
    fn slot(&self, major: Major, x: u32, y: u32) -> usize {
        match major {
            Major::Row => (y & 3) as usize * self.stride + x as usize,
            Major::Column => (x & 3) as usize * self.stride + y as usize,
        }
    }

    #[inline(always)]
    fn is_transformed(&self, gi: usize) -> bool {
        self.transformed[gi >> 6] >> (gi & 63) & 1 != 0
    }

    /// The transform of valid sample `(x, y)` of `r` (`None`: culled).
    #[inline(always)]
    fn warped(&mut self, tu: &TransformUnit, r: &HwReference, major: Major, x: u32, y: u32) -> Option<Warped> {
        let s = self.slot(major, x, y);
        let wno = self.warp_no;
        let e = &mut self.warps[s];
        if e.warp == wno && e.x == x && e.y == y {
            return e.some.then_some(e.w);
        }
        let w = tu.warp(x as f64, y as f64, r.rec(major, x, y).inv_z);
        *e = WarpEntry { x, y, warp: wno, some: w.is_some(), w: w.unwrap_or(e.w) };
        w
    }
}

/// A kernel travelling from kernel setup to the compositor.
struct Kernel {
    line: u32,
    sample: (u32, u32),
    pos: DVec2,
    inv_z: f64,
    /// The transform's expected spacing (for the forward-edge test).
    e: f64,
    corners_box: (f64, f64, f64, f64),
}

/// A rasterized stamp waiting for the compositor.
struct Job {
    line: u32,
    stamp: Stamp,
    cand: Candidate,
    sample: (u32, u32),
    /// The reference sample's 1/Z and slopes (for the better mask).
    src_inv_z: f64,
    src_slopes: [f32; 2],
    better: Option<u32>,
    counted: bool,
}

/// The hardware model: create one per configuration and run frames on it.
pub struct Engine {
    cfg: EngineConfig,
    scratch: Scratch,
}

impl Engine {
    /// An engine for a validated configuration.
    ///
    /// # Errors
    /// The configuration's validation message.
    pub fn new(cfg: EngineConfig) -> Result<Engine, String> {
        cfg.validate()?;
        if cfg.tile_size % cfg.supersample != 0 {
            return Err(format!(
                "tile_size = {}: expected a multiple of supersample ({}) so that tiles hold whole pixels",
                cfg.tile_size, cfg.supersample
            ));
        }
        Ok(Engine { cfg, scratch: Scratch::default() })
    }

    /// The configuration.
    pub fn config(&self) -> &EngineConfig {
        &self.cfg
    }

    /// Run derived frame `cmd` from its references (`refs[j]` for
    /// `cmd.warps[j]`, packed with this configuration).
    ///
    /// # Panics
    /// If `cmd.supersample` differs from the configuration's.
    pub fn run_frame(&mut self, cmd: &FrameCommands, refs: &[&HwReference]) -> FrameOutput {
        assert_eq!(cmd.supersample, self.cfg.supersample, "trace and configuration disagree on supersampling");
        let cfg = self.cfg.clone();
        let dst = cmd.derived_camera.sample_grid(cfg.supersample);
        let (dw, dh) = (dst.intrinsics.width, dst.intrinsics.height);
        let tile = cfg.tile_size;
        let tiles = (dw.div_ceil(tile), dh.div_ceil(tile));
        let n_tiles = (tiles.0 * tiles.1) as usize;
        let tile_cap = (cfg.dest_cache_bytes / (tile as u64 * tile as u64 * CACHE_BYTES_PER_SAMPLE)) as usize;
        let mut f = DestFrame::new(dw, dh);
        let mut m = Machine {
            cfg: cfg.clone(),
            dram: Dram::new(cfg.dram()),
            now: Cycle::ZERO,
            port: Port::default(),
            units: [[0; 3]; 7],
            cache: TileCache::new(tile_cap, n_tiles),
            tile_bytes: vec![0; n_tiles],
            tiles,
            tile_x: (0..dw).map(|x| x / tile).collect(),
            tile_y: (0..dh).map(|y| y / tile * tiles.0).collect(),
            stats: FrameStats { rects: vec![vec![0; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1], ..FrameStats::default() },
            ab: AbufferCounters::default(),
        };
        m.dram.tick(m.now);
        let centres: Vec<_> = cmd.warps.iter().map(|w| w.reference_camera.pose.position).collect();
        for (j, (warp, r)) in cmd.warps.iter().zip(refs).enumerate() {
            let tu = TransformUnit::new(warp.setup, warp.reference_camera, dst, centres.clone(), j, cfg.better_margin);
            m.run_warp(&mut f, &tu, r, j, &warp.setup.epipole_derived, &mut self.scratch);
        }
        m.display_read();
        m.stats.cycles = m.now.get();
        m.stats.units = m.units.map(|[busy, stall, idle]| UnitCycles { busy, stall, idle });
        m.stats.dram = m.dram.counters().clone();
        m.stats.dest_cache = m.cache.counters.clone();
        m.stats.fragments_per_pixel = m.ab.fragments_per_pixel.clone();
        m.stats.forced_merges = m.ab.forced_merges;
        m.stats.hole_samples = f.hole.count_ones() as u64;
        m.stats.empty_samples = (0..f.len()).filter(|&i| !f.real[i] && !f.hole[i]).count() as u64;
        let (pixels, covered) = resolve(&f, cfg.supersample);
        FrameOutput { frame: f, pixels, covered, stats: m.stats }
    }
}

/// Clocked state shared by the warps of one frame.
struct Machine {
    cfg: EngineConfig,
    dram: Dram,
    now: Cycle,
    port: Port,
    /// Per unit: busy, stalled and idle cycles (indexed by [`State`]).
    units: [[u64; 3]; 7],
    cache: TileCache,
    /// Packed bytes of each tile as last written back (0: never written).
    tile_bytes: Vec<u64>,
    tiles: (u32, u32),
    /// Per derived column: its tile column (`x / tile_size`).
    tile_x: Vec<u32>,
    /// Per derived row: the number of its tile row's first tile
    /// (`y / tile_size · tiles.0`).
    tile_y: Vec<u32>,
    stats: FrameStats,
    ab: AbufferCounters,
}

impl Machine {
    #[inline(always)]
    fn tile_of(&self, x: u32, y: u32) -> u32 {
        self.tile_y[y as usize] + self.tile_x[x as usize]
    }

    fn raw_tile_bytes(&self) -> u64 {
        self.cfg.tile_size as u64 * self.cfg.tile_size as u64 * CACHE_BYTES_PER_SAMPLE
    }

    /// Account one cycle's unit states and move to the next cycle, or jump
    /// to `next_event` when nothing moved (module doc, "Skipping").
    /// Returns the number of cycles accounted (1, or the skipped span).
    fn advance(&mut self, states: &[State; 7], moved: bool, next_event: Option<Cycle>) -> u64 {
        let mut span = 1;
        if !moved && let Some(t) = next_event.filter(|&t| t > self.now + 1) {
            span = t - self.now;
        }
        for (u, &s) in self.units.iter_mut().zip(states) {
            u[s as usize] += span;
        }
        if span > 1 {
            self.dram.skip_to(self.now + (span - 1));
        }
        self.now += span;
        self.dram.tick(self.now);
        span
    }

    /// A tile access by a unit: returns true when the tile is resident.
    /// Starts loads and spills as needed (tile cache rules 2–4).
    #[inline]
    fn want_tile(&mut self, t: u32, counted: bool, pinned: &[u32], f: &mut DestFrame, warp: usize) -> bool {
        self.cache.hit(t, self.now.get(), counted) || self.want_tile_miss(t, counted, pinned, f, warp)
    }

    /// [`Machine::want_tile`] when the tile is not resident.
    #[inline(never)]
    fn want_tile_miss(&mut self, t: u32, counted: bool, pinned: &[u32], f: &mut DestFrame, warp: usize) -> bool {
        let (lookup, spilled) = self.cache.access(t, self.now.get(), counted, pinned);
        if let Some(v) = spilled {
            let bytes = self.raw_tile_bytes();
            self.port.writes.push_back(Req {
                client: Client::TileWriteBack,
                access: Access::Write,
                bytes,
                tag: TAG_WRITE,
            });
            let _ = v;
        }
        match lookup {
            Lookup::Hit => true,
            Lookup::Wait | Lookup::Full => false,
            Lookup::Compulsory => {
                self.stats.tile_loads[warp] += 1;
                if warp == 0 {
                    // First warp: the tile is empty, cleared on chip.
                    self.tile_arrived(t, f);
                } else {
                    let bytes = self.tile_bytes[t as usize];
                    self.port.demand.push_back(Req {
                        client: Client::TileFill,
                        access: Access::Read,
                        bytes,
                        tag: TAG_TILE | t as u64,
                    });
                    if bytes == 0 {
                        self.tile_arrived(t, f);
                    }
                }
                false
            }
            Lookup::Capacity => {
                self.stats.tile_loads[warp] += 1;
                let bytes = self.raw_tile_bytes();
                self.port.demand.push_back(Req {
                    client: Client::TileFill,
                    access: Access::Read,
                    bytes,
                    tag: TAG_TILE | (1 << 40) | t as u64,
                });
                false
            }
        }
    }

    /// A tile load completed. A compulsory load resets the cache-only
    /// planes of the tile's samples.
    fn tile_arrived(&mut self, t: u32, f: &mut DestFrame) {
        self.tile_arrived_kind(t, f, true);
    }

    fn tile_arrived_kind(&mut self, t: u32, f: &mut DestFrame, fresh: bool) {
        self.cache.loaded(t, self.now.get());
        if fresh {
            let ts = self.cfg.tile_size;
            let (tx, ty) = (t % self.tiles.0, t / self.tiles.0);
            for y in ty * ts..((ty + 1) * ts).min(f.height) {
                for x in tx * ts..((tx + 1) * ts).min(f.width) {
                    let i = f.index(x, y);
                    f.begin_warp_sample(i);
                }
            }
        }
    }

    /// Deliver DRAM completions of this cycle; true if any.
    #[inline]
    fn completions(&mut self, f: &mut DestFrame, src: Option<&mut SourceCache>) -> bool {
        self.dram.next_completion().is_some_and(|c| c <= self.now) && self.deliver(f, src)
    }

    #[inline(never)]
    fn deliver(&mut self, f: &mut DestFrame, src: Option<&mut SourceCache>) -> bool {
        let mut any = false;
        let mut src = src;
        while let Some((tag, _)) = self.dram.completed(self.now) {
            any = true;
            match tag & TAG_MASK {
                TAG_BLOCK => {
                    if let Some(s) = src.as_deref_mut() {
                        s.arrived((tag & 0xffff_ffff) as u32, self.now.get());
                    }
                }
                TAG_TILE => {
                    let t = (tag & 0xffff_ffff) as u32;
                    let fresh = tag & (1 << 40) == 0;
                    self.tile_arrived_kind(t, f, fresh);
                }
                _ => {}
            }
        }
        any
    }

    /// After the last warp: the display reads the frame as written back.
    fn display_read(&mut self) {
        for t in 0..self.tile_bytes.len() {
            let bytes = self.tile_bytes[t];
            self.port.output.push_back(Req { client: Client::Output, access: Access::Read, bytes, tag: TAG_OUTPUT });
        }
        let idle = [State::Idle; 7];
        loop {
            let arrived = self.completions(&mut DestFrame::new(0, 0), None);
            let issued = self.port.issue(&mut self.dram, self.now);
            if self.port.is_empty() && self.dram.outstanding() == 0 {
                break;
            }
            let next = self.dram.next_completion();
            self.advance(&idle, arrived || issued, next);
        }
    }

    #[allow(clippy::too_many_lines)]
    fn run_warp(
        &mut self,
        f: &mut DestFrame,
        tu: &TransformUnit,
        r: &HwReference,
        warp: usize,
        epipole_derived: &Epipole,
        sc: &mut Scratch,
    ) {
        let cfg = self.cfg.clone();
        let img = &r.samples;
        let (w, h) = (img.width, img.height);
        let (dw, dh) = (f.width, f.height);
        let ts = cfg.tile_size;
        self.stats.tile_loads.push(0);
        self.stats.tile_evictions.push(0);
        self.cache.begin_warp();

        // Tile manager: the schedule (software).
        let lines = reverse_lines(w, h, &tu.setup.epipole_reference);
        let sched = Schedule::new(img, &r.depth, &tu.setup, lines, (dw, dh), ts);
        self.stats.live_lines += sched.live.iter().filter(|&&l| l).count() as u64;
        self.stats.dead_lines += sched.live.iter().filter(|&&l| !l).count() as u64;
        let hf_params = HoleFillParams {
            far_distance: cfg.hole_far_distance,
            far_offset: cfg.hole_far_offset,
            max_distance: cfg.hole_max_distance,
        };
        let mut fill = HoleFillUnit::new(dw, dh, epipole_derived, hf_params);
        let fill_lines = fill.lines().to_vec();
        let releases =
            release_order(&fill_lines, (dw, dh), ts, |l, x, y| HoleFillUnit::tap_positions(l, x, y, &hf_params));
        let mut retire_order: Vec<(u32, u32)> = Vec::new();
        let mut retired: BitVec = BitVec::repeat(false, sched.retire.len());
        for (t, rl) in sched.retire.iter().enumerate() {
            match rl {
                None => retired.set(t, true),
                Some(l) => retire_order.push((*l, t as u32)),
            }
        }
        retire_order.sort_unstable();

        // Per-sample scratch.
        let grid = r.grid;
        sc.begin_warp(w, h, &grid);
        let wno = sc.warp_no;

        // Units' state.
        let side = cfg.tile_size / cfg.supersample;
        let packed = &r.packed;
        let mut src = SourceCache::new(cfg.source_cache_bytes, w, h, cfg.supersample, side, |bx, by| {
            packed.bytes_in_pixels(bx * side, by * side, (bx + 1) * side, (by + 1) * side)
        });
        let thr = cfg.transform_throughput as usize;
        let rate = cfg.rects_per_cycle as usize;
        let lat = cfg.transform_latency as u64;
        let mut tpipe: Fifo<(u32, u32)> = Fifo::new(thr * (cfg.transform_latency as usize + 1), lat);
        let mut kfifo: Fifo<Kernel> = Fifo::new(2 * rate, 1);
        let mut cfifo: Fifo<Job> = Fifo::new(2 * rate, 1);
        let (mut fi, mut fk) = (0usize, 0u32);
        let mut prefetched = 0usize; // intervals whose blocks are queued
        let (mut kl, mut kj) = (0usize, 0u32); // kernel setup: line, position
        let mut outstanding = vec![0u32; sched.lines.len()];
        let mut complete = 0usize; // lines fully composited
        let mut retire_ptr = 0usize;
        let (mut hl, mut hj) = (0usize, 0u32); // hole fill: line, position
        let mut visits = 0u64;
        let mut fill_tile: Option<u32> = None;
        let mut release_ptr = 0usize;
        let mut packer_free = self.now;
        let ab_params = abuffer_params(&cfg);
        let line_samples = |l: &crate::traversal::Line, j: u32| -> (u32, u32) {
            let a = if l.step > 0 { l.lo + j } else { l.hi - j };
            l.at(a)
        };

        loop {
            let mut moved = self.completions(f, Some(&mut src));
            moved |= self.port.issue(&mut self.dram, self.now);
            let mut st = [State::Idle; 7];

            // 3. A-buffer packer: release tiles whose fill is complete.
            if release_ptr < releases.len() {
                let (need, t) = releases[release_ptr];
                if visits >= need {
                    if self.now < packer_free {
                        st[ABUFFER] = State::Busy;
                    } else if self.port.writes.len() >= 8 {
                        st[ABUFFER] = State::Stall;
                    } else if self.want_tile(t, false, &[t], f, warp) {
                        let (tx, ty) = (t % self.tiles.0, t / self.tiles.0);
                        let ss = cfg.supersample;
                        let (px0, py0) = (tx * ts / ss, ty * ts / ss);
                        let bytes = abuffer::round_trip_dest_pixels(
                            f,
                            px0,
                            py0,
                            px0 + ts / ss,
                            py0 + ts / ss,
                            &ab_params,
                            &mut self.ab,
                        );
                        self.tile_bytes[t as usize] = bytes;
                        self.port.writes.push_back(Req {
                            client: Client::TileWriteBack,
                            access: Access::Write,
                            bytes,
                            tag: TAG_WRITE,
                        });
                        self.cache.release(t);
                        self.stats.tile_evictions[warp] += 1;
                        release_ptr += 1;
                        packer_free = self.now + u64::from((ts / ss) * (ts / ss));
                        st[ABUFFER] = State::Busy;
                        moved = true;
                    } else {
                        st[ABUFFER] = State::Stall;
                    }
                } else if self.now < packer_free {
                    st[ABUFFER] = State::Busy;
                }
            } else if self.now < packer_free {
                st[ABUFFER] = State::Busy;
            }

            // 4. Hole fill.
            let mut did = 0;
            while did < cfg.hole_fill_per_cycle && hl < fill_lines.len() {
                let line = fill_lines[hl];
                let (x, y) = line_samples(&line, hj);
                let t = self.tile_of(x, y);
                if !retired[t as usize] {
                    break;
                }
                let entering = fill_tile != Some(t);
                if !self.want_tile(t, entering, &[t], f, warp) {
                    fill_tile = Some(t);
                    break;
                }
                fill_tile = Some(t);
                let i = f.index(x, y);
                if !f.fill_valid[i] {
                    // Taps read tiles visited earlier: they must be on chip.
                    let mut ready = true;
                    for (tx, ty) in HoleFillUnit::tap_positions(&line, x, y, &fill.params()) {
                        if tx < 0 || ty < 0 || tx >= dw as i64 || ty >= dh as i64 {
                            continue;
                        }
                        let tt = self.tile_of(tx as u32, ty as u32);
                        if tt == t || matches!(self.cache.state(tt), TileState::Untouched | TileState::Released) {
                            continue;
                        }
                        if !self.want_tile(tt, true, &[t, tt], f, warp) {
                            ready = false;
                        }
                    }
                    if !ready {
                        break;
                    }
                }
                match fill.fill_sample(f, &line, x, y) {
                    FillOutcome::Filled { .. } => self.stats.hole_fill_filled += 1,
                    FillOutcome::Unreached => self.stats.hole_fill_unreached += 1,
                    FillOutcome::Surface => {}
                }
                visits += 1;
                did += 1;
                hj += 1;
                if hj == line.len() {
                    hl += 1;
                    hj = 0;
                }
            }
            st[HOLE_FILL] = if did > 0 {
                moved = true;
                State::Busy
            } else if hl < fill_lines.len() {
                State::Stall
            } else {
                State::Idle
            };

            // 5. Composite.
            let mut did = 0;
            while did < rate {
                let Some(job) = cfifo.peek(self.now) else { break };
                let mut tiles = [u32::MAX; 4];
                let (tx0, tx1) = (self.tile_x[job.stamp.x.0 as usize], self.tile_x[job.stamp.x.1 as usize]);
                let (ty0, ty1) = (self.tile_y[job.stamp.y.0 as usize], self.tile_y[job.stamp.y.1 as usize]);
                let mut k = 0;
                let mut row = ty0;
                while row <= ty1 {
                    for tx in tx0..=tx1 {
                        tiles[k] = row + tx;
                        k += 1;
                    }
                    row += self.tiles.0;
                }
                let counted = !job.counted;
                let mut ready = true;
                for &t in &tiles[..k] {
                    ready &= self.want_tile(t, counted, &tiles[..k], f, warp);
                }
                if !ready {
                    if let Some(j) = cfifo.oldest_mut() {
                        j.counted = true;
                    }
                    break;
                }
                let mut job = cfifo.pop(self.now).expect("peeked");
                let (sx, sy) = job.sample;
                let (src_inv_z, src_slopes) = (job.src_inv_z, job.src_slopes);
                job.stamp.for_each(|x, y| {
                    let i = f.index(x, y);
                    let better = &mut job.better;
                    let v = composite(
                        f,
                        i,
                        &job.cand,
                        || *better.get_or_insert_with(|| tu.better_mask(sx as f64, sy as f64, src_inv_z, src_slopes)),
                        cfg.slope_tol,
                        cfg.rel_tol,
                    );
                    let slot = match v {
                        Verdict::Filled => 0,
                        Verdict::Nearer => 1,
                        Verdict::Better => 2,
                        Verdict::Lost => 3,
                    };
                    self.stats.composite[slot] += 1;
                });
                outstanding[job.line as usize] -= 1;
                did += 1;
            }
            st[COMPOSITE] = if did > 0 {
                moved = true;
                State::Busy
            } else if cfifo.is_empty() {
                State::Idle
            } else {
                State::Stall
            };

            // 6. Raster.
            let mut did = 0;
            let mut blocked = false;
            while did < rate && kfifo.can_pop(self.now) {
                if !cfifo.can_push(self.now) {
                    blocked = true;
                    break;
                }
                let k = kfifo.pop(self.now).expect("visible");
                did += 1;
                let (x0, x1, y0, y1) = k.corners_box;
                let s = stamp(x0, x1, y0, y1, (k.pos.x, k.pos.y), cfg.kernel_limit, (dw, dh));
                self.stats.kernels_over_limit += s.over_limit as u64;
                if s.is_empty() {
                    outstanding[k.line as usize] -= 1;
                    continue;
                }
                let (cw, ch) = s.drawn();
                self.stats.rects[(cw as usize).min(RECT_HIST_MAX)][(ch as usize).min(RECT_HIST_MAX)] += 1;
                let major = sched.lines[k.line as usize].major;
                let t = Warped { pos: k.pos, inv_z: k.inv_z, e: k.e };
                let cand = candidate(tu, r, sc, major, k.sample, &t, warp as u8, cfg.threshold);
                let rec = r.rec(major, k.sample.0, k.sample.1);
                let _ = cfifo.push(
                    self.now,
                    Job {
                        line: k.line,
                        stamp: s,
                        cand,
                        sample: k.sample,
                        src_inv_z: rec.inv_z,
                        src_slopes: rec.slopes,
                        better: None,
                        counted: false,
                    },
                );
            }
            st[RASTER] = if did > 0 {
                moved = true;
                State::Busy
            } else if blocked {
                State::Stall
            } else {
                State::Idle
            };

            // 7. Kernel setup: absorb transformed samples, then emit kernels.
            let mut absorbed = 0;
            while absorbed < thr && tpipe.pop(self.now).is_some() {
                absorbed += 1;
            }
            let done_intervals = match tpipe.oldest() {
                Some(&(_, iv)) => iv as usize,
                None => fi,
            };
            let mut emitted = 0;
            let mut k_state = State::Idle;
            while emitted < thr && kl < sched.lines.len() {
                let Some(need) = sched.need[kl] else {
                    // Dead line: no kernels.
                    kl += 1;
                    kj = 0;
                    continue;
                };
                if need >= done_intervals {
                    k_state = State::Stall;
                    break;
                }
                let line = sched.lines[kl];
                if kj == line.len() {
                    kl += 1;
                    kj = 0;
                    continue;
                }
                let (x, y) = line_samples(&line, kj);
                let i = grid.index(x, y);
                if !r.valid_at(i) {
                    kj += 1;
                    continue;
                }
                if !kfifo.can_push(self.now) {
                    k_state = State::Stall;
                    break;
                }
                kj += 1;
                emitted += 1;
                assert!(sc.is_transformed(i), "kernel setup read ({x}, {y}) before the fetch plan transformed it");
                let major = line.major;
                let Some(t) = sc.warped(tu, r, major, x, y) else {
                    self.stats.culled_samples += 1;
                    continue;
                };
                let g = |gx: i64, gy: i64, sc: &mut Scratch| -> Option<Group> {
                    if gx < 0 || gy < 0 || gx as u32 + 1 >= w || gy as u32 + 1 >= h {
                        return None;
                    }
                    let (gx, gy) = (gx as u32, gy as u32);
                    let s = sc.slot(major, gx, gy);
                    let e = &sc.groups[s];
                    if e.warp != wno || e.x != gx || e.y != gy {
                        let mut at = |x: u32, y: u32| {
                            let j = grid.index(x, y);
                            if r.valid_at(j) {
                                assert!(sc.is_transformed(j), "group read ({x}, {y}) before it was transformed");
                                sc.warped(tu, r, major, x, y)
                            } else {
                                None
                            }
                        };
                        let (a, b, c, d) = (at(gx, gy), at(gx + 1, gy), at(gx, gy + 1), at(gx + 1, gy + 1));
                        let g = group(a, b, c, d, cfg.threshold);
                        sc.groups[s] = GroupEntry { x: gx, y: gy, warp: wno, g };
                    }
                    Some(sc.groups[s].g)
                };
                let (xi, yi) = (x as i64, y as i64);
                let groups = [g(xi - 1, yi - 1, sc), g(xi, yi - 1, sc), g(xi - 1, yi, sc), g(xi, yi, sc)];
                let rec = r.rec(major, x, y);
                let (c, _) = corners(tu, &t, x, y, rec.inv_z, rec.slopes, groups);
                self.stats.kernels += 1;
                outstanding[kl] += 1;
                let _ = kfifo.push(
                    self.now,
                    Kernel {
                        line: kl as u32,
                        sample: (x, y),
                        pos: t.pos,
                        inv_z: t.inv_z,
                        e: t.e,
                        corners_box: bounding_box(&c),
                    },
                );
            }
            st[KERNEL] = if emitted > 0 || absorbed > 0 {
                moved = true;
                State::Busy
            } else {
                k_state
            };
            // Lines complete once emitted and composited; tiles retire.
            while complete < kl && outstanding[complete] == 0 {
                complete += 1;
            }
            while retire_ptr < retire_order.len() && (retire_order[retire_ptr].0 as usize) < complete {
                retired.set(retire_order[retire_ptr].1 as usize, true);
                retire_ptr += 1;
                moved = true;
            }

            // 8. Fetch.
            let mut pushed = 0;
            let mut f_state = State::Idle;
            // The fetch unit found the next sample's block absent this cycle.
            let mut block_wait = false;
            while fi < sched.fetch.len() {
                // Prefetch this interval's and the next one's blocks.
                while prefetched < (fi + 2).min(sched.fetch.len()) {
                    let iv = sched.fetch[prefetched];
                    let port = &mut self.port;
                    let mut list = Vec::new();
                    src.blocks_of(&iv, |b| list.push(b));
                    for b in list {
                        if src.request(b) {
                            port.prefetch.push_back(Req {
                                client: Client::ReferenceFetch,
                                access: Access::Read,
                                bytes: src.bytes(b),
                                tag: TAG_BLOCK | b as u64,
                            });
                        }
                    }
                    prefetched += 1;
                }
                let iv = sched.fetch[fi];
                if fk == iv.len() {
                    fi += 1;
                    fk = 0;
                    continue;
                }
                if pushed == thr {
                    break;
                }
                let (x, y) = iv.at(fk);
                let i = grid.index(x, y);
                if !r.valid_at(i) {
                    fk += 1;
                    continue;
                }
                let b = src.block_of(x, y);
                if !src.touch(b, self.now.get()) {
                    if src.state(b) == BlockState::Absent && src.request(b) {
                        self.port.prefetch.push_back(Req {
                            client: Client::ReferenceFetch,
                            access: Access::Read,
                            bytes: src.bytes(b),
                            tag: TAG_BLOCK | b as u64,
                        });
                    }
                    block_wait = true;
                    f_state = State::Stall;
                    break;
                }
                if tpipe.push(self.now, (i as u32, fi as u32)).is_err() {
                    f_state = State::Stall;
                    st[TRANSFORM] = State::Stall;
                    break;
                }
                sc.transformed[i >> 6] |= 1 << (i & 63);
                self.stats.samples_transformed += 1;
                pushed += 1;
                fk += 1;
            }
            if pushed > 0 {
                moved = true;
                st[FETCH] = State::Busy;
                st[TRANSFORM] = State::Busy;
            } else {
                st[FETCH] = f_state;
            }

            let done = fi >= sched.fetch.len()
                && tpipe.is_empty()
                && kl >= sched.lines.len()
                && kfifo.is_empty()
                && cfifo.is_empty()
                && hl >= fill_lines.len()
                && release_ptr >= releases.len()
                && self.port.writes.is_empty()
                && self.now >= packer_free;
            if done {
                break;
            }
            // The next event matters only when nothing moved.
            let next = if moved {
                None
            } else {
                let mut next = (packer_free > self.now).then_some(packer_free);
                for c in [self.dram.next_completion(), tpipe.next_visible(), kfifo.next_visible(), cfifo.next_visible()]
                    .into_iter()
                    .flatten()
                {
                    if next.is_none_or(|n| c < n) {
                        next = Some(c);
                    }
                }
                next
            };
            let span = self.advance(&st, moved, next);
            if block_wait {
                // Skipped cycles count too: the fetch unit waits through them.
                src.counters.wait_cycles += span;
            }
        }
        self.stats.source_cache.block_reads += src.counters.block_reads;
        self.stats.source_cache.evictions += src.counters.evictions;
        self.stats.source_cache.wait_cycles += src.counters.wait_cycles;
    }
}

/// The flat candidate of a kernel whose stamp covers something: colour,
/// derived 1/Z and slopes, source, and the hole-fill colour (the forward
/// edge's backward neighbour's colour, kernel setup rule 5).
#[allow(clippy::too_many_arguments)]
fn candidate(
    tu: &TransformUnit,
    r: &HwReference,
    sc: &mut Scratch,
    major: Major,
    (x, y): (u32, u32),
    t: &Warped,
    source: u8,
    threshold: f64,
) -> Candidate {
    let img = &r.samples;
    let rec = r.rec(major, x, y);
    let slopes = tu.dest_slopes(x as f64, y as f64, rec.inv_z, rec.slopes);
    let mut fill_colour = rec.colour;
    if let Some((dx, dy)) = backward_step(&tu.setup.epipole_reference, x, y) {
        let (nx, ny) = (x as i64 + dx as i64, y as i64 + dy as i64);
        if nx >= 0 && ny >= 0 && nx < img.width as i64 && ny < img.height as i64 {
            let k = r.grid.index(nx as u32, ny as u32);
            if r.valid_at(k)
                && let Some(tn) = sc.warped(tu, r, major, nx as u32, ny as u32)
            {
                let offset = DVec2::new(dx as f64, dy as f64).length();
                let nk = r.rec(major, nx as u32, ny as u32);
                if nk.z > rec.z && !one_surface(t, &tn, offset, threshold) {
                    fill_colour = nk.colour;
                }
            }
        }
    }
    Candidate {
        colour: rec.colour,
        inv_z: t.inv_z as f32,
        slopes: [slopes[0] as f32, slopes[1] as f32],
        source,
        fill_colour,
    }
}
