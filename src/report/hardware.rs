//! The hardware model's per-frame counters in `report.json`
//! (`postwarp simulate`), mirroring [`postwarp_rtl::engine::FrameStats`],
//! and the rates derived from them.
//!
//! To add a statistic: add the field to [`HwCounters`] (or to one of its
//! parts: [`DestCache`], [`SourceCache`], [`UnitCycles`], …), fill it in
//! [`HwCounters::of`], and give it a row in the part's key table
//! ([`counter_keys`] and the tables next to it) with its unit, meaning and
//! reduction. `total` and `mean` follow from the row
//! ([`super::keys`]); `docs/report.md`'s tables are generated from the rows
//! and a test compares them, and another fails if a key has no row. A
//! ratio of counters goes in [`HwRates`] (derived at report time), never
//! in the counters.
//!
//! `N` is `u64` in a frame and in `total`, `f64` in `mean`.

use super::dram::{DramBackendCounters, DramRates};
use super::keys::{KeyDoc, Reduce, Shape, nested, scalar};
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{FrameStats, UNITS};
use postwarp_rtl::mem::Client;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Bytes one client read and wrote.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReadWrite<N> {
    /// Bytes read (bytes, rounded up to whole bursts).
    pub read: N,
    /// Bytes written (bytes, rounded up to whole bursts).
    pub write: N,
}

/// One value per DRAM client, in [`Client::ALL`] order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ByClient<T> {
    /// Reference blocks read by the fetch unit.
    pub reference_fetch: T,
    /// Destination tiles read into the cache.
    pub tile_fill: T,
    /// Destination tiles written from the cache.
    pub tile_write_back: T,
    /// The display's read of the finished frame.
    pub output: T,
}

impl<T> ByClient<T> {
    /// From a function of each client.
    pub fn from_fn(f: impl Fn(Client) -> T) -> ByClient<T> {
        ByClient {
            reference_fetch: f(Client::ReferenceFetch),
            tile_fill: f(Client::TileFill),
            tile_write_back: f(Client::TileWriteBack),
            output: f(Client::Output),
        }
    }

    /// The four values with their client names, in [`Client::ALL`] order.
    pub fn iter(&self) -> [(&'static str, &T); 4] {
        [
            (Client::ReferenceFetch.name(), &self.reference_fetch),
            (Client::TileFill.name(), &self.tile_fill),
            (Client::TileWriteBack.name(), &self.tile_write_back),
            (Client::Output.name(), &self.output),
        ]
    }
}

/// Destination tile cache counters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DestCache<N> {
    /// Tile look-ups (accesses).
    pub accesses: N,
    /// Look-ups that found the tile resident (accesses).
    pub hits: N,
    /// Tiles loaded for their first use in a warp, by prefetch or on
    /// demand (tiles; before report_version 4: accesses, the same count
    /// without a prefetch).
    pub misses_compulsory: N,
    /// Look-ups that found a tile the schedule had not loaded (accesses).
    #[serde(default)]
    pub misses_demand: N,
    /// Look-ups that found the tile's load in flight (accesses).
    #[serde(default)]
    pub misses_late: N,
    /// Tiles the schedule loaded ahead of their first use (tiles).
    #[serde(default)]
    pub prefetches: N,
    /// Prefetched tiles dropped unused to make room (tiles).
    #[serde(default)]
    pub prefetch_drops: N,
    /// Use of a tile spilled earlier in the warp (accesses).
    pub misses_capacity: N,
    /// Tiles spilled raw to make room (tiles).
    pub spills: N,
}

/// Source (reference) cache counters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SourceCache<N> {
    /// Reference blocks read (blocks).
    pub block_reads: N,
    /// Blocks evicted (blocks).
    pub evictions: N,
    /// Cycles the fetch unit waited for a block (cycles).
    pub wait_cycles: N,
}

/// Composite verdicts per covered derived sample.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Composite<N> {
    /// Candidate written over an empty or hole-fill sample (samples).
    pub filled: N,
    /// Candidate won the depth test (samples).
    pub nearer: N,
    /// Candidate won the same-surface arbitration (samples).
    pub better: N,
    /// Candidate lost (samples).
    pub lost: N,
}

/// One unit's cycles.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UnitCycles<N> {
    /// Cycles the unit moved work (cycles).
    pub busy: N,
    /// Cycles it had work but waited (cycles).
    pub stall: N,
    /// Cycles it had nothing to do (cycles).
    pub idle: N,
    /// The stall cycles by reason; they sum to `stall` (cycles). Absent
    /// from reports written before the split.
    #[serde(default = "absent", skip_serializing_if = "Option::is_none")]
    pub stall_by_reason: Option<StallReasons<N>>,
}

/// A key absent from an older report.
fn absent<T>() -> Option<T> {
    None
}

/// A unit's stall cycles by reason (`postwarp_rtl::units::StallReason`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StallReasons<N> {
    /// Waiting for DRAM data (cycles).
    pub dram: N,
    /// Waiting for a destination tile (cycles).
    pub tile: N,
    /// Output FIFO or queue full (cycles).
    pub fifo_full: N,
    /// Waiting on an upstream dependency (cycles).
    pub upstream: N,
}

