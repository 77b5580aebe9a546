//! The engine: owns the clock and the wires, and runs one derived frame
//! through the warper's units, cycle by cycle.
//!
//! Flow per derived frame: for each reference in warp order, the tile
//! manager computes the schedule (`crate::schedule`); then
//! fetch → transform → kernel setup → raster → composite write the
//! destination tiles, the hole fill follows the sweep front over retired
//! tiles, and the A-buffer packer writes released tiles back. After the
//! last warp the display reads the frame (`units::display`) and the
//! display controller resolves it (`units::resolve`).
//!
//! Phase order within a cycle ([`Machine::clock_warp`]: one call per phase;
//! downstream first, so a FIFO of latency L sustains its rate with L slots
//! per lane):
//! 1. DRAM tick; completions delivered (source blocks, tiles).
//! 2. Memory port: at most one request issued (`mem::port`).
//! 3. A-buffer packer (`units::packer`).
//! 4. Hole fill (`units::hole_fill`).
//! 5. Composite (`units::composite`).
//! 6. Raster (`units::raster`), then a host-speed hint that changes
//!    nothing in the model: the host CPU is asked to fetch the planes of
//!    the stamps that entered the stamp FIFO this cycle, which the
//!    compositor reaches from the next cycle on
//!    (`units::composite::prefetch_stamps`).
//! 7. Kernel setup (`units::kernel_setup`), then the tile manager's
//!    retirement (`units::tile_manager`), then the schedule's tile
//!    prefetch (`units::tile_prefetch`) ahead of kernel setup's and the
//!    hole fill's line cursors.
//! 8. Fetch (`units::fetch`) into the transform pipeline, then the
//!    transform's state (`units::transform`).
//!
//! Wires (the engine owns them; each unit's ports struct names the ones it
//! uses): the transform pipeline (fetch → kernel setup, inside
//! [`TransformStage`]), the kernel FIFO (kernel setup → raster), the stamp
//! FIFO (raster → composite), the memory port and the DRAM, the
//! destination cache and the derived frame's planes, the tile manager's
//! retired bits, the hole fill's visit count (→ packer) and the fetch
//! unit's interval cursor (→ kernel setup).
//!
//! Per-unit accounting: each unit's tick returns its state (busy, stall
//! with a reason, idle); the engine charges it with the cycles it lasted.
//!
//! Skipping: a cycle in which nothing moved and nothing arrived is followed
//! by a jump to the next event (a DRAM completion, a FIFO item becoming
//! visible, the packer finishing); the skipped cycles are charged to each
//! unit's state of that cycle, so cycle counts stay exact while idle time
//! costs no host time.
//!
//! Host threads ([`Engine::look_ahead`], on by default on a multi-core
//! host): kernel setup's lines (`units::line_kernels`) and the warp plans,
//! pure functions of their inputs, are computed on other host threads
//! while the clocked loop runs (during a warp: one for the lines, one for
//! the next warp's plan); every value and counter is the same as on one
//! thread.
//!
//! Rules:
//! 1. Warps run one after another: a warp starts when the previous one has
//!    released every tile and its write queue has been issued. The cycle in
//!    which a warp ends is the first cycle of the next one.
//! 2. The values computed (warp, kernels, composite, hole fill, A-buffer)
//!    do not depend on timing; only when they are computed does.
//! 3. After the last warp, with `fallback_fill`, the hole fill's fallback
//!    pass (`units::fallback_fill`) reads back the tiles holding empty
//!    samples, fills them and writes back what changed, every other unit
//!    idle; then the display read.
//!
//! Not modelled: overlap of consecutive warps or frames, the schedule's
//! computation time (driver software), clock gating.

