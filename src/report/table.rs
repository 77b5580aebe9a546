//! The printed table: one row per frame and a mean row, with the same
//! numbers as `report.json` (rounded for print).

use serde_json::Value;
use std::fmt::Write as _;

/// Columns: (report key, header, decimals, scale).
pub const COLUMNS: &[(&str, &str, usize, f64)] = &[
    ("psnr_rgb_db", "psnr_rgb", 2, 1.0),
    ("psnr_rgb_covered_db", "psnr_cov", 2, 1.0),
    ("psnr_luma_db", "psnr_luma", 2, 1.0),
    ("ssim_luma", "ssim", 4, 1.0),
    ("flip_mean", "flip", 4, 1.0),
    ("hole_fraction", "holes%", 2, 100.0),
    ("delta_e20_fraction", "dE>20%", 2, 100.0),
    ("host_ms", "host_ms", 1, 1.0),
];

/// Format one value of a column: `-` for null, except a PSNR that is null
/// while pixels were scored, which is +∞ (identical images; docs/metrics.md)
/// and prints `inf`.
pub fn cell(entry: &Value, key: &str, decimals: usize, scale: f64) -> String {
    match entry.get(key).and_then(|v| v.as_f64()) {
        Some(x) => format!("{:.*}", decimals, x * scale),
        None if key.starts_with("psnr") && entry["scored_pixels"].as_f64().is_some_and(|n| n > 0.0) => "inf".into(),
        None => "-".into(),
    }
}

/// The table text for `frames` and their `mean`.
pub fn render(frames: &[Value], mean: &Value) -> String {
    let mut s = String::new();
    let _ = write!(s, "{:>6}", "frame");
    for (_, h, _, _) in COLUMNS {
        let _ = write!(s, " {h:>10}");
    }
    s.push('\n');
    let row = |s: &mut String, label: String, v: &Value| {
        let _ = write!(s, "{label:>6}");
        for (k, _, d, sc) in COLUMNS {
            let _ = write!(s, " {:>10}", cell(v, k, *d, *sc));
        }
        s.push('\n');
    };
    for f in frames {
        row(&mut s, f["index"].to_string(), f);
    }
    row(&mut s, "mean".into(), mean);
    s
}

/// Kernels by largest side, as shares of all kernels reaching the image:
/// sides 1, 2, 3, 4 and 5 or more (from the `kernel_sizes` histogram).
fn kernel_side_shares(v: &Value) -> (f64, [f64; 5]) {
    let mut by_side = [0.0f64; 5];
    if let Some(rows) = v["kernel_sizes"].as_array() {
        for (w, row) in rows.iter().enumerate() {
            for (h, n) in row.as_array().into_iter().flatten().enumerate() {
                let side = w.max(h);
                if side > 0 {
                    by_side[(side - 1).min(4)] += n.as_f64().unwrap_or(0.0);
                }
            }
        }
    }
    let total: f64 = by_side.iter().sum();
    (total, by_side.map(|n| if total > 0.0 { 100.0 * n / total } else { 0.0 }))
}

/// Mean A-buffer fragments per pixel from the `fragments_per_pixel` histogram.
fn fragments_per_pixel(v: &Value) -> f64 {
    let h: Vec<f64> = v["fragments_per_pixel"].as_array().into_iter().flatten().filter_map(|x| x.as_f64()).collect();
    let pixels: f64 = h.iter().sum();
    if pixels == 0.0 { 0.0 } else { h.iter().enumerate().map(|(k, n)| k as f64 * n).sum::<f64>() / pixels }
}

/// The counters table: per frame the excluded (unknown-truth) pixels, hole
/// and empty samples, forced A-buffer merges, mean fragments per pixel, and
/// the kernel-size histogram (kernels, over the limit, shares by largest
/// side). Counts print as integers; the mean row with one decimal
/// (histogram columns of the mean row are over all frames).
pub fn render_counters(frames: &[Value], mean: &Value) -> String {
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
    let row = |s: &mut String, label: String, v: &Value, decimals: usize| {
        let _ = write!(s, "{label:>6}");
        for k in ["excluded_pixels", "hole_samples", "empty_samples", "forced_merges"] {
            let _ = write!(s, " {:>9}", cell(v, k, decimals, 1.0));
        }
        let _ = write!(s, " {:>9.3}", fragments_per_pixel(v));
        let (total, shares) = kernel_side_shares(v);
        let _ = write!(s, " {:>9.0} {:>9}", total, cell(v, "kernels_over_limit", decimals, 1.0));
        for sh in shares {
            let _ = write!(s, " {sh:>9.2}");
        }
        s.push('\n');
    };
    for f in frames {
        row(&mut s, f["index"].to_string(), f, 0);
    }
    row(&mut s, "mean".into(), mean, 1);
    s
}
