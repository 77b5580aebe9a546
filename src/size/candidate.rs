//! One configuration `postwarp size` tries, run through `postwarp
//! simulate`'s code ([`measure_hardware`]) and reduced to what the search
//! needs.

use crate::run::simulate::measure_hardware;
use crate::sweep::point::Metrics;
use crate::trace::Trace;
use postwarp_rtl::config::{CACHE_BYTES_PER_SAMPLE, EngineConfig};
use serde::Serialize;

/// The search stage a candidate belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Super-samples and fragments against the quality floor.
    Quality,
    /// Destination cache and tile size against capacity misses.
    Cache,
}

/// A configuration tried and what it measured.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// Search stage.
    pub stage: Stage,
    /// Super-samples per pixel along each axis (samples).
    pub supersample: u32,
    /// A-buffer fragments per pixel in memory (fragments/pixel).
    pub abuffer_fragments: u32,
    /// Side of a destination tile (samples).
    pub tile_size: u32,
    /// Destination tile cache capacity (bytes).
    pub dest_cache_bytes: u64,
    /// Destination tile cache capacity (tiles of `tile_size`² × 16 B).
    pub dest_cache_tiles: u64,
    /// Mean luma PSNR against ground truth over the frames (dB).
    pub psnr_luma_db: Option<f64>,
    /// Mean luma SSIM over the frames (1).
    pub ssim_luma: Option<f64>,
    /// Destination-cache capacity misses over all frames (misses).
    pub capacity_misses: u64,
    /// Mean engine cycles per frame (cycles).
    pub cycles_per_frame: f64,
    /// Mean DRAM bytes read + written per frame (bytes).
    pub dram_bytes_per_frame: f64,
    /// DRAM bandwidth at the configuration's target frame rate (GB/s).
    pub dram_gbps_at_target_rate: f64,
    /// Frames per second at the configuration's clock (Hz).
    pub frame_rate_at_clock_hz: f64,
    /// Frames whose image equals the golden model's bit for bit (frames).
    pub golden_identical_frames: u64,
    /// Derived frames run (frames).
    pub frames: u64,
    /// Whether it passed its stage's test (quality floor; no capacity
    /// misses).
    pub passes: bool,
}

/// Tiles of a cache of `bytes` with `tile`-sample tiles.
pub fn cache_tiles(bytes: u64, tile: u32) -> u64 {
    bytes / (u64::from(tile).pow(2) * CACHE_BYTES_PER_SAMPLE)
}

/// Run `cfg` on `trace` (whose super-sampling it must have).
pub fn evaluate(stage: Stage, trace: &Trace, cfg: &EngineConfig) -> anyhow::Result<Candidate> {
    debug_assert_eq!(cfg.supersample, trace.display.supersample);
    let quiet = indicatif::ProgressBar::hidden();
    // Sizing reads PSNR and SSIM only: no FLIP.
    let r = measure_hardware(trace, cfg, false, None, &quiet)?;
    let m = Metrics::from_hardware_report(&r.report);
    let capacity_misses = r.report.total.counters.dest_cache.misses_capacity;
    let c = Candidate {
        stage,
        supersample: cfg.supersample,
        abuffer_fragments: cfg.abuffer_fragments,
        tile_size: cfg.tile_size,
        dest_cache_bytes: cfg.dest_cache_bytes,
        dest_cache_tiles: cache_tiles(cfg.dest_cache_bytes, cfg.tile_size),
        psnr_luma_db: m.psnr_luma_db,
        ssim_luma: m.ssim_luma,
        capacity_misses,
        cycles_per_frame: m.cycles_per_frame.unwrap_or(f64::NAN),
        dram_bytes_per_frame: m.dram_read_bytes_per_frame.unwrap_or(0.0) + m.dram_write_bytes_per_frame.unwrap_or(0.0),
        dram_gbps_at_target_rate: m.dram_gbps_at_target_rate.unwrap_or(f64::NAN),
        frame_rate_at_clock_hz: m.frame_rate_at_clock_hz.unwrap_or(f64::NAN),
        golden_identical_frames: m.golden_identical_frames.unwrap_or(0),
        frames: m.frames,
        passes: false,
    };
    eprintln!(
        "size: {:?} ss={} fragments={} tile={} cache={} B: psnr_luma {:.3} dB, {} capacity misses",
        stage,
        c.supersample,
        c.abuffer_fragments,
        c.tile_size,
        c.dest_cache_bytes,
        c.psnr_luma_db.unwrap_or(f64::NAN),
        c.capacity_misses
    );
    Ok(c)
}
