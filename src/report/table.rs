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

/// Format one value of a column: `-` for null, `inf` for an infinite PSNR
/// (identical images serialize as null too; see docs/metrics.md).
pub fn cell(v: Option<&Value>, decimals: usize, scale: f64) -> String {
    match v.and_then(|v| v.as_f64()) {
        Some(x) => format!("{:.*}", decimals, x * scale),
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
            let _ = write!(s, " {:>10}", cell(v.get(*k), *d, *sc));
        }
        s.push('\n');
    };
    for f in frames {
        row(&mut s, f["index"].to_string(), f);
    }
    row(&mut s, "mean".into(), mean);
    s
}