/// One value per hardware unit, in [`UNITS`] order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Units<T> {
    /// Reference fetch and expand.
    pub fetch: T,
    /// Transform pipeline.
    pub transform: T,
    /// Kernel setup.
    pub kernel_setup: T,
    /// Rasterizer.
    pub raster: T,
    /// Compositor.
    pub composite: T,
    /// Hole-fill unit.
    pub hole_fill: T,
    /// A-buffer packer.
    pub abuffer: T,
}

/// Every counter of one frame (`N` = `u64`), or their `total` (`u64`) or
/// `mean` (`f64`) over frames.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HwCounters<N> {
    /// Engine cycles for the frame (cycles).
    pub cycles: N,
    /// DRAM bytes read, all clients (bytes).
    pub dram_read_bytes: N,
    /// DRAM bytes written, all clients (bytes).
    pub dram_write_bytes: N,
    /// Per client, bytes read and written (bytes).
    pub dram_bytes_by_client: ByClient<ReadWrite<N>>,
    /// DRAM requests accepted (requests).
    pub dram_requests: N,
    /// DRAM bursts moved, reads and writes: the transactions of a
    /// `--dram-trace` (transactions). Absent from older reports (0).
    #[serde(default)]
    pub dram_transactions: N,
    /// Bytes asked for before burst rounding (bytes).
    #[serde(default)]
    pub dram_requested_bytes: N,
    /// Cycles with a refused DRAM request (cycles).
    #[serde(default)]
    pub dram_refused_cycles: N,
    /// Cycles with a DRAM request outstanding (cycles).
    #[serde(default)]
    pub dram_outstanding_cycles: N,
    /// DRAM requests outstanding, summed over cycles (request-cycles).
    #[serde(default)]
    pub dram_outstanding_request_cycles: N,
    /// Most DRAM requests outstanding at once (requests).
    #[serde(default)]
    pub dram_peak_outstanding: N,
    /// Memory-port requests waiting, summed over cycles (request-cycles).
    #[serde(default)]
    pub port_queued_request_cycles: N,
    /// Most memory-port requests waiting (requests).
    #[serde(default)]
    pub port_peak_queued: N,
    /// Read requests by latency `"cycles"` (requests).
    #[serde(default)]
    pub dram_read_latency: BTreeMap<String, N>,
    /// Write requests by latency `"cycles"` (requests).
    #[serde(default)]
    pub dram_write_latency: BTreeMap<String, N>,
    /// The DRAM backend's own counters (0 for `ideal`).
    #[serde(default)]
    pub dram_backend: DramBackendCounters<N>,
    /// Destination tile cache.
    pub dest_cache: DestCache<N>,
    /// Source cache.
    pub source_cache: SourceCache<N>,
    /// Destination tiles brought into the cache, per reference warp (tiles).
    pub tile_loads: Vec<N>,
    /// Destination tiles released and written back, per reference warp (tiles).
    pub tile_evictions: Vec<N>,
    /// Most destination tiles held at once, per reference warp (tiles).
    #[serde(default)]
    pub peak_tiles: Vec<N>,
    /// Tiles held when the warp's last line was set up, last written
    /// max(8, span/16) or more ring bands before its last live line, per reference warp (tiles).
    #[serde(default)]
    pub tiles_held_to_warp_end: Vec<N>,
    /// Stamps composited ahead of an older stamp in the miss queue (stamps).
    #[serde(default)]
    pub composite_bypasses: N,
    /// The working-set model's prediction per reference warp (tiles).
    #[serde(default)]
    pub ws_model_tiles: Vec<N>,
    /// Pixels of the derived frame (pixels).
    #[serde(default)]
    pub display_pixels: N,
    /// The references' size in A-buffer format, summed over the warps (bytes).
    #[serde(default)]
    pub reference_packed_bytes: N,
    /// The derived frame's size in A-buffer format after each warp (bytes).
    #[serde(default)]
    pub dest_packed_bytes: Vec<N>,
    /// Rectangles by drawn size `"WxH"` (rectangles).
    pub rects_by_size: BTreeMap<String, N>,
    /// Rectangles rasterized (rectangles).
    pub rects: N,
    /// Kernels set up (kernels).
    pub kernels: N,
    /// Kernels wider or taller than `kernel_limit` (kernels).
    pub kernels_over_limit: N,
    /// Reference samples streamed to the transform unit (samples).
    pub samples_transformed: N,
    /// Reference samples behind the derived camera (samples).
    pub culled_samples: N,
    /// Reference lines that may reach the derived image (lines).
    pub live_lines: N,
    /// Reference lines skipped as off-screen (lines).
    pub dead_lines: N,
    /// Composite verdicts (samples).
    pub composite: Composite<N>,
    /// Derived pixels by A-buffer fragments needed (pixels; index = fragments).
    pub fragments_per_pixel: Vec<N>,
    /// A-buffer merges forced by `abuffer_fragments` (merges).
    pub forced_merges: N,
    /// Derived samples holding hole fill at the end (samples).
    pub hole_samples: N,
    /// Derived samples with neither surface nor fill (samples).
    pub empty_samples: N,
    /// Hole samples filled, summed over passes (samples).
    pub hole_fill_filled: N,
    /// Hole samples no tap reached, summed over passes (samples).
    pub hole_fill_unreached: N,
    /// The fallback fill pass after the last warp. Absent from reports
    /// written before it (read as zeros).
    #[serde(default)]
    pub fallback: Fallback<N>,
    /// Per unit, busy, stall and idle cycles (cycles).
    pub units: Units<UnitCycles<N>>,
    /// Fixed mode only (`arith = "fixed"`): values that saturated, per
    /// stage (counts). Absent in float mode.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saturations: Option<SaturationCounts<N>>,
}

