//! Precision charts: luma PSNR against the fraction bits of ONE datapath
//! format of the fixed-point mode, against the FP64 golden image and
//! against ground truth, with the A-buffer's bytes per sample beside each
//! point and the smallest format within [`TOLERANCE_DB`] of float marked
//!.
//!
//! Rules:
//! 1. Precision columns are the knob columns named `q_…` (a Q format,
//!    `Q16_12`: x = its fraction bits) and `recip_…` (a number: x = it).
//!    Rows taken: `hardware` rows of one trace whose `arith` is `fixed`.
//! 2. One chart per trace and precision column that takes more than one
//!    value among the rows whose every *other* precision column holds its
//!    most common value there (the generous default; ties: first in the
//!    CSV). File `precision.<trace>.<knob>.svg` / `.png` (the knob's name:
//!    the column's without its unit, `_q_format`).
//! 3. Two series: `vs FP64 golden` (`psnr_luma_vs_float_db`; a point whose
//!    every frame equals the float image, so no finite PSNR, is drawn on
//!    the top edge as a diamond) and `vs ground truth` (`psnr_luma_db`).
//!    The trace's float row (`arith` = `float`), if present, gives a dashed
//!    line at its PSNR against ground truth.
//! 4. Minimal ([`minimal_point`]): the smallest x such that this point and
//!    every larger x are within [`TOLERANCE_DB`] of the float PSNR against
//!    ground truth (of the most generous point when there is no float row).
//!    It is ringed and named in the legend.
//! 5. Each point of the truth series is labelled with
//!    `dest_bytes_per_sample`, the destination planes' bytes per sample at
//!    that point's widths.

use super::font::{self, FAMILY};
use super::scatter::{HEIGHT, WIDTH, tick};
use super::style::{Shape, draw_marker, series_style};
use crate::sweep::results::{ResultsRow, ResultsTable};
use plotters::coord::Shift;
use plotters::prelude::*;

/// How close to float (dB of luma PSNR against ground truth) a format must
/// stay to count as enough (the 0.1 dB).
pub const TOLERANCE_DB: f64 = 0.1;

const LEGEND_WIDTH: u32 = 290;
const TITLE_HEIGHT: u32 = 40;
const MARKER: i32 = 5;
/// The marker of a point identical to float, on the top edge.
const IDENTICAL: Shape = Shape::Diamond;

/// One precision chart.
#[derive(Clone, Debug, PartialEq)]
pub struct PrecisionChart {
    /// Title (specification, trace, column).
    pub title: String,
    /// The precision column (`q_position`, …).
    pub column: String,
    /// x-axis description with unit.
    pub x_label: String,
    /// `(x, PSNR against the float image)`; `+inf` = identical to float.
    pub vs_float: Vec<(f64, f64)>,
    /// `(x, PSNR against ground truth)`.
    pub vs_truth: Vec<(f64, f64)>,
    /// Label of each `vs_truth` point (bytes per sample), or empty.
    pub labels: Vec<String>,
    /// The cell text (format) of each x, for the legend.
    pub formats: Vec<(f64, String)>,
    /// The float configuration's PSNR against ground truth.
    pub float_truth_db: Option<f64>,
    /// The smallest x within tolerance (rule 4).
    pub minimal: Option<f64>,
}

/// The x of a precision cell (rule 1): the fraction bits of `Qm_n`, or a
/// plain number.
pub fn precision_x(column: &str, cell: &str) -> Option<f64> {
    if column.starts_with("q_") {
        let (_, frac) = cell.strip_prefix('Q')?.split_once('_')?;
        frac.parse::<u32>().ok().map(f64::from)
    } else {
        cell.parse::<f64>().ok().filter(|x| x.is_finite())
    }
}

/// Is `name` a precision column (rule 1)?
pub fn is_precision_column(name: &str) -> bool {
    name.starts_with("q_") || name.starts_with("recip_")
}

/// The smallest x within `tol` of `reference` at which every point of at
/// least that x is within `tol` too (rule 4); `points` are `(x, PSNR)`.
/// `None` if even the largest x is not.
pub fn minimal_point(points: &[(f64, f64)], reference: f64, tol: f64) -> Option<f64> {
    let mut p: Vec<(f64, f64)> = points.to_vec();
    p.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut best = None;
    for (x, y) in p {
        if !(y.is_finite() && (y - reference).abs() <= tol) {
            break;
        }
        best = Some(x);
    }
    best
}