use crate::camera::{Camera, Epipole};
use crate::clock::Cycle;
use crate::cmd::FrameCommands;
use crate::config::EngineConfig;
use crate::dest_frame::DestFrame;
use crate::fifo::Fifo;
use crate::frame_stats::{ABUFFER, HOLE_FILL, Saturations};
use crate::hw_reference::abuffer_params;
use crate::mem::{Dram, DramBackendFactory, MemPort, MemoryLayout, Region, Tag};
use crate::qformat::FixedFormats;
use crate::timeline::{Occupancy, RequestSpan, Timeline};
use crate::units::abuffer::AbufferCounters;
use crate::units::composite::{CompositePorts, CompositeStage, prefetch_stamps};
use crate::units::dest_cache::DestCache;
use crate::units::fallback_fill::{FallbackPorts, FallbackStage};
use crate::units::fetch::{FetchPorts, FetchStage, SourceCache};
use crate::units::hole_fill::{HoleFillParams, HoleFillPorts, HoleFillStage};
use crate::units::kernel_setup::{Kernel, KernelSetupPorts, KernelSetupStage};
use crate::units::line_buffer::LineBuffer;
use crate::units::line_kernels::{LineKernels, LineSource, LinesAhead};
use crate::units::packer::{PackerPorts, PackerStage};
use crate::units::raster::{RasterPorts, RasterStage, StampShape, Stamped};
use crate::units::resolve::resolve;
use crate::units::tile_manager::TileManager;
use crate::units::tile_prefetch::{Fronts, TilePrefetch};
use crate::units::transform::{TransformStage, TransformUnit};
use crate::units::{Activity, StallReason, Tick, UnitCycles as Cycles, UnitState, display};
use crate::warp_plan::WarpPlan;
pub use crate::warp_plan::held_bands;
use crate::watchdog::{self, Watchdog};
use bitvec::vec::BitVec;

pub use crate::frame_stats::{FrameStats, RECT_HIST_MAX, UNITS, UnitCycles};
pub use crate::hw_reference::HwReference;

/// The hardware model's output for one derived frame.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    /// Final per-sample planes.
    pub frame: DestFrame,
    /// Resolved display pixels (linear RGB).
    pub pixels: Vec<[f32; 3]>,
    /// Pixels whose samples all hold real surfaces.
    pub covered: BitVec,
    /// Pixels holding a sample the fallback pass filled
    /// (`units::fallback_fill`): no epipolar pass reached them.
    pub unseen: BitVec,
    /// Counters.
    pub stats: FrameStats,
    /// The frame's timeline, when recording ([`Engine::record_timeline`]).
    pub timeline: Option<Timeline>,
    /// The frame's memory map (`mem::layout`): every request's address.
    pub layout: MemoryLayout,
    /// Every DRAM request in acceptance order, when recording
    /// ([`Engine::record_requests`]); else empty.
    pub requests: Vec<RequestSpan>,
}

/// The hardware model: create one per configuration and run frames on it.
pub struct Engine {
    cfg: EngineConfig,
    /// The fixed mode's formats (`None`: float).
    fixed: Option<FixedFormats>,
    buffer: LineBuffer,
    record: bool,
    record_requests: bool,
    skip: bool,
    /// Compute kernel setup's lines and the warp plans on other host
    /// threads ([`Engine::look_ahead`]).
    look_ahead: bool,
    /// The DRAM backend of `dram_backend` other than `ideal`, one per frame.
    backend: Option<DramBackendFactory>,
}

impl Engine {
    /// An engine for a validated configuration.
    ///
    /// # Errors
    /// The configuration's validation message.
    pub fn new(cfg: EngineConfig) -> Result<Engine, String> {
        if cfg.dram_backend != "ideal" {
            return Err(format!(
                "dram_backend = \"{}\": not part of the cycle model; the `postwarp` crate provides it \
                 (Engine::with_dram_backend)",
                cfg.dram_backend
            ));
        }
        Engine::make(cfg, None)
    }

    /// An engine whose DRAM channel is timed by a backend `factory` makes
    /// afresh for every frame (`mem::backend`; the backend named by
    /// `dram_backend`, e.g. DRAMsim3 in the `postwarp` crate).
    ///
    /// # Errors
    /// The configuration's validation message.
    pub fn with_dram_backend(cfg: EngineConfig, factory: DramBackendFactory) -> Result<Engine, String> {
        Engine::make(cfg, Some(factory))
    }

    fn make(cfg: EngineConfig, backend: Option<DramBackendFactory>) -> Result<Engine, String> {
        cfg.validate()?;
        if cfg.tile_size % cfg.supersample != 0 {
            return Err(format!(
                "tile_size = {}: expected a multiple of supersample ({}) so that tiles hold whole pixels",
                cfg.tile_size, cfg.supersample
            ));
        }
        // Checked here, as the tile size above, because the trace's
        // super-sampling decides the blocks (`units::fetch` rule 2).
        let block = crate::config::largest_block_bytes(&cfg);
        if cfg.source_cache_bytes < block {
            return Err(format!(
                "source_cache_bytes = {}: expected at least the largest reference block, {block} bytes \
                 ((tile_size {} / supersample {})² pixels of a header and min(abuffer_fragments {}, supersample²) \
                 fragments), so that the block the fetch unit streams from fits on chip",
                cfg.source_cache_bytes, cfg.tile_size, cfg.supersample, cfg.abuffer_fragments
            ));
        }
        let fixed = cfg.fixed_formats()?;
        Ok(Engine {
            cfg,
            fixed,
            buffer: LineBuffer::default(),
            record: false,
            record_requests: false,
            skip: true,
            look_ahead: std::thread::available_parallelism().is_ok_and(|n| n.get() > 1),
            backend,
        })
    }

