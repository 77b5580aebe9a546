//! Per-frame statistics of the hardware model, and their flat, described
//! form.
//!
//! Job: hold the raw counters one derived frame produced ([`FrameStats`])
//! and list every one of them as `(name, value)` with a declared unit and
//! description ([`FRAME_STATS`], [`FrameStats::flat`]), so that snapshots,
//! reports and docs read one list.
//!
//! Rules:
//! - Only raw counts; ratios are derived by reports.
//! - [`FrameStats::flat`] emits every counter, in a fixed order. Families
//!   indexed at run time (per warp, per rectangle size, per histogram value)
//!   emit one name per index, `family.index`; [`FRAME_STATS`] declares the
//!   family once with `<…>` in place of the index, and
//!   [`frame_stat_def`] finds a name's declaration.
//! - Zero-valued bins of sparse families (rectangle sizes, latency
//!   histogram) are not emitted; dense families (per warp, per unit) are.
//!
//! Not modelled: nothing (plain data).

use crate::mem::backend::BackendCounters;
use crate::mem::dram::DramCounters;
use crate::stats::StatDef;
use crate::units::StallReason;
pub use crate::units::UnitCycles;
use crate::units::fetch::SourceCacheCounters;
use crate::units::tile_cache::TileCacheCounters;

/// The units whose cycles are accounted, in report order.
pub const UNITS: [&str; 7] = ["fetch", "transform", "kernel_setup", "raster", "composite", "hole_fill", "abuffer"];

/// Index of the hole-fill unit in [`UNITS`] (its account in `units`).
pub const HOLE_FILL: usize = 5;
/// Index of the A-buffer packer in [`UNITS`].
pub const ABUFFER: usize = 6;
const _: () =
    assert!(matches!(UNITS[HOLE_FILL].as_bytes(), b"hole_fill") && matches!(UNITS[ABUFFER].as_bytes(), b"abuffer"));

/// Largest rectangle side tracked in [`FrameStats::rects`].
pub const RECT_HIST_MAX: usize = 8;

