//! Stability charts: quality against ONE stressed quantity, with the point
//! where each method fails marked (`docs/stability.md`).
//!
//! Rules:
//! 1. A CSV is a stress sweep when exactly one generated-trace column
//!    ([`crate::sweep::trace_fields::TRACE_FIELDS`]) takes more than one
//!    value, all of them numbers: that column is the stress axis. One chart
//!    per scene, `stability.<scene>.psnr_luma_db-vs-<column>.svg` / `.png`
//!    (a scene file by its stem).
//! 2. x = the stress value, y = luma PSNR (dB); one line with markers per
//!    method and hole fill, styled as in the cost charts. The x axis is
//!    logarithmic, ticked at the stress values, when they are all positive
//!    and span more than a factor of 20 (`log_x`).
//! 3. Threshold: luma PSNR [`THRESHOLD_DB`] = 25 dB, a horizontal dashed
//!    line. Failure ([`failure_points`]): the *unstressed* value is the
//!    first value of the axis in the CSV (the specification lists the
//!    unstressed value first, then increasing stress); on each side of it,
//!    the method fails at the first listed value whose PSNR is below the
//!    threshold. Failures are ringed in black, and the legend lists them
//!    ("below unstressed" when the unstressed point is already below).

use super::font::{self, FAMILY};
use super::scatter::{HEIGHT, WIDTH, tick};
use super::style::{draw_marker, series_style};
use crate::sweep::results::{ResultsRow, ResultsTable};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::ops::Range;

/// The quality threshold (luma PSNR, dB) below which a method has failed.
pub const THRESHOLD_DB: f64 = 25.0;

const LEGEND_WIDTH: u32 = 290;
const TITLE_HEIGHT: u32 = 40;
const MARKER: i32 = 5;

/// One stability chart.
#[derive(Clone, Debug, PartialEq)]
pub struct StressChart {
    /// Title (specification, scene, stress).
    pub title: String,
    /// x-axis description with unit (the stress column).
    pub x_label: String,
    /// Failure threshold (dB).
    pub threshold: f64,
    /// Series in legend order.
    pub series: Vec<StressSeries>,
}

/// One method's points.
#[derive(Clone, Debug, PartialEq)]
pub struct StressSeries {
    /// Legend text (method, hole fill).
    pub name: String,
    /// Style number, as in the cost charts.
    pub style: usize,
    /// `(stress, luma PSNR)` in CSV order (the first is the unstressed point).
    pub points: Vec<(f64, f64)>,
    /// Stress values where it fails ([`failure_points`]).
    pub failures: Vec<f64>,
}

/// Where a method fails (module rule 3): `points` are `(stress, quality)`
/// in axis order as the specification lists it, the first being the
/// unstressed value `x0`. Returns, for the side below `x0` and then the
/// side above, the first value in that order whose quality is below
/// `threshold` (NaN counts as below: nothing usable); or `x0` alone if it
/// is already below.
pub fn failure_points(points: &[(f64, f64)], threshold: f64) -> Vec<f64> {
    let Some(&(x0, y0)) = points.first() else { return Vec::new() };
    let below = |y: f64| y.is_nan() || y < threshold;
    if below(y0) {
        return vec![x0];
    }
    [-1.0, 1.0]
        .into_iter()
        .filter_map(|side| points.iter().find(|p| (p.0 - x0) * side > 0.0 && below(p.1)).map(|p| p.0))
        .collect()
}

/// The stress column of a read `results.csv` (module rule 1), or `None`.
pub fn stress_column(t: &ResultsTable) -> Option<usize> {
    let mut found = None;
    for (_, _, _, col) in crate::sweep::trace_fields::TRACE_FIELDS {
        let Some(c) = t.col(col) else { continue };
        let mut values: Vec<&str> = t.rows.iter().map(|r| r.cells[c].as_str()).collect();
        values.sort();
        values.dedup();
        if values.len() > 1 {
            if found.is_some() || values.iter().any(|v| v.parse::<f64>().map_or(true, |x| !x.is_finite())) {
                return None;
            }
            found = Some(c);
        }
    }
    found
}

/// Every stability chart `csv` gives, with its file stem (empty when the
/// CSV is not a stress sweep); errors are `LINE: message`.
pub fn stress_charts_from_csv(csv: &str) -> Result<Vec<(String, StressChart)>, String> {
    Ok(stress_charts(&crate::sweep::results::read_csv(csv)?))
}