    /// Record a [`Timeline`] of every frame from now on (or stop). Values
    /// and cycles do not change.
    pub fn record_timeline(&mut self, on: bool) {
        self.record = on;
    }

    /// Record every DRAM request of every frame from now on (or stop), in
    /// [`FrameOutput::requests`]. Values and cycles do not change.
    pub fn record_requests(&mut self, on: bool) {
        self.record_requests = on;
    }

    /// Skip idle stretches (the default) or step every cycle. Stepping is
    /// slow and exists to check that skipping is exact: every counter and
    /// value must be the same either way (`tests/hw_skip_exact.rs`).
    pub fn skip_idle(&mut self, on: bool) {
        self.skip = on;
    }

    /// Compute kernel setup's lines (pure functions of the reference and
    /// the warp) on another host thread, ahead of the clocked loop
    /// (`units::line_kernels`), and the next warp's plan during the
    /// current warp (the first warp's two halves at once); or all on the
    /// loop's own thread, each line when kernel setup reaches it. Values,
    /// cycles and every counter are the same either way
    /// (`tests/hw_look_ahead.rs`); only host time differs. On by default
    /// when the host has more than one core.
    pub fn look_ahead(&mut self, on: bool) {
        self.look_ahead = on;
    }

    /// Whether [`Engine::look_ahead`] is on.
    pub fn looks_ahead(&self) -> bool {
        self.look_ahead
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
        let cfg = &self.cfg;
        let dst = cmd.derived_camera.sample_grid(cfg.supersample);
        let (dw, dh) = (dst.intrinsics.width, dst.intrinsics.height);
        let fixed = self.fixed.clone();
        let sizes: Vec<(u32, u32)> = refs.iter().map(|r| (r.width, r.height)).collect();
        let layout = MemoryLayout::new(cfg, (dw, dh), &sizes);
        let mut m = Machine {
            cfg,
            skip: self.skip,
            look_ahead: self.look_ahead,
            dram: match &self.backend {
                None => Dram::new(cfg.dram()),
                Some(make) => Dram::with_backend(cfg.dram(), make()),
            },
            now: Cycle::ZERO,
            port: MemPort::default(),
            cache: DestCache::new(cfg.dest_cache_bytes, cfg.tile_size, dw, dh),
            units: [Cycles::default(); 7],
            stats: FrameStats {
                rects: vec![vec![0; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1],
                saturations: fixed.as_ref().map(|_| Saturations::default()),
                ..FrameStats::default()
            },
            fixed: fixed.as_ref(),
            ab: AbufferCounters::default(),
            timeline: self.record.then(|| Timeline::new(UNITS.len(), occupancy_series(cfg))),
        };
        m.cache.place(*layout.dest_tiles(), *layout.dest_spill());
        if m.timeline.is_some() || self.record_requests {
            m.dram.record_requests();
        }
        m.dram.tick(m.now);
        let centres: Vec<_> = cmd.warps.iter().map(|w| w.reference_camera.pose.position).collect();
        let tus: Vec<TransformUnit> = (cmd.warps.iter().enumerate())
            .map(|(j, warp)| {
                TransformUnit::new(warp.setup, warp.reference_camera, dst, centres.clone(), j, cfg.better_margin)
                    .with_fixed(fixed.clone())
            })
            .collect();
        let inputs: Vec<WarpInput<'_>> = (tus.iter().zip(refs).enumerate())
            .map(|(j, (tu, r))| WarpInput { tu, r, number: j, dst, region: *layout.reference(j) })
            .collect();
        let plan = |w: &WarpInput<'_>| WarpPlan::new(cfg, w, (dw, dh), false);
        let mut f = DestFrame::new(dw, dh);
        let mut next = inputs.first().map(|w| WarpPlan::new(cfg, w, (dw, dh), m.look_ahead));
        for (j, w) in inputs.iter().enumerate() {
            if let Some(sat) = &mut m.stats.saturations {
                sat.fetch += w.r.fetch_saturations;
            }
            let this = next.take().expect("each warp is planned before it runs");
            std::thread::scope(|scope| {
                // The next warp's plan (driver software, a pure function
                // of its inputs) on another host thread meanwhile.
                let ahead = inputs.get(j + 1).filter(|_| m.look_ahead).map(|w| scope.spawn(move || plan(w)));
                m.run_warp(&mut f, w, &this, &mut self.buffer);
                next = match ahead {
                    Some(h) => Some(h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))),
                    None => inputs.get(j + 1).map(plan),
                };
            });
            m.stats.reference_packed_bytes += w.r.packed.bytes_in_pixels(0, 0, u32::MAX, u32::MAX);
            m.stats.dest_packed_bytes.push(m.cache.packed_bytes().iter().sum());
        }
        let (pw, ph) = (dw / cfg.supersample, dh / cfg.supersample);
        let mut unseen = BitVec::repeat(false, (pw * ph) as usize);
        if cfg.fallback_fill
            && let Some(last) = cmd.warps.last()
            && let Some(changed) = m.run_fallback(&mut f, &last.setup.epipole_derived, cmd.warps.len())
        {
            unseen = changed;
        }
        m.display_read();
        let mut stats = m.stats;
        stats.cycles = m.now.get();
        stats.units = m.units;
        stats.dram = m.dram.counters().clone();
        stats.dram_backend = m.dram.backend_counters();
        stats.dest_cache = m.cache.tags().counters.clone();
        stats.fragments_per_pixel = m.ab.fragments_per_pixel.clone();
        stats.forced_merges = m.ab.forced_merges;
        stats.display_pixels = (dw / cfg.supersample) as u64 * (dh / cfg.supersample) as u64;
        stats.hole_samples = f.hole.count_ones() as u64;
        stats.empty_samples = (0..f.len()).filter(|&i| !f.real[i] && !f.hole[i]).count() as u64;
        let spans = m.dram.take_requests();
        let timeline = m.timeline.take().map(|mut t| {
            t.close(m.now);
            t.requests = spans.clone();
            t
        });
        let requests = if self.record_requests { spans } else { Vec::new() };
        let (pixels, covered) = resolve(&f, self.cfg.supersample);
        FrameOutput { frame: f, pixels, covered, unseen, stats, timeline, layout, requests }
    }
}

