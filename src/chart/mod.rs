//! Charts of a sweep's `results.csv`: quality against cost with the Pareto
//! front, one chart per trace and (quality, cost) pair that has points, as
//! SVG and PNG (`docs/sweep.md`).
//!
//! API: [`charts_from_csv`] (the charts a CSV gives), [`write_charts`]
//! (render them into a directory), [`pareto::pareto_front`],
//! [`scatter::render_svg`] / [`scatter::render_png`] for one
//! [`scatter::Scatter`].
//!
//! Rules:
//! 1. Qualities: luma PSNR and SSIM (higher is better) and mean FLIP
//!    (lower is better). Costs: host time per frame (CPU methods), cycles
//!    per frame, DRAM GB/s at the target frame rate and DRAM GB/s
//!    delivered over the frame's time (hardware). A chart
//!    holds the rows of one trace with both values.
//! 2. A series is a method with its hole fill (`hardware` alone); its
//!    colour and shape follow its first appearance in the CSV, so a method
//!    looks the same in every chart of a sweep.
//! 3. Within a series, each point is labelled with the knob columns
//!    (between `runs` and `point` in the CSV) whose values differ between
//!    the series' points in that chart, e.g. `dest_cache_bytes=65536`.
//! 4. File names: `<trace>.<quality>-vs-<cost>.svg` / `.png`, the trace
//!    label with characters other than letters, digits, `-`, `_`, `.`, `=`
//!    replaced by `_`.
//! 5. A stress sweep (exactly one generated-trace column varies) also
//!    gives stability charts of luma PSNR against that column, with each
//!    method's failure point marked ([`stability`]).
//! 6. A precision sweep (an `arith` knob column and `q_…` format columns)
//!    also gives charts of luma PSNR against each format's fraction bits,
//!    against float and against ground truth ([`precision`]).
//! 7. Same CSV, same bytes. Charts are written atomically; chart files of
//!    an earlier run that this CSV no longer gives are removed.

pub mod axis;
pub mod font;
pub mod pareto;
pub mod precision;
pub mod scatter;
pub mod stability;
pub mod style;

use crate::sweep::point::Metrics;
use crate::sweep::results::{ResultsTable, read_csv};
use anyhow::Context;
use pareto::Better;
use scatter::{Scatter, Series};
use std::path::{Path, PathBuf};

/// A quantity a chart plots: its `results.csv` column (for file names),
/// the axis label with its unit, a short name for titles, and how it is
/// read from a row's [`Metrics`].
pub struct Measure {
    /// The column (a [`Metrics`] field).
    pub column: &'static str,
    /// Axis label: what it is, with its unit.
    pub label: &'static str,
    /// Short name for titles.
    pub short: &'static str,
    /// The value in a row.
    pub value: fn(&Metrics) -> Option<f64>,
}

/// Qualities, with which direction is better.
pub const QUALITIES: &[(Measure, Better)] = &[
    (
        Measure {
            column: "psnr_luma_db",
            label: "luma PSNR (dB), higher is better",
            short: "luma PSNR",
            value: |m| m.psnr_luma_db,
        },
        Better::Higher,
    ),
    (
        Measure {
            column: "ssim_luma",
            label: "luma SSIM (1), higher is better",
            short: "SSIM",
            value: |m| m.ssim_luma,
        },
        Better::Higher,
    ),
    (
        Measure { column: "flip_mean", label: "mean FLIP (1), lower is better", short: "FLIP", value: |m| m.flip_mean },
        Better::Lower,
    ),
];

/// Costs.
pub const COSTS: &[Measure] = &[
    Measure {
        column: "host_ms_per_frame",
        label: "host time per frame (ms, one core, median of runs)",
        short: "host time",
        value: |m| m.host_ms_per_frame,
    },
    Measure {
        column: "cycles_per_frame",
        label: "engine cycles per frame (cycles)",
        short: "cycles",
        value: |m| m.cycles_per_frame,
    },
    Measure {
        column: "dram_gbps_at_target_rate",
        label: "DRAM bandwidth at the target frame rate (GB/s)",
        short: "DRAM bandwidth",
        value: |m| m.dram_gbps_at_target_rate,
    },
    Measure {
        column: "dram_achieved_gbps",
        label: "DRAM bandwidth delivered over the frame's time (GB/s)",
        short: "achieved DRAM bandwidth",
        value: |m| m.dram_achieved_gbps,
    },
];

/// File-name form of a trace label (module rule 4).
pub fn file_label(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.=".contains(c) { c } else { '_' }).collect()
}

/// Check the text of a `results.csv` as the charts read it (errors are
/// `LINE: message`).
pub fn check_csv(csv: &str) -> Result<(), String> {
    read_csv(csv).map(|_| ())
}

/// Every chart `csv` (the text of a `results.csv`) gives, with its file
/// stem, in order: trace (first appearance), cost, quality.
pub fn charts_from_csv(csv: &str) -> Result<Vec<(String, Scatter)>, String> {
    Ok(charts_from_table(&read_csv(csv)?))
}