/// Every stability chart of a read `results.csv` (see
/// [`stress_charts_from_csv`]). Luma PSNR is read from the rows'
/// [`crate::sweep::point::Metrics`]; a row without one (nothing scored)
/// counts as a failure.
pub fn stress_charts(t: &ResultsTable) -> Vec<(String, StressChart)> {
    let Some(sc) = stress_column(t) else { return Vec::new() };
    let series_name = |r: &ResultsRow| {
        let (m, f) = (t.cell(r, "method"), t.cell(r, "hole_fill"));
        if f.is_empty() { m.to_string() } else { format!("{m} + {f}") }
    };
    let mut all_series: Vec<String> = Vec::new();
    let mut scenes: Vec<&str> = Vec::new();
    for r in &t.rows {
        let s = series_name(r);
        if !all_series.contains(&s) {
            all_series.push(s);
        }
        if !scenes.contains(&t.cell(r, "scene")) {
            scenes.push(t.cell(r, "scene"));
        }
    }
    let stress = t.header[sc].clone();
    let mut out = Vec::new();
    for scene in &scenes {
        let mut series: Vec<StressSeries> = Vec::new();
        let mut spec_name = String::new();
        for r in t.rows.iter().filter(|r| t.cell(r, "scene") == *scene) {
            spec_name = t.cell(r, "spec").to_string();
            let Ok(x) = r.cells[sc].parse::<f64>() else { continue };
            let y = r.metrics.psnr_luma_db.unwrap_or(f64::NAN);
            let name = series_name(r);
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push((x, y)),
                None => series.push(StressSeries {
                    style: all_series.iter().position(|s| *s == name).unwrap_or(0),
                    name,
                    points: vec![(x, y)],
                    failures: Vec::new(),
                }),
            }
        }
        for s in &mut series {
            s.failures = failure_points(&s.points, THRESHOLD_DB);
        }
        series.sort_by_key(|s| s.style);
        let (label, short) = stress_label(&stress);
        out.push((
            format!("stability.{}.psnr_luma_db-vs-{stress}", super::file_label(&scene_label(scene))),
            StressChart {
                title: format!("{spec_name}: {}, luma PSNR against {short}", scene_label(scene)),
                x_label: label,
                threshold: THRESHOLD_DB,
                series,
            },
        ));
    }
    out
}

/// A scene as the charts name it: a built-in scene's name, or a scene
/// file's stem (`scenes/fence.toml` → `fence`).
fn scene_label(scene: &str) -> String {
    match std::path::Path::new(scene).file_stem() {
        Some(stem) if scene.ends_with(".toml") => stem.to_string_lossy().into_owned(),
        _ => scene.to_string(),
    }
}

/// Axis label and short name of a stress column: what it is, in words,
/// with its unit (`derived camera rolled about its view axis, in [-180,
/// 180] (degrees)`), not the column name.
fn stress_label(col: &str) -> (String, String) {
    match crate::sweep::trace_fields::TRACE_FIELDS.iter().find(|f| f.3 == col) {
        Some(f) => {
            let what = f.2.strip_prefix("stress: ").unwrap_or(f.2);
            let short = what.split(',').next().unwrap_or(what).to_string();
            (format!("{what} ({})", f.1), short)
        }
        None => (col.to_string(), col.to_string()),
    }
}

type DrawResult<T> = Result<T, String>;

fn e<E: std::fmt::Display>(err: E) -> String {
    format!("drawing a chart: {err}")
}

