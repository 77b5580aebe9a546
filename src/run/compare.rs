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
use crate::report::method::MethodMean;
use crate::trace::Trace;
use anyhow::Context;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A column of the table: the report's `mean` value, CSV header with
/// unit, Markdown header, decimals, scale for print.
pub struct Column {
    /// The value in the run's `mean`.
    pub value: fn(&MethodMean) -> Option<f64>,
    /// `compare.csv` header (with unit).
    pub csv: &'static str,
    /// `compare.md` header.
    pub markdown: &'static str,
    /// Decimals in `compare.md` (two more in `compare.csv`).
    pub decimals: usize,
    /// Scale in `compare.md` (100 for a fraction shown as %).
    pub scale: f64,
}

/// Columns of the table, read from the report's `mean` (typed).
pub const COLUMNS: &[Column] = &[
    Column {
        value: |m| Some(m.primitives),
        csv: "primitives_per_frame",
        markdown: "primitives",
        decimals: 0,
        scale: 1.0,
    },
    Column { value: |m| Some(m.host_ms), csv: "host_ms_per_frame", markdown: "host ms", decimals: 2, scale: 1.0 },
    Column { value: |m| m.scores.psnr_luma_db, csv: "psnr_luma_db", markdown: "PSNR luma dB", decimals: 2, scale: 1.0 },
    Column { value: |m| m.scores.ssim_luma, csv: "ssim_luma", markdown: "SSIM", decimals: 4, scale: 1.0 },
    Column { value: |m| m.scores.flip_mean, csv: "flip_mean", markdown: "FLIP", decimals: 4, scale: 1.0 },
    Column { value: |m| m.scores.hole_fraction, csv: "hole_fraction", markdown: "holes %", decimals: 2, scale: 100.0 },
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
    pub mean: MethodMean,
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
            rows.push(Row { trace: name.clone(), method: m.into(), hole_fill: f.into(), mean: r.report.mean.clone() });
        }
    }
    let csv = csv(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.csv"), csv.as_bytes())?;
    let md = markdown(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.md"), md.as_bytes())?;
    Ok(rows)
}

fn cell(v: Option<f64>, decimals: usize, scale: f64) -> String {
    v.map_or("-".into(), |x| format!("{:.*}", decimals, x * scale))
}

/// `compare.csv`: one row per (trace, method, hole fill).
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("trace,method,hole_fill");
    for c in COLUMNS {
        s += ",";
        s += c.csv;
    }
    s.push('\n');
    for r in rows {
        let _ = write!(s, "{},{},{}", r.trace, r.method, r.hole_fill);
        for c in COLUMNS {
            let _ = write!(s, ",{}", cell((c.value)(&r.mean), c.decimals + 2, 1.0));
        }
        s.push('\n');
    }
    s
}

/// `compare.md`: the Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from("| trace | method | hole fill |");
    for c in COLUMNS {
        let _ = write!(s, " {} |", c.markdown);
    }
    s += "\n|---|---|---|";
    s += &"---:|".repeat(COLUMNS.len());
    s.push('\n');
    for r in rows {
        let _ = write!(s, "| {} | {} | {} |", r.trace, r.method, r.hole_fill);
        for c in COLUMNS {
            let _ = write!(s, " {} |", cell((c.value)(&r.mean), c.decimals, c.scale));
        }
        s.push('\n');
    }
    s
}
