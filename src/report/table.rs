//! The printed tables: one row per frame and a mean row, with the numbers
//! of `report.json` (rounded for print). The mean row is the report's
//! `mean`: means over frames by the key rules (`super::keys`), so its
//! counters are per frame, never sums.

use super::golden::{GoldenCounters, GoldenReport};
use super::method::MethodReport;
use super::quality::Scores;
use std::fmt::Write as _;

/// One row of the quality table.
pub struct Row<'a> {
    /// `frame` column: the index, or `mean`.
    pub label: String,
    /// Scores.
    pub scores: &'a Scores,
    /// Known pixels (pixels), if scored.
    pub scored_pixels: Option<f64>,
    /// Known pixels covered by real samples (pixels), if scored.
    pub covered_pixels: Option<f64>,
    /// Pixels of the common mask (pixels), if scored.
    pub common_pixels: Option<f64>,
    /// Host time (ms).
    pub host_ms: f64,
}

/// A PSNR cell: `-` when there is no value and nothing was scored; `inf`
/// when the value is null although `pixels` (the pixels that PSNR is over)
/// were scored: identical images (docs/metrics.md).
fn psnr_cell(v: Option<f64>, pixels: Option<f64>) -> String {
    match v {
        Some(x) => format!("{x:.2}"),
        None if pixels.is_some_and(|n| n > 0.0) => "inf".into(),
        None => "-".into(),
    }
}

fn cell(v: Option<f64>, decimals: usize, scale: f64) -> String {
    v.map_or("-".into(), |x| format!("{:.*}", decimals, x * scale))
}

/// The quality table of `rows`.
pub fn render(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = write!(s, "{:>6}", "frame");
    for h in ["psnr_rgb", "psnr_cov", "psnr_com", "psnr_luma", "ssim", "flip", "holes%", "dE>20%", "host_ms"] {
        let _ = write!(s, " {h:>10}");
    }
    s.push('\n');
    for r in rows {
        let q = r.scores;
        let cells = [
            psnr_cell(q.psnr_rgb_db, r.scored_pixels),
            psnr_cell(q.psnr_rgb_covered_db, r.covered_pixels),
            psnr_cell(q.psnr_rgb_common_db, r.common_pixels),
            psnr_cell(q.psnr_luma_db, r.scored_pixels),
            cell(q.ssim_luma, 4, 1.0),
            cell(q.flip_mean, 4, 1.0),
            cell(q.hole_fraction, 2, 100.0),
            cell(q.delta_e20_fraction, 2, 100.0),
            cell(Some(r.host_ms), 1, 1.0),
        ];
        let _ = write!(s, "{:>6}", r.label);
        for c in cells {
            let _ = write!(s, " {c:>10}");
        }
        s.push('\n');
    }
    s
}

/// The quality table of a golden report.
pub fn golden_table(r: &GoldenReport) -> String {
    let mut rows: Vec<Row> = r
        .frames
        .iter()
        .map(|f| Row {
            label: f.index.to_string(),
            scores: &f.scores,
            scored_pixels: f.pixels.scored_pixels.map(|n| n as f64),
            covered_pixels: f.pixels.covered_pixels.map(|n| n as f64),
            common_pixels: f.pixels.common_pixels.map(|n| n as f64),
            host_ms: f.host_ms,
        })
        .collect();
    rows.push(Row {
        label: "mean".into(),
        scores: &r.mean.scores,
        scored_pixels: r.mean.pixels.scored_pixels,
        covered_pixels: r.mean.pixels.covered_pixels,
        common_pixels: r.mean.pixels.common_pixels,
        host_ms: r.mean.host_ms,
    });
    render(&rows)
}

/// The quality table of a method report.
pub fn method_table(r: &MethodReport) -> String {
    let mut rows: Vec<Row> = r
        .frames
        .iter()
        .map(|f| Row {
            label: f.index.to_string(),
            scores: &f.scores,
            scored_pixels: f.pixels.scored_pixels.map(|n| n as f64),
            covered_pixels: f.pixels.covered_pixels.map(|n| n as f64),
            common_pixels: f.pixels.common_pixels.map(|n| n as f64),
            host_ms: f.host_ms,
        })
        .collect();
    rows.push(Row {
        label: "mean".into(),
        scores: &r.mean.scores,
        scored_pixels: r.mean.pixels.scored_pixels,
        covered_pixels: r.mean.pixels.covered_pixels,
        common_pixels: r.mean.pixels.common_pixels,
        host_ms: r.mean.host_ms,
    });
    render(&rows)
}

