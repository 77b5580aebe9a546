//! One scatter chart of quality against cost, with its Pareto front, drawn
//! the same way into SVG text or PNG bytes.
//!
//! Layout: the title across the top; the plot on the left (cost on x,
//! logarithmic when the costs span more than a factor of 20; quality on
//! y); a legend on the right with every series' marker and the front.
//! The front is a black step line with a black ring around each of its
//! points. Output bytes depend only on the [`Scatter`]: no time stamps,
//! no randomness, one thread.

use super::axis::{Ticked, ticked_linear};
use super::font::{self, FAMILY};
use super::pareto::{Better, pareto_front, step_line};
use super::style::{draw_marker, series_style};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::ops::Range;

/// Width of every chart (pixels).
pub const WIDTH: u32 = 960;
/// Height of every chart (pixels).
pub const HEIGHT: u32 = 600;
const LEGEND_WIDTH: u32 = 250;
const TITLE_HEIGHT: u32 = 40;
const MARKER: i32 = 5;

/// A chart's content.
#[derive(Clone, Debug, PartialEq)]
pub struct Scatter {
    /// Title (names the specification and the trace).
    pub title: String,
    /// x-axis description with unit (cost; lower is better).
    pub x_label: String,
    /// y-axis description with unit (quality).
    pub y_label: String,
    /// Which direction of quality is better.
    pub better: Better,
    /// Series in legend order; `style` picks colour and shape
    /// ([`series_style`]).
    pub series: Vec<Series>,
}

/// The points of one method.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Style number ([`series_style`]), the same for a method in every
    /// chart of a sweep.
    pub style: usize,
    /// `(cost, quality)` points; non-finite ones are not drawn.
    pub points: Vec<(f64, f64)>,
    /// A short label beside each point (the knob values that differ
    /// between the series' points), or empty.
    pub labels: Vec<String>,
}

type DrawResult<T> = Result<T, String>;

fn e<E: std::fmt::Display>(err: E) -> String {
    format!("drawing a chart: {err}")
}

/// Tick labels: at most 4 significant digits, k/M/G for large values.
pub fn tick(v: f64) -> String {
    let a = v.abs();
    if a >= 1e12 || (a > 0.0 && a < 1e-4) {
        // Scientific beyond G and below 0.0001: `1.7e308`, `2.5e-7`.
        let s = format!("{v:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
        return format!("{m}e{e}");
    }
    let (x, suffix) = if a >= 1e9 {
        (v / 1e9, "G")
    } else if a >= 1e6 {
        (v / 1e6, "M")
    } else if a >= 1e4 {
        (v / 1e3, "k")
    } else {
        (v, "")
    };
    let digits = if x.abs() >= 100.0 {
        1
    } else if x.abs() >= 10.0 {
        2
    } else if x.abs() >= 1.0 || x == 0.0 {
        3
    } else {
        4
    };
    let mut s = format!("{x:.digits$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".into();
    }
    s + suffix
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, s: &Scatter) -> DrawResult<()> {
    font::register()?;
    root.fill(&WHITE).map_err(e)?;
    let (title, body) = root.split_vertically(TITLE_HEIGHT);
    title
        .draw(&Text::new(
            s.title.clone(),
            ((WIDTH / 2) as i32, (TITLE_HEIGHT / 2) as i32),
            (FAMILY, 20).into_font().color(&BLACK).pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Center,
            )),
        ))
        .map_err(e)?;
    let (plot, legend) = body.split_horizontally(WIDTH - legend_width(root, s)?);
    let all: Vec<(f64, f64)> = s.series.iter().flat_map(|x| x.points.iter().copied()).collect();
    let costs = || all.iter().map(|p| p.0).filter(|c| c.is_finite());
    let lo = costs().fold(f64::INFINITY, f64::min);
    let hi = costs().fold(f64::NEG_INFINITY, f64::max);
    let y = super::axis::linear(all.iter().map(|p| p.1), 0.06);
    match super::axis::log(costs()).filter(|_| lo > 0.0 && hi / lo > 20.0) {
        Some(r) => {
            let ticks = super::axis::log_ticks(&r);
            plot_on(root, &plot, s, Ticked::new(r.log_scale(), ticks), y)?;
        }
        None => plot_on(root, &plot, s, ticked_linear(super::axis::linear(costs(), 0.06)), y)?,
    }
    draw_legend(&legend, s)
}

/// A chart context whose x axis is `X` and y axis a ticked linear one.
pub(super) type Axes<'a, DB, X> = ChartContext<'a, DB, Cartesian2d<X, Ticked<plotters::coord::types::RangedCoordf64>>>;

/// A chart on `area` with the house style: margins, label areas, the
/// `(x, y)` axis descriptions at `desc_size` points, ticks by [`tick`],
/// light grey grid lines at the ticks only.
pub(super) fn axes<'a, DB, X>(
    area: &DrawingArea<DB, Shift>,
    x: X,
    y: Range<f64>,
    (x_desc, y_desc): (&str, &str),
    desc_size: u32,
) -> DrawResult<Axes<'a, DB, X::CoordDescType>>
where
    DB: DrawingBackend + 'a,
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(x, ticked_linear(y))
        .map_err(e)?;
    let fmt = |v: &f64| tick(*v);
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&fmt)
        .y_label_formatter(&fmt)
        .axis_desc_style((FAMILY, desc_size))
        .label_style((FAMILY, 13))
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(e)?;
    Ok(chart)
}