/// The fixed mode's saturations per stage (`FrameStats::saturations`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SaturationCounts<N> {
    /// Reference expansion (values).
    pub fetch: N,
    /// Transform, drawn kernels (values).
    pub transform: N,
    /// Kernel setup, drawn kernels' shared corners (values).
    pub kernel_setup: N,
    /// Raster, drawn kernels' derived slopes (values).
    pub raster: N,
    /// Hole fill and its fallback pass (values).
    pub hole_fill: N,
}

/// The hole fill's fallback pass (`units::fallback_fill`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Fallback<N> {
    /// Cycles of the pass (cycles).
    pub cycles: N,
    /// Samples visited: those of tiles holding an empty sample (samples).
    pub visits: N,
    /// Empty samples filled (samples).
    pub filled: N,
    /// Empty samples left empty (samples).
    pub unreached: N,
    /// Destination tiles brought into the cache (tiles).
    pub tile_loads: N,
    /// Destination tiles changed and written back (tiles).
    pub tiles_written: N,
    /// Display pixels holding a sample the pass filled (pixels).
    pub unseen_pixels: N,
}

impl HwCounters<u64> {
    /// The counters of one frame of the engine, on a channel of
    /// `burst_bytes`-byte bursts.
    pub fn of(s: &FrameStats, burst_bytes: u64) -> HwCounters<u64> {
        let u = |name: &str| {
            let i = UNITS.iter().position(|n| *n == name).expect("a unit of engine::UNITS");
            let c = &s.units[i];
            let [dram, tile, fifo_full, upstream] = c.stall_by_reason;
            UnitCycles {
                busy: c.busy,
                stall: c.stall,
                idle: c.idle,
                stall_by_reason: Some(StallReasons { dram, tile, fifo_full, upstream }),
            }
        };
        let d = &s.dest_cache;
        let mut rects_by_size = BTreeMap::new();
        for (w, row) in s.rects.iter().enumerate() {
            for (h, &n) in row.iter().enumerate() {
                if n > 0 {
                    rects_by_size.insert(format!("{w}x{h}"), n);
                }
            }
        }
        HwCounters {
            cycles: s.cycles,
            dram_read_bytes: s.dram.bytes_read,
            dram_write_bytes: s.dram.bytes_written,
            dram_bytes_by_client: ByClient::from_fn(|c| ReadWrite {
                read: s.dram.client_bytes_read[c.index()],
                write: s.dram.client_bytes_written[c.index()],
            }),
            dram_requests: s.dram.requests,
            dram_transactions: (s.dram.bytes_read + s.dram.bytes_written) / burst_bytes,
            dram_requested_bytes: s.dram.requested_bytes,
            dram_refused_cycles: s.dram.refused_cycles,
            dram_outstanding_cycles: s.dram.outstanding_cycles,
            dram_outstanding_request_cycles: s.dram.outstanding_request_cycles,
            dram_peak_outstanding: s.dram.peak_outstanding,
            port_queued_request_cycles: s.port_queued_request_cycles,
            port_peak_queued: s.port_peak_queued,
            dram_read_latency: super::dram::histogram_map(&s.dram.read_latency),
            dram_write_latency: super::dram::writes_of(&s.dram.latency, &s.dram.read_latency),
            dram_backend: DramBackendCounters::of(&s.dram_backend),
            dest_cache: DestCache {
                accesses: d.accesses,
                hits: d.hits,
                misses_compulsory: d.misses_compulsory,
                misses_demand: d.misses_demand,
                misses_late: d.misses_late,
                prefetches: d.prefetches,
                prefetch_drops: d.prefetch_drops,
                misses_capacity: d.misses_capacity,
                spills: d.spills,
            },
            source_cache: SourceCache {
                block_reads: s.source_cache.block_reads,
                evictions: s.source_cache.evictions,
                wait_cycles: s.source_cache.wait_cycles,
            },
            tile_loads: s.tile_loads.clone(),
            tile_evictions: s.tile_evictions.clone(),
            peak_tiles: s.peak_tiles.clone(),
            tiles_held_to_warp_end: s.tiles_held_to_warp_end.clone(),
            composite_bypasses: s.composite_bypasses,
            ws_model_tiles: s.ws_model_tiles.clone(),
            display_pixels: s.display_pixels,
            reference_packed_bytes: s.reference_packed_bytes,
            dest_packed_bytes: s.dest_packed_bytes.clone(),
            rects: rects_by_size.values().sum(),
            rects_by_size,
            kernels: s.kernels,
            kernels_over_limit: s.kernels_over_limit,
            samples_transformed: s.samples_transformed,
            culled_samples: s.culled_samples,
            live_lines: s.live_lines,
            dead_lines: s.dead_lines,
            composite: Composite {
                filled: s.composite[0],
                nearer: s.composite[1],
                better: s.composite[2],
                lost: s.composite[3],
            },
            fragments_per_pixel: s.fragments_per_pixel.clone(),
            forced_merges: s.forced_merges,
            hole_samples: s.hole_samples,
            empty_samples: s.empty_samples,
            hole_fill_filled: s.hole_fill_filled,
            hole_fill_unreached: s.hole_fill_unreached,
            fallback: Fallback {
                cycles: s.fallback_cycles,
                visits: s.fallback_visits,
                filled: s.fallback_filled,
                unreached: s.fallback_unreached,
                tile_loads: s.fallback_tile_loads,
                tiles_written: s.fallback_tiles_written,
                unseen_pixels: s.unseen_pixels,
            },
            saturations: s.saturations.map(|t| SaturationCounts {
                fetch: t.fetch,
                transform: t.transform,
                kernel_setup: t.kernel_setup,
                raster: t.raster,
                hole_fill: t.hole_fill,
            }),
            units: Units {
                fetch: u("fetch"),
                transform: u("transform"),
                kernel_setup: u("kernel_setup"),
                raster: u("raster"),
                composite: u("composite"),
                hole_fill: u("hole_fill"),
                abuffer: u("abuffer"),
            },
        }
    }