fn modal<'a>(values: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for v in values {
        match counts.iter_mut().find(|c| c.0 == v) {
            Some(c) => c.1 += 1,
            None => counts.push((v, 1)),
        }
    }
    // The first of the most common (max_by_key keeps the last of equals).
    let most = counts.iter().map(|c| c.1).max()?;
    counts.iter().find(|c| c.1 == most).map(|c| c.0)
}

/// Every precision chart of a read `results.csv`, with its file stem.
pub fn precision_charts(t: &ResultsTable) -> Vec<(String, PrecisionChart)> {
    let Some(arith) = t.header.iter().position(|h| h == "arith" || h.starts_with("arith_")) else {
        return Vec::new();
    };
    let cols: Vec<usize> = t.knob_columns().filter(|&c| is_precision_column(&t.header[c])).collect();
    let mut traces: Vec<&str> = Vec::new();
    for r in &t.rows {
        if !traces.contains(&t.cell(r, "trace")) {
            traces.push(t.cell(r, "trace"));
        }
    }
    let mut out = Vec::new();
    for tr in traces {
        let hw = |r: &&ResultsRow| t.cell(r, "trace") == tr && t.cell(r, "method") == "hardware";
        let fixed: Vec<&ResultsRow> = t.rows.iter().filter(hw).filter(|r| r.cells[arith] == "fixed").collect();
        let float_truth =
            t.rows.iter().filter(hw).find(|r| r.cells[arith] == "float").and_then(|r| r.metrics.psnr_luma_db);
        let modes: Vec<Option<&str>> = cols.iter().map(|&c| modal(fixed.iter().map(|r| r.cells[c].as_str()))).collect();
        for (k, &c) in cols.iter().enumerate() {
            let name = &t.header[c];
            // The knob's name: the column's without its unit (`_q_format`).
            let knob = name.strip_suffix("_q_format").unwrap_or(name);
            let rows: Vec<&&ResultsRow> = fixed
                .iter()
                .filter(|r| {
                    cols.iter().zip(&modes).enumerate().all(|(j, (&o, m))| j == k || Some(r.cells[o].as_str()) == *m)
                })
                .collect();
            let mut chart = PrecisionChart {
                title: String::new(),
                column: name.clone(),
                x_label: if name.starts_with("q_") { format!("fraction bits of {knob} (bits)") } else { name.clone() },
                vs_float: Vec::new(),
                vs_truth: Vec::new(),
                labels: Vec::new(),
                formats: Vec::new(),
                float_truth_db: float_truth,
                minimal: None,
            };
            for r in &rows {
                let Some(x) = precision_x(name, &r.cells[c]) else { continue };
                if chart.formats.iter().any(|f| f.0 == x) {
                    continue;
                }
                chart.formats.push((x, r.cells[c].clone()));
                // No finite PSNR but frames counted identical: every frame
                // equals the float image.
                let identical = r.metrics.vs_float_identical_frames.is_some_and(|n| n > 0);
                match r.metrics.psnr_luma_vs_float_db {
                    Some(y) => chart.vs_float.push((x, y)),
                    None if identical => chart.vs_float.push((x, f64::INFINITY)),
                    None => {}
                }
                if let Some(y) = r.metrics.psnr_luma_db {
                    chart.vs_truth.push((x, y));
                    chart
                        .labels
                        .push(r.metrics.dest_bytes_per_sample.map_or(String::new(), |b| format!("{} B", tick(b))));
                }
            }
            if chart.formats.len() < 2 {
                continue;
            }
            let reference =
                float_truth.or_else(|| chart.vs_truth.iter().copied().max_by(|a, b| a.0.total_cmp(&b.0)).map(|p| p.1));
            chart.minimal = reference.and_then(|r| minimal_point(&chart.vs_truth, r, TOLERANCE_DB));
            let spec = rows.first().map_or("", |r| t.cell(r, "spec"));
            chart.title = format!("{spec}: {tr}, luma PSNR against the bits of {knob}");
            out.push((format!("precision.{}.{}", super::file_label(tr), super::file_label(knob)), chart));
        }
    }
    out
}