fn plot_on<DB, X>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    s: &Scatter,
    x: X,
    y: Range<f64>,
) -> DrawResult<()>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = axes(area, x, y, (&s.x_label, &s.y_label), 15)?;
    let all: Vec<(f64, f64)> = s.series.iter().flat_map(|x| x.points.iter().copied()).collect();
    let front: Vec<(f64, f64)> = pareto_front(&all, s.better).into_iter().map(|i| all[i]).collect();
    chart.draw_series(std::iter::once(PathElement::new(step_line(&front), BLACK.stroke_width(2)))).map_err(e)?;
    let area = chart.plotting_area();
    let label_style = (FAMILY, 11).into_font().color(&RGBColor(70, 70, 70));
    let mut taken: Vec<(i32, i32, i32, i32)> = Vec::new();
    for ser in &s.series {
        let (colour, shape) = series_style(ser.style);
        for (i, p) in ser.points.iter().enumerate().filter(|(_, p)| p.0.is_finite() && p.1.is_finite()) {
            let c = area.map_coordinate(p);
            draw_marker(root, c, MARKER, shape, colour).map_err(e)?;
            if let Some(l) = ser.labels.get(i).filter(|l| !l.is_empty()) {
                let (w, h) = root.estimate_text_size(l, &label_style).map_err(e)?;
                let at = label_place(c, (w as i32, h as i32), &taken, area.get_pixel_range());
                taken.push((at.0, at.1, at.0 + w as i32, at.1 + h as i32));
                root.draw(&Text::new(l.clone(), at, label_style.clone())).map_err(e)?;
            }
        }
    }
    for p in &front {
        root.draw(&Circle::new(area.map_coordinate(p), MARKER + 4, BLACK.stroke_width(2))).map_err(e)?;
    }
    Ok(())
}

/// Top-left corner for a point label of size `(w, h)` next to the marker at
/// `c`: the first of a few places around it (right above, right below,
/// further up and down on the right, then left) that lies inside `bounds`
/// (x range, y range) and overlaps no label drawn before; failing that,
/// the first place inside `bounds`.
fn label_place(
    c: (i32, i32),
    (w, h): (i32, i32),
    taken: &[(i32, i32, i32, i32)],
    bounds: (Range<i32>, Range<i32>),
) -> (i32, i32) {
    let gap = MARKER + 3;
    let (right, left) = (c.0 + gap, c.0 - gap - w);
    let (above, below) = (c.1 - gap - h, c.1 + gap);
    let mut places = vec![(right, above), (right, below)];
    for k in 1..=3 {
        places.push((right, above - k * (h + 2)));
        places.push((right, below + k * (h + 2)));
    }
    places.extend([(left, above), (left, below)]);
    let inside = |&(x, y): &(i32, i32)| {
        x >= bounds.0.start && x + w <= bounds.0.end && y >= bounds.1.start && y + h <= bounds.1.end
    };
    let free =
        |&(x, y): &(i32, i32)| !taken.iter().any(|&(x0, y0, x1, y1)| x < x1 && x + w > x0 && y < y1 && y + h > y0);
    places
        .iter()
        .copied()
        .find(|p| inside(p) && free(p))
        .or_else(|| places.iter().copied().find(inside))
        .unwrap_or(places[0])
}

/// The legend's width: [`LEGEND_WIDTH`], or wider for a long series name
/// (up to half the chart), so that no name is cut at the chart's edge.
fn legend_width<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, s: &Scatter) -> DrawResult<u32> {
    let style = (FAMILY, LEGEND_FONT).into_font().color(&BLACK);
    let mut widest = 0;
    for ser in &s.series {
        widest = widest.max(root.estimate_text_size(&ser.name, &style).map_err(e)?.0);
    }
    // The marker column (x0 + 24) before the name, a margin after it.
    Ok((widest + LEGEND_TEXT_X + 12).clamp(LEGEND_WIDTH, WIDTH / 2))
}

/// Legend text size (points) and where a name starts (pixels from the
/// legend's left edge).
const LEGEND_FONT: u32 = 14;
const LEGEND_TEXT_X: u32 = 14 + 24;

fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, s: &Scatter) -> DrawResult<()> {
    let style = (FAMILY, LEGEND_FONT).into_font().color(&BLACK);
    let (x0, mut y) = (14, 24);
    for ser in &s.series {
        let (colour, shape) = series_style(ser.style);
        draw_marker(area, (x0 + 8, y), MARKER, shape, colour).map_err(e)?;
        area.draw(&Text::new(ser.name.clone(), (x0 + 24, y - 8), style.clone())).map_err(e)?;
        y += 24;
    }
    y += 6;
    area.draw(&PathElement::new(vec![(x0 - 4, y), (x0 + 20, y)], BLACK.stroke_width(2))).map_err(e)?;
    area.draw(&Circle::new((x0 + 8, y), MARKER + 4, BLACK.stroke_width(2))).map_err(e)?;
    area.draw(&Text::new("Pareto front", (x0 + 24, y - 8), style.clone())).map_err(e)?;
    let hint = match s.better {
        Better::Higher => "best: up and to the left",
        Better::Lower => "best: down and to the left",
    };
    area.draw(&Text::new(hint, (x0, y + 22), (FAMILY, 12).into_font().color(&RGBColor(90, 90, 90)))).map_err(e)?;
    Ok(())
}

/// The chart as SVG text.
pub fn render_svg(s: &Scatter) -> DrawResult<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, s)?;
        root.present().map_err(e)?;
    }
    Ok(out)
}

/// The chart as PNG bytes (8-bit RGB).
pub fn render_png(s: &Scatter) -> DrawResult<Vec<u8>> {
    let mut rgb = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, s)?;
        root.present().map_err(e)?;
    }
    encode_png(&rgb)
}

/// 8-bit RGB pixels of a [`WIDTH`]x[`HEIGHT`] chart as PNG bytes (best
/// compression).
pub fn encode_png(rgb: &[u8]) -> DrawResult<Vec<u8>> {
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new_with_quality(
            &mut png,
            image::codecs::png::CompressionType::Best,
            image::codecs::png::FilterType::Adaptive,
        ),
        rgb,
        WIDTH,
        HEIGHT,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(e)?;
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Scatter {
        Scatter {
            title: "t".into(),
            x_label: "cost (ms)".into(),
            y_label: "PSNR (dB)".into(),
            better: Better::Higher,
            series: vec![
                Series {
                    name: "a".into(),
                    style: 0,
                    points: vec![(1.0, 20.0), (2.0, 25.0)],
                    labels: vec!["k=1".into(), "k=2".into()],
                },
                Series { name: "b".into(), style: 1, points: vec![(1.5, 21.0), (f64::NAN, 3.0)], labels: vec![] },
            ],
        }
    }

    #[test]
    fn point_labels_avoid_each_other() {
        let all = || (0..1000, 0..1000);
        let a = label_place((100, 100), (50, 10), &[], all());
        let b = label_place((102, 100), (50, 10), &[(a.0, a.1, a.0 + 50, a.1 + 10)], all());
        assert_eq!(a, (108, 82));
        assert_eq!(b, (110, 108), "below the first");
        let c = label_place((990, 100), (50, 10), &[], all());
        assert_eq!(c, (932, 82), "left of a point at the right edge");
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(1_250_000.0), "1.25M");
        assert_eq!(tick(0.5), "0.5");
        assert_eq!(tick(12.3456), "12.35");
        assert_eq!(tick(30000.0), "30k");
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(1.7e308), "1.7e308");
        assert_eq!(tick(-2.5e-7), "-2.5e-7");
        assert_eq!(tick(f64::MAX), "1.798e308");
    }

    #[test]
    fn renders_are_repeatable_and_of_the_stated_size() {
        let s = sample();
        let svg = render_svg(&s).unwrap();
        assert_eq!(svg, render_svg(&s).unwrap());
        assert!(svg.starts_with("<svg") && svg.contains(&format!("width=\"{WIDTH}\"")), "{}", &svg[..100]);
        let png = render_png(&s).unwrap();
        assert_eq!(png, render_png(&s).unwrap());
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (WIDTH, HEIGHT));
    }

    /// Where the SVG draws text `t`: its x.
    fn text_x(svg: &str, t: &str) -> i32 {
        let end = svg.find(&format!(">\n{t}\n<")).unwrap_or_else(|| panic!("{t} not drawn"));
        let open = &svg[svg[..end].rfind("<text").unwrap()..end];
        let x = &open[open.find(" x=\"").unwrap() + 4..];
        x[..x.find('"').unwrap()].parse().unwrap()
    }

    #[test]
    fn a_long_series_name_widens_the_legend_and_stays_inside_the_chart() {
        let long = "schollmeyer-transparent + low-pass";
        let mut s = sample();
        let svg = render_svg(&s).unwrap();
        let short_x = text_x(&svg, "a");
        s.series[1].name = long.into();
        let svg = render_svg(&s).unwrap();
        let x = text_x(&svg, long);
        let mut out = String::new();
        let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
        font::register().unwrap();
        let w = root.estimate_text_size(long, &(FAMILY, LEGEND_FONT).into_font().color(&BLACK)).unwrap().0 as i32;
        assert!(w > (LEGEND_WIDTH - LEGEND_TEXT_X) as i32, "the name ({w} px) is longer than the default legend holds");
        assert!(x + w <= WIDTH as i32, "the name ends at {} of {WIDTH}", x + w);
        assert!(x < short_x, "the legend moved left to make room: {x} against {short_x}");
        assert_eq!(text_x(&svg, "a"), x, "every name starts in the same column");
    }
}
