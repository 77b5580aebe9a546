//! Step three of a sweep, `postwarp sweep merge`: every planned point read
//! back from `points/`, `results.csv` and the charts written.
//!
//! Rules:
//! 1. Merging needs every point of the plan stored by this build under its
//!    key; otherwise it writes nothing and fails naming the slices (at the
//!    given points per task) that hold the missing points, why each is
//!    missing, and the newest Slurm log of each such slice if there is one.
//! 2. `results.csv` depends only on the plan and the stored points: rows in
//!    plan order, numbers exactly as stored. So merging slices run in any
//!    order, by any processes, gives the bytes a one-process sweep writes.
//! 3. A shared file system may show another node's new files late: with a
//!    wait, missing points are looked for again every second until they
//!    appear or the wait is over.

use super::plan_file::Prepared;
use super::point::Metrics;
use super::{results, slice, store};
use anyhow::Context;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Points of a plan that are not stored (rule 1), as an error.
#[derive(Clone, Debug, PartialEq)]
pub struct MissingPoints {
    /// The sweep directory.
    pub out: PathBuf,
    /// Points in the plan.
    pub total: usize,
    /// (point index, why it is missing: [`store::Stored::why_missing`]), ascending.
    pub missing: Vec<(usize, &'static str)>,
    /// Points per task the slices are counted at.
    pub per_task: usize,
}

/// At most this many slices are listed one per line.
const LISTED: usize = 20;

impl MissingPoints {
    /// The slices holding missing points, ascending, once each.
    pub fn slices(&self) -> Vec<usize> {
        let mut s: Vec<usize> = self.missing.iter().map(|&(i, _)| slice::of_point(i, self.per_task)).collect();
        s.dedup();
        s
    }

    /// The newest log of slice `index` in `DIR/slurm/logs/` (`<job>_<index>.out`).
    pub fn newest_log(&self, index: usize) -> Option<PathBuf> {
        let suffix = format!("_{index}.out");
        let logs = std::fs::read_dir(self.out.join("slurm").join("logs")).ok()?;
        logs.filter_map(Result::ok)
            .filter(|e| e.file_name().to_string_lossy().ends_with(&suffix))
            .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
            .max()
            .map(|(_, p)| p)
    }
}

impl std::fmt::Display for MissingPoints {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let k = self.per_task;
        let slices = self.slices();
        let mut why: Vec<(&str, usize)> = Vec::new();
        for &(_, w) in &self.missing {
            match why.iter_mut().find(|(x, _)| *x == w) {
                Some(e) => e.1 += 1,
                None => why.push((w, 1)),
            }
        }
        let why: Vec<String> = why.iter().map(|(w, n)| format!("{n} {w}")).collect();
        write!(
            f,
            "{} of {} planned points are not stored in {} ({}); at {k} points per task they are in {} of {} slices: {}",
            self.missing.len(),
            self.total,
            self.out.join("points").display(),
            why.join(", "),
            slices.len(),
            slice::count(self.total, k),
            slice::compress(&slices)
        )?;
        for &s in slices.iter().take(LISTED) {
            let r = slice::range(s, k, self.total).expect("a slice of the plan");
            let here: Vec<&(usize, &str)> = self.missing.iter().filter(|(i, _)| r.contains(i)).collect();
            write!(f, "\n  slice {s} (points {}-{}): {} missing", r.start, r.end - 1, here.len())?;
            if let Some(log) = self.newest_log(s) {
                write!(f, "; log {}", log.display())?;
            }
        }
        if slices.len() > LISTED {
            write!(f, "\n  ... and {} more slices", slices.len() - LISTED)?;
        }
        write!(
            f,
            "\nrun each with `postwarp sweep run {} --index I --points-per-task {k}`, or run the sweep again \
             (`postwarp sweep SPEC --out {}`; with --slurm it resubmits only these slices)",
            self.out.display(),
            self.out.display()
        )
    }
}

impl std::error::Error for MissingPoints {}

/// The stored metrics of every planned point, waiting up to `wait` for
/// missing ones (rule 3); the missing points if some stay missing.
pub fn stored_metrics(
    p: &Prepared,
    out: &Path,
    per_task: usize,
    wait: Duration,
) -> Result<Vec<Metrics>, MissingPoints> {
    let start = Instant::now();
    let mut got: Vec<Option<Metrics>> = vec![None; p.points.len()];
    loop {
        let mut missing = Vec::new();
        for (i, q) in p.points.iter().enumerate() {
            if got[i].is_none() {
                match store::check(out, &q.hash, &q.key) {
                    store::Stored::Finished(m) => got[i] = Some(*m),
                    other => missing.push((i, other.why_missing())),
                }
            }
        }
        if missing.is_empty() {
            return Ok(got.into_iter().map(|m| m.expect("every point stored")).collect());
        }
        if start.elapsed() >= wait {
            return Err(MissingPoints { out: out.to_path_buf(), total: p.points.len(), missing, per_task });
        }
        std::thread::sleep(Duration::from_secs(1).min(wait.saturating_sub(start.elapsed())));
    }
}

/// The text of `results.csv` for `p` with every point's `metrics`.
pub fn csv_text(p: &Prepared, metrics: &[Metrics]) -> String {
    let rows: Vec<results::Row> = p
        .points
        .iter()
        .zip(metrics)
        .map(|(q, m)| results::Row { trace: &p.traces[q.trace], run: &q.run, hash: &q.hash, metrics: m })
        .collect();
    results::csv_text(&p.spec.name, &p.plan, &rows)
}

/// What a merge wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct MergeOutcome {
    /// Points merged.
    pub points: usize,
    /// `results.csv`.
    pub results: PathBuf,
    /// Chart files written.
    pub charts: Vec<PathBuf>,
}

/// Merge the sweep in `out` (rules 1 to 3): `results.csv` and the charts.
/// The error is a [`MissingPoints`] when points are missing.
pub fn merge(p: &Prepared, out: &Path, per_task: usize, wait: Duration) -> anyhow::Result<MergeOutcome> {
    anyhow::ensure!(per_task >= 1, "--points-per-task must be at least 1");
    let metrics = stored_metrics(p, out, per_task, wait)?;
    let csv = csv_text(p, &metrics);
    let results = out.join("results.csv");
    crate::io_util::write_bytes_atomically(&results, csv.as_bytes())
        .with_context(|| format!("writing {}", results.display()))?;
    let charts = crate::chart::write_charts(&csv, &out.join("charts"))?;
    Ok(MergeOutcome { points: p.points.len(), results, charts })
}