type DrawResult<T> = Result<T, String>;

/// A drawn line: legend name, points, style number.
type Line<'a> = (&'a str, &'a [(f64, f64)], usize);

fn e<E: std::fmt::Display>(err: E) -> String {
    format!("drawing a chart: {err}")
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, s: &PrecisionChart) -> DrawResult<()> {
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
    let finite_y = s.vs_float.iter().chain(&s.vs_truth).map(|p| p.1).chain(s.float_truth_db).filter(|y| y.is_finite());
    let y = super::axis::linear(finite_y.clone(), 0.08);
    // Identical-to-float points sit on the top edge (rule 3).
    let top = y.end;
    let xs = s.formats.iter().map(|f| f.0);
    let x = super::axis::linear(xs, 0.06);
    let mut chart = super::scatter::axes(
        &plot,
        super::axis::ticked_linear(x),
        y,
        (&s.x_label, "luma PSNR (dB), higher is better"),
        14,
    )?;
    if let Some(f) = s.float_truth_db {
        let r = chart.x_range();
        let n = 40;
        let w = (r.end - r.start) / n as f64;
        chart
            .draw_series((0..n).map(|i| {
                let a = r.start + i as f64 * w;
                PathElement::new(vec![(a, f), (a + 0.5 * w, f)], BLACK.stroke_width(2))
            }))
            .map_err(e)?;
    }
    let series: [Line; 2] = [("vs FP64 golden", &s.vs_float, 0), ("vs ground truth", &s.vs_truth, 1)];
    let label_style = (FAMILY, 11).into_font().color(&RGBColor(70, 70, 70));
    for (_, pts, style) in series {
        let (colour, shape) = series_style(style);
        // (x, y drawn, identical to float), in x order.
        let mut marks: Vec<(f64, f64, bool)> =
            pts.iter().map(|p| if p.1.is_finite() { (p.0, p.1, false) } else { (p.0, top, true) }).collect();
        marks.sort_by(|a, b| a.0.total_cmp(&b.0));
        let line: Vec<(f64, f64)> = marks.iter().map(|m| (m.0, m.1)).collect();
        chart.draw_series(std::iter::once(PathElement::new(line, colour.stroke_width(2)))).map_err(e)?;
        for &(x, y, identical) in &marks {
            let c = chart.plotting_area().map_coordinate(&(x, y));
            draw_marker(root, c, MARKER, if identical { IDENTICAL } else { shape }, colour).map_err(e)?;
        }
    }
    let area = chart.plotting_area();
    for (p, l) in s.vs_truth.iter().zip(&s.labels).filter(|(_, l)| !l.is_empty()) {
        let c = area.map_coordinate(p);
        root.draw(&Text::new(l.clone(), (c.0 + MARKER + 2, c.1 + MARKER + 2), label_style.clone())).map_err(e)?;
    }
    if let Some(m) = s.minimal {
        if let Some(p) = s.vs_truth.iter().find(|p| p.0 == m) {
            root.draw(&Circle::new(area.map_coordinate(p), MARKER + 5, BLACK.stroke_width(2))).map_err(e)?;
        }
    }
    // Legend.
    let style = (FAMILY, 13).into_font().color(&BLACK);
    let small = (FAMILY, 12).into_font().color(&RGBColor(70, 70, 70));
    let (x0, mut ly) = (14, 24);
    for (name, _, st) in series {
        let (colour, shape) = series_style(st);
        draw_marker(&legend, (x0 + 8, ly), MARKER, shape, colour).map_err(e)?;
        legend.draw(&Text::new(name, (x0 + 24, ly - 8), style.clone())).map_err(e)?;
        ly += 26;
    }
    let (colour, _) = series_style(0);
    draw_marker(&legend, (x0 + 8, ly), MARKER, IDENTICAL, colour).map_err(e)?;
    legend.draw(&Text::new("= float (identical frames)", (x0 + 24, ly - 8), small.clone())).map_err(e)?;
    ly += 28;
    if let Some(f) = s.float_truth_db {
        for i in 0..3 {
            legend
                .draw(&PathElement::new(vec![(x0 - 4 + 10 * i, ly), (x0 + 2 + 10 * i, ly)], BLACK.stroke_width(2)))
                .map_err(e)?;
        }
        legend
            .draw(&Text::new(format!("float vs truth {} dB", tick(f)), (x0 + 30, ly - 8), style.clone()))
            .map_err(e)?;
        ly += 28;
    }
    legend.draw(&Circle::new((x0 + 8, ly), MARKER + 5, BLACK.stroke_width(2))).map_err(e)?;
    let minimal = match s.minimal.and_then(|m| s.formats.iter().find(|f| f.0 == m)) {
        Some((_, f)) => format!("smallest within {TOLERANCE_DB} dB: {f}"),
        None => format!("none within {TOLERANCE_DB} dB of float"),
    };
    legend.draw(&Text::new(minimal, (x0 + 30, ly - 8), style)).map_err(e)?;
    ly += 24;
    legend.draw(&Text::new("labels: destination bytes/sample", (x0, ly), small)).map_err(e)?;
    Ok(())
}