/// Counters of one derived frame (units in the field docs; ratios are
/// derived by reports).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Engine cycles from the first fetch to the last display read (cycles).
    pub cycles: u64,
    /// DRAM counters (bytes per client, requests, latency).
    pub dram: DramCounters,
    /// The DRAM backend's own counters (`mem::backend`; 0 for `ideal`).
    pub dram_backend: BackendCounters,
    /// Requests waiting in the memory port's queues at the end of each
    /// cycle, summed over the cycles (request-cycles).
    pub port_queued_request_cycles: u64,
    /// Most requests waiting in the memory port's queues at the end of a
    /// cycle (requests).
    pub port_peak_queued: u64,
    /// Destination tile cache counters.
    pub dest_cache: TileCacheCounters,
    /// Source cache counters, over all warps.
    pub source_cache: SourceCacheCounters,
    /// Destination tiles brought into the cache, per reference warp (tiles).
    pub tile_loads: Vec<u64>,
    /// Most destination tiles held at once (resident or loading), per
    /// reference warp (tiles).
    pub peak_tiles: Vec<u64>,
    /// Destination tiles released and written back, per reference warp (tiles).
    pub tile_evictions: Vec<u64>,
    /// Destination tiles still held when kernel setup finished the warp's
    /// last line although their last write came at least
    /// [`crate::engine::held_bands`] ring bands before the warp's last
    /// live line: the fill could not follow the warp to them (fill on
    /// eviction failed), per reference warp (tiles).
    pub tiles_held_to_warp_end: Vec<u64>,
    /// Stamps the compositor drew ahead of an older stamp waiting in its
    /// miss queue (stamps).
    pub composite_bypasses: u64,
    /// The working-set model's prediction (`docs/warper-reference.md` §5,
    /// [`crate::working_set`]), per reference warp (tiles).
    pub ws_model_tiles: Vec<u64>,
    /// Pixels of the derived frame (pixels).
    pub display_pixels: u64,
    /// The references' size in memory (A-buffer format), summed over the
    /// warps: the reference fetch's floor (bytes).
    pub reference_packed_bytes: u64,
    /// The derived frame's size in memory (A-buffer format) after each
    /// warp's write-back, per reference warp (bytes).
    pub dest_packed_bytes: Vec<u64>,
    /// Reference samples streamed to the transform unit, over all warps (samples).
    pub samples_transformed: u64,
    /// Reference samples behind the derived camera (samples).
    pub culled_samples: u64,
    /// Kernels set up (kernels).
    pub kernels: u64,
    /// Rectangles rasterized by drawn size: `rects[w][h]` (rectangles).
    pub rects: Vec<Vec<u64>>,
    /// Kernels wider or taller than the stamp, clipped (kernels).
    pub kernels_over_limit: u64,
    /// Reference lines with a kernel that may reach the derived image (lines).
    pub live_lines: u64,
    /// Reference lines skipped as off-screen (lines).
    pub dead_lines: u64,
    /// Composite verdicts: filled, nearer, better, lost (samples).
    pub composite: [u64; 4],
    /// Hole samples filled, summed over passes (samples).
    pub hole_fill_filled: u64,
    /// Hole samples no tap reached, summed over passes (samples).
    pub hole_fill_unreached: u64,
    /// Cycles of the fallback pass after the last warp (cycles).
    pub fallback_cycles: u64,
    /// Samples the fallback pass visited: those of tiles holding an empty
    /// sample (samples).
    pub fallback_visits: u64,
    /// Empty samples the fallback pass filled (samples).
    pub fallback_filled: u64,
    /// Empty samples the fallback pass could not reach (samples).
    pub fallback_unreached: u64,
    /// Destination tiles the fallback pass brought into the cache (tiles).
    pub fallback_tile_loads: u64,
    /// Destination tiles the fallback pass changed and wrote back (tiles).
    pub fallback_tiles_written: u64,
    /// Display pixels holding a sample the fallback pass filled (pixels).
    pub unseen_pixels: u64,
    /// Derived samples holding hole fill at the end (samples).
    pub hole_samples: u64,
    /// Derived samples with neither surface nor fill at the end (samples).
    pub empty_samples: u64,
    /// Derived pixels by A-buffer fragments needed, over every write-back
    /// of the frame (pixels; index = fragments).
    pub fragments_per_pixel: Vec<u64>,
    /// Merges forced by the fragment limit in derived write-backs (merges).
    pub forced_merges: u64,
    /// Per unit, in [`UNITS`] order.
    pub units: [UnitCycles; 7],
    /// Fixed mode only (`arith = "fixed"`; `None` in float mode): values
    /// that saturated their Q format, per stage (counts).
    pub saturations: Option<Saturations>,
}

/// Saturations of the fixed mode per stage (`docs/fixed-point.md`; counts
/// of values, over the sets both engines share).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Saturations {
    /// Reference expansion: colour channels, 1/Z, slopes of every valid
    /// sample of each warped reference, and samples dropped for their
    /// coordinates.
    pub fetch: u64,
    /// Transform: positions, derived 1/Z, `E` and edge corners of the
    /// drawn kernels.
    pub transform: u64,
    /// Kernel setup: saturated shared corners used by the drawn kernels.
    pub kernel_setup: u64,
    /// Raster: derived slopes of the drawn kernels.
    pub raster: u64,
    /// Hole fill (and its fallback pass): fill colours and weights.
    pub hole_fill: u64,
}

