//! `postwarp sweep`: the cross product of traces × methods × hole fills ×
//! knobs of a specification file (`docs/sweep.md`), run in parallel,
//! resumable, into `results.csv` and charts.
//!
//! API (for other tools: stability sweeps, sizing):
//! - [`Spec::load`] / [`Spec::parse`]: the specification, checked;
//! - [`plan::plan`]: its trace variants and points, in order;
//! - [`trace_set::materialize`]: a trace variant on disk, with its
//!   identity;
//! - [`point::run_point`]: one point on one trace → [`point::Metrics`]
//!   (the same code as `postwarp golden --method` and `postwarp simulate`);
//! - the three steps any process can drive (`postwarp sweep plan|run|merge`):
//!   [`plan_file::prepare`] (plan, render, write `plan.json`) and
//!   [`plan_file::load`], [`slice::run_slice`] (one slice of the points),
//!   [`merge::merge`] (`results.csv` and charts from the stored points);
//! - [`run_sweep`]: the three steps in one process, with the files below;
//! - [`slurm::run`]: the three steps as a Slurm job array and a merge job;
//! - [`crate::chart::write_charts`]: the charts of a `results.csv`.
//!
//! Rules:
//! 1. Outputs in `DIR`: `plan.json` (the plan), `traces/<hash>/`
//!    (generated traces), `points/<hash>.json` (one per finished point),
//!    `results.csv`,
//!    `charts/*.svg|png`, and with `images = true` `images/<hash>/` (the
//!    point's frames and report), and with `--slurm` `slurm/` (the job
//!    scripts and task logs). Every file is written to a temporary name
//!    and renamed.
//! 2. Resumable: a point whose file exists with the same key, stored by
//!    the same build ([`build::build_id`]), is loaded, not run again
//!    ([`Outcome::skipped`]); one stored by another build is run again
//!    ([`Outcome::stale`]), and so is a generated trace rendered by one.
//! 3. Deterministic: every column of `results.csv` except `host_ms_per_frame`
//!    is the same whatever `jobs` is; rows follow the plan, not
//!    completion. Host time is measured with one timed section at a time
//!    in the process ([`crate::run::timing`]), while untimed work (other
//!    points' loading, scoring, the hardware model) goes on beside it.
//! 4. A failing point does not stop the others; the sweep then reports
//!    every failure, writes no `results.csv`, and a rerun resumes.
//! 5. `results.csv` is a function of the plan and the stored points only, so
//!    slices run in any order, in any processes, on any nodes, merge into
//!    the bytes of a one-process sweep (host times aside, which are
//!    whatever the process that ran each point measured).

pub mod build;
pub mod hash;
pub mod knobs;
pub mod merge;
pub mod plan;
pub mod plan_file;
pub mod point;
pub mod results;
pub mod slice;
pub mod slurm;
pub mod spec;
pub mod spec_error;
pub mod store;
pub mod trace_fields;
pub mod trace_set;

pub use spec::Spec;
pub use spec_error::SpecError;

use anyhow::Context;
use std::path::{Path, PathBuf};

/// How to run a sweep.
#[derive(Clone, Debug)]
pub struct Options {
    /// Worker threads (at least 1).
    pub jobs: usize,
    /// Show progress bars (on a terminal only).
    pub progress: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options { jobs: std::thread::available_parallelism().map_or(1, |n| n.get()), progress: true }
    }
}

/// What a sweep did.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Points in the plan.
    pub points: usize,
    /// Points loaded from `points/` (finished by an earlier run).
    pub skipped: usize,
    /// Points run now.
    pub computed: usize,
    /// Of those, points whose file in `points/` was not used: stored by
    /// another build of the program (or under another key).
    pub stale: usize,
    /// Traces rendered now (generated traces not found in `traces/`).
    pub traces_generated: usize,
    /// `results.csv`.
    pub results: PathBuf,
    /// Chart files written.
    pub charts: Vec<PathBuf>,
}

/// Run `spec` into `out` (module rules) in this process: the three steps
/// of a sweep one after the other, [`plan_file::prepare`] (writes
/// `plan.json`), [`slice::run_points`] on every point, [`merge::merge`].
pub fn run_sweep(spec: &Spec, out: &Path, opts: &Options) -> anyhow::Result<Outcome> {
    anyhow::ensure!(opts.jobs >= 1, "--jobs must be at least 1");
    let pool = pool(opts.jobs)?;
    let p = plan_file::prepare(spec, out, &pool, opts.progress)?;
    let all: Vec<usize> = (0..p.points.len()).collect();
    let r = slice::run_points(&p, out, &all, &pool, opts.progress);
    if !r.failures.is_empty() {
        anyhow::bail!(
            "{} of {} points failed (the {} others are stored in {}; run again to resume):\n  {}",
            r.failures.len(),
            p.points.len(),
            p.points.len() - r.failures.len(),
            out.join("points").display(),
            r.failures.join("\n  ")
        );
    }
    let m = merge::merge(&p, out, 1, std::time::Duration::ZERO)?;
    Ok(Outcome {
        points: p.points.len(),
        skipped: r.skipped,
        computed: r.computed,
        stale: r.stale,
        traces_generated: p.traces_generated,
        results: m.results,
        charts: m.charts,
    })
}

/// A pool of `jobs` worker threads.
pub fn pool(jobs: usize) -> anyhow::Result<rayon::ThreadPool> {
    anyhow::ensure!(jobs >= 1, "--jobs must be at least 1");
    rayon::ThreadPoolBuilder::new().num_threads(jobs).build().context("starting the worker threads")
}