/// The chart as SVG text.
pub fn render_svg(s: &PrecisionChart) -> DrawResult<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, s)?;
        root.present().map_err(e)?;
    }
    Ok(out)
}

/// The chart as PNG bytes (8-bit RGB).
pub fn render_png(s: &PrecisionChart) -> DrawResult<Vec<u8>> {
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
    use crate::sweep::results::read_csv;

    #[test]
    fn minimal_is_the_smallest_of_an_unbroken_run_within_tolerance() {
        let p = [(16.0, 30.0), (12.0, 30.05), (10.0, 29.95), (8.0, 29.5), (6.0, 29.99)];
        assert_eq!(minimal_point(&p, 30.0, 0.1), Some(10.0), "6 recovers but 8 broke the run");
        assert_eq!(minimal_point(&p, 35.0, 0.1), None);
        assert_eq!(minimal_point(&[(4.0, f64::NAN)], 30.0, 0.1), None);
    }

    #[test]
    fn q_cells_read_as_fraction_bits() {
        assert_eq!(precision_x("q_position", "Q16_12"), Some(12.0));
        assert_eq!(precision_x("recip_iterations", "2"), Some(2.0));
        assert_eq!(precision_x("q_position", "16"), None);
        assert!(is_precision_column("q_colour") && !is_precision_column("tile_size_samples"));
    }

    #[test]
    fn one_chart_per_varied_column_with_the_others_at_their_defaults() {
        let csv = "spec,trace,method,hole_fill,runs,arith,q_a,q_b,point,psnr_luma_db,golden_identical_frames,psnr_luma_vs_float_db,vs_float_identical_frames,dest_bytes_per_sample\n\
                   p,room,hardware,,,float,Q8_24,Q8_8,x,30,1,,,40\n\
                   p,room,hardware,,,fixed,Q8_24,Q8_8,x,30,1,,1,40\n\
                   p,room,hardware,,,fixed,Q8_12,Q8_8,x,29.95,1,50,0,36\n\
                   p,room,hardware,,,fixed,Q8_6,Q8_8,x,25,1,20,0,33\n\
                   p,room,hardware,,,fixed,Q8_24,Q8_4,x,30,1,60,0,40\n\
                   p,room,mark-aa,none,1,,,,x,31,,,,\n";
        let t = read_csv(csv).unwrap();
        let charts = precision_charts(&t);
        let stems: Vec<&str> = charts.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(stems, ["precision.room.q_a", "precision.room.q_b"]);
        let a = &charts[0].1;
        assert_eq!(a.vs_truth, [(24.0, 30.0), (12.0, 29.95), (6.0, 25.0)]);
        assert_eq!(a.vs_float[0], (24.0, f64::INFINITY), "identical frames sit at the top");
        assert_eq!(a.float_truth_db, Some(30.0));
        assert_eq!(a.minimal, Some(12.0));
        assert_eq!(a.labels[1], "36 B");
        assert_eq!(charts[1].1.formats.len(), 2);
        let svg = render_svg(a).unwrap();
        assert!(svg.contains("smallest within 0.1 dB: Q8_12"), "the legend names the minimal format");
        assert_eq!(render_png(a).unwrap(), render_png(a).unwrap());
        // No arith column: not a precision sweep.
        assert!(precision_charts(&read_csv(&csv.replace("arith", "other")).unwrap()).is_empty());
    }
}
