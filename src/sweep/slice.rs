//! Step two of a sweep, `postwarp sweep run`: the points of one slice of
//! the plan, each stored as it finishes.
//!
//! Rules:
//! 1. With K points per task, slice I is the points I·K to I·K + K − 1 of
//!    the plan (the last slice may be shorter): slices are fixed by the
//!    plan and K alone, so any process, on any node, in any order, runs
//!    the same points for the same I.
//! 2. A point already stored by this build under its key is loaded, not run
//!    ([`super::store::check`]); a point file that is absent, unreadable
//!    (torn, edited), of another key or of another build is run again.
//! 3. Each finished point is written atomically (`points/<hash>.json`); a
//!    failing point does not stop the others of the slice, and the run
//!    then fails naming every failed point.
//! 4. The index may come from `SLURM_ARRAY_TASK_ID` ([`index_from_env`]).

use super::plan_file::Prepared;
use super::{point, store};
use anyhow::{Context, bail};
use rayon::prelude::*;
use std::ops::Range;
use std::path::Path;

/// The environment variable an array task's index is read from.
pub const TASK_ID_VAR: &str = "SLURM_ARRAY_TASK_ID";

/// Number of slices of `points` points at `per_task` points per slice.
pub fn count(points: usize, per_task: usize) -> usize {
    points.div_ceil(per_task.max(1))
}

/// The points of slice `index` (module rule 1); `None` past the last slice.
pub fn range(index: usize, per_task: usize, points: usize) -> Option<Range<usize>> {
    let k = per_task.max(1);
    let start = index.checked_mul(k)?;
    (start < points).then(|| start..(start + k).min(points))
}

/// The slice holding point `i`.
pub fn of_point(i: usize, per_task: usize) -> usize {
    i / per_task.max(1)
}

/// Indices as Slurm's `--array` list: ascending runs joined, `0-3,5,7-9`.
pub fn compress(indices: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < indices.len() {
        let mut j = i;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        parts.push(if j == i { indices[i].to_string() } else { format!("{}-{}", indices[i], indices[j]) });
        i = j + 1;
    }
    parts.join(",")
}

/// The slice index: `given`, else `SLURM_ARRAY_TASK_ID`.
pub fn index_from_env(given: Option<usize>) -> anyhow::Result<usize> {
    if let Some(i) = given {
        return Ok(i);
    }
    match std::env::var(TASK_ID_VAR) {
        Ok(v) => v
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("{TASK_ID_VAR}=`{v}`: expected a whole number (the array task's index)")),
        Err(_) => bail!("no slice given: pass --index I (or run as a Slurm array task, which sets {TASK_ID_VAR})"),
    }
}

/// What running some points did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointsOutcome {
    /// Points loaded from `points/` (finished earlier).
    pub skipped: usize,
    /// Points run now.
    pub computed: usize,
    /// Of those, points whose file existed but was not used (another build,
    /// another key, unreadable).
    pub stale: usize,
    /// Points that failed, each with its error.
    pub failures: Vec<String>,
}

/// Run the points `indices` of `p` that are not stored yet (module rules 2
/// and 3), on `pool`, with a progress bar if `progress`.
pub fn run_points(
    p: &Prepared,
    out: &Path,
    indices: &[usize],
    pool: &rayon::ThreadPool,
    progress: bool,
) -> PointsOutcome {
    let status: Vec<store::Stored> =
        indices.iter().map(|&i| store::check(out, &p.points[i].hash, &p.points[i].key)).collect();
    let todo: Vec<usize> = indices
        .iter()
        .zip(&status)
        .filter(|(_, s)| !matches!(s, store::Stored::Finished(_)))
        .map(|(&i, _)| i)
        .collect();
    let stale = status.iter().filter(|s| !matches!(s, store::Stored::Finished(_) | store::Stored::Absent)).count();
    let bar =
        if progress { crate::progress::bar(todo.len() as u64, "sweep") } else { indicatif::ProgressBar::hidden() };
    let failures: Vec<String> = pool.install(|| {
        todo.par_iter()
            .filter_map(|&i| {
                let q = &p.points[i];
                let r = (|| {
                    let trace = p.traces[q.trace].open()?;
                    let images = p.spec.images.then(|| out.join("images").join(&q.hash));
                    let m = point::run_point(&q.run, &trace, images.as_deref())?;
                    store::save(out, &q.hash, &q.key, &m)
                })()
                .with_context(|| p.describe(i));
                bar.inc(1);
                r.err().map(|e| format!("{e:#}"))
            })
            .collect()
    });
    bar.finish_and_clear();
    PointsOutcome { skipped: indices.len() - todo.len(), computed: todo.len(), stale, failures }
}

/// What `sweep run` did for one slice.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceOutcome {
    /// The slice.
    pub index: usize,
    /// Its points.
    pub points: Range<usize>,
    /// Slices in the plan at this K.
    pub slices: usize,
    /// Skipped, computed, failed.
    pub run: PointsOutcome,
}

/// Run slice `index` of the plan in `out` at `per_task` points per slice
/// (`postwarp sweep run`). Fails if any of its points failed (the others are
/// stored).
pub fn run_slice(
    p: &Prepared,
    out: &Path,
    index: usize,
    per_task: usize,
    pool: &rayon::ThreadPool,
    progress: bool,
) -> anyhow::Result<SliceOutcome> {
    anyhow::ensure!(per_task >= 1, "--points-per-task must be at least 1");
    let n = p.points.len();
    let slices = count(n, per_task);
    let Some(points) = range(index, per_task, n) else {
        bail!(
            "slice {index}: the plan in {} has {n} points, {slices} slices of {per_task} (indices 0 to {})",
            out.display(),
            slices.saturating_sub(1)
        );
    };
    let indices: Vec<usize> = points.clone().collect();
    p.verify_traces(&indices)?;
    let run = run_points(p, out, &indices, pool, progress);
    if !run.failures.is_empty() {
        bail!(
            "slice {index}: {} of {} points failed (the others are stored in {}):\n  {}",
            run.failures.len(),
            indices.len(),
            out.join("points").display(),
            run.failures.join("\n  ")
        );
    }
    Ok(SliceOutcome { index, points, slices, run })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_cover_the_plan_once_in_order() {
        for n in [0, 1, 7, 32] {
            for k in [1, 2, 5, 32, 40] {
                let all: Vec<usize> = (0..count(n, k)).flat_map(|i| range(i, k, n).unwrap()).collect();
                assert_eq!(all, (0..n).collect::<Vec<_>>(), "n {n} k {k}");
                assert_eq!(range(count(n, k), k, n), None);
                for i in 0..n {
                    assert!(range(of_point(i, k), k, n).unwrap().contains(&i));
                }
            }
        }
        assert_eq!(range(usize::MAX, 2, 10), None);
    }

    #[test]
    fn array_lists_join_runs() {
        assert_eq!(compress(&[]), "");
        assert_eq!(compress(&[4]), "4");
        assert_eq!(compress(&[0, 1, 2, 3, 5, 7, 8, 9]), "0-3,5,7-9");
        assert_eq!(compress(&[1, 3]), "1,3");
    }
}
