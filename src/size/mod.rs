//! `postwarp size`: the smallest hardware configuration whose output meets
//! a quality floor, with the cycles and DRAM bandwidth it needs ("model no
//! more than the scene needs"). `docs/size.md`.
//!
//! Rules (the definition of *smallest*):
//! 1. Among the knobs searched, only super-samples (`supersample`) and
//!    A-buffer fragments per pixel (`abuffer_fragments`) change the image; the
//!    destination cache (`dest_cache_bytes`) and the tile size
//!    (`tile_size`) change cost only (the hardware image is the golden
//!    model's whatever they are; every cache-stage candidate is checked to
//!    be bit-identical to the golden model and to score exactly the
//!    quality-stage result).
//! 2. Quality stage: candidates in the order super-samples ascending
//!    ([`variants::SUPERSAMPLES`]), then fragments ascending from 1 to
//!    min(4, supersample²) (more fragments than samples per pixel cannot
//!    change anything). `abuffer_fragments = 0` (no A-buffer, samples stored
//!    raw) is not tried: it is lossless but stores every sample, so it is
//!    not smaller hardware. The first candidate whose mean luma PSNR (and
//!    mean luma SSIM, if a floor is given) over the frames meets the floor
//!    is chosen; later ones are not run.
//! 3. Cache stage, for the chosen (supersample, fragments) and each tile
//!    size in {4, 8, 16} samples that is a multiple of the super-sampling
//!    and at least the preset's `kernel_limit`: caches of 8, 16, 32, …
//!    tiles (powers of two; 8 tiles is the engine's minimum), up to the
//!    first power of two holding every tile of the frame, are tried in
//!    order; the smallest with no capacity misses over all frames (the
//!    cache holds the working set) is that tile size's cache. With
//!    `--max-dram-overhead F` (a fraction, default 0), a smaller cache of
//!    the same search also passes if its DRAM bytes per frame are at most
//!    (1 + F) times the miss-free cache's: capacity misses are then
//!    accepted as long as the traffic they add stays within F.
//! 4. The configuration is the tile size whose cache has the fewest bytes;
//!    ties: fewer DRAM bytes per frame, then the smaller tile. Every other
//!    knob is the preset's.
//! 5. Quality and cost are means over the trace's derived frames
//!    (`--frames N`: the first N), as `postwarp simulate` reports them;
//!    the result is deterministic.

pub mod candidate;
pub mod output;
pub mod variants;

use anyhow::{anyhow, bail};
use candidate::{Candidate, Stage, cache_tiles, evaluate};
use postwarp_rtl::config::{CACHE_BYTES_PER_SAMPLE, EngineConfig};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use variants::{SsSource, ss_traces};

/// Tile sizes tried (samples).
pub const TILE_SIZES: &[u32] = &[4, 8, 16];
/// Most fragments per pixel tried (fragments/pixel).
pub const MAX_FRAGMENTS_TRIED: u32 = 4;
/// Fewest tiles the destination cache may hold (tiles; `EngineConfig::validate`).
pub const MIN_CACHE_TILES: u64 = 8;

/// The quality floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Floor {
    /// Least mean luma PSNR against ground truth (dB).
    pub min_psnr_db: f64,
    /// Least mean luma SSIM (1), if given.
    pub min_ssim: Option<f64>,
}

impl Floor {
    /// Check the values; the message names the flag.
    pub fn validate(&self) -> anyhow::Result<()> {
        let p = self.min_psnr_db;
        if !(p.is_finite() && p >= 0.0) {
            bail!("--min-psnr {p}: expected a PSNR of 0 dB or more");
        }
        if let Some(s) = self.min_ssim
            && !(s.is_finite() && (0.0..=1.0).contains(&s))
        {
            bail!("--min-ssim {s}: expected an SSIM from 0 to 1");
        }
        Ok(())
    }

    /// Whether a candidate's quality meets the floor.
    pub fn met(&self, c: &Candidate) -> bool {
        c.psnr_luma_db.is_some_and(|p| p >= self.min_psnr_db)
            && self.min_ssim.is_none_or(|s| c.ssim_luma.is_some_and(|q| q >= s))
    }

    /// The floor as text.
    pub fn describe(&self) -> String {
        match self.min_ssim {
            None => format!("mean luma PSNR >= {} dB", self.min_psnr_db),
            Some(s) => format!("mean luma PSNR >= {} dB and mean luma SSIM >= {s}", self.min_psnr_db),
        }
    }
}

/// What `postwarp size` is asked.
#[derive(Clone, Debug)]
pub struct Options {
    /// The trace.
    pub trace: PathBuf,
    /// The quality floor.
    pub floor: Floor,
    /// Preset the other knobs come from.
    pub preset: String,
    /// Derived frames used (the first N), or all.
    pub frames: Option<usize>,
    /// Where regenerated traces are cached (`cache_dir/traces/`).
    pub cache_dir: PathBuf,
    /// DRAM traffic a smaller cache may add over the miss-free one
    /// (fraction of its DRAM bytes per frame; 0 = no capacity misses).
    pub max_dram_overhead: f64,
}