    /// The same counters as `f64` (for rates).
    pub fn as_f64(&self) -> HwCounters<f64> {
        serde_json::from_value(serde_json::to_value(self).expect("counters serialize")).expect("u64 reads as f64")
    }
}

/// Ratios and rates of a frame's counters (or of the mean counters),
/// derived at report time (module doc).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HwRates {
    /// Frames per second one warper sustains at the clock, every view (Hz).
    pub frame_rate_at_clock_hz: Option<f64>,
    /// DRAM bandwidth at the target frame rate, every view (GB/s).
    pub dram_gbps_at_target_rate: f64,
    /// The same per client, read + write (GB/s).
    pub dram_gbps_by_client: ByClient<f64>,
    /// DRAM bytes moved over the bytes the channel could move in the
    /// frame's cycles (fraction).
    pub dram_utilisation: Option<f64>,
    /// Destination-cache hits over accesses (fraction).
    pub dest_cache_hit_rate: Option<f64>,
    /// The largest, over the warps, of peak destination tiles over the
    /// working-set model's prediction (ratio).
    pub peak_over_ws_model: Option<f64>,
    /// DRAM bytes per pixel of the derived frame, per client, read + write
    /// (bytes/pixel).
    pub bytes_per_display_pixel: Option<ByClient<f64>>,
    /// The analytic floor of the same (`docs/warper-reference.md` §5):
    /// each reference read once in A-buffer format, the derived frame read
    /// before every warp but the first and written after each in A-buffer
    /// format, the display reading the last (bytes/pixel).
    pub floor_bytes_per_display_pixel: Option<ByClient<f64>>,
    /// Display pixels the fallback pass filled over display pixels: the
    /// never-seen share, apart from holes inside the image (fraction).
    pub unseen_fraction: Option<f64>,
    /// The DRAM rates (`super::dram`).
    #[serde(flatten)]
    pub dram: DramRates,
}

fn ratio(a: f64, b: f64) -> Option<f64> {
    (b > 0.0 && (a / b).is_finite()).then(|| a / b)
}

impl HwRates {
    /// The rates of counters `c` (one frame's, or the mean) under `cfg`.
    pub fn of(c: &HwCounters<f64>, cfg: &EngineConfig) -> HwRates {
        let views = cfg.views as f64;
        let gbps = |bytes: f64| bytes * views * cfg.target_frame_rate_hz / 1e9;
        let bytes = c.dram_read_bytes + c.dram_write_bytes;
        HwRates {
            frame_rate_at_clock_hz: ratio(cfg.clock_hz as f64, c.cycles * views),
            dram_gbps_at_target_rate: gbps(bytes),
            dram_gbps_by_client: ByClient {
                reference_fetch: gbps(
                    c.dram_bytes_by_client.reference_fetch.read + c.dram_bytes_by_client.reference_fetch.write,
                ),
                tile_fill: gbps(c.dram_bytes_by_client.tile_fill.read + c.dram_bytes_by_client.tile_fill.write),
                tile_write_back: gbps(
                    c.dram_bytes_by_client.tile_write_back.read + c.dram_bytes_by_client.tile_write_back.write,
                ),
                output: gbps(c.dram_bytes_by_client.output.read + c.dram_bytes_by_client.output.write),
            },
            dram_utilisation: ratio(bytes, c.cycles * cfg.dram_peak_bytes_per_cycle as f64),
            dest_cache_hit_rate: ratio(c.dest_cache.hits, c.dest_cache.accesses),
            peak_over_ws_model: c
                .peak_tiles
                .iter()
                .zip(&c.ws_model_tiles)
                .filter_map(|(&p, &m)| ratio(p, m))
                .fold(None, |a: Option<f64>, r| Some(a.map_or(r, |a| a.max(r)))),
            bytes_per_display_pixel: (c.display_pixels > 0.0).then(|| {
                let b = &c.dram_bytes_by_client;
                let per = |rw: &ReadWrite<f64>| (rw.read + rw.write) / c.display_pixels;
                ByClient {
                    reference_fetch: per(&b.reference_fetch),
                    tile_fill: per(&b.tile_fill),
                    tile_write_back: per(&b.tile_write_back),
                    output: per(&b.output),
                }
            }),
            floor_bytes_per_display_pixel: (c.display_pixels > 0.0 && !c.dest_packed_bytes.is_empty()).then(|| {
                let d = &c.dest_packed_bytes;
                let all: f64 = d.iter().sum();
                ByClient {
                    reference_fetch: c.reference_packed_bytes / c.display_pixels,
                    tile_fill: (all - d[d.len() - 1]) / c.display_pixels,
                    tile_write_back: all / c.display_pixels,
                    output: d[d.len() - 1] / c.display_pixels,
                }
            }),
            unseen_fraction: ratio(c.fallback.unseen_pixels, c.display_pixels),
            dram: DramRates::of(c, cfg),
        }
    }
}

