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
//! 3. The common mask (`docs/metrics.md`): when every pair of a trace has
//!    run, each frame with ground truth is scored again on the pixels the
//!    truth knows and a reference sees (`seen`) that *every* pair covered
//!    with a real sample (read back from the runs' `frame-NNNN.png` and
//!    `holes-NNNN.png`, which hold exactly what the metrics see). Each run's
//!    `report.json` is rewritten with those `*_common` keys, so within one
//!    comparison they are over the same pixels for every pair.
//! 4. `OUT/compare.csv` (units in the header) and `OUT/compare.md` (the
//!    Markdown table `docs/methods.md` shows) are written atomically.

use super::method::run_method;
use crate::methods::{HoleFill, Reconstruction};
use crate::metrics::{MetricInput, common_mask, evaluate};
use crate::picture::srgb_to_linear;
use crate::report::MethodReport;
use crate::report::method::MethodMean;
use crate::trace::Trace;
use anyhow::Context;
use bitvec::vec::BitVec;
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
    Column { value: |m| m.scores.psnr_rgb_db, csv: "psnr_rgb_db", markdown: "PSNR RGB dB", decimals: 2, scale: 1.0 },
    Column {
        value: |m| m.scores.psnr_rgb_common_db,
        csv: "psnr_rgb_common_db",
        markdown: "common PSNR RGB dB",
        decimals: 2,
        scale: 1.0,
    },
    Column {
        value: |m| m.scores.ssim_luma_common,
        csv: "ssim_luma_common",
        markdown: "common SSIM",
        decimals: 4,
        scale: 1.0,
    },
    Column {
        value: |m| m.scores.flip_mean_common,
        csv: "flip_mean_common",
        markdown: "common FLIP",
        decimals: 4,
        scale: 1.0,
    },
    Column {
        value: |m| m.scores.psnr_rgb_never_seen_db,
        csv: "psnr_rgb_never_seen_db",
        markdown: "never-seen PSNR RGB dB",
        decimals: 2,
        scale: 1.0,
    },
    Column {
        value: |m| m.pixels.common_pixels,
        csv: "common_pixels_per_frame",
        markdown: "common px",
        decimals: 0,
        scale: 1.0,
    },
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
pub fn run_compare(traces: &[PathBuf], pairs: &[Pair], runs: u32, flip: bool, out: &Path) -> anyhow::Result<Vec<Row>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut rows = Vec::new();
    for t in traces {
        let trace = Trace::open(t)?;
        let name = trace_name(t);
        let mut runs_of_trace = Vec::new();
        for (rec, fill) in pairs {
            let (m, f) = (rec.info().name, fill.info().name);
            let dir = out.join(&name).join(format!("{m}+{f}"));
            let r = run_method(&trace, rec.as_ref(), fill.as_ref(), runs, flip, &dir)
                .with_context(|| format!("{name}: method {m} with hole fill {f}"))?;
            runs_of_trace.push((m, f, dir, r.report));
        }
        let dirs: Vec<&Path> = runs_of_trace.iter().map(|r| r.2.as_path()).collect();
        let mut reports: Vec<_> = runs_of_trace.iter().map(|r| r.3.clone()).collect();
        score_common(&trace, &dirs, &mut reports).with_context(|| format!("{name}: scoring on the common mask"))?;
        for ((m, f, dir, _), report) in runs_of_trace.into_iter().zip(reports) {
            let report = report.reduced_again();
            crate::report::write(&report, &dir)?;
            rows.push(Row { trace: name.clone(), method: m.into(), hole_fill: f.into(), mean: report.mean });
        }
    }
    let csv = csv(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.csv"), csv.as_bytes())?;
    let md = markdown(&rows);
    crate::io_util::write_bytes_atomically(&out.join("compare.md"), md.as_bytes())?;
    Ok(rows)
}

/// An 8-bit RGB PNG of `expected` size, as written by the runs.
fn read_rgb8(path: &Path, expected: (u32, u32)) -> anyhow::Result<Vec<[u8; 3]>> {
    let img = image::ImageReader::open(path)
        .with_context(|| format!("opening {}", path.display()))?
        .decode()
        .with_context(|| format!("{}: cannot decode as PNG", path.display()))?
        .to_rgb8();
    anyhow::ensure!(
        img.dimensions() == expected,
        "{} is {}x{}; expected {}x{} (the trace's display)",
        path.display(),
        img.width(),
        img.height(),
        expected.0,
        expected.1
    );
    Ok(img.pixels().map(|p| p.0).collect())
}

/// Rule 3: score every frame with ground truth of the runs in `dirs` on
/// their common mask, into the `*_common` keys of `reports` (same order).
pub fn score_common(trace: &Trace, dirs: &[&Path], reports: &mut [MethodReport]) -> anyhow::Result<()> {
    let size = (trace.display.width, trace.display.height);
    for k in 0..trace.derived.len() {
        let Some(truth) = trace.load_truth(k)? else { continue };
        let mut images = Vec::with_capacity(dirs.len());
        let mut covered = Vec::with_capacity(dirs.len());
        for d in dirs {
            let rgb = read_rgb8(&d.join(format!("frame-{k:04}.png")), size)?;
            images.push(rgb.iter().map(|c| c.map(srgb_to_linear)).collect::<Vec<[f32; 3]>>());
            // Black in the hole mask: every sample of the pixel real.
            let holes = read_rgb8(&d.join(format!("holes-{k:04}.png")), size)?;
            covered.push(holes.iter().map(|c| *c == [0, 0, 0]).collect::<BitVec>());
        }
        let refs: Vec<&BitVec> = covered.iter().collect();
        let common = common_mask(&truth.known, truth.seen.as_ref(), &refs)?;
        for ((img, cov), report) in images.iter().zip(&covered).zip(reports.iter_mut()) {
            let q = evaluate(&MetricInput {
                width: size.0,
                height: size.1,
                image: img,
                truth: &truth.colour,
                known: &truth.known,
                covered: Some(cov),
                common: Some(&common),
                seen: truth.seen.as_ref(),
                flip: report.flip,
            })?;
            let f = report.frames.iter_mut().find(|f| f.index == k).context("a run without the frame")?;
            f.scores.psnr_rgb_common_db = q.psnr_rgb_common_db.is_finite().then_some(q.psnr_rgb_common_db);
            f.scores.ssim_luma_common = q.ssim_luma_common.is_finite().then_some(q.ssim_luma_common);
            f.scores.flip_mean_common = q.flip_mean_common.is_finite().then_some(q.flip_mean_common);
            f.pixels.common_pixels = Some(q.common_pixels);
        }
    }
    Ok(())
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