/// The answer.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The trace as given.
    pub trace: PathBuf,
    /// The floor.
    pub floor: Floor,
    /// Preset of the other knobs.
    pub preset: String,
    /// Super-samplings available and where they came from.
    pub supersamples: Vec<u32>,
    /// Where they came from.
    pub ss_source: SsSource,
    /// Every candidate run, in order.
    pub candidates: Vec<Candidate>,
    /// The chosen configuration (`None`: nothing met the floor).
    pub chosen: Option<usize>,
    /// The chosen configuration in full.
    pub config: Option<EngineConfig>,
    /// Its SRAM and arithmetic budget, for the frame and references of the
    /// trace it was scored on (`docs/budget.md`).
    pub budget: Option<postwarp_rtl::budget::Budget>,
    /// The trace each super-sampling was run on: (samples, directory).
    pub trace_dirs: Vec<(u32, PathBuf)>,
    /// The ground truth every candidate was scored against: the trace
    /// whose truth it is, and the super-sampling it was rendered at
    /// (`variants` rule 3).
    pub truth: (u32, PathBuf),
    /// The trace's own super-sampling (samples).
    pub own_supersample: u32,
    /// The output folder (`--out`), if any: paths under it are named
    /// relative to it in the files written there.
    pub out: Option<PathBuf>,
}

impl Outcome {
    /// The trace the chosen configuration was scored on.
    pub fn scored_on(&self) -> Option<&Path> {
        let ss = self.config.as_ref()?.supersample;
        self.trace_dirs.iter().find(|(s, _)| *s == ss).map(|(_, d)| d.as_path())
    }

    /// Every path under `from` named as under `to` instead (a folder built
    /// under a temporary name, then renamed).
    pub fn relocate(&mut self, from: &Path, to: &Path) {
        let fix = |p: &mut PathBuf| {
            if let Ok(rest) = p.strip_prefix(from) {
                *p = to.join(rest);
            }
        };
        for (_, d) in &mut self.trace_dirs {
            fix(d);
        }
        fix(&mut self.truth.1);
        if let SsSource::Regenerated { cache, .. } = &mut self.ss_source {
            fix(cache);
        }
    }
}

impl Outcome {
    /// The best quality candidate (highest PSNR; first on ties).
    pub fn best_quality(&self) -> Option<&Candidate> {
        self.candidates.iter().filter(|c| c.stage == Stage::Quality).fold(None, |b: Option<&Candidate>, c| match b {
            Some(b) if b.psnr_luma_db.unwrap_or(f64::NEG_INFINITY) >= c.psnr_luma_db.unwrap_or(f64::NEG_INFINITY) => {
                Some(b)
            }
            _ => Some(c),
        })
    }
}

/// Tiles of a frame of `trace` with `tile`-sample tiles.
fn frame_tiles(trace: &crate::trace::Trace, tile: u32) -> u64 {
    let ss = trace.display.supersample;
    let w = u64::from(trace.display.width * ss).div_ceil(u64::from(tile));
    let h = u64::from(trace.display.height * ss).div_ceil(u64::from(tile));
    w * h
}

