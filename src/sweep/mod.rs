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
//! - [`run_sweep`]: all of it, with the files below;
//! - [`crate::chart::write_charts`]: the charts of a `results.csv`.
//!
//! Rules:
//! 1. Outputs in `DIR`: `traces/<hash>/` (generated traces),
//!    `points/<hash>.json` (one per finished point), `results.csv`,
//!    `charts/*.svg|png`, and with `images = true` `images/<hash>/` (the
//!    point's frames and report). Every file is written to a temporary
//!    name and renamed.
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

pub mod build;
pub mod hash;
pub mod knobs;
pub mod plan;
pub mod point;
pub mod results;
pub mod spec;
pub mod spec_error;
pub mod store;
pub mod trace_fields;
pub mod trace_set;

pub use spec::Spec;
pub use spec_error::SpecError;

use anyhow::Context;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use trace_set::ReadyTrace;

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

/// A point with its key, ready to run or load.
struct Keyed<'a> {
    trace: &'a ReadyTrace,
    run: &'a point::PointRun,
    key: String,
    hash: String,
}

/// One line naming a point, for errors.
fn describe(k: &Keyed) -> String {
    let mut s = format!("trace {}, method {}", k.trace.variant.label, k.run.method());
    if !k.run.hole_fill().is_empty() {
        s += &format!(" + {}", k.run.hole_fill());
    }
    format!("{s} (points/{}.json)", k.hash)
}

/// Run `spec` into `out` (module rules).
pub fn run_sweep(spec: &Spec, out: &Path, opts: &Options) -> anyhow::Result<Outcome> {
    anyhow::ensure!(opts.jobs >= 1, "--jobs must be at least 1");
    let plan = plan::plan(spec)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(opts.jobs).build().context("starting the worker threads")?;
    let bar = |n: usize, what: &str| {
        if opts.progress { crate::progress::bar(n as u64, what) } else { indicatif::ProgressBar::hidden() }
    };

    // Traces: existing ones opened, generated ones rendered unless present.
    let missing = plan
        .traces
        .iter()
        .filter(|v| match &v.source {
            trace_set::VariantSource::Generated { given, file, spec: ts } => {
                trace_set::generated_hash(given, file.as_deref(), ts)
                    .map(|h| trace_set::needs_render(&out.join("traces").join(h)))
                    .unwrap_or(true)
            }
            trace_set::VariantSource::Existing { .. } => false,
        })
        .count();
    let tbar = bar(missing, "traces");
    let ready: Vec<ReadyTrace> = pool.install(|| {
        plan.traces
            .par_iter()
            .map(|v| {
                let r = trace_set::materialize(v, out)
                    .with_context(|| format!("{}: trace {} ({})", spec.file.display(), v.label, v.at));
                if matches!(v.source, trace_set::VariantSource::Generated { .. }) {
                    tbar.inc(1);
                }
                r
            })
            .collect::<anyhow::Result<Vec<_>>>()
    })?;
    tbar.finish_and_clear();

    // Keys, duplicates (same key reached from two plan entries) once.
    let mut keyed: Vec<Keyed> = Vec::new();
    for p in &plan.points {
        let t = &ready[p.trace];
        let key = p.run.key(&t.identity, t.frames);
        let hash = hash::hash_str(&key);
        if !keyed.iter().any(|k| k.hash == hash) {
            keyed.push(Keyed { trace: t, run: &p.run, key, hash });
        }
    }

    let mut metrics: Vec<Option<point::Metrics>> = keyed.iter().map(|k| store::load(out, &k.hash, &k.key)).collect();
    let skipped = metrics.iter().filter(|m| m.is_some()).count();
    let stale =
        keyed.iter().zip(&metrics).filter(|(k, m)| m.is_none() && store::point_file(out, &k.hash).is_file()).count();
    let todo: Vec<usize> = (0..keyed.len()).filter(|&i| metrics[i].is_none()).collect();
    let pbar = bar(todo.len(), "sweep");
    let done: Vec<(usize, anyhow::Result<point::Metrics>)> = pool.install(|| {
        todo.par_iter()
            .map(|&i| {
                let k = &keyed[i];
                let r = (|| {
                    let trace = k.trace.open()?;
                    let images = spec.images.then(|| out.join("images").join(&k.hash));
                    let m = point::run_point(k.run, &trace, images.as_deref())?;
                    store::save(out, &k.hash, &k.key, &m)?;
                    Ok::<_, anyhow::Error>(m)
                })()
                .with_context(|| describe(k));
                pbar.inc(1);
                (i, r)
            })
            .collect()
    });
    pbar.finish_and_clear();
    let computed = done.len();
    let mut failures = Vec::new();
    for (i, r) in done {
        match r {
            Ok(m) => metrics[i] = Some(m),
            Err(e) => failures.push(format!("{e:#}")),
        }
    }
    if !failures.is_empty() {
        anyhow::bail!(
            "{} of {} points failed (the {} others are stored in {}; run again to resume):\n  {}",
            failures.len(),
            keyed.len(),
            keyed.len() - failures.len(),
            out.join("points").display(),
            failures.join("\n  ")
        );
    }

    let rows: Vec<results::Row> = keyed
        .iter()
        .zip(&metrics)
        .map(|(k, m)| results::Row {
            trace: k.trace,
            run: k.run,
            hash: &k.hash,
            metrics: m.as_ref().expect("every point finished"),
        })
        .collect();
    let csv = results::csv_text(&spec.name, &plan, &rows);
    let results = out.join("results.csv");
    crate::io_util::write_bytes_atomically(&results, csv.as_bytes())
        .with_context(|| format!("writing {}", results.display()))?;
    let charts = crate::chart::write_charts(&csv, &out.join("charts"))?;
    Ok(Outcome { points: keyed.len(), skipped, computed, stale, traces_generated: missing, results, charts })
}