fn failure_text(s: &StressSeries) -> String {
    let x0 = s.points.first().map(|p| p.0);
    if s.failures.is_empty() {
        "holds".into()
    } else if s.failures.first().copied() == x0 {
        format!("below unstressed ({})", tick(x0.unwrap_or(0.0)))
    } else {
        let v: Vec<String> = s.failures.iter().map(|x| tick(*x)).collect();
        format!("fails at {}", v.join(", "))
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, s: &StressChart) -> DrawResult<()> {
    font::register()?;
    root.fill(&WHITE).map_err(e)?;
    let (title, body) = root.split_vertically(TITLE_HEIGHT);
    let centre = plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Center,
        plotters::style::text_anchor::VPos::Center,
    );
    title
        .draw(&Text::new(
            s.title.clone(),
            ((WIDTH / 2) as i32, (TITLE_HEIGHT / 2) as i32),
            (FAMILY, 18).into_font().color(&BLACK).pos(centre),
        ))
        .map_err(e)?;
    let (plot, legend) = body.split_horizontally(WIDTH - LEGEND_WIDTH);
    let pts: Vec<(f64, f64)> = s.series.iter().flat_map(|x| x.points.iter().copied()).collect();
    let xs = || pts.iter().map(|p| p.0).filter(|v| v.is_finite());
    let (x_lo, x_hi) = (xs().fold(f64::INFINITY, f64::min), xs().fold(f64::NEG_INFINITY, f64::max));
    let y = super::axis::linear(pts.iter().map(|p| p.1).chain([s.threshold]), 0.08);
    match super::axis::log(xs()).filter(|_| log_x(x_lo, x_hi)) {
        Some(r) => {
            // Ticks at the stress values themselves (a log axis spanning
            // less than a decade on one side of 1 would otherwise have none
            // there), thinned to a readable number.
            let mut ticks: Vec<f64> = xs().collect();
            ticks.sort_by(f64::total_cmp);
            ticks.dedup();
            let every = ticks.len().div_ceil(3 * super::axis::MAX_TICKS).max(1);
            let ticks: Vec<f64> = ticks.into_iter().step_by(every).collect();
            plot_on(root, &plot, s, super::axis::Ticked::new(r.log_scale(), ticks), y, true)?;
        }
        None => {
            plot_on(root, &plot, s, super::axis::ticked_linear(super::axis::linear(xs(), 0.05)), y, false)?;
        }
    }
    // Legend: marker, name, where it fails.
    let style = (FAMILY, 13).into_font().color(&BLACK);
    let small = (FAMILY, 12).into_font().color(&RGBColor(70, 70, 70));
    let (x0, mut y) = (14, 24);
    for ser in &s.series {
        let (colour, shape) = series_style(ser.style);
        draw_marker(&legend, (x0 + 8, y), MARKER, shape, colour).map_err(e)?;
        legend.draw(&Text::new(ser.name.clone(), (x0 + 24, y - 8), style.clone())).map_err(e)?;
        legend.draw(&Text::new(failure_text(ser), (x0 + 24, y + 7), small.clone())).map_err(e)?;
        y += 36;
    }
    y += 4;
    for i in 0..3 {
        legend
            .draw(&PathElement::new(vec![(x0 - 4 + 10 * i, y), (x0 + 2 + 10 * i, y)], BLACK.stroke_width(2)))
            .map_err(e)?;
    }
    legend
        .draw(&Text::new(format!("threshold {} dB", tick(s.threshold)), (x0 + 30, y - 8), style.clone()))
        .map_err(e)?;
    y += 26;
    legend.draw(&Circle::new((x0 + 8, y), MARKER + 5, BLACK.stroke_width(2))).map_err(e)?;
    legend.draw(&Text::new("failure: the first value below", (x0 + 30, y - 8), style.clone())).map_err(e)?;
    legend.draw(&Text::new("the threshold on each side of the", (x0 + 30, y + 8), small.clone())).map_err(e)?;
    legend.draw(&Text::new("unstressed value (the axis' first)", (x0 + 30, y + 24), small)).map_err(e)?;
    Ok(())
}

/// The x axis is logarithmic when every stress value is positive and they
/// span more than a factor of 20 (as the cost axes of the scatter charts).
fn log_x(lo: f64, hi: f64) -> bool {
    lo > 0.0 && hi / lo > 20.0
}