/// One reference warp's inputs.
pub(crate) struct WarpInput<'a> {
    /// The warp's transform unit.
    pub(crate) tu: &'a TransformUnit,
    /// The reference.
    pub(crate) r: &'a HwReference,
    /// Its number in the frame's warp order.
    pub(crate) number: usize,
    /// The derived sample grid.
    pub(crate) dst: Camera,
    /// Where the reference is in DRAM.
    pub(crate) region: Region,
}

/// Clocked state shared by the warps of one frame: the clock, the memory
/// and the destination cache.
struct Machine<'c> {
    cfg: &'c EngineConfig,
    /// The fixed mode's formats (`None`: float).
    fixed: Option<&'c FixedFormats>,
    /// Skip idle stretches ([`Engine::skip_idle`]).
    skip: bool,
    /// Kernel setup's lines and the warp plans on other host threads
    /// ([`Engine::look_ahead`]).
    look_ahead: bool,
    dram: Dram<Tag>,
    now: Cycle,
    port: MemPort,
    cache: DestCache,
    /// Per unit, over the frame.
    units: [Cycles; 7],
    stats: FrameStats,
    ab: AbufferCounters,
    timeline: Option<Timeline>,
}

/// The occupancy series a timeline records, in [`Pipeline::occupancy`]
/// order.
/// Index of the memory port's queues in [`occupancy_series`].
const PORT_SERIES: usize = 3;
/// Index of the destination cache in [`occupancy_series`].
const CACHE_SERIES: usize = 4;

fn occupancy_series(cfg: &EngineConfig) -> Vec<Occupancy> {
    let tile_bytes = crate::config::tile_bytes(cfg);
    let pipe = cfg.transform_throughput as u64 * (cfg.transform_latency as u64 + 1);
    vec![
        Occupancy::new("transform pipeline", "samples", Some(pipe)),
        Occupancy::new("kernel FIFO", "kernels", Some(2 * cfg.rects_per_cycle as u64)),
        Occupancy::new("stamp FIFO", "stamps", Some(2 * cfg.rects_per_cycle as u64)),
        // Not bounded in the model (`mem::port`, "Not modelled").
        Occupancy::new("memory port queues", "requests", None),
        Occupancy::new("destination cache", "tiles", Some(cfg.dest_cache_bytes / tile_bytes)),
    ]
}

