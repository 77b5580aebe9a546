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

/// One row of a `results.csv` read back: its line, its cells, and its
/// metrics read into [`Metrics`] (the only way charts read results).
#[derive(Clone, Debug, PartialEq)]
pub struct ResultsRow {
    /// 1-based line in the file.
    pub line: usize,
    /// Every cell, in header order.
    pub cells: Vec<String>,
    /// The metric columns present, typed.
    pub metrics: Metrics,
}

/// A `results.csv` read back and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct ResultsTable {
    /// The header.
    pub header: Vec<String>,
    /// The rows, in file order.
    pub rows: Vec<ResultsRow>,
}

/// Columns every `results.csv` has.
const REQUIRED: &[&str] = &["spec", "trace", "method", "hole_fill"];

impl ResultsTable {
    /// Position of column `name`.
    pub fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Cell `name` of `row` (empty if the column is absent).
    pub fn cell<'a>(&self, row: &'a ResultsRow, name: &str) -> &'a str {
        self.col(name).and_then(|c| row.cells.get(c)).map_or("", String::as_str)
    }

    /// The knob columns: between `runs` and `point` (module doc).
    pub fn knob_columns(&self) -> std::ops::Range<usize> {
        match (self.col("runs"), self.col("point")) {
            (Some(a), Some(b)) if a < b => a + 1..b,
            _ => 0..0,
        }
    }
}

/// Read the text of a `results.csv`. Errors are `LINE: message`: an
/// empty file, a missing column, a row with another number of cells than
/// the header, a metric cell that is neither empty nor a finite number.
pub fn read_csv(text: &str) -> Result<ResultsTable, String> {
    let mut all = csv::parse_lines(text)?.into_iter();
    let Some((_, header)) = all.next().filter(|(_, h)| h.iter().any(|c| !c.is_empty())) else {
        return Err(format!(
            "1: empty file; expected the header line of a results.csv written by `postwarp sweep` ({}, …)",
            REQUIRED.join(",")
        ));
    };
    for r in REQUIRED {
        if !header.iter().any(|h| h == r) {
            return Err(format!("1: no `{r}` column; expected a results.csv written by `postwarp sweep`"));
        }
    }
    let metric_cols: Vec<(usize, &str)> =
        METRIC_COLUMNS.iter().filter_map(|m| header.iter().position(|h| h == m.0).map(|i| (i, m.0))).collect();
    let mut lines: Vec<(usize, Vec<String>)> = all.collect();
    while lines.last().is_some_and(|(_, c)| c.len() == 1 && c[0].is_empty()) {
        lines.pop();
    }
    let mut rows = Vec::new();
    for (line, cells) in lines {
        if cells.len() == 1 && cells[0].is_empty() {
            return Err(format!("{line}: blank line; expected a row of {} cells", header.len()));
        }
        if cells.len() != header.len() {
            return Err(format!(
                "{line}: {} cells; the header has {} (a ragged row: every row has one cell per column)",
                cells.len(),
                header.len()
            ));
        }
        let mut m = serde_json::Map::new();
        m.insert("frames".into(), 0.into());
        for &(i, name) in &metric_cols {
            let c = cells[i].trim();
            if c.is_empty() {
                continue;
            }
            let v = if name == "golden_identical_frames" || name == "vs_float_identical_frames" {
                c.parse::<u64>().ok().map(serde_json::Value::from)
            } else {
                c.parse::<f64>().ok().filter(|x| x.is_finite()).map(serde_json::Value::from)
            };
            let Some(v) = v else {
                return Err(format!(
                    "{line}: column `{name}` is `{c}`; expected a finite number (or an empty cell where the metric does \
                     not apply)"
                ));
            };
            m.insert(name.to_string(), v);
        }
        let metrics: Metrics = serde_json::from_value(serde_json::Value::Object(m))
            .map_err(|e| format!("{line}: metric cells do not read as metrics: {e}"))?;
        rows.push(ResultsRow { line, cells, metrics });
    }
    if rows.is_empty() {
        return Err("2: no rows after the header; expected one row per point".into());
    }
    Ok(ResultsTable { header, rows })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "spec,trace,method,hole_fill,runs,tile,point,psnr_luma_db,golden_identical_frames\n\
                        s,room,a,x,1,,p,20.5,\n\
                        s,room,hardware,,,8,q,24,2\n";

    #[test]
    fn metrics_read_into_the_shared_struct() {
        let t = read_csv(GOOD).unwrap();
        assert_eq!(t.rows[0].metrics.psnr_luma_db, Some(20.5));
        assert_eq!(t.rows[1].metrics.golden_identical_frames, Some(2));
        assert_eq!(t.rows[1].line, 3);
        assert_eq!(t.knob_columns(), 5..6);
        assert_eq!(t.cell(&t.rows[1], "tile"), "8");
    }

    #[test]
    fn malformed_files_are_errors_at_their_line() {
        let cases = [
            ("", "1: empty file"),
            ("\n", "1: empty file"),
            ("spec,trace,method\n", "1: no `hole_fill` column"),
            ("spec,trace,method,hole_fill,psnr_luma_db\n", "2: no rows"),
            (&GOOD.replace("20.5,\n", "20.5\n"), "2: 8 cells; the header has 9"),
            (&GOOD.replace("20.5", "NaN"), "2: column `psnr_luma_db` is `NaN`"),
            (&GOOD.replace("20.5", "inf"), "2: column `psnr_luma_db` is `inf`"),
            (&GOOD.replace("20.5", "good"), "2: column `psnr_luma_db` is `good`"),
            (&GOOD.replace(",24,2", ",24,-2"), "3: column `golden_identical_frames` is `-2`"),
            (&format!("{GOOD}\ns,room,a,x,1,,p,20.5,\n"), "4: blank line"),
            (&GOOD.replace("s,room,a", "s,\"room,a"), "2: unterminated quoted field"),
        ];
        for (text, want) in cases {
            let e = read_csv(text).unwrap_err();
            assert!(e.starts_with(want), "{text:?}: {e}");
        }
    }
}
