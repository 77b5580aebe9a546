//! `postwarp sweep`: run a sweep specification (docs/sweep.md).

use crate::sweep::{Options, Spec, run_sweep};
use std::path::PathBuf;

/// Flags of `postwarp sweep`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Sweep specification (TOML, docs/sweep.md).
    pub spec: PathBuf,
    /// Output directory: results.csv, charts/, points/ (finished points,
    /// reused on a rerun), traces/ (generated traces).
    #[arg(long)]
    pub out: PathBuf,
    /// Worker threads [default: all cores]. Results other than host time
    /// do not depend on it.
    #[arg(long)]
    pub jobs: Option<usize>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let spec = Spec::load(&a.spec)?;
    let mut opts = Options::default();
    if let Some(j) = a.jobs {
        anyhow::ensure!(j >= 1, "--jobs {j}: expected at least 1 thread");
        opts.jobs = j;
    }
    let start = std::time::Instant::now();
    let o = run_sweep(&spec, &a.out, &opts)?;
    println!(
        "{}: {} points, {} skipped (finished earlier, loaded from {}), {} computed; {} traces generated; {} threads, {:.1} s",
        spec.file.display(),
        o.points,
        o.skipped,
        a.out.join("points").display(),
        o.computed,
        o.traces_generated,
        opts.jobs,
        start.elapsed().as_secs_f64()
    );
    if o.stale > 0 {
        println!(
            "{} stored points were made by another build of postwarp (or under another key) and were run again",
            o.stale
        );
    }
    println!("results: {}", o.results.display());
    println!("charts: {} files in {}", o.charts.len(), a.out.join("charts").display());
    Ok(())
}