fn read_write_keys() -> Vec<KeyDoc> {
    vec![
        scalar("read", "bytes", Reduce::Sum, "bytes the client read, rounded up to whole bursts"),
        scalar("write", "bytes", Reduce::Sum, "bytes the client wrote, rounded up to whole bursts"),
    ]
}

fn by_client_bytes_keys() -> Vec<KeyDoc> {
    vec![
        nested(
            "reference_fetch",
            Reduce::Sum,
            read_write_keys,
            "reference blocks read in A-buffer format by the fetch unit",
        ),
        nested(
            "tile_fill",
            Reduce::Sum,
            read_write_keys,
            "destination tiles read into the cache: compulsory loads (packed) and capacity reloads (raw)",
        ),
        nested(
            "tile_write_back",
            Reduce::Sum,
            read_write_keys,
            "destination tiles written from the cache: releases (packed) and spills (raw)",
        ),
        nested("output", Reduce::Sum, read_write_keys, "the display's read of the finished frame (packed)"),
    ]
}

fn dest_cache_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "accesses",
            "accesses",
            Reduce::Sum,
            "tile look-ups by the compositor (once per stamp and tile) and the hole fill (entering a tile, tap tiles); \
             retries after a wait and the packer's look-ups are not counted",
        ),
        scalar("hits", "accesses", Reduce::Sum, "look-ups that found the tile resident"),
        scalar(
            "misses_compulsory",
            "tiles",
            Reduce::Sum,
            "tiles loaded for their first use in a warp, by the schedule's prefetch or on demand \
             (`prefetches + misses_demand`)",
        ),
        scalar(
            "misses_demand",
            "accesses",
            Reduce::Sum,
            "look-ups that found a tile the schedule had not loaded (never prefetched, or prefetched and dropped \
             unused): loaded on demand; 0 when the prefetch covers every use",
        ),
        scalar(
            "misses_late",
            "accesses",
            Reduce::Sum,
            "look-ups that found the tile's load still in flight: a prefetch issued too late, or another unit's miss",
        ),
        scalar("prefetches", "tiles", Reduce::Sum, "tiles the schedule loaded ahead of their first use"),
        scalar(
            "prefetch_drops",
            "tiles",
            Reduce::Sum,
            "prefetched tiles dropped unused (clean: no write) to make room for a miss",
        ),
        scalar("misses_capacity", "accesses", Reduce::Sum, "use of a tile spilled earlier in the same warp"),
        scalar("spills", "tiles", Reduce::Sum, "tiles spilled raw to make room"),
    ]
}

fn source_cache_keys() -> Vec<KeyDoc> {
    vec![
        scalar("block_reads", "blocks", Reduce::Sum, "reference blocks read (demand and prefetch), over all warps"),
        scalar("evictions", "blocks", Reduce::Sum, "blocks evicted to make room"),
        scalar(
            "wait_cycles",
            "cycles",
            Reduce::Sum,
            "cycles the fetch unit waited for a block, including the idle cycles the engine skipped while waiting; at \
             most `units.fetch.stall` + `units.fetch.busy`",
        ),
    ]
}

fn composite_keys() -> Vec<KeyDoc> {
    vec![
        scalar("filled", "samples", Reduce::Sum, "candidate written over an empty or hole-fill sample"),
        scalar("nearer", "samples", Reduce::Sum, "candidate won the depth test"),
        scalar("better", "samples", Reduce::Sum, "candidate won the same-surface arbitration"),
        scalar("lost", "samples", Reduce::Sum, "candidate lost"),
    ]
}

fn unit_cycle_keys() -> Vec<KeyDoc> {
    vec![
        scalar("busy", "cycles", Reduce::Sum, "cycles the unit moved work"),
        scalar(
            "stall",
            "cycles",
            Reduce::Sum,
            "cycles it had work but waited (memory, a full FIFO, an upstream dependency)",
        ),
        scalar("idle", "cycles", Reduce::Sum, "cycles it had nothing to do"),
        nested(
            "stall_by_reason",
            Reduce::Sum,
            stall_reason_keys,
            "the stall cycles by reason (`docs/units.md`, per-unit accounting); they sum to `stall`",
        ),
    ]
}

fn stall_reason_keys() -> Vec<KeyDoc> {
    vec![
        scalar("dram", "cycles", Reduce::Sum, "waiting for DRAM data (a source block still in flight)"),
        scalar(
            "tile",
            "cycles",
            Reduce::Sum,
            "waiting for a destination tile (its load in flight, or no cache slot free)",
        ),
        scalar("fifo_full", "cycles", Reduce::Sum, "its output FIFO or queue full (back-pressure)"),
        scalar(
            "upstream",
            "cycles",
            Reduce::Sum,
            "waiting on an upstream dependency (next line, a tile not yet retired, an item in transit)",
        ),
    ]
}

