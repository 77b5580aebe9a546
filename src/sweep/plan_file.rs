//! Step one of a sweep, `postwarp sweep plan`: the specification planned,
//! its generated traces rendered, every point keyed, written to
//! `DIR/plan.json` so that other processes (`sweep run`, `sweep merge`, a
//! Slurm array task on another node) work from the same plan.
//!
//! Rules:
//! 1. `plan.json` holds the format, the build that wrote it
//!    ([`super::build::build_id`]), the specification's absolute path and its
//!    text, every trace variant (label, the path shown in `results.csv`,
//!    content identity, display size, frames used) and every point in plan
//!    order (hash, trace, method, hole fill), with their number. It is
//!    written atomically.
//! 2. Loading re-plans the stored text (relative paths still start from the
//!    specification's directory) and checks that this gives the same traces
//!    and point hashes: a plan is used only by the build that wrote it and
//!    only as it was written. A mismatch is an error that says to plan again.
//! 3. Points are kept once (the same key reached twice runs once), at their
//!    first place, so a point's index in `plan.json` is its row in
//!    `results.csv` less the header.
//! 4. Loading opens no trace: `run` checks the identities of the traces its
//!    slice uses ([`Prepared::verify_traces`]) before it runs them.

use super::hash::{hash_str, trace_identity};
use super::plan::{self, Plan};
use super::point::PointRun;
use super::spec::Spec;
use super::trace_set::{self, ReadyTrace, VariantSource};
use anyhow::{Context, bail};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format of `plan.json`.
pub const FORMAT: u32 = 1;

/// The file name of the plan in a sweep directory.
pub const PLAN_FILE: &str = "plan.json";

/// A point with its key, ready to run or load.
#[derive(Clone, Debug)]
pub struct PreparedPoint {
    /// Index into [`Prepared::traces`].
    pub trace: usize,
    /// What runs.
    pub run: PointRun,
    /// Canonical key ([`PointRun::key`]).
    pub key: String,
    /// Hash of the key: `points/<hash>.json`.
    pub hash: String,
}

/// A planned sweep: traces on disk, points keyed, in plan order.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The specification.
    pub spec: Spec,
    /// Its plan (trace variants, points before keying, knob columns).
    pub plan: Plan,
    /// One per [`Plan::traces`] entry.
    pub traces: Vec<ReadyTrace>,
    /// Points, once each (module rule 3).
    pub points: Vec<PreparedPoint>,
    /// Generated traces rendered by [`prepare`] (0 when loaded).
    pub traces_generated: usize,
}

impl Prepared {
    /// One line naming point `i`, for messages.
    pub fn describe(&self, i: usize) -> String {
        let p = &self.points[i];
        let mut s = format!("trace {}, method {}", self.traces[p.trace].variant.label, p.run.method());
        if !p.run.hole_fill().is_empty() {
            s += &format!(" + {}", p.run.hole_fill());
        }
        format!("{s} (points/{}.json)", p.hash)
    }

    /// Check that the traces points `indices` use still have the content
    /// identity the plan recorded (an existing trace edited, or a generated
    /// one replaced, since `sweep plan`).
    pub fn verify_traces(&self, indices: &[usize]) -> anyhow::Result<()> {
        let mut used: Vec<usize> = indices.iter().map(|&i| self.points[i].trace).collect();
        used.sort_unstable();
        used.dedup();
        for t in used {
            let r = &self.traces[t];
            let now = crate::trace::Trace::open(&r.dir)
                .map_err(anyhow::Error::from)
                .and_then(|tr| trace_identity(&tr))
                .with_context(|| format!("trace {} ({})", r.variant.label, r.dir.display()))?;
            if now != r.identity {
                bail!(
                    "trace {} ({}) changed since the sweep was planned (identity {} then, {now} now): \
                     run `postwarp sweep plan` again",
                    r.variant.label,
                    r.dir.display(),
                    r.identity
                );
            }
        }
        Ok(())
    }
}

/// Key the points of `plan` on `traces`, keeping each key once.
fn key_points(plan: &Plan, traces: &[ReadyTrace]) -> Vec<PreparedPoint> {
    let mut out: Vec<PreparedPoint> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for p in &plan.points {
        let t = &traces[p.trace];
        let key = p.run.key(&t.identity, t.frames);
        let hash = hash_str(&key);
        if seen.insert(hash.clone()) {
            out.push(PreparedPoint { trace: p.trace, run: p.run.clone(), key, hash });
        }
    }
    out
}

/// Plan `spec` into `out`: render the generated traces that are not there
/// yet (on `pool`, with a progress bar if `progress`), key the points and
/// write `out/plan.json`.
pub fn prepare(spec: &Spec, out: &Path, pool: &rayon::ThreadPool, progress: bool) -> anyhow::Result<Prepared> {
    let plan = plan::plan(spec)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let missing = plan
        .traces
        .iter()
        .filter(|v| match &v.source {
            VariantSource::Generated { given, file, spec: ts } => trace_set::generated_hash(given, file.as_deref(), ts)
                .map(|h| trace_set::needs_render(&out.join("traces").join(h)))
                .unwrap_or(true),
            VariantSource::Existing { .. } => false,
        })
        .count();
    let tbar = if progress { crate::progress::bar(missing as u64, "traces") } else { indicatif::ProgressBar::hidden() };
    let traces: Vec<ReadyTrace> = pool.install(|| {
        plan.traces
            .par_iter()
            .map(|v| {
                let r = trace_set::materialize(v, out)
                    .with_context(|| format!("{}: trace {} ({})", spec.file.display(), v.label, v.at));
                if matches!(v.source, VariantSource::Generated { .. }) {
                    tbar.inc(1);
                }
                r
            })
            .collect::<anyhow::Result<Vec<_>>>()
    })?;
    tbar.finish_and_clear();
    let points = key_points(&plan, &traces);
    let prepared = Prepared { spec: spec.clone(), plan, traces, points, traces_generated: missing };
    write(&prepared, out)?;
    Ok(prepared)
}