/// Kernels by largest side, as shares of all kernels reaching the image:
/// sides 1, 2, 3, 4 and 5 or more (from the `kernel_sizes` histogram).
fn kernel_side_shares(kernel_sizes: &[Vec<f64>]) -> (f64, [f64; 5]) {
    let mut by_side = [0.0f64; 5];
    for (w, row) in kernel_sizes.iter().enumerate() {
        for (h, n) in row.iter().enumerate() {
            let side = w.max(h);
            if side > 0 {
                by_side[(side - 1).min(4)] += n;
            }
        }
    }
    let total: f64 = by_side.iter().sum();
    (total, by_side.map(|n| if total > 0.0 { 100.0 * n / total } else { 0.0 }))
}

/// Mean A-buffer fragments per pixel from the `fragments_per_pixel` histogram.
fn fragments_per_pixel(h: &[f64]) -> f64 {
    let pixels: f64 = h.iter().sum();
    if pixels == 0.0 { 0.0 } else { h.iter().enumerate().map(|(k, n)| k as f64 * n).sum::<f64>() / pixels }
}

/// The counters table of a golden report: per frame the excluded
/// (unknown-truth) pixels, hole and empty samples, forced A-buffer merges,
/// mean fragments per pixel, and the kernel-size histogram (kernels, over
/// the limit, shares by largest side). Counts print as integers; the mean
/// row (per frame) with one decimal.
pub fn golden_counters(r: &GoldenReport) -> String {
    let mut s = String::new();
    let heads = [
        "excluded",
        "hole_smp",
        "empty_smp",
        "merges",
        "frag/px",
        "kernels",
        "k>limit",
        "side1%",
        "side2%",
        "side3%",
        "side4%",
        "side5+%",
    ];
    let _ = write!(s, "{:>6}", "frame");
    for h in heads {
        let _ = write!(s, " {h:>9}");
    }
    s.push('\n');
    let row = |s: &mut String, label: String, excluded: Option<f64>, c: &GoldenCounters<f64>, decimals: usize| {
        let _ = write!(s, "{label:>6}");
        for v in [excluded, Some(c.hole_samples), Some(c.empty_samples), Some(c.forced_merges)] {
            let _ = write!(s, " {:>9}", cell(v, decimals, 1.0));
        }
        let _ = write!(s, " {:>9.3}", fragments_per_pixel(&c.fragments_per_pixel));
        let (total, shares) = kernel_side_shares(&c.kernel_sizes);
        let _ = write!(s, " {:>9.*} {:>9}", decimals, total, cell(Some(c.kernels_over_limit), decimals, 1.0));
        for sh in shares {
            let _ = write!(s, " {sh:>9.2}");
        }
        s.push('\n');
    };
    for f in &r.frames {
        let c: GoldenCounters<f64> =
            serde_json::from_value(serde_json::to_value(&f.counters).expect("counters serialize")).expect("as f64");
        row(&mut s, f.index.to_string(), f.pixels.excluded_pixels.map(|n| n as f64), &c, 0);
    }
    row(&mut s, "mean".into(), r.mean.pixels.excluded_pixels, &r.mean.counters, 1);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_psnr_is_infinite_only_over_pixels_that_were_scored() {
        let q = Scores { psnr_rgb_db: None, psnr_rgb_covered_db: None, ..Scores::default() };
        // Every pixel known, none covered (all hole-filled): the covered
        // PSNR has no pixel to be over; the RGB PSNR is +inf (identical).
        let t = render(&[Row {
            label: "0".into(),
            scores: &q,
            scored_pixels: Some(12.0),
            covered_pixels: Some(0.0),
            common_pixels: Some(0.0),
            host_ms: 1.0,
        }]);
        let cells: Vec<&str> = t.lines().nth(1).unwrap().split_whitespace().collect();
        assert_eq!(&cells[..4], ["0", "inf", "-", "-"], "{t}");
    }

    #[test]
    fn kernel_shares_come_from_the_histogram() {
        let (n, shares) = kernel_side_shares(&[vec![0.0, 0.0], vec![0.0, 3.0, 1.0]]);
        assert_eq!(n, 4.0);
        assert_eq!(shares, [75.0, 25.0, 0.0, 0.0, 0.0]);
    }
}