fn units_keys() -> Vec<KeyDoc> {
    vec![
        nested("fetch", Reduce::Sum, unit_cycle_keys, "reference fetch and expand"),
        nested(
            "transform",
            Reduce::Sum,
            unit_cycle_keys,
            "transform pipeline (busy when fetch pushes; stalls when the pipeline is full)",
        ),
        nested(
            "kernel_setup",
            Reduce::Sum,
            unit_cycle_keys,
            "kernel setup (busy when it absorbs transformed samples or emits kernels)",
        ),
        nested("raster", Reduce::Sum, unit_cycle_keys, "rasterizer"),
        nested("composite", Reduce::Sum, unit_cycle_keys, "compositor"),
        nested(
            "hole_fill",
            Reduce::Sum,
            unit_cycle_keys,
            "hole-fill unit (stalls while waiting for retired or resident tiles)",
        ),
        nested("abuffer", Reduce::Sum, unit_cycle_keys, "A-buffer packer (busy while packing a released tile)"),
    ]
}

/// The rows of `saturations` (also the golden report's).
pub(super) fn saturation_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "fetch",
            "values",
            Reduce::Sum,
            "reference colour channels, 1/Z and slopes that saturated, and samples dropped for coordinates beyond \
             `q_ref_coord`, over every valid sample of each warped reference",
        ),
        scalar(
            "transform",
            "values",
            Reduce::Sum,
            "positions, derived 1/Z, E and edge corners of the drawn kernels that saturated",
        ),
        scalar("kernel_setup", "values", Reduce::Sum, "saturated shared corners used by the drawn kernels"),
        scalar("raster", "values", Reduce::Sum, "derived slopes of the drawn kernels that saturated"),
        scalar(
            "hole_fill",
            "values",
            Reduce::Sum,
            "hole-fill colours and weights that saturated, fallback pass included",
        ),
    ]
}

fn fallback_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "cycles",
            "cycles",
            Reduce::Sum,
            "cycles from the end of the last warp to the pass's last write-back queued (the hole fill and the packer \
             work, every other unit idle)",
        ),
        scalar("visits", "samples", Reduce::Sum, "samples the cursor visited: those of tiles holding an empty sample"),
        scalar("filled", "samples", Reduce::Sum, "empty samples the pass filled"),
        scalar("unreached", "samples", Reduce::Sum, "empty samples no tap reached (left empty, black)"),
        scalar(
            "tile_loads",
            "tiles",
            Reduce::Sum,
            "destination tiles brought into the cache by the pass (packed loads and reloads after a spill)",
        ),
        scalar("tiles_written", "tiles", Reduce::Sum, "destination tiles the pass changed, re-packed and wrote back"),
        scalar(
            "unseen_pixels",
            "pixels",
            Reduce::Sum,
            "display pixels holding a sample the pass filled: seen by no reference along the epipolar passes",
        ),
    ]
}

const fn list(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit, reduce: Reduce::Sum, shape: Shape::List, meaning }
}

