//! `postwarp simulate`: the cycle-level hardware model on a trace, checked
//! against the golden model.

use crate::run::hw_config_toml::load;
use crate::run::simulate::run_simulate;
use crate::trace::Trace;
use std::path::PathBuf;

/// Flags of `postwarp simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest).
    pub trace: PathBuf,
    /// Output directory: frame-NNNN.png, diff-NNNN.png, report.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Hardware knobs as TOML (keys as in docs/units.md; `preset = "NAME"` picks the base).
    #[arg(long, conflicts_with = "preset")]
    pub config: Option<PathBuf>,
    /// A named configuration: mark1998 (default) or hmd2026.
    #[arg(long)]
    pub preset: Option<String>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let cfg = load(a.config.as_deref(), a.preset.as_deref())?;
    let trace = Trace::open(&a.trace)?;
    let r = run_simulate(&trace, &cfg, &a.out)?;
    let total = &r.report.total;
    println!(
        "{}: {} frames on the hardware model; {} of {} identical to the golden model",
        trace.manifest.display(),
        trace.derived.len(),
        total.identical_frames,
        total.frames
    );
    print!("{}", r.summary);
    println!("report: {}", a.out.join("report.json").display());
    Ok(())
}