#[derive(Serialize, Deserialize)]
struct FileTrace {
    label: String,
    path: String,
    identity: String,
    width: u32,
    height: u32,
    supersample: u32,
    frames: usize,
}

#[derive(Serialize, Deserialize)]
struct FilePoint {
    hash: String,
    trace: usize,
    method: String,
    hole_fill: String,
}

#[derive(Serialize, Deserialize)]
struct FileSpec {
    file: PathBuf,
    text: String,
}

#[derive(Serialize, Deserialize)]
struct PlanFile {
    format: u32,
    build: String,
    spec: FileSpec,
    traces: Vec<FileTrace>,
    points_total: usize,
    points: Vec<FilePoint>,
}

/// Write `out/plan.json` (module rule 1).
pub fn write(p: &Prepared, out: &Path) -> anyhow::Result<()> {
    let file =
        std::path::absolute(&p.spec.file).with_context(|| format!("the absolute path of {}", p.spec.file.display()))?;
    let f = PlanFile {
        format: FORMAT,
        build: super::build::build_id().to_string(),
        spec: FileSpec { file, text: p.spec.text.clone() },
        traces: p
            .traces
            .iter()
            .map(|t| FileTrace {
                label: t.variant.label.clone(),
                path: t.shown.clone(),
                identity: t.identity.clone(),
                width: t.display.width,
                height: t.display.height,
                supersample: t.display.supersample,
                frames: t.frames,
            })
            .collect(),
        points_total: p.points.len(),
        points: p
            .points
            .iter()
            .map(|q| FilePoint {
                hash: q.hash.clone(),
                trace: q.trace,
                method: q.run.method().to_string(),
                hole_fill: q.run.hole_fill().to_string(),
            })
            .collect(),
    };
    let path = out.join(PLAN_FILE);
    let text = serde_json::to_string_pretty(&f).context("plan.json")? + "\n";
    crate::io_util::write_bytes_atomically(&path, text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

/// Read `out/plan.json` and check it against its specification (module
/// rule 2).
pub fn load(out: &Path) -> anyhow::Result<Prepared> {
    let path = out.join(PLAN_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "{}: no such file: {} is not a planned sweep (run `postwarp sweep plan SPEC --out {}` first)",
            path.display(),
            out.display(),
            out.display()
        ),
        Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
    };
    let again = format!("run `postwarp sweep plan SPEC --out {}` again", out.display());
    let f: PlanFile = serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!("{}:{}:{}: not a sweep plan ({e}): {again}", path.display(), e.line(), e.column())
    })?;
    if f.format != FORMAT {
        bail!("{}: plan format {} (this build reads {FORMAT}): {again}", path.display(), f.format);
    }
    if f.build != super::build::build_id() {
        bail!(
            "{}: planned by another build of postwarp ({}; this is {}), whose traces and points this build does \
             not reuse: {again} with this build",
            path.display(),
            f.build,
            super::build::build_id()
        );
    }
    let spec = Spec::parse(&f.spec.text, &f.spec.file)
        .map_err(|e| anyhow::anyhow!("{}: the planned specification: {e}", path.display()))?;
    let plan = plan::plan(&spec).map_err(|e| anyhow::anyhow!("{}: the planned specification: {e}", path.display()))?;
    let mismatch = |what: String| anyhow::anyhow!("{}: {what}: {again}", path.display());
    if plan.traces.len() != f.traces.len() {
        return Err(mismatch(format!(
            "{} traces planned, the specification now gives {}",
            f.traces.len(),
            plan.traces.len()
        )));
    }
    let mut traces = Vec::with_capacity(f.traces.len());
    for (v, t) in plan.traces.iter().zip(&f.traces) {
        if v.label != t.label {
            return Err(mismatch(format!(
                "trace `{}` planned where the specification now gives `{}`",
                t.label, v.label
            )));
        }
        let dir = match &v.source {
            VariantSource::Existing { path, .. } => path.clone(),
            VariantSource::Generated { .. } => out.join(&t.path),
        };
        traces.push(ReadyTrace {
            variant: v.clone(),
            dir,
            shown: t.path.clone(),
            identity: t.identity.clone(),
            display: crate::trace::Display { width: t.width, height: t.height, supersample: t.supersample },
            frames: t.frames,
        });
    }
    let points = key_points(&plan, &traces);
    let same = points.len() == f.points.len()
        && points.iter().zip(&f.points).all(|(a, b)| a.hash == b.hash && a.trace == b.trace);
    if !same || f.points_total != f.points.len() {
        return Err(mismatch(format!(
            "the {} planned points are not the {} this build makes of the specification",
            f.points.len(),
            points.len()
        )));
    }
    Ok(Prepared { spec, plan, traces, points, traces_generated: 0 })
}