/// The rows of [`HwCounters`], in field order.
pub fn counter_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "cycles",
            "cycles",
            Reduce::Sum,
            "engine cycles for the frame, from cycle 0 until the last display read completes (all warps, write-backs \
             and the display read)",
        ),
        scalar("dram_read_bytes", "bytes", Reduce::Sum, "DRAM bytes read, all clients, rounded up to whole bursts"),
        scalar("dram_write_bytes", "bytes", Reduce::Sum, "DRAM bytes written, all clients, rounded up to whole bursts"),
        nested("dram_bytes_by_client", Reduce::Sum, by_client_bytes_keys, "per DRAM client, `{read, write}` bytes"),
        scalar("dram_requests", "requests", Reduce::Sum, "DRAM requests accepted"),
        scalar(
            "dram_transactions",
            "transactions",
            Reduce::Sum,
            "DRAM bursts moved, reads and writes: `(dram_read_bytes + dram_write_bytes) / dram_burst_bytes`, one line or \
             packet each in a `--dram-trace` (docs/memory-layout.md), the count its replay reproduces",
        ),
    ]
    .into_iter()
    .chain(super::dram::counter_keys())
    .chain([
        nested("dest_cache", Reduce::Sum, dest_cache_keys, "destination tile cache counters"),
        nested("source_cache", Reduce::Sum, source_cache_keys, "source (reference) cache counters"),
        list(
            "tile_loads",
            "tiles",
            "per reference warp, in warp order: destination tiles brought into the cache, every compulsory miss plus \
             every reload of a spilled tile, including reloads by the A-buffer packer's and the hole-fill cursor's \
             look-ups (so with spills it can exceed `misses_compulsory + misses_capacity`); first-warp tiles are \
             cleared on chip and counted too",
        ),
        list(
            "tile_evictions",
            "tiles",
            "per reference warp: destination tiles released, packed to A-buffer format and written back (raw spills \
             not included)",
        ),
        KeyDoc {
            key: "peak_tiles",
            unit: "tiles",
            reduce: Reduce::Max,
            shape: Shape::List,
            meaning: "per reference warp: the most destination tiles held in the cache at once (resident or loading); \
                      the warp's working set when the cache is large enough not to spill",
        },
        list(
            "tiles_held_to_warp_end",
            "tiles",
            "per reference warp: destination tiles still held (loading, resident or spilled) when kernel setup set up \
             the warp's last line although their last write came max(8, span/16) ring bands before its last live line \
             (span: the ring bands its live lines cover): the hole fill could not follow the warp to them, so fill on eviction failed for them",
        ),
        scalar(
            "composite_bypasses",
            "stamps",
            Reduce::Sum,
            "stamps the compositor drew ahead of an older stamp waiting in its miss queue for a tile",
        ),
        KeyDoc {
            key: "ws_model_tiles",
            unit: "tiles",
            reduce: Reduce::Max,
            shape: Shape::List,
            meaning: "per reference warp: the working-set model of `docs/warper-reference.md` §5 with this warp's sweep \
                      width, roll and parallax spread (`rtl-model/src/working_set.rs`)",
        },
        scalar("display_pixels", "pixels", Reduce::Sum, "pixels of the derived frame"),
        scalar(
            "reference_packed_bytes",
            "bytes",
            Reduce::Sum,
            "the references' size in A-buffer format, summed over the warps (the reference fetch's floor; culling \
             off-screen lines can read less)",
        ),
        list(
            "dest_packed_bytes",
            "bytes",
            "per reference warp: the derived frame's size in A-buffer format after the warp's write-back",
        ),
        KeyDoc {
            key: "rects_by_size",
            unit: "rectangles",
            reduce: Reduce::Sum,
            shape: Shape::Map,
            meaning: "rasterized rectangles by drawn size, key `\"WxH\"` (columns x rows of sample centres after \
                      clipping to the stamp and the image; 8 = 8 or more); sizes that did not occur are absent",
        },
        scalar("rects", "rectangles", Reduce::Sum, "rectangles rasterized (sum of `rects_by_size`)"),
        scalar("kernels", "kernels", Reduce::Sum, "kernels set up"),
        scalar(
            "kernels_over_limit",
            "kernels",
            Reduce::Sum,
            "kernels wider or taller than `kernel_limit`, clipped to the stamp; counted before clipping to the image \
             (report version 1: `kernels_over_4x4`)",
        ),
        scalar(
            "samples_transformed",
            "samples",
            Reduce::Sum,
            "reference samples streamed to the transform unit, over all warps (border and neighbour-line samples \
             fetched by two sheets count twice)",
        ),
        scalar("culled_samples", "samples", Reduce::Sum, "reference samples on live lines behind the derived camera"),
        scalar(
            "live_lines",
            "lines",
            Reduce::Sum,
            "reference lines that may reach the derived image, summed over warps",
        ),
        scalar("dead_lines", "lines", Reduce::Sum, "reference lines skipped as off-screen, summed over warps"),
        nested("composite", Reduce::Sum, composite_keys, "composite verdicts, one per covered derived sample"),
        list(
            "fragments_per_pixel",
            "pixels",
            "histogram: derived pixels by A-buffer fragments needed before merging (index = count), over every tile \
             write-back of the frame",
        ),
        scalar(
            "forced_merges",
            "merges",
            Reduce::Sum,
            "A-buffer merges forced by `abuffer_fragments` in derived write-backs",
        ),
        scalar("hole_samples", "samples", Reduce::Sum, "derived samples holding hole fill at the end"),
        scalar(
            "empty_samples",
            "samples",
            Reduce::Sum,
            "derived samples with neither a surface nor fill at the end (output black)",
        ),
        scalar("hole_fill_filled", "samples", Reduce::Sum, "hole samples filled, summed over hole-fill passes"),
        scalar("hole_fill_unreached", "samples", Reduce::Sum, "hole samples no tap reached, summed over passes"),
        nested(
            "fallback",
            Reduce::Sum,
            fallback_keys,
            "the hole fill's fallback pass after the last warp (`fallback_fill`, `docs/units.md`); all 0 when no \
             sample was empty or the knob is off",
        ),
        nested(
            "units",
            Reduce::Sum,
            units_keys,
            "per unit (`engine::UNITS`), `{busy, stall, idle}` cycles (the three sum to `cycles`) and `stall_by_reason`",
        ),
        nested(
            "saturations",
            Reduce::Sum,
            saturation_keys,
            "fixed mode only (`arith = \"fixed\"`, absent in float mode): values that saturated their Q format, per \
             stage (`docs/fixed-point.md`)",
        ),
    ])
    .collect()
}

fn by_client_gbps_keys() -> Vec<KeyDoc> {
    by_client_bytes_keys().into_iter().map(|k| scalar(k.key, "GB/s", Reduce::Derived, k.meaning)).collect()
}