/// Run the search (module rules).
pub fn run_size(o: &Options) -> anyhow::Result<Outcome> {
    o.floor.validate()?;
    let base = EngineConfig::preset(&o.preset).map_err(|e| anyhow!("--preset: {e}"))?;
    let (traces, ss_source) = ss_traces(&o.trace, o.frames, &o.cache_dir)?;
    if traces[0].trace.derived.iter().any(|f| f.truth.is_none()) {
        bail!(
            "{}: the trace has no ground truth for every derived frame, so its quality cannot be scored",
            o.trace.display()
        );
    }
    let mut out = Outcome {
        trace: o.trace.clone(),
        floor: o.floor,
        preset: o.preset.clone(),
        supersamples: traces.iter().map(|t| t.supersample).collect(),
        ss_source,
        candidates: Vec::new(),
        chosen: None,
        config: None,
        budget: None,
        trace_dirs: traces.iter().map(|t| (t.supersample, t.dir.clone())).collect(),
        truth: {
            let hi = traces.last().expect("at least the trace itself");
            (hi.supersample, hi.dir.clone())
        },
        own_supersample: traces
            .iter()
            .find(|t| !t.dir.starts_with(&o.cache_dir))
            .map_or(traces[0].supersample, |t| t.supersample),
        out: None,
    };
    // Quality stage (rule 2).
    let mut found = None;
    'search: for t in &traces {
        for f in 1..=MAX_FRAGMENTS_TRIED.min(t.supersample * t.supersample) {
            let mut cfg = base.clone();
            cfg.supersample = t.supersample;
            cfg.abuffer_fragments = f;
            cfg.validate().map_err(|e| anyhow!("hardware configuration: {e}"))?;
            let mut c = evaluate(Stage::Quality, &t.trace, &cfg)?;
            c.passes = o.floor.met(&c);
            let pass = c.passes;
            out.candidates.push(c);
            if pass {
                found = Some((t, cfg, out.candidates.len() - 1));
                break 'search;
            }
        }
    }
    let Some((t, qcfg, qi)) = found else { return Ok(out) };
    let quality = out.candidates[qi].clone();
    // Cache stage (rule 3), one search per tile size, in parallel.
    let tiles: Vec<u32> =
        TILE_SIZES.iter().copied().filter(|&s| s % t.supersample == 0 && s >= base.kernel_limit).collect();
    if tiles.is_empty() {
        bail!("no tile size of {TILE_SIZES:?} is a multiple of {} and at least kernel_limit", t.supersample);
    }
    let searches: Vec<anyhow::Result<Vec<Candidate>>> = tiles
        .par_iter()
        .map(|&tile| {
            let cap = frame_tiles(&t.trace, tile).max(MIN_CACHE_TILES).next_power_of_two();
            let mut tried = Vec::new();
            let mut n = MIN_CACHE_TILES;
            while n <= cap {
                let mut cfg = qcfg.clone();
                cfg.tile_size = tile;
                cfg.dest_cache_bytes = n * u64::from(tile).pow(2) * CACHE_BYTES_PER_SAMPLE;
                cfg.validate().map_err(|e| anyhow!("hardware configuration: {e}"))?;
                let mut c = evaluate(Stage::Cache, &t.trace, &cfg)?;
                check_same_image(&c, &quality)?;
                c.passes = c.capacity_misses == 0;
                let pass = c.passes;
                tried.push(c);
                if pass {
                    break;
                }
                n *= 2;
            }
            // Rule 3 with a DRAM allowance: against the miss-free cache's
            // traffic (the last one tried, if it is miss-free).
            if o.max_dram_overhead > 0.0 {
                if let Some(d0) = tried.last().filter(|c| c.capacity_misses == 0).map(|c| c.dram_bytes_per_frame) {
                    for c in &mut tried {
                        c.passes = c.dram_bytes_per_frame <= (1.0 + o.max_dram_overhead) * d0;
                    }
                }
            }
            Ok(tried)
        })
        .collect();
    let mut best: Option<usize> = None;
    for s in searches {
        for c in s? {
            out.candidates.push(c);
            let i = out.candidates.len() - 1;
            let c = &out.candidates[i];
            if !c.passes {
                continue;
            }
            let better = match best {
                None => true,
                Some(b) => {
                    let b = &out.candidates[b];
                    (c.dest_cache_bytes, c.dram_bytes_per_frame, c.tile_size).partial_cmp(&(
                        b.dest_cache_bytes,
                        b.dram_bytes_per_frame,
                        b.tile_size,
                    )) == Some(std::cmp::Ordering::Less)
                }
            };
            if better {
                best = Some(i);
            }
        }
    }
    let Some(b) = best else {
        bail!("no cache of up to a whole frame of tiles avoided capacity misses (tile sizes {tiles:?})")
    };
    let c = &out.candidates[b];
    let mut cfg = qcfg;
    cfg.tile_size = c.tile_size;
    cfg.dest_cache_bytes = c.dest_cache_bytes;
    debug_assert_eq!(cache_tiles(cfg.dest_cache_bytes, cfg.tile_size), c.dest_cache_tiles);
    out.chosen = Some(b);
    let sizes = crate::report::budget::trace_sizes(&t.trace, cfg.supersample);
    out.budget = Some(postwarp_rtl::budget::Budget::sized(&cfg, sizes));
    out.config = Some(cfg);
    Ok(out)
}

/// Rule 1's check: a cache-stage run makes the quality stage's image.
fn check_same_image(c: &Candidate, q: &Candidate) -> anyhow::Result<()> {
    if c.golden_identical_frames != c.frames || c.psnr_luma_db != q.psnr_luma_db || c.ssim_luma != q.ssim_luma {
        bail!(
            "internal check failed: tile_size {} with a {} B cache changed the image (PSNR {:?} dB against {:?} dB, {} of {} frames identical to the golden model); the cache must change cost only",
            c.tile_size,
            c.dest_cache_bytes,
            c.psnr_luma_db,
            q.psnr_luma_db,
            c.golden_identical_frames,
            c.frames
        );
    }
    Ok(())
}

/// `run_size`, then the files of [`output`] in `out_dir` (if given), the
/// paths they name shown as under `shown_dir` (the final folder, when
/// `out_dir` is its temporary name).
pub fn size_and_write(o: &Options, out_dir: Option<(&Path, &Path)>) -> anyhow::Result<Outcome> {
    let mut r = run_size(o)?;
    if let Some((d, shown)) = out_dir {
        r.relocate(d, shown);
        r.out = Some(shown.to_path_buf());
        output::write_files(&r, d)?;
    }
    Ok(r)
}