/// The plot: axes, threshold, one line per series, failures ringed.
fn plot_on<DB, X>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    s: &StressChart,
    x: X,
    y: Range<f64>,
    log: bool,
) -> DrawResult<()>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = super::scatter::axes(area, x, y, (&s.x_label, "luma PSNR (dB), higher is better"), 14)?;
    // The dashed threshold: 40 dashes evenly spaced on screen, so in the
    // logarithm of x on a log axis.
    let (x_lo, x_hi) = {
        let r = chart.x_range();
        (r.start, r.end)
    };
    let to = |v: f64| if log { v.ln() } else { v };
    let from = |u: f64| if log { u.exp() } else { u };
    let n = 40;
    let w = (to(x_hi) - to(x_lo)) / n as f64;
    let dashes: Vec<(f64, f64)> =
        (0..n).map(|i| to(x_lo) + i as f64 * w).map(|u| (from(u), from(u + 0.5 * w))).collect();
    chart
        .draw_series(
            dashes
                .into_iter()
                .map(|(a, b)| PathElement::new(vec![(a, s.threshold), (b, s.threshold)], BLACK.stroke_width(2))),
        )
        .map_err(e)?;
    for ser in &s.series {
        let (colour, shape) = series_style(ser.style);
        let mut line: Vec<(f64, f64)> =
            ser.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart.draw_series(std::iter::once(PathElement::new(line.clone(), colour.stroke_width(2)))).map_err(e)?;
        for p in &line {
            draw_marker(root, chart.plotting_area().map_coordinate(p), MARKER, shape, colour).map_err(e)?;
        }
    }
    let plot = chart.plotting_area();
    for ser in &s.series {
        for x in &ser.failures {
            if let Some(p) = ser.points.iter().find(|p| p.0 == *x && p.1.is_finite()) {
                let c = plot.map_coordinate(p);
                root.draw(&Circle::new(c, MARKER + 5, BLACK.stroke_width(2))).map_err(e)?;
            }
        }
    }
    Ok(())
}

/// The chart as SVG text.
pub fn render_svg(s: &StressChart) -> DrawResult<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, s)?;
        root.present().map_err(e)?;
    }
    Ok(out)
}

/// The chart as PNG bytes (8-bit RGB).
pub fn render_png(s: &StressChart) -> DrawResult<Vec<u8>> {
    let mut rgb = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, s)?;
        root.present().map_err(e)?;
    }
    super::scatter::encode_png(&rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_are_nearest_the_unstressed_value_on_each_side() {
        let p = [(0.0, 30.0), (0.5, 27.0), (1.0, 24.0), (2.0, 20.0), (-0.5, 26.0), (-1.0, f64::NAN)];
        assert_eq!(failure_points(&p, 25.0), vec![-1.0, 1.0]);
        assert_eq!(failure_points(&p[..3], 23.0), Vec::<f64>::new(), "holds");
        assert_eq!(failure_points(&[(16.0, 24.0), (8.0, 30.0)], 25.0), vec![16.0], "below at the baseline");
        // Not monotone: the first failure counts even if it recovers later.
        assert_eq!(failure_points(&[(0.0, 30.0), (1.0, 20.0), (2.0, 26.0)], 25.0), vec![1.0]);
        // Listed order, not distance: depth bits 0 (exact), 24, 16, 8, 4.
        let bits = [(0.0, 30.0), (24.0, 30.0), (16.0, 29.0), (8.0, 24.0), (4.0, 20.0)];
        assert_eq!(failure_points(&bits, 25.0), vec![8.0]);
        assert!(failure_points(&[], 25.0).is_empty());
    }

    #[test]
    fn one_varying_numeric_trace_column_is_the_stress_axis() {
        let csv = "spec,trace,scene,derived_roll_deg,prediction_s,method,hole_fill,runs,point,psnr_luma_db\n\
                   s,a,room,0,0.4,m,x,1,p,30\n\
                   s,b,room,10,0.4,m,x,1,p,24\n\
                   s,a,room,0,0.4,n,,1,p,26\n\
                   s,b,room,10,0.4,n,,1,p,\n";
        let charts = stress_charts_from_csv(csv).unwrap();
        assert_eq!(charts.len(), 1);
        assert_eq!(charts[0].0, "stability.room.psnr_luma_db-vs-derived_roll_deg");
        let file = stress_charts_from_csv(&csv.replace(",room,", ",specs/scenes/fence.toml,")).unwrap();
        assert_eq!(file[0].0, "stability.fence.psnr_luma_db-vs-derived_roll_deg", "a scene file by its stem");
        let c = &charts[0].1;
        assert_eq!(c.series[0].failures, vec![10.0]);
        assert_eq!(c.series[1].name, "n");
        assert_eq!(c.series[1].failures, vec![10.0], "nothing scored is a failure");
        let svg = render_svg(c).unwrap();
        assert!(svg.contains("fails at 10"));
        assert_eq!(render_png(c).unwrap(), render_png(c).unwrap());
        // Two varying columns: not a stress sweep.
        let two = csv.replace("0.4,m,x,1,p,24", "0.5,m,x,1,p,24");
        assert!(stress_charts_from_csv(&two).unwrap().is_empty());
    }
}