/// The rows of [`HwRates`], in field order.
pub fn rate_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "frame_rate_at_clock_hz",
            "Hz",
            Reduce::Derived,
            "`clock_hz / (cycles × views)`: frame rate one warper sustains for every view at the configured clock, for \
             the trace's frame size (`null` for 0 cycles)",
        ),
        scalar(
            "dram_gbps_at_target_rate",
            "GB/s",
            Reduce::Derived,
            "`(dram_read_bytes + dram_write_bytes) × views × target_frame_rate_hz / 1e9`, for the trace's frame size \
             (report version 1: `bandwidth_gbps_at_target_rate`; `dram_gbps_at_target_rate` in `results.csv`)",
        ),
        nested(
            "dram_gbps_by_client",
            Reduce::Derived,
            by_client_gbps_keys,
            "per DRAM client, `(read + write) × views × target_frame_rate_hz / 1e9`; they sum to \
             `dram_gbps_at_target_rate`",
        ),
        scalar(
            "dram_utilisation",
            "fraction",
            Reduce::Derived,
            "`(dram_read_bytes + dram_write_bytes) / (cycles × dram_peak_bytes_per_cycle)`: share of the channel's \
             peak the frame used over its cycles (`null` for 0 cycles)",
        ),
        scalar(
            "dest_cache_hit_rate",
            "fraction",
            Reduce::Derived,
            "`dest_cache.hits / dest_cache.accesses` (`null` without accesses; report version 1: `dest_cache.hit_rate`)",
        ),
        scalar(
            "peak_over_ws_model",
            "ratio",
            Reduce::Derived,
            "the largest over the warps of `peak_tiles / ws_model_tiles` (`null` without a prediction); about 1 when \
             the §5 model holds, far above it when the fill waits (an epipole inside the image)",
        ),
        nested(
            "bytes_per_display_pixel",
            Reduce::Derived,
            by_client_bytes_per_pixel_keys,
            "per DRAM client, `(read + write) / display_pixels` (`null` without pixels)",
        ),
        nested(
            "floor_bytes_per_display_pixel",
            Reduce::Derived,
            by_client_bytes_per_pixel_keys,
            "the analytic floor per client (`docs/warper-reference.md` §5): `reference_packed_bytes`, the derived \
             frame before every warp but the first (`dest_packed_bytes` but the last), after every warp (all of \
             `dest_packed_bytes`), and the display's read of the last, each over `display_pixels`; bursts not \
             rounded, so a run without spills can sit a little above it, and culling can read references below it",
        ),
        scalar(
            "unseen_fraction",
            "fraction",
            Reduce::Derived,
            "`fallback.unseen_pixels / display_pixels`: the share of the frame no reference saw along the epipolar \
             passes (a border strip), apart from the holes inside the image (`null` without pixels)",
        ),
    ]
    .into_iter()
    .chain(super::dram::rate_keys())
    .collect()
}

fn by_client_bytes_per_pixel_keys() -> Vec<KeyDoc> {
    by_client_bytes_keys().into_iter().map(|k| scalar(k.key, "bytes/pixel", Reduce::Derived, k.meaning)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::keys::find;

    /// Every field of the structs has its row, in field order, and rows
    /// describe nothing that is not a field.
    fn same_keys(v: &serde_json::Value, keys: &[KeyDoc], path: &str) {
        let m = v.as_object().unwrap();
        let fields: Vec<&str> = m.keys().map(String::as_str).collect();
        let rows: Vec<&str> = keys.iter().map(|k| k.key).collect();
        assert_eq!(fields, rows, "{path}: fields and key rows differ");
        for k in keys {
            if let Shape::Struct(sub) = k.shape {
                same_keys(&m[k.key], &sub(), &format!("{path}.{}", k.key));
            }
        }
    }

    #[test]
    fn every_field_has_a_row() {
        // Fixed mode's saturations present (absent in float mode).
        let stats = FrameStats { saturations: Some(Default::default()), ..FrameStats::default() };
        let c = HwCounters::of(&stats, 32);
        same_keys(&serde_json::to_value(&c).unwrap(), &counter_keys(), "counters");
        let rates = HwRates {
            bytes_per_display_pixel: Some(ByClient::default()),
            floor_bytes_per_display_pixel: Some(ByClient::default()),
            unseen_fraction: Some(0.0),
            dram: DramRates {
                dram_utilisation_by_client: Some(ByClient::default()),
                dram_read_latency_cycles: Some(Default::default()),
                dram_write_latency_cycles: Some(Default::default()),
                ..DramRates::default()
            },
            ..HwRates::default()
        };
        same_keys(&serde_json::to_value(rates).unwrap(), &rate_keys(), "rates");
        assert!(find(&counter_keys(), "kernels_over_limit").is_some());
    }

    #[test]
    fn rates_are_ratios_of_the_counters() {
        let mut c =
            HwCounters::<u64> { cycles: 1000, dram_read_bytes: 6000, dram_write_bytes: 2000, ..Default::default() };
        c.dram_bytes_by_client.tile_fill = ReadWrite { read: 6000, write: 2000 };
        c.dest_cache.accesses = 4;
        c.dest_cache.hits = 3;
        let cfg = EngineConfig::default();
        let r = HwRates::of(&c.as_f64(), &cfg);
        assert_eq!(r.frame_rate_at_clock_hz, Some(1e8 / 1000.0));
        assert_eq!(r.dram_gbps_at_target_rate, 8000.0 * 30.0 / 1e9);
        assert_eq!(r.dram_gbps_by_client.tile_fill, r.dram_gbps_at_target_rate);
        assert_eq!(r.dram_utilisation, Some(8000.0 / (1000.0 * 16.0)));
        assert_eq!(r.dest_cache_hit_rate, Some(0.75));
        assert_eq!((r.bytes_per_display_pixel, r.floor_bytes_per_display_pixel), (None, None), "no pixels");
        c.display_pixels = 100;
        c.reference_packed_bytes = 3000;
        c.dest_packed_bytes = vec![1000, 1500];
        let r = HwRates::of(&c.as_f64(), &cfg);
        let b = r.bytes_per_display_pixel.unwrap();
        assert_eq!((b.tile_fill, b.reference_fetch), (80.0, 0.0));
        let f = r.floor_bytes_per_display_pixel.unwrap();
        assert_eq!((f.reference_fetch, f.tile_fill, f.tile_write_back, f.output), (30.0, 10.0, 25.0, 15.0));
        assert_eq!(HwRates::of(&HwCounters::default(), &cfg).frame_rate_at_clock_hz, None);
    }
}
