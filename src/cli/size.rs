//! `postwarp size`: the smallest hardware configuration meeting a quality
//! floor (docs/size.md).

use crate::size::{Floor, Options, output, size_and_write};
use anyhow::bail;
use std::path::PathBuf;

/// Flags of `postwarp size` (the definition of smallest is the
/// subcommand's help, `src/cli/mod.rs`, and `docs/size.md`).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest); needs ground truth.
    pub trace: PathBuf,
    /// Quality floor: least mean luma PSNR against ground truth (dB, >= 0).
    #[arg(long, allow_negative_numbers = true)]
    pub min_psnr: f64,
    /// Also a least mean luma SSIM (0 to 1).
    #[arg(long, allow_negative_numbers = true)]
    pub min_ssim: Option<f64>,
    /// Output directory: config.toml, size.json, candidates.csv, and
    /// traces/ (traces rendered at other super-samplings, reused by later
    /// runs). Without it those traces are cached in the system's
    /// temporary directory (postwarp-size/traces/). Must not exist unless
    /// --force (checked before any work); written under a temporary name
    /// beside it and renamed when complete.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace --out if it exists (its traces/ cache is kept and reused;
    /// everything else is replaced, not mixed).
    #[arg(long, requires = "out")]
    pub force: bool,
    /// Preset of every other knob: mark1998 (default), hmd2026 or fixed-minimal (`docs/precision.md`).
    #[arg(long, default_value = "mark1998")]
    pub preset: String,
    /// Use the first N derived frames (frames).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Accept a smaller destination cache with capacity misses if its DRAM
    /// bytes per frame are at most (1 + F) times the miss-free cache's
    /// (fraction, >= 0; 0 = the cache must hold the working set).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub max_dram_overhead: f64,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let floor = Floor { min_psnr_db: a.min_psnr, min_ssim: a.min_ssim };
    floor.validate()?;
    if !a.trace.exists() {
        bail!("{}: no such trace (expected a trace directory or its postwarp.trace)", a.trace.display());
    }
    if !(a.max_dram_overhead.is_finite() && a.max_dram_overhead >= 0.0) {
        bail!(
            "--max-dram-overhead {}: expected a fraction >= 0 (0.25 = 25 % more DRAM bytes than the miss-free cache)",
            a.max_dram_overhead
        );
    }
    // --out is checked before any work.
    let out = match &a.out {
        Some(d) => Some(crate::io_util::OutDir::create(d, a.force, &[&a.trace])?),
        None => None,
    };
    // Traces rendered at other super-samplings are cached in the old
    // folder if there is one (--force), else in the new one.
    let old_cache = out.as_ref().map(|o| o.target().to_path_buf()).filter(|t| t.join("traces").is_dir());
    let cache_dir = match (&out, &old_cache) {
        (_, Some(t)) => t.clone(),
        (Some(o), None) => o.path().to_path_buf(),
        (None, _) => std::env::temp_dir().join("postwarp-size"),
    };
    let o = Options {
        trace: a.trace,
        floor,
        preset: a.preset,
        frames: a.frames,
        cache_dir: cache_dir.clone(),
        max_dram_overhead: a.max_dram_overhead,
    };
    let written = out.as_ref().map(|d| (d.path(), d.target()));
    let mut r = size_and_write(&o, written)?;
    if let Some(d) = out {
        if let Some(old) = &old_cache {
            r.relocate(old, d.target());
            let (from, to) = (old.join("traces"), d.path().join("traces"));
            std::fs::rename(&from, &to).map_err(|e| {
                anyhow::anyhow!("moving the trace cache {} into the new {}: {e}", from.display(), to.display())
            })?;
        }
        let dir = d.commit()?;
        print!("{}", output::text(&r));
        // config.toml only when a configuration was found (`write_files`).
        let files = ["config.toml", "size.json", "candidates.csv"].into_iter().filter(|f| dir.join(f).is_file());
        println!("files: {}", files.map(|f| dir.join(f).display().to_string()).collect::<Vec<_>>().join(", "));
    } else {
        print!("{}", output::text(&r));
    }
    if r.chosen.is_none() {
        let best = r.best_quality();
        bail!(
            "no configuration meets the floor ({}): the best mean luma PSNR reached is {:.3} dB (SSIM {:.4}) with supersample = {}, abuffer_fragments = {}",
            r.floor.describe(),
            best.and_then(|b| b.psnr_luma_db).unwrap_or(f64::NAN),
            best.and_then(|b| b.ssim_luma).unwrap_or(f64::NAN),
            best.map_or(0, |b| b.supersample),
            best.map_or(0, |b| b.abuffer_fragments)
        );
    }
    Ok(())
}