/// Every chart of a read `results.csv` (see [`charts_from_csv`]).
pub fn charts_from_table(t: &ResultsTable) -> Vec<(String, Scatter)> {
    let knob_cols: Vec<usize> = t.knob_columns().collect();
    let series_name = |r: &crate::sweep::results::ResultsRow| {
        let (m, f) = (t.cell(r, "method"), t.cell(r, "hole_fill"));
        if f.is_empty() { m.to_string() } else { format!("{m} + {f}") }
    };
    let mut all_series: Vec<String> = Vec::new();
    let mut traces: Vec<&str> = Vec::new();
    for r in &t.rows {
        let s = series_name(r);
        if !all_series.contains(&s) {
            all_series.push(s);
        }
        let tr = t.cell(r, "trace");
        if !traces.contains(&tr) {
            traces.push(tr);
        }
    }
    let present = |m: &Measure| t.col(m.column).is_some();
    let mut out = Vec::new();
    for tr in &traces {
        let mine: Vec<_> = t.rows.iter().filter(|r| t.cell(r, "trace") == *tr).collect();
        let spec_name = mine.first().map(|r| t.cell(r, "spec")).unwrap_or_default();
        for cost in COSTS.iter().filter(|m| present(m)) {
            for (quality, better) in QUALITIES.iter().filter(|(m, _)| present(m)) {
                let mut series: Vec<Series> = Vec::new();
                let mut knobs: Vec<Vec<Vec<String>>> = Vec::new();
                for r in &mine {
                    let (Some(x), Some(y)) = ((cost.value)(&r.metrics), (quality.value)(&r.metrics)) else { continue };
                    let name = series_name(r);
                    let values: Vec<String> = knob_cols.iter().map(|&c| r.cells[c].clone()).collect();
                    match series.iter().position(|s| s.name == name) {
                        Some(i) => {
                            series[i].points.push((x, y));
                            knobs[i].push(values);
                        }
                        None => {
                            series.push(Series {
                                style: all_series.iter().position(|s| *s == name).unwrap_or(0),
                                name,
                                points: vec![(x, y)],
                                labels: Vec::new(),
                            });
                            knobs.push(vec![values]);
                        }
                    }
                }
                if series.is_empty() {
                    continue;
                }
                for (ser, vals) in series.iter_mut().zip(&knobs) {
                    let varying: Vec<usize> =
                        (0..knob_cols.len()).filter(|&k| vals.iter().any(|v| v[k] != vals[0][k])).collect();
                    ser.labels = vals
                        .iter()
                        .map(|v| {
                            let parts: Vec<String> =
                                varying.iter().map(|&k| format!("{}={}", t.header[knob_cols[k]], v[k])).collect();
                            parts.join(", ")
                        })
                        .collect();
                }
                series.sort_by_key(|s| s.style);
                out.push((
                    format!("{}.{}-vs-{}", file_label(tr), quality.column, cost.column),
                    Scatter {
                        title: format!("{spec_name}: {tr}, {} against {}", quality.short, cost.short),
                        x_label: cost.label.to_string(),
                        y_label: quality.label.to_string(),
                        better: *better,
                        series,
                    },
                ));
            }
        }
    }
    out
}

/// Render every chart of `csv` into `dir` as `.svg` and `.png` (module
/// rules); returns the files written.
pub fn write_charts(csv: &str, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let table = read_csv(csv).map_err(|e| anyhow::anyhow!("line {e}"))?;
    let charts = charts_from_table(&table);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    let mut put = |stem: &str, svg: Result<String, String>, png: Result<Vec<u8>, String>| -> anyhow::Result<()> {
        for (ext, bytes) in [("svg", svg.map(String::into_bytes)), ("png", png)] {
            let path = dir.join(format!("{stem}.{ext}"));
            crate::io_util::write_bytes_atomically(&path, &bytes.map_err(anyhow::Error::msg)?)
                .with_context(|| format!("writing {}", path.display()))?;
            written.push(path);
        }
        Ok(())
    };
    for (stem, c) in &charts {
        put(stem, scatter::render_svg(c), scatter::render_png(c))?;
    }
    for (stem, c) in stability::stress_charts(&table) {
        put(&stem, stability::render_svg(&c), stability::render_png(&c))?;
    }
    for (stem, c) in precision::precision_charts(&table) {
        put(&stem, precision::render_svg(&c), precision::render_png(&c))?;
    }
    for entry in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let p = entry?.path();
        let chart_file = p.extension().is_some_and(|x| x == "svg" || x == "png");
        if chart_file && !written.contains(&p) {
            std::fs::remove_file(&p).with_context(|| format!("removing stale chart {}", p.display()))?;
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_per_trace_and_measure_with_stable_styles() {
        let csv = "spec,trace,method,hole_fill,runs,tile,point,host_ms_per_frame,cycles_per_frame,dram_gbps_at_target_rate,psnr_luma_db,ssim_luma,flip_mean\n\
                   s,room,a,x,1,,p,1.0,,,20,0.8,0.1\n\
                   s,room,b,x,1,,p,2.0,,,25,0.9,0.05\n\
                   s,room,hardware,,,8,p,,1000,0.5,24,0.85,0.06\n\
                   s,room,hardware,,,16,p,,900,0.4,24,0.85,0.06\n\
                   s,room a,b,x,1,,p,2.0,,,25,0.9,0.05\n";
        let charts = charts_from_csv(csv).unwrap();
        let stems: Vec<&str> = charts.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(stems.len(), 3 * 3 + 3, "{stems:?}");
        assert_eq!(stems[0], "room.psnr_luma_db-vs-host_ms_per_frame");
        assert!(stems.contains(&"room.flip_mean-vs-dram_gbps_at_target_rate"));
        assert!(stems.contains(&"room_a.ssim_luma-vs-host_ms_per_frame"));
        let other = &charts.iter().find(|c| c.0.starts_with("room_a")).unwrap().1;
        assert_eq!((other.series[0].name.as_str(), other.series[0].style), ("b + x", 1));
        let hw = &charts.iter().find(|c| c.0 == "room.psnr_luma_db-vs-cycles_per_frame").unwrap().1;
        assert_eq!(hw.series[0].name, "hardware");
        assert_eq!(hw.series[0].labels, ["tile=8", "tile=16"], "only varying knobs label points");
        assert_eq!(other.series[0].labels, [""]);
        assert!(hw.title.starts_with("s: room"));
    }
}
