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
//!    per frame and DRAM GB/s at the target frame rate (hardware). A chart
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
//! 6. Same CSV, same bytes. Charts are written atomically; chart files of
//!    an earlier run that this CSV no longer gives are removed.

pub mod font;
pub mod pareto;
pub mod scatter;
pub mod stability;
pub mod style;

use anyhow::Context;
use pareto::Better;
use scatter::{Scatter, Series};
use std::path::{Path, PathBuf};

/// Quality columns: (column, axis label, short name, better).
pub const QUALITIES: &[(&str, &str, &str, Better)] = &[
    ("psnr_luma_db", "luma PSNR (dB), higher is better", "luma PSNR", Better::Higher),
    ("ssim_luma", "luma SSIM (1), higher is better", "SSIM", Better::Higher),
    ("flip_mean", "mean FLIP (1), lower is better", "FLIP", Better::Lower),
];

/// Cost columns: (column, axis label, short name).
pub const COSTS: &[(&str, &str, &str)] = &[
    ("host_ms_per_frame", "host time per frame (ms, one core, median of runs)", "host time"),
    ("cycles_per_frame", "engine cycles per frame (cycles)", "cycles"),
    ("dram_gbps_at_target_rate", "DRAM bandwidth at the target frame rate (GB/s)", "DRAM bandwidth"),
];

/// File-name form of a trace label (module rule 4).
pub fn file_label(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.=".contains(c) { c } else { '_' }).collect()
}

/// Every chart `csv` (the text of a `results.csv`) gives, with its file
/// stem, in order: trace (first appearance), cost, quality.
pub fn charts_from_csv(csv: &str) -> Result<Vec<(String, Scatter)>, String> {
    let rows = crate::report::csv::parse(csv)?;
    let Some((header, rows)) = rows.split_first() else { return Ok(Vec::new()) };
    let col =
        |name: &str| header.iter().position(|h| h == name).ok_or_else(|| format!("results CSV has no `{name}` column"));
    let (c_spec, c_trace, c_method, c_fill) = (col("spec")?, col("trace")?, col("method")?, col("hole_fill")?);
    // Knob columns: between `runs` and `point` (docs/sweep.md).
    let knob_cols: Vec<usize> = match (col("runs"), col("point")) {
        (Ok(a), Ok(b)) if a < b => (a + 1..b).collect(),
        _ => Vec::new(),
    };
    let cell = |r: &Vec<String>, c: usize| r.get(c).cloned().unwrap_or_default();
    let num = |r: &Vec<String>, c: usize| r.get(c).and_then(|v| v.parse::<f64>().ok()).filter(|v| v.is_finite());
    let series_name = |r: &Vec<String>| {
        let (m, f) = (cell(r, c_method), cell(r, c_fill));
        if f.is_empty() { m } else { format!("{m} + {f}") }
    };
    let mut all_series: Vec<String> = Vec::new();
    let mut traces: Vec<String> = Vec::new();
    for r in rows {
        let s = series_name(r);
        if !all_series.contains(&s) {
            all_series.push(s);
        }
        let t = cell(r, c_trace);
        if !traces.contains(&t) {
            traces.push(t);
        }
    }
    let mut out = Vec::new();
    for t in &traces {
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| cell(r, c_trace) == *t).collect();
        let spec_name = mine.first().map(|r| cell(r, c_spec)).unwrap_or_default();
        for (cost, cost_label, cost_short) in COSTS {
            let Ok(cc) = col(cost) else { continue };
            for (quality, q_label, q_short, better) in QUALITIES {
                let Ok(qc) = col(quality) else { continue };
                let mut series: Vec<Series> = Vec::new();
                let mut knobs: Vec<Vec<Vec<String>>> = Vec::new();
                for r in &mine {
                    let (Some(x), Some(y)) = (num(r, cc), num(r, qc)) else { continue };
                    let name = series_name(r);
                    let values: Vec<String> = knob_cols.iter().map(|&c| cell(r, c)).collect();
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
                                varying.iter().map(|&k| format!("{}={}", header[knob_cols[k]], v[k])).collect();
                            parts.join(", ")
                        })
                        .collect();
                }
                series.sort_by_key(|s| s.style);
                out.push((
                    format!("{}.{quality}-vs-{cost}", file_label(t)),
                    Scatter {
                        title: format!("{spec_name}: {t}, {q_short} against {cost_short}"),
                        x_label: cost_label.to_string(),
                        y_label: q_label.to_string(),
                        better: *better,
                        series,
                    },
                ));
            }
        }
    }
    Ok(out)
}

/// Render every chart of `csv` into `dir` as `.svg` and `.png` (module
/// rules); returns the files written.
pub fn write_charts(csv: &str, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let charts = charts_from_csv(csv).map_err(anyhow::Error::msg)?;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    for (stem, chart) in &charts {
        let svg = dir.join(format!("{stem}.svg"));
        crate::io_util::write_bytes_atomically(
            &svg,
            scatter::render_svg(chart).map_err(anyhow::Error::msg)?.as_bytes(),
        )
        .with_context(|| format!("writing {}", svg.display()))?;
        let png = dir.join(format!("{stem}.png"));
        crate::io_util::write_bytes_atomically(&png, &scatter::render_png(chart).map_err(anyhow::Error::msg)?)
            .with_context(|| format!("writing {}", png.display()))?;
        written.push(svg);
        written.push(png);
    }
    for (stem, chart) in stability::stress_charts_from_csv(csv).map_err(anyhow::Error::msg)? {
        let svg = dir.join(format!("{stem}.svg"));
        crate::io_util::write_bytes_atomically(
            &svg,
            stability::render_svg(&chart).map_err(anyhow::Error::msg)?.as_bytes(),
        )
        .with_context(|| format!("writing {}", svg.display()))?;
        let png = dir.join(format!("{stem}.png"));
        crate::io_util::write_bytes_atomically(&png, &stability::render_png(&chart).map_err(anyhow::Error::msg)?)
            .with_context(|| format!("writing {}", png.display()))?;
        written.push(svg);
        written.push(png);
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
