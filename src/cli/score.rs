//! `postwarp score RUN_DIR... [--trace TRACE]` and `postwarp score --sweep
//! DIR --region R --csv OUT`: score the frames runs wrote against their
//! trace's ground truth, over the whole image and the truth's non-diffuse
//! mask (`src/rescore.rs`, `docs/non-diffuse.md`).

use crate::rescore::{csv, markdown, score_run, sweep_region};
use crate::trace::Trace;
use anyhow::{Context, bail};
use std::path::PathBuf;

/// Flags of `postwarp score`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directories of `postwarp golden`, `golden --method`,
    /// `simulate` or one `compare` run (each holds frame-NNNN.png and
    /// report.json).
    pub runs: Vec<PathBuf>,
    /// The trace the runs were made from [default: the one each run's
    /// report.json names].
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Write the scores as CSV here (with --sweep: the region's results.csv).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// A sweep output directory made with `images = true`: score every
    /// point again over `--region` into `--csv` (a results.csv that
    /// `postwarp chart` draws).
    #[arg(long, conflicts_with_all = ["runs", "trace"], requires_all = ["region", "csv"])]
    pub sweep: Option<PathBuf>,
    /// Region for --sweep: whole, mask (specular or transparent pixels) or
    /// rest (the others).
    #[arg(long, requires = "sweep")]
    pub region: Option<String>,
}

/// The trace of `run`: `given`, or the one its report.json names.
fn trace_of(run: &std::path::Path, given: &Option<PathBuf>) -> anyhow::Result<PathBuf> {
    if let Some(t) = given {
        return Ok(t.clone());
    }
    let (trace, _) = crate::rescore::run_header(run).context("reading the run's report.json (or give --trace)")?;
    Ok(PathBuf::from(trace))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(dir) = &a.sweep {
        let (region, out) = (a.region.as_deref().unwrap_or("mask"), a.csv.as_ref().expect("required by clap"));
        let text = sweep_region(dir, region)?;
        crate::io_util::write_bytes_atomically(out, text.as_bytes())?;
        eprintln!("wrote {}", out.display());
        return Ok(());
    }
    if a.runs.is_empty() {
        bail!("give run directories to score, or --sweep DIR --region R --csv OUT");
    }
    let mut rows = Vec::new();
    for d in &a.runs {
        let trace = Trace::open(&trace_of(d, &a.trace)?)?;
        rows.push(score_run(&trace, d)?);
    }
    print!("{}", markdown(&rows));
    if let Some(p) = &a.csv {
        crate::io_util::write_bytes_atomically(p, csv(&rows).as_bytes())?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