impl Machine<'_> {
    /// Phase 1: deliver the DRAM completions of this cycle; true if any.
    #[inline]
    fn deliver(&mut self, f: &mut DestFrame, mut src: Option<&mut SourceCache>) -> bool {
        if self.dram.next_completion().is_none_or(|c| c > self.now) {
            return false;
        }
        while let Some((tag, _)) = self.dram.completed(self.now) {
            match tag {
                Tag::Block { block, warp } => {
                    if let Some(s) = src.as_deref_mut()
                        && s.warp == warp
                    {
                        s.arrived(block, self.now);
                    }
                }
                Tag::Tile { tile, fresh } => self.cache.arrived(self.now, tile, fresh, f),
                Tag::Write | Tag::Output => {}
            }
        }
        true
    }

    /// The memory's next event after `now`: the next cycle if a request
    /// is waiting and the DRAM has room (a unit may queue one in a cycle
    /// it reports as a stall, such as a tile miss), else the next DRAM
    /// completion.
    #[inline]
    fn memory_event(&self, now: Cycle) -> Option<Cycle> {
        if !self.port.is_empty() && self.dram.has_room() {
            return Some(now + 1);
        }
        self.dram.next_completion()
    }

    /// Move to the next cycle, or jump to `next_event` when nothing moved
    /// (module doc, "Skipping"). Returns the cycles the states of this
    /// cycle last (1, or the skipped span).
    fn advance(&mut self, moved: bool, next_event: Option<Cycle>) -> u64 {
        let mut span = 1;
        if self.skip
            && !moved
            && let Some(t) = next_event.filter(|&t| t > self.now + 1)
        {
            span = t - self.now;
        }
        if span > 1 {
            // A waiting request is offered in every skipped cycle and
            // refused (the DRAM is full: else the next cycle is an event).
            self.dram.skip_to(self.now + (span - 1), !self.port.is_empty());
        }
        // The memory port's queues as this cycle left them, for the
        // cycles its state lasts.
        let queued = self.port.queued() as u64;
        self.stats.port_queued_request_cycles += queued * span;
        self.stats.port_peak_queued = self.stats.port_peak_queued.max(queued);
        self.now += span;
        self.dram.tick(self.now);
        span
    }

    /// What a stuck clock loop reports besides the units' states
    /// (`watchdog` rule 3): the destination cache and the memory port.
    fn stuck_details(&self) -> String {
        let tags = self.cache.tags();
        format!(
            "destination cache {} of {} tiles held, reserved {:?}; memory port {} requests queued, {} writes waiting",
            tags.occupancy(),
            tags.capacity(),
            self.cache.reserved(),
            self.port.queued(),
            self.port.writes_waiting()
        )
    }

    /// After the last warp: the display reads the frame as written back,
    /// every unit idle.
    fn display_read(&mut self) {
        display::queue_frame_read(&mut self.port, &self.cache);
        let mut none = DestFrame::new(0, 0);
        // A read issued or arrived is the display's progress (`watchdog`
        // rule 1): a memory that stops answering is reported, not waited
        // for.
        let mut guard = Watchdog::new(["display"], self.now, watchdog::limit_for(self.cfg));
        loop {
            let arrived = self.deliver(&mut none, None);
            let issued = self.port.issue(&mut self.dram, self.now);
            if self.port.is_empty() && self.dram.outstanding() == 0 {
                break;
            }
            guard.note(0, self.now, if arrived || issued { Tick::BUSY } else { Tick::stall(StallReason::Dram) });
            guard.check(self.now, || self.stuck_details());
            let next = self.memory_event(self.now);
            let before = self.now;
            let span = self.advance(arrived || issued, next);
            for u in &mut self.units {
                u.charge(UnitState::Idle, span);
            }
            if let Some(t) = &mut self.timeline {
                t.occupancy[PORT_SERIES].add(before, span, self.port.queued() as u64);
            }
        }
    }

    /// After the last warp (`warp` warps done): the hole fill's fallback
    /// pass (`units::fallback_fill`), cycle by cycle; the pixels it
    /// changed, or `None` if there was nothing to fill (no cycle spent).
    fn run_fallback(&mut self, f: &mut DestFrame, e: &Epipole, warp: usize) -> Option<BitVec> {
        let cfg = self.cfg;
        let hole = HoleFillParams {
            far_distance: cfg.hole_far_distance,
            far_offset: cfg.hole_far_offset,
            max_distance: cfg.hole_max_distance,
        };
        let (ab, lanes, record) = (abuffer_params(cfg), cfg.hole_fill_per_cycle, self.timeline.is_some());
        let mut p = FallbackStage::new(f, e, hole, lanes, ab, &self.cache, self.now, record)?
            .with_fixed(self.fixed.map(|f| (f.colour, f.hole_weight)));
        let start = self.now;
        self.cache.begin_warp(warp);
        let mut guard = Watchdog::new(["fallback_fill"], self.now, watchdog::limit_for(cfg));
        loop {
            let now = self.now;
            let mut moved = self.deliver(f, None);
            moved |= self.port.issue(&mut self.dram, now);
            let marks = (self.port.queued(), self.cache.loads());
            let ports = &mut FallbackPorts { frame: f, cache: &mut self.cache, port: &mut self.port };
            moved |= guard.note(0, now, p.tick(now, ports)).moved;
            moved |= marks != (self.port.queued(), self.cache.loads());
            if p.is_done(now) && self.port.writes_waiting() == 0 {
                break;
            }
            guard.check(now, || self.stuck_details());
            let next =
                if moved { None } else { [p.next_event(now), self.memory_event(now)].into_iter().flatten().min() };
            let span = self.advance(moved, next);
            if let Some(t) = &mut self.timeline {
                t.occupancy[PORT_SERIES].add(now, span, self.port.queued() as u64);
                t.occupancy[CACHE_SERIES].add(now, span, self.cache.tags().occupancy() as u64);
            }
        }
        let span = self.now - start;
        // The fallback pass runs the hole-fill unit and the packer; every
        // unit before them in `UNITS` is idle.
        for u in &mut self.units[..HOLE_FILL] {
            u.charge(UnitState::Idle, span);
        }
        for (k, (c, runs)) in [HOLE_FILL, ABUFFER].into_iter().zip(p.close(self.now)) {
            self.units[k].add(&c);
            if let Some(t) = &mut self.timeline {
                t.append_runs(k, runs);
            }
        }
        let c = p.counters();
        let s = &mut self.stats;
        s.fallback_cycles = span;
        s.fallback_visits = c.visits;
        s.fallback_filled = c.filled;
        s.fallback_unreached = c.unreached;
        s.fallback_tile_loads = self.cache.loads();
        s.fallback_tiles_written = c.tiles_written;
        s.unseen_pixels = p.changed_pixels().count_ones() as u64;
        if let Some(sat) = &mut s.saturations {
            sat.hole_fill += p.saturations();
        }
        self.ab.add(p.abuffer_counters());
        Some(p.changed_pixels().clone())
    }

    /// One reference warp: its line source (on another host thread with
    /// the look-ahead), then [`Machine::clock_warp`].
    fn run_warp(&mut self, f: &mut DestFrame, w: &WarpInput<'_>, plan: &WarpPlan, buffer: &mut LineBuffer) {
        self.cache.begin_warp(w.number);
        let start = self.now;
        std::thread::scope(|scope| {
            let (sched, threshold) = (&plan.sched, self.cfg.threshold);
            let size = (w.dst.intrinsics.width, w.dst.intrinsics.height);
            let shape = StampShape { limit: self.cfg.kernel_limit, size };
            let line_kernels = LineKernels::new(w.r, w.tu, buffer, threshold, shape);
            let source = if self.look_ahead {
                LineSource::Ahead(LinesAhead::spawn(scope, &sched.lines, &sched.need, line_kernels))
            } else {
                LineSource::Inline(line_kernels)
            };
            let p = Pipeline::new(self.cfg, w, plan, source, self.now, self.timeline.is_some());
            self.clock_warp(f, plan, p);
        });
        if let Some(t) = &mut self.timeline {
            t.warps.push((start, self.now));
        }
    }

    /// Clock a warp's pipeline until every unit has finished it.
    fn clock_warp(&mut self, f: &mut DestFrame, plan: &WarpPlan, mut p: Pipeline<'_>) {
        let names = ["packer", "hole_fill", "composite", "raster", "kernel_setup", "fetch"];
        let mut guard = Watchdog::new(names, self.now, watchdog::limit_for(self.cfg));
        loop {
            let now = self.now;
            // 1–2. Memory: completions, then one request.
            let mut moved = self.deliver(f, Some(&mut p.fetch.cache));
            moved |= self.port.issue(&mut self.dram, now);
            // A request queued or a tile made resident in a stalled tick
            // (a first-warp tile cleared on chip) changes what the next
            // cycle can do: it counts as movement for the skip.
            let marks = (self.port.queued(), self.cache.loads());
            let (frame, cache, port) = (&mut *f, &mut self.cache, &mut self.port);
            // 3. A-buffer packer.
            let fill_visits = p.fill.visits();
            moved |= guard.note(0, now, p.packer.tick(now, &mut PackerPorts { fill_visits, frame, cache, port })).moved;
            // 4. Hole fill.
            moved |=
                guard.note(1, now, p.fill.tick(now, &mut HoleFillPorts { frame, cache, port, tiles: &p.tiles })).moved;
            // 5. Composite.
            let (input, tiles) = (&mut p.stamps, &mut p.tiles);
            moved |= guard
                .note(2, now, p.composite.tick(now, &mut CompositePorts { input, frame, cache, port, tiles }))
                .moved;
            // 6. Raster.
            let held = p.stamps.len();
            let (input, out) = (&mut p.kernels, &mut p.stamps);
            moved |= guard.note(3, now, p.raster.tick(now, &mut RasterPorts { input, out, tiles })).moved;
            prefetch_stamps(&p.stamps, held, frame);
            // 7. Kernel setup, then tile retirement.
            let (transform, fetch_interval) = (&mut p.transform, p.fetch.interval());
            let mut io = KernelSetupPorts { transform, fetch_interval, out: &mut p.kernels, tiles };
            moved |= guard.note(4, now, p.kernel.tick(now, &mut io)).moved;
            moved |= p.tiles.tick(p.kernel.lines_emitted());
            if p.held_to_end.is_none() && p.kernel.is_done() {
                p.held_to_end = Some(plan.held_to_end(cache));
            }
            // 7b. The schedule's tile prefetch, ahead of both fronts.
            let fronts = Fronts { warp_lines: p.kernel.lines_emitted(), fill_lines: p.fill.lines_done() };
            moved |= p.prefetch.tick(now, fronts, cache, frame, port);
            // 8. Fetch, then the transform pipeline's state.
            moved |= guard.note(5, now, p.fetch.tick(now, &mut FetchPorts { transform: &mut p.transform, port })).moved;
            p.transform.tick(now);
            moved |= marks != (self.port.queued(), self.cache.loads());

            if p.is_done(now) && self.port.writes_waiting() == 0 {
                break;
            }
            guard.check(now, || self.stuck_details());
            let next = if moved { None } else { p.next_event(now, self.memory_event(now)) };
            let span = self.advance(moved, next);
            if let Some(t) = &mut self.timeline {
                for (o, v) in t.occupancy.iter_mut().zip(p.occupancy(&self.port, &self.cache)) {
                    o.add(now, span, v);
                }
            }
        }
        p.finish(plan, self);
    }
}

