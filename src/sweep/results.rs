//! `DIR/results.csv`: one row per point, in plan order (the order of the
//! specification, not of completion), every parameter and every metric as
//! a column, the unit in the column name.
//!
//! Columns, in order: `spec`, `trace` (label), `trace_path`, `scene`, the
//! trace fields ([`TRACE_FIELDS`] columns), `method`, `hole_fill`, `runs`,
//! the knob columns the specification names ([`Plan::knob_columns`]),
//! `point` (the hash naming `points/<hash>.json`), then
//! [`METRIC_COLUMNS`]. A cell is empty where the parameter or metric does
//! not apply. Numbers are printed exactly (shortest round-trip form), so
//! the file is the same byte for byte whether points were computed now or
//! loaded from `points/`.

use super::plan::{Plan, knob_cell};
use super::point::{METRIC_COLUMNS, Metrics, PointRun};
use super::trace_fields::TRACE_FIELDS;
use super::trace_set::ReadyTrace;
use crate::report::csv;

/// A finished point: its place in the plan, its hash and its metrics.
pub struct Row<'a> {
    /// The point's trace.
    pub trace: &'a ReadyTrace,
    /// What ran.
    pub run: &'a PointRun,
    /// Hash of its key.
    pub hash: &'a str,
    /// Results.
    pub metrics: &'a Metrics,
}

/// The header of `results.csv` for `plan`.
pub fn header(plan: &Plan) -> Vec<String> {
    let mut h: Vec<String> = ["spec", "trace", "trace_path", "scene"].iter().map(|s| s.to_string()).collect();
    h.extend(TRACE_FIELDS.iter().map(|f| f.3.to_string()));
    h.extend(["method", "hole_fill", "runs"].iter().map(|s| s.to_string()));
    h.extend(plan.knob_columns.iter().map(|c| c.0.clone()));
    h.push("point".into());
    h.extend(METRIC_COLUMNS.iter().map(|c| c.0.to_string()));
    h
}

/// The text of `results.csv`.
pub fn csv_text(spec_name: &str, plan: &Plan, rows: &[Row]) -> String {
    let mut s = csv::line(&header(plan));
    for r in rows {
        let mut f: Vec<String> =
            vec![spec_name.to_string(), r.trace.variant.label.clone(), r.trace.shown.clone(), r.trace.field("scene")];
        f.extend(TRACE_FIELDS.iter().map(|t| r.trace.field(t.0)));
        f.push(r.run.method().to_string());
        f.push(r.run.hole_fill().to_string());
        f.push(match r.run {
            PointRun::Method { runs, .. } => runs.to_string(),
            PointRun::Hardware { .. } => String::new(),
        });
        f.extend(plan.knob_columns.iter().map(|(_, table, knob)| knob_cell(r.run, table, knob)));
        f.push(r.hash.to_string());
        f.extend(METRIC_COLUMNS.iter().map(|c| r.metrics.cell(c.0)));
        s += &csv::line(&f);
    }
    s
}
