//! `postwarp chart`: draw the charts of a sweep's results.csv again.

use std::path::PathBuf;

/// Flags of `postwarp chart`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A results.csv written by `postwarp sweep`.
    pub results: PathBuf,
    /// Directory for the charts (*.svg, *.png); must not exist, unless
    /// --force, which replaces it whole.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let csv = crate::io_util::read_text(&a.results, "results CSV written by `postwarp sweep`")?;
    // Checked before anything is written: a bad CSV leaves --out as it was.
    crate::chart::check_csv(&csv).map_err(|e| anyhow::anyhow!("{}:{e}", a.results.display()))?;
    let out = crate::io_util::OutDir::create(&a.out, a.force, &[&a.results])?;
    let files =
        crate::chart::write_charts(&csv, out.path()).map_err(|e| anyhow::anyhow!("{}: {e:#}", a.results.display()))?;
    let dir = out.commit()?;
    println!("{}: {} chart files in {}", a.results.display(), files.len(), dir.display());
    Ok(())
}
