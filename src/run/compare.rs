//! `postwarp compare`: every comparison method on every trace given, one
//! after another on one thread (so host times are comparable), into a
//! table of primitives, host time and quality (`docs/methods.md`).
//!
//! Rules:
//! 1. Each (trace, reconstruction, hole fill) runs with
//!    [`run_method`](super::method::run_method) into
//!    `OUT/<trace>/<method>+<fill>/`, with that run's frames and report.
//! 2. The table row is that report's `mean`: `primitives`, `host_ms`
//!    (mean over frames of each frame's median of `runs` runs),
//!    `psnr_luma_db`, `ssim_luma`, `flip_mean`, `hole_fraction`.
//! 3. `OUT/compare.csv` (units in the header) and `OUT/compare.md` (the
//!    Markdown table `docs/methods.md` shows) are written atomically.

use super::method::run_method;
use crate::methods::{HoleFill, Reconstruction};
use crate::trace::Trace;
use anyhow::Context;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Columns of the table: (report key in `mean`, CSV header with unit,
/// Markdown header, decimals).
pub const COLUMNS: &[(&str, &str, &str, usize)] = &[
    ("primitives", "primitives_per_frame", "primitives", 0),
    ("host_ms", "host_ms_per_frame", "host ms", 2),
    ("psnr_luma_db", "psnr_luma_db", "PSNR luma dB", 2),
    ("ssim_luma", "ssim_luma", "SSIM", 4),
    ("flip_mean", "flip_mean", "FLIP", 4),
    ("hole_fraction", "hole_fraction", "holes %", 2),
];

/// One row: trace name, method, hole fill, and the mean entry.
pub struct Row {
    /// Trace directory name.
    pub trace: String,
    /// Reconstruction name.
    pub method: String,
    /// Hole-fill name.
    pub hole_fill: String,
    /// The run's `mean` entry.
    pub mean: Value,
}

fn trace_name(p: &Path) -> String {
    let p = if p.file_name().is_some_and(|n| n == "postwarp.trace") { p.parent().unwrap_or(p) } else { p };
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

/// A reconstruction and the hole fill it runs with.
pub type Pair = (Box<dyn Reconstruction>, Box<dyn HoleFill>);

/// Run every `(reconstruction, hole fill)` pair on every trace.
pub fn run_compare(traces: &[PathBuf], pairs: &[Pair], runs: u32, out: &Path) -> anyhow::Result<Vec<Row>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut rows = Vec::new();
    for t in traces {
        let trace = Trace::open(t)?;
        let name = trace_name(t);
        for (rec, fill) in pairs {
            let (m, f) = (rec.info().name, fill.info().name);
            let dir = out.join(&name).join(format!("{m}+{f}"));
            let r = run_method(&trace, rec.as_ref(), fill.as_ref(), runs, &dir)
                .with_context(|| format!("{name}: method {m} with hole fill {f}"))?;
            rows.push(Row {
                trace: name.clone(),
                method: m.into(),
                hole_fill: f.into(),
                mean: r.report["mean"].clone(),
            });
        }
    }
    let csv = csv(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.csv"), csv.as_bytes())?;
    let md = markdown(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.md"), md.as_bytes())?;
    Ok(rows)
}

fn cell(v: &Value, key: &str, decimals: usize, scale: f64) -> String {
    v.get(key).and_then(Value::as_f64).map_or("-".into(), |x| format!("{:.*}", decimals, x * scale))
}

/// `compare.csv`: one row per (trace, method, hole fill).
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("trace,method,hole_fill");
    for (_, h, _, _) in COLUMNS {
        s += ",";
        s += h;
    }
    s.push('\n');
    for r in rows {
        let _ = write!(s, "{},{},{}", r.trace, r.method, r.hole_fill);
        for (k, _, _, d) in COLUMNS {
            let _ = write!(s, ",{}", cell(&r.mean, k, d + 2, 1.0));
        }
        s.push('\n');
    }
    s
}

/// `compare.md`: the Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from("| trace | method | hole fill |");
    for (_, _, h, _) in COLUMNS {
        let _ = write!(s, " {h} |");
    }
    s += "\n|---|---|---|";
    s += &"---:|".repeat(COLUMNS.len());
    s.push('\n');
    for r in rows {
        let _ = write!(s, "| {} | {} | {} |", r.trace, r.method, r.hole_fill);
        for (k, _, _, d) in COLUMNS {
            let scale = if *k == "hole_fraction" { 100.0 } else { 1.0 };
            let _ = write!(s, " {} |", cell(&r.mean, k, *d, scale));
        }
        s.push('\n');
    }
    s
}