/// The units of one warp and the FIFOs between them.
struct Pipeline<'s> {
    fetch: FetchStage<'s>,
    transform: TransformStage,
    kernel: KernelSetupStage<'s>,
    kernels: Fifo<Kernel>,
    raster: RasterStage<'s>,
    stamps: Fifo<Stamped>,
    composite: CompositeStage<'s>,
    tiles: TileManager,
    prefetch: TilePrefetch,
    /// [`WarpPlan::held_to_end`], once kernel setup is done.
    held_to_end: Option<u64>,
    fill: HoleFillStage,
    packer: PackerStage<'s>,
}

impl<'s> Pipeline<'s> {
    fn new(
        cfg: &EngineConfig,
        w: &WarpInput<'s>,
        plan: &'s WarpPlan,
        line_source: LineSource<'s>,
        now: Cycle,
        record: bool,
    ) -> Pipeline<'s> {
        let (r, tu, sched) = (w.r, w.tu, &plan.sched);
        let side = cfg.tile_size / cfg.supersample;
        let mut cache = SourceCache::new(cfg.source_cache_bytes, r.width, r.height, cfg.supersample, side, |bx, by| {
            r.packed.bytes_in_pixels(bx * side, by * side, (bx + 1) * side, (by + 1) * side)
        });
        cache.warp = w.number as u32;
        cache.place(w.region);
        let (thr, rate) = (cfg.transform_throughput, cfg.rects_per_cycle);
        let a = || Activity::starting(now, record);
        Pipeline {
            fetch: FetchStage::new(&sched.fetch, r, cache, thr, a()),
            transform: TransformStage::new(thr, cfg.transform_latency, r.grid.len(), a()),
            kernel: KernelSetupStage::with_source(&sched.lines, &sched.need, r, line_source, thr, a()),
            kernels: Fifo::new(2 * rate as usize, 1),
            raster: RasterStage::new(tu, w.number as u8, rate, a()),
            stamps: Fifo::new(2 * rate as usize, 1),
            composite: CompositeStage::new(tu, cfg.slope_tol, cfg.rel_tol, rate, cfg.composite_miss_queue, a()),
            tiles: TileManager::new(sched.lines.len(), &sched.retire),
            prefetch: TilePrefetch::new(&sched.first, &plan.fill_first, cfg.tile_prefetch_distance),
            held_to_end: None,
            fill: HoleFillStage::new(plan.fill.clone(), cfg.hole_fill_per_cycle, a()),
            packer: PackerStage::new(&plan.releases, abuffer_params(cfg), cfg.packer_pixels_per_cycle, now, a()),
        }
    }

    /// Every unit has finished the warp (the write queue aside).
    fn is_done(&self, now: Cycle) -> bool {
        self.fetch.is_done()
            && self.transform.is_empty()
            && self.kernel.is_done()
            && self.kernels.is_empty()
            && self.stamps.is_empty()
            && self.composite.is_idle()
            && self.fill.is_done()
            && self.packer.is_done(now)
    }

    /// Occupancies for a timeline, in `occupancy_series` order.
    fn occupancy(&self, port: &MemPort, cache: &DestCache) -> [u64; 5] {
        [
            self.transform.len() as u64,
            self.kernels.len() as u64,
            self.stamps.len() as u64,
            port.queued() as u64,
            cache.tags().occupancy() as u64,
        ]
    }

    /// The earliest event after a cycle in which nothing moved: a packing
    /// done, a DRAM completion, or an item of a FIFO becoming visible. An
    /// item already visible is no event (its consumer did not take it and
    /// will not until something else moves); counting it would walk a long
    /// DRAM wait behind a blocked head cycle by cycle.
    fn next_event(&self, now: Cycle, dram: Option<Cycle>) -> Option<Cycle> {
        [
            self.packer.next_event(now),
            dram,
            self.transform.next_visible_after(now),
            self.kernels.next_visible_after(now),
            self.stamps.next_visible_after(now),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Add the warp's counters to the frame's.
    fn finish(mut self, plan: &WarpPlan, m: &mut Machine<'_>) {
        let now = m.now;
        let closed = [
            self.fetch.close(now),
            self.transform.close(now),
            self.kernel.close(now),
            self.raster.close(now),
            self.composite.close(now),
            self.fill.close(now),
            self.packer.close(now),
        ];
        let s = &mut m.stats;
        let live = plan.sched.live.iter().filter(|&&l| l).count() as u64;
        s.live_lines += live;
        s.dead_lines += plan.sched.live.len() as u64 - live;
        s.tile_loads.push(m.cache.loads());
        s.peak_tiles.push(m.cache.tags().peak() as u64);
        s.ws_model_tiles.push(plan.working_set.tiles);
        let (evictions, ab) = self.packer.counts();
        s.tile_evictions.push(evictions);
        s.tiles_held_to_warp_end.push(self.held_to_end.unwrap_or(0));
        s.composite_bypasses += self.composite.bypasses();
        m.ab.add(ab);
        s.samples_transformed += self.transform.samples();
        let (kernels, culled) = self.kernel.counts();
        s.kernels += kernels;
        s.culled_samples += culled;
        let (over, rects) = self.raster.counts();
        s.kernels_over_limit += over;
        for (row, add) in s.rects.iter_mut().zip(rects) {
            for (a, b) in row.iter_mut().zip(add) {
                *a += b;
            }
        }
        for (a, b) in s.composite.iter_mut().zip(self.composite.verdicts()) {
            *a += b;
        }
        let fill = self.fill.unit().counters();
        s.hole_fill_filled += fill.filled;
        s.hole_fill_unreached += fill.unreached;
        if let Some(sat) = &mut s.saturations {
            let [t, k, r] = self.raster.saturations();
            sat.transform += t;
            sat.kernel_setup += k;
            sat.raster += r;
            sat.hole_fill += fill.saturations;
        }
        let src = &self.fetch.cache.counters;
        s.source_cache.block_reads += src.block_reads;
        s.source_cache.evictions += src.evictions;
        s.source_cache.wait_cycles += src.wait_cycles;
        for (k, (c, runs)) in closed.into_iter().enumerate() {
            m.units[k].add(&c);
            if let Some(t) = &mut m.timeline {
                t.append_runs(k, runs);
            }
        }
    }
}
