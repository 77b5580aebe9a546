//! `postwarp golden`: the golden model on a trace.

use crate::golden::config::{GoldenConfig, OverLimit, Reconstruction, WarpOrder};
use crate::run::golden::run_golden;
use crate::trace::Trace;
use std::path::PathBuf;

/// Flags of `postwarp golden`. Knob flags override `--config`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest).
    pub trace: PathBuf,
    /// Output directory: frame-NNNN.png/.exr, holes-NNNN.png, diff-NNNN.png,
    /// report.json (must not exist, unless --force; written under a
    /// temporary name beside it and renamed when complete).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
    /// Golden-model knobs as TOML (keys as in docs/golden.md).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Discontinuity threshold, as a ratio of the expected spacing (TR98: 1.4 to 2.3) [default: 1.4].
    #[arg(long)]
    pub threshold: Option<f64>,
    /// A-buffer fragments per pixel between warps (0 = no A-buffer) [default: 3].
    #[arg(long)]
    pub abuffer_fragments: Option<u32>,
    /// Disable the epipolar hole fill.
    #[arg(long)]
    pub no_hole_fill: bool,
    /// Disable the fallback fill after the last warp (samples no epipolar
    /// pass reached stay empty, black).
    #[arg(long)]
    pub no_fallback_fill: bool,
    /// Kernels larger than 4x4: clip (hardware) or allow [default: clip].
    #[arg(long, value_enum)]
    pub over_limit: Option<OverLimit>,
    /// Warp traversal order [default: reverse].
    #[arg(long, value_enum)]
    pub warp_order: Option<WarpOrder>,
    /// Reconstruction: anti-aliased rectangles or mesh + edge splats [default: aa-rect].
    #[arg(long, value_enum)]
    pub reconstruction: Option<Reconstruction>,
    /// Run a comparison method instead of the configured golden model
    /// (`postwarp methods` lists them; `mark-aa` and `mark-general` are the
    /// golden model's defaults behind the same interface).
    #[arg(long)]
    pub method: Option<String>,
    /// Hole fill to combine with `--method` [default: the one its paper uses].
    #[arg(long, requires = "method")]
    pub hole_fill: Option<String>,
    /// Runs per frame with `--method`; `host_ms` is their median.
    #[arg(long, default_value_t = 3, requires = "method")]
    pub runs: u32,
    /// Also score FLIP (`flip_mean`, `flip_mean_common`; otherwise null):
    /// two single-threaded evaluations per frame, the costliest metric.
    #[arg(long)]
    pub flip: bool,
}

/// True if any golden knob flag or `--config` was given.
fn knobs_given(a: &Args) -> bool {
    a.config.is_some()
        || a.threshold.is_some()
        || a.abuffer_fragments.is_some()
        || a.no_hole_fill
        || a.no_fallback_fill
        || a.over_limit.is_some()
        || a.warp_order.is_some()
        || a.reconstruction.is_some()
}

/// Build the configuration from `--config` and the knob flags.
pub fn config(a: &Args) -> anyhow::Result<GoldenConfig> {
    let mut cfg = match &a.config {
        None => GoldenConfig::default(),
        Some(p) => {
            let text = crate::io_util::read_text(p, "golden-model configuration (TOML)")?;
            GoldenConfig::from_toml(&text).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?
        }
    };
    if let Some(v) = a.threshold {
        cfg.threshold = v;
    }
    if let Some(v) = a.abuffer_fragments {
        cfg.abuffer_fragments = v;
    }
    if a.no_hole_fill {
        cfg.hole_fill = false;
    }
    if a.no_fallback_fill {
        cfg.fallback_fill = false;
    }
    if let Some(v) = a.over_limit {
        cfg.over_limit = v;
    }
    if let Some(v) = a.warp_order {
        cfg.warp_order = v;
    }
    if let Some(v) = a.reconstruction {
        cfg.reconstruction = v;
    }
    cfg.validate().map_err(|e| anyhow::anyhow!("golden configuration: {e}"))?;
    Ok(cfg)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(name) = &a.method {
        return run_method(&a, name);
    }
    let cfg = config(&a)?;
    let trace = Trace::open(&a.trace)?;
    let out = crate::io_util::OutDir::create(&a.out, a.force, &[&trace.manifest])?;
    let r = run_golden(&trace, &cfg, a.flip, out.path())?;
    out.commit()?;
    println!("{}: {} frames, method {}", trace.manifest.display(), trace.derived.len(), r.report.method);
    let slopes = &r.report.references.slopes;
    if slopes.iter().any(|s| s.as_deref() == Some("finite-difference")) {
        let list: Vec<&str> = slopes.iter().map(|s| s.as_deref().unwrap_or("unused")).collect();
        println!("slopes: computed from depth by finite differences for some reference frames ({})", list.join(", "));
    }
    print!("{}", r.table);
    println!();
    print!("{}", crate::report::table::golden_counters(&r.report));
    println!("wrote {}", a.out.join("report.json").display());
    Ok(())
}

/// `--method NAME [--hole-fill NAME]`.
fn run_method(a: &Args, name: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        !knobs_given(a),
        "--config and the golden knob flags configure the golden model; with --method each method runs with its documented defaults (docs/methods.md)"
    );
    let rec = crate::methods::reconstruction(name)?;
    let fill_name = a.hole_fill.clone().unwrap_or_else(|| rec.info().default_hole_fill.to_string());
    let fill = crate::methods::hole_fill(&fill_name)?;
    let trace = Trace::open(&a.trace)?;
    let out = crate::io_util::OutDir::create(&a.out, a.force, &[&trace.manifest])?;
    let r = crate::run::method::run_method(&trace, rec.as_ref(), fill.as_ref(), a.runs, a.flip, out.path())?;
    out.commit()?;
    println!(
        "{}: {} frames, method {} + hole fill {} ({}), host_ms = median of {} runs",
        trace.manifest.display(),
        trace.derived.len(),
        rec.info().name,
        fill.info().name,
        rec.info().paper,
        a.runs
    );
    print!("{}", r.table);
    println!("primitives per frame (mean): {:.0} {}", r.report.mean.primitives, rec.info().primitive);
    println!("wrote {}", a.out.join("report.json").display());
    Ok(())
}