impl Saturations {
    /// The stages' names, in field order (`saturations.<stage>`).
    pub const STAGES: [&'static str; 5] = ["fetch", "transform", "kernel_setup", "raster", "hole_fill"];

    /// The counts in [`Saturations::STAGES`] order.
    pub fn values(&self) -> [u64; 5] {
        [self.fetch, self.transform, self.kernel_setup, self.raster, self.hole_fill]
    }
}

/// Composite verdict names, in [`FrameStats::composite`] order.
pub const COMPOSITE_VERDICTS: [&str; 4] = ["filled", "nearer", "better", "lost"];

/// Every counter [`FrameStats::flat`] emits, by family; `<…>` stands for
/// an index filled in at run time.
pub const FRAME_STATS: &[StatDef] = &[
    StatDef::counter("cycles", "cycles", "engine cycles from cycle 0 until the last display read completes"),
    StatDef::counter("dram.bytes_read", "bytes", "bytes read, all clients, rounded up to whole bursts"),
    StatDef::counter("dram.bytes_written", "bytes", "bytes written, all clients, rounded up to whole bursts"),
    StatDef::counter("dram.bytes_read.<client>", "bytes", "bytes read by one client, rounded up to whole bursts"),
    StatDef::counter("dram.bytes_written.<client>", "bytes", "bytes written by one client, rounded up to whole bursts"),
    StatDef::counter("dram.requests", "requests", "DRAM requests accepted"),
    StatDef::counter("dram.requested_bytes", "bytes", "bytes asked for, before rounding up to bursts"),
    StatDef::counter("dram.refused_cycles", "cycles", "cycles in which at least one DRAM request was refused"),
    StatDef::counter("dram.outstanding_cycles", "cycles", "cycles with at least one DRAM request outstanding"),
    StatDef::histogram("dram.latency.<cycles>", "cycles", "requests by cycles from acceptance to completion"),
    StatDef::counter(
        "dram.outstanding_request_cycles",
        "request-cycles",
        "DRAM requests outstanding, summed over cycles (mean occupancy = this / cycles)",
    ),
    StatDef::counter("dram.peak_outstanding", "requests", "most DRAM requests outstanding at once"),
    StatDef::histogram(
        "dram.read_latency.<cycles>",
        "cycles",
        "read requests by cycles from acceptance to completion (writes: dram.latency minus this)",
    ),
    StatDef::counter("dram.backend.dram_cycles", "DRAM cycles", "DRAM clock cycles the backend simulated (0: ideal)"),
    StatDef::counter(
        "dram.backend.peak_bytes",
        "bytes",
        "bytes the backend's DRAM data bus could have moved in those cycles, every channel (0: ideal)",
    ),
    StatDef::counter(
        "dram.backend.read_transactions",
        "transactions",
        "read transactions handed to the DRAM simulator (0: ideal)",
    ),
    StatDef::counter(
        "dram.backend.write_transactions",
        "transactions",
        "write transactions handed to the DRAM simulator (0: ideal)",
    ),
    StatDef::counter(
        "dram.backend.transaction_bytes",
        "bytes",
        "bytes of those transactions at the simulator's transaction size (0: ideal)",
    ),
    StatDef::counter("dram.backend.row_hits", "transactions", "transactions to the row open in their bank (0: ideal)"),
    StatDef::counter(
        "dram.backend.row_misses",
        "transactions",
        "transactions to a bank with no row open yet (0: ideal)",
    ),
    StatDef::counter(
        "dram.backend.row_conflicts",
        "transactions",
        "transactions to a bank with another row open (0: ideal)",
    ),
    StatDef::counter(
        "port.queued_request_cycles",
        "request-cycles",
        "requests waiting in the memory port's queues at the end of each cycle, summed over cycles",
    ),
    StatDef::counter("port.peak_queued", "requests", "most requests waiting in the memory port's queues"),
    StatDef::counter("dest_cache.accesses", "accesses", "destination-tile look-ups, each counted once"),
    StatDef::counter("dest_cache.hits", "accesses", "look-ups that found the tile resident"),
    StatDef::counter(
        "dest_cache.misses_compulsory",
        "tiles",
        "tiles loaded for their first use in a warp, by the schedule's prefetch or on demand",
    ),
    StatDef::counter(
        "dest_cache.misses_demand",
        "accesses",
        "look-ups that found a tile the schedule had not loaded: loaded on demand",
    ),
    StatDef::counter(
        "dest_cache.misses_late",
        "accesses",
        "look-ups that found the tile's load still in flight (a late prefetch or another unit's miss)",
    ),
    StatDef::counter("dest_cache.prefetches", "tiles", "tiles the schedule loaded ahead of their first use"),
    StatDef::counter(
        "dest_cache.prefetch_drops",
        "tiles",
        "prefetched tiles dropped unused (clean, no write) to make room for a miss",
    ),
    StatDef::counter("dest_cache.misses_capacity", "accesses", "use of a tile spilled earlier in the same warp"),
    StatDef::counter("dest_cache.spills", "tiles", "tiles spilled raw to make room"),
    StatDef::counter("source_cache.block_reads", "blocks", "reference block reads issued, over all warps"),
    StatDef::counter("source_cache.evictions", "blocks", "blocks evicted from the source cache to make room"),
    StatDef::counter("source_cache.wait_cycles", "cycles", "cycles the fetch unit waited for a block"),
    StatDef::counter("tile_loads.<warp>", "tiles", "destination tiles brought into the cache in one warp"),
    StatDef::counter(
        "peak_tiles.<warp>",
        "tiles",
        "most destination tiles held in the cache at once (resident or loading) in one warp",
    ),
    StatDef::counter(
        "ws_model_tiles.<warp>",
        "tiles",
        "the working-set model's prediction for one warp (docs/warper-reference.md §5)",
    ),
    StatDef::counter("display_pixels", "pixels", "pixels of the derived frame"),
    StatDef::counter(
        "reference_packed_bytes",
        "bytes",
        "the references' size in A-buffer format, summed over the warps",
    ),
    StatDef::counter(
        "dest_packed_bytes.<warp>",
        "bytes",
        "the derived frame's size in A-buffer format after one warp's write-back",
    ),
    StatDef::counter("tile_evictions.<warp>", "tiles", "destination tiles released and written back in one warp"),
    StatDef::counter(
        "tiles_held_to_warp_end.<warp>",
        "tiles",
        "tiles still held when the warp's last line was set up, last written max(8, span/16) or more ring bands before its last live line, span = ring bands of its live lines (fill on eviction failed)",
    ),
    StatDef::counter(
        "composite_bypasses",
        "stamps",
        "stamps composited ahead of an older stamp waiting in the miss queue",
    ),
    StatDef::counter("samples_transformed", "samples", "reference samples streamed to the transform unit"),
    StatDef::counter("culled_samples", "samples", "reference samples on live lines behind the derived camera"),
    StatDef::counter("kernels", "kernels", "kernels set up"),
    StatDef::counter("rects.<w>x<h>", "rectangles", "non-empty stamps of one drawn size (8 = 8 or more)"),
    StatDef::counter("kernels_over_limit", "kernels", "kernels wider or taller than kernel_limit, clipped"),
    StatDef::counter("live_lines", "lines", "reference lines that may reach the derived image, over warps"),
    StatDef::counter("dead_lines", "lines", "reference lines skipped as off-screen, over warps"),
    StatDef::counter("composite.<verdict>", "samples", "composite verdicts: filled, nearer, better, lost"),
    StatDef::counter("hole_fill_filled", "samples", "hole samples filled, summed over passes"),
    StatDef::counter("hole_fill_unreached", "samples", "hole samples no tap reached, summed over passes"),
    StatDef::counter("fallback_cycles", "cycles", "cycles of the fallback fill pass after the last warp"),
    StatDef::counter("fallback_visits", "samples", "samples the fallback pass visited (tiles holding an empty sample)"),
    StatDef::counter("fallback_filled", "samples", "empty samples the fallback pass filled"),
    StatDef::counter("fallback_unreached", "samples", "empty samples the fallback pass could not reach"),
    StatDef::counter("fallback_tile_loads", "tiles", "destination tiles the fallback pass brought into the cache"),
    StatDef::counter("fallback_tiles_written", "tiles", "destination tiles the fallback pass changed and wrote back"),
    StatDef::counter("unseen_pixels", "pixels", "display pixels holding a sample the fallback pass filled"),
    StatDef::counter("hole_samples", "samples", "derived samples holding hole fill at the end"),
    StatDef::counter("empty_samples", "samples", "derived samples with neither surface nor fill at the end"),
    StatDef::counter("fragments_per_pixel.<fragments>", "pixels", "derived pixels by A-buffer fragments needed"),
    StatDef::counter("forced_merges", "merges", "A-buffer merges forced by abuffer_fragments in write-backs"),
    StatDef::counter(
        "saturations.fetch",
        "values",
        "fixed mode only: reference colour channels, 1/Z and slopes that saturated, and samples dropped for their coordinates",
    ),
    StatDef::counter(
        "saturations.transform",
        "values",
        "fixed mode only: positions, derived 1/Z, E and edge corners of drawn kernels that saturated",
    ),
    StatDef::counter(
        "saturations.kernel_setup",
        "values",
        "fixed mode only: saturated shared corners used by drawn kernels",
    ),
    StatDef::counter("saturations.raster", "values", "fixed mode only: derived slopes of drawn kernels that saturated"),
    StatDef::counter(
        "saturations.hole_fill",
        "values",
        "fixed mode only: hole-fill colours and weights that saturated (fallback pass included)",
    ),
    StatDef::counter("units.<unit>.busy", "cycles", "cycles the unit moved work"),
    StatDef::counter("units.<unit>.stall", "cycles", "cycles the unit had work but waited"),
    StatDef::counter("units.<unit>.idle", "cycles", "cycles the unit had nothing to do"),
    StatDef::counter(
        "units.<unit>.stall.<reason>",
        "cycles",
        "stall cycles by reason: dram, tile, fifo_full, upstream (docs/stats.md)",
    ),
];

/// The declaration of a name [`FrameStats::flat`] emits: the family whose
/// pattern matches it, a `<…>` segment matching any one index.
pub fn frame_stat_def(name: &str) -> Option<&'static StatDef> {
    FRAME_STATS.iter().find(|d| pattern_matches(d.name, name))
}

