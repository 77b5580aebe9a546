//! Fixtures shared by the per-unit tests (`unit_*.rs`, `schedule_props.rs`):
//! tiny cameras on a sample grid, a synthetic reference packed as the
//! hardware holds it, the warp's transform unit and schedule, and the
//! accounting check every stage's test ends with.
//!
//! The units' neighbours in these tests are the real [`Fifo`]s,
//! [`MemPort`]s, [`DestCache`]s and [`TileManager`]s, set up by the test:
//! the test decides what is in them and when (Ramulator's style of a mock).
//!
//! [`Fifo`]: postwarp_rtl::fifo::Fifo
//! [`MemPort`]: postwarp_rtl::mem::MemPort
//! [`DestCache`]: postwarp_rtl::units::dest_cache::DestCache
//! [`TileManager`]: postwarp_rtl::units::tile_manager::TileManager
#![allow(dead_code)]

use glam::{DQuat, DVec3};
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::hw_reference::HwReference;
use postwarp_rtl::mem::MemPort;
use postwarp_rtl::schedule::{FetchInterval, Schedule};
use postwarp_rtl::traversal::warp_lines;
use postwarp_rtl::units::fetch::{FetchPorts, FetchStage, SourceCache};
use postwarp_rtl::units::raster::StampShape;
use postwarp_rtl::units::transform::{InFlightSample, TransformStage, TransformUnit};
use postwarp_rtl::units::{Activity, Run, StallReason, Tick, UnitCycles, UnitState};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage, WarpSetup};

/// A camera of `w x h` samples (fx = fy = 40, principal point at the
/// centre) at `position`, turned by `yaw` radians about +y.
pub fn camera(w: u32, h: u32, position: DVec3, yaw: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics {
            width: w,
            height: h,
            fx: 40.0,
            fy: 40.0,
            cx: (w as f64 - 1.0) / 2.0,
            cy: (h as f64 - 1.0) / 2.0,
        },
        pose: Pose { position, orientation: DQuat::from_rotation_y(yaw) },
    }
}

/// A `w x h` reference: sample `(x, y)` sees a surface at depth `z` with
/// colour `c` where `f(x, y) = Some((z, c))`; slopes from the depths.
pub fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> Option<(f32, [f32; 3])>) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for y in 0..h {
        for x in 0..w {
            if let Some((z, c)) = f(x, y) {
                let i = img.index(x, y);
                img.z[i] = z;
                img.colour[i] = c;
                img.object_id[i] = 1;
                img.valid.set(i, true);
            }
        }
    }
    img.slopes_from_depth();
    img
}

/// A fronto-parallel plane at depth `z` filling the whole `w x h` image,
/// its colour a function of the position (so samples differ).
pub fn plane(w: u32, h: u32, z: f32) -> SampleImage {
    image(w, h, |x, y| Some((z, [x as f32 / w as f32, y as f32 / h as f32, 0.5])))
}

/// The configuration of the unit tests: one sample per pixel (the images
/// above are sample grids), 4-sample tiles, everything else the default.
pub fn config() -> EngineConfig {
    EngineConfig { supersample: 1, tile_size: 4, ..EngineConfig::default() }
}

/// One reference warp set up as the engine sets it up (`Pipeline::new`):
/// the reference packed, the cameras, the transform unit and the schedule.
pub struct Warp {
    /// The configuration.
    pub cfg: EngineConfig,
    /// Reference camera (sample grid).
    pub src: Camera,
    /// Derived camera (sample grid, the reference's size).
    pub dst: Camera,
    /// The reference as the warper holds it.
    pub r: HwReference,
    /// Its samples as the fetch unit expands them.
    pub samples: SampleImage,
    /// 1/Z of every expanded sample (0 without a surface).
    pub inv_z: Vec<f64>,
    /// The warp's transform unit.
    pub tu: TransformUnit,
    /// The tile manager's schedule of the warp.
    pub sched: Schedule,
}

impl Warp {
    /// The warp's stamp shape: the configuration's stamp side, the derived
    /// image's size.
    pub fn shape(&self) -> StampShape {
        StampShape { limit: self.cfg.kernel_limit, size: (self.dst.intrinsics.width, self.dst.intrinsics.height) }
    }

    /// Warp `img` seen from the origin to a camera of the same size at
    /// `dst_pos` turned by `yaw`.
    pub fn new(img: &SampleImage, dst_pos: DVec3, yaw: f64, cfg: EngineConfig) -> Warp {
        let (w, h) = (img.width, img.height);
        let src = camera(w, h, DVec3::ZERO, 0.0);
        let dst = camera(w, h, dst_pos, yaw);
        let r = HwReference::new(img, &cfg);
        let samples = r.expanded();
        let inv_z =
            (0..samples.len()).map(|i| if samples.valid[i] { 1.0 / samples.z[i] as f64 } else { 0.0 }).collect();
        let setup = WarpSetup::new(&src, &dst);
        let tu = TransformUnit::new(setup, src, dst, vec![src.pose.position], 0, cfg.better_margin);
        let lines = warp_lines(w, h, &setup.epipole_reference);
        let sched = Schedule::new((r.width, r.height), &r.depth, &setup, lines, (w, h), cfg.tile_size, None);
        Warp { cfg, src, dst, r, samples, inv_z, tu, sched }
    }

    /// The source cache of the warp, as the engine builds it (every block
    /// absent).
    pub fn source_cache(&self, capacity: u64) -> SourceCache {
        source_cache(&self.r, &self.cfg, capacity)
    }
}

