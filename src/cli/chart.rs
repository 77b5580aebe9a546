//! `postwarp chart`: draw the charts of a sweep's results.csv again.

use std::path::PathBuf;

/// Flags of `postwarp chart`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A results.csv written by `postwarp sweep`.
    pub results: PathBuf,
    /// Directory for the charts (*.svg, *.png; other chart files in it are removed).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let csv = std::fs::read_to_string(&a.results)
        .map_err(|e| anyhow::anyhow!("{}: cannot read the results: {e}", a.results.display()))?;
    let files =
        crate::chart::write_charts(&csv, &a.out).map_err(|e| anyhow::anyhow!("{}: {e:#}", a.results.display()))?;
    println!("{}: {} chart files in {}", a.results.display(), files.len(), a.out.display());
    Ok(())
}