fn pattern_matches(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<&str>, Vec<&str>) = (pattern.split('.').collect(), name.split('.').collect());
    p.len() == n.len()
        && p.iter().zip(&n).all(|(p, n)| {
            if p.contains(">x<") {
                // `<w>x<h>`: two indices around a literal `x`.
                n.split_once('x').is_some_and(|(a, b)| !a.is_empty() && !b.is_empty())
            } else if p.starts_with('<') {
                !n.is_empty()
            } else {
                p == n
            }
        })
}

impl FrameStats {
    /// Every counter as `(name, value)`, in a fixed order (module rules).
    pub fn flat(&self) -> Vec<(String, u64)> {
        let mut v: Vec<(String, u64)> = Vec::with_capacity(96);
        let mut put = |name: String, value: u64| v.push((name, value));
        put("cycles".into(), self.cycles);
        let d = &self.dram;
        put("dram.bytes_read".into(), d.bytes_read);
        put("dram.bytes_written".into(), d.bytes_written);
        for c in crate::mem::Client::ALL {
            put(format!("dram.bytes_read.{}", c.name()), d.client_bytes_read[c.index()]);
            put(format!("dram.bytes_written.{}", c.name()), d.client_bytes_written[c.index()]);
        }
        put("dram.requests".into(), d.requests);
        put("dram.requested_bytes".into(), d.requested_bytes);
        put("dram.refused_cycles".into(), d.refused_cycles);
        put("dram.outstanding_cycles".into(), d.outstanding_cycles);
        for (value, n) in d.latency.bins() {
            put(format!("dram.latency.{value}"), n);
        }
        put("dram.outstanding_request_cycles".into(), d.outstanding_request_cycles);
        put("dram.peak_outstanding".into(), d.peak_outstanding);
        for (value, n) in d.read_latency.bins() {
            put(format!("dram.read_latency.{value}"), n);
        }
        let b = &self.dram_backend;
        put("dram.backend.dram_cycles".into(), b.dram_cycles);
        put("dram.backend.peak_bytes".into(), b.peak_bytes);
        put("dram.backend.read_transactions".into(), b.read_transactions);
        put("dram.backend.write_transactions".into(), b.write_transactions);
        put("dram.backend.transaction_bytes".into(), b.transaction_bytes);
        put("dram.backend.row_hits".into(), b.row_hits);
        put("dram.backend.row_misses".into(), b.row_misses);
        put("dram.backend.row_conflicts".into(), b.row_conflicts);
        put("port.queued_request_cycles".into(), self.port_queued_request_cycles);
        put("port.peak_queued".into(), self.port_peak_queued);
        let c = &self.dest_cache;
        put("dest_cache.accesses".into(), c.accesses);
        put("dest_cache.hits".into(), c.hits);
        put("dest_cache.misses_compulsory".into(), c.misses_compulsory);
        put("dest_cache.misses_demand".into(), c.misses_demand);
        put("dest_cache.misses_late".into(), c.misses_late);
        put("dest_cache.prefetches".into(), c.prefetches);
        put("dest_cache.prefetch_drops".into(), c.prefetch_drops);
        put("dest_cache.misses_capacity".into(), c.misses_capacity);
        put("dest_cache.spills".into(), c.spills);
        let s = &self.source_cache;
        put("source_cache.block_reads".into(), s.block_reads);
        put("source_cache.evictions".into(), s.evictions);
        put("source_cache.wait_cycles".into(), s.wait_cycles);
        for (warp, &n) in self.tile_loads.iter().enumerate() {
            put(format!("tile_loads.{warp}"), n);
        }
        for (warp, &n) in self.peak_tiles.iter().enumerate() {
            put(format!("peak_tiles.{warp}"), n);
        }
        for (warp, &n) in self.ws_model_tiles.iter().enumerate() {
            put(format!("ws_model_tiles.{warp}"), n);
        }
        put("display_pixels".into(), self.display_pixels);
        put("reference_packed_bytes".into(), self.reference_packed_bytes);
        for (warp, &n) in self.dest_packed_bytes.iter().enumerate() {
            put(format!("dest_packed_bytes.{warp}"), n);
        }
        for (warp, &n) in self.tile_evictions.iter().enumerate() {
            put(format!("tile_evictions.{warp}"), n);
        }
        for (warp, &n) in self.tiles_held_to_warp_end.iter().enumerate() {
            put(format!("tiles_held_to_warp_end.{warp}"), n);
        }
        put("composite_bypasses".into(), self.composite_bypasses);
        put("samples_transformed".into(), self.samples_transformed);
        put("culled_samples".into(), self.culled_samples);
        put("kernels".into(), self.kernels);
        for (w, row) in self.rects.iter().enumerate() {
            for (h, &n) in row.iter().enumerate() {
                if n > 0 {
                    put(format!("rects.{w}x{h}"), n);
                }
            }
        }
        put("kernels_over_limit".into(), self.kernels_over_limit);
        put("live_lines".into(), self.live_lines);
        put("dead_lines".into(), self.dead_lines);
        for (verdict, &n) in COMPOSITE_VERDICTS.iter().zip(&self.composite) {
            put(format!("composite.{verdict}"), n);
        }
        put("hole_fill_filled".into(), self.hole_fill_filled);
        put("hole_fill_unreached".into(), self.hole_fill_unreached);
        put("fallback_cycles".into(), self.fallback_cycles);
        put("fallback_visits".into(), self.fallback_visits);
        put("fallback_filled".into(), self.fallback_filled);
        put("fallback_unreached".into(), self.fallback_unreached);
        put("fallback_tile_loads".into(), self.fallback_tile_loads);
        put("fallback_tiles_written".into(), self.fallback_tiles_written);
        put("unseen_pixels".into(), self.unseen_pixels);
        put("hole_samples".into(), self.hole_samples);
        put("empty_samples".into(), self.empty_samples);
        for (k, &n) in self.fragments_per_pixel.iter().enumerate() {
            put(format!("fragments_per_pixel.{k}"), n);
        }
        put("forced_merges".into(), self.forced_merges);
        if let Some(sat) = &self.saturations {
            for (stage, n) in Saturations::STAGES.iter().zip(sat.values()) {
                put(format!("saturations.{stage}"), n);
            }
        }
        for (name, u) in UNITS.iter().zip(&self.units) {
            put(format!("units.{name}.busy"), u.busy);
            put(format!("units.{name}.stall"), u.stall);
            put(format!("units.{name}.idle"), u.idle);
            for r in StallReason::ALL {
                put(format!("units.{name}.stall.{}", r.name()), u.stall_by_reason[r.index()]);
            }
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_flat_name_is_declared_once() {
        let mut s = FrameStats {
            tile_loads: vec![3, 4],
            tile_evictions: vec![3, 4],
            rects: vec![vec![0; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1],
            fragments_per_pixel: vec![1, 2, 3],
            saturations: Some(Saturations { raster: 7, ..Saturations::default() }),
            ..FrameStats::default()
        };
        s.rects[2][3] = 5;
        s.dram.latency.record(17);
        let flat = s.flat();
        for (name, _) in &flat {
            let matches = FRAME_STATS.iter().filter(|d| pattern_matches(d.name, name)).count();
            assert_eq!(matches, 1, "{name} matches {matches} declarations");
        }
        assert!(flat.contains(&("rects.2x3".to_string(), 5)));
        assert!(flat.contains(&("dram.latency.17".to_string(), 1)));
        assert!(flat.contains(&("tile_loads.1".to_string(), 4)));
        assert!(flat.contains(&("saturations.raster".to_string(), 7)));
        let float = FrameStats { saturations: None, ..s.clone() }.flat();
        assert!(!float.iter().any(|(n, _)| n.starts_with("saturations.")), "float mode has none");
        assert_eq!(frame_stat_def("units.raster.stall").map(|d| d.unit), Some("cycles"));
        assert!(frame_stat_def("units.raster").is_none());
        assert!(frame_stat_def("rects.23").is_none());
    }
}