/// A source cache of `capacity` bytes over reference `r`, its blocks'
/// sizes as packed (the engine's `Pipeline::new`).
pub fn source_cache(r: &HwReference, cfg: &EngineConfig, capacity: u64) -> SourceCache {
    let side = cfg.tile_size / cfg.supersample;
    SourceCache::new(capacity, r.width, r.height, cfg.supersample, side, |bx, by| {
        r.packed.bytes_in_pixels(bx * side, by * side, (bx + 1) * side, (by + 1) * side)
    })
}

/// An upper bound on the grid indices of a `w x h` reference: the host
/// layout (`hw_reference::Grid`) pads the image to whole 8x8 tiles.
pub fn grid_len(w: u32, h: u32) -> usize {
    (w.div_ceil(8) * 8 * h.div_ceil(8) * 8) as usize
}

/// The samples of `plan` as the fetch unit streams them (grid index and
/// interval, in streaming order), with every block on chip: the real
/// fetch unit is the only public way to name a sample's grid index.
pub fn streamed(r: &HwReference, cfg: &EngineConfig, plan: &[FetchInterval]) -> Vec<InFlightSample> {
    let mut cache = source_cache(r, cfg, u64::MAX);
    for b in 0..cache.blocks.0 * cache.blocks.1 {
        cache.arrived(b, Cycle(0));
    }
    let total: u32 = plan.iter().map(|iv| iv.len()).sum();
    let len = grid_len(r.width, r.height);
    let mut transform = TransformStage::new(total + 1, 0, len, Activity::starting(Cycle(0), false));
    let mut fetch = FetchStage::new(plan, r, cache, total + 1, Activity::starting(Cycle(0), false));
    let mut port = MemPort::default();
    let mut out = Vec::new();
    let mut now = Cycle(0);
    while !fetch.is_done() {
        fetch.tick(now, &mut FetchPorts { transform: &mut transform, port: &mut port });
        transform.tick(now);
        while let Some(s) = transform.take(now) {
            assert!((s.grid_index as usize) < len, "grid index {} past the bound {len}", s.grid_index);
            out.push(s);
        }
        now += 1;
        assert!(now.get() < 1000, "the fetch unit did not finish the plan");
    }
    assert!(port.is_empty(), "every block was on chip: no read expected");
    out
}

/// The tick states a test saw, to check a stage's accounting: each state
/// holds from its tick to the next one (the engine skips cycles between
/// ticks), the first tick's predecessor being the idle start.
pub struct TickLog {
    start: Cycle,
    ticks: Vec<(Cycle, UnitState)>,
}

impl TickLog {
    /// A stage started (idle) at `start`.
    pub fn new(start: Cycle) -> TickLog {
        TickLog { start, ticks: Vec::new() }
    }

    /// Note the tick of cycle `now` and pass it on.
    pub fn note(&mut self, now: Cycle, t: Tick) -> Tick {
        assert!(self.ticks.last().is_none_or(|&(c, _)| c < now), "ticks must move forward");
        self.ticks.push((now, t.state));
        t
    }

    /// The states, charged up to `end`, as (state, start, end) runs with
    /// consecutive equal states merged and empty runs dropped.
    fn runs(&self, end: Cycle) -> Vec<Run> {
        let mut points = vec![(self.start, UnitState::Idle)];
        points.extend(self.ticks.iter().copied());
        let mut runs: Vec<Run> = Vec::new();
        for (k, &(at, state)) in points.iter().enumerate() {
            let until = points.get(k + 1).map_or(end, |p| p.0);
            if until == at {
                continue;
            }
            match runs.last_mut() {
                Some(r) if r.state == state => r.end = until,
                _ => runs.push(Run { state, start: at, end: until }),
            }
        }
        runs
    }

    /// Check a stage's `close(end)` against the ticks seen: `busy + stall +
    /// idle = end − start`, stalls split by reason sum to the stalls,
    /// each state charged exactly the cycles it held, and the recorded
    /// runs tile `start..end` in the states seen.
    pub fn check(&self, end: Cycle, (cycles, runs): (UnitCycles, Vec<Run>)) {
        assert_eq!(cycles.busy + cycles.stall + cycles.idle, end - self.start, "busy + stall + idle: {cycles:?}");
        assert_eq!(cycles.stall_by_reason.iter().sum::<u64>(), cycles.stall, "stalls by reason: {cycles:?}");
        let expected = self.runs(end);
        let mut want = UnitCycles::default();
        for r in &expected {
            want.charge(r.state, r.end - r.start);
        }
        assert_eq!(cycles, want, "cycles charged per state");
        assert_eq!(runs, expected, "recorded runs");
    }

    /// How many ticks were seen in `state`.
    pub fn count(&self, state: UnitState) -> usize {
        self.ticks.iter().filter(|t| t.1 == state).count()
    }
}

/// A recording activity starting at `now`.
pub fn activity(now: Cycle) -> Activity {
    Activity::starting(now, true)
}

/// Shorthand for a stalled state.
pub fn stall(r: StallReason) -> UnitState {
    UnitState::Stall(r)
}

/// Proptest configuration: `default` cases, or the number in the
/// environment variable `PROPTEST_CASES` when it is set. Failing seeds
/// are kept in `tests/<suite>.proptest-regressions` and replayed first.
pub fn prop_config(default: u32) -> proptest::test_runner::Config {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default);
    proptest::test_runner::Config {
        cases,
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..proptest::test_runner::Config::default()
    }
}
