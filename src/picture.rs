//! Colour encoding and PNG output for pictures people look at.
//!
//! Traces store linear RGB; PNG files hold 8-bit sRGB. [`srgb_to_linear`]
//! and [`linear_to_srgb8`] are exact inverses on the 256 sRGB codes, even
//! through half-float storage (tested), so an 8-bit photo survives a trace
//! round trip unchanged.

use crate::io_util::write_atomically;
use std::path::Path;

/// sRGB EOTF: an 8-bit code to linear intensity in [0, 1] (a table of the
/// 256 values of [`srgb_to_linear_formula`]).
pub fn srgb_to_linear(code: u8) -> f32 {
    tables().to_linear[code as usize]
}

/// The sRGB EOTF as a formula (what [`srgb_to_linear`] tabulates).
fn srgb_to_linear_formula(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Inverse sRGB EOTF, rounded to the nearest 8-bit code (clamped to [0, 1];
/// NaN maps to 0). The same code as [`linear_to_srgb8_formula`] for every
/// `f32`: that formula is monotonic in `l`, so the code is the number of
/// code boundaries (the smallest `f32` giving each code 1..=255, found by
/// bisection on the formula once) at or below `l` (tested around every
/// boundary and on a sweep of values). The count starts from a table of it
/// at the first `f32` of each run of 2^16 bit patterns `l` falls in (such a
/// run spans at most one boundary in [0, 1]), then steps over the
/// boundaries between that `f32` and `l`.
pub fn linear_to_srgb8(l: f32) -> u8 {
    if l.is_nan() || l <= 0.0 {
        return 0;
    }
    if l >= 1.0 {
        return 255;
    }
    let t = tables();
    let mut code = t.bucket[(l.to_bits() >> BUCKET_SHIFT) as usize] as usize;
    while code < t.boundary.len() && t.boundary[code] <= l {
        code += 1;
    }
    code as u8
}

/// `f32` bit patterns per [`Tables::bucket`] entry: 2^16.
const BUCKET_SHIFT: u32 = 16;

/// The inverse sRGB EOTF as a formula (what [`linear_to_srgb8`] computes
/// through its boundary table).
fn linear_to_srgb8_formula(l: f32) -> u8 {
    let l = if l.is_nan() { 0.0 } else { (l as f64).clamp(0.0, 1.0) };
    let c = if l <= 0.0031308 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (c * 255.0).round() as u8
}

/// The tables behind [`srgb_to_linear`] and [`linear_to_srgb8`].
struct Tables {
    to_linear: [f32; 256],
    /// `boundary[c - 1]`: the smallest non-negative `f32` whose code is `c`.
    boundary: [f32; 255],
    /// `bucket[i]`: the code of `f32::from_bits(i << BUCKET_SHIFT)`, for the
    /// bit patterns of [0, 1).
    bucket: Vec<u8>,
}

fn tables() -> &'static Tables {
    static T: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        let mut to_linear = [0.0f32; 256];
        for (c, v) in to_linear.iter_mut().enumerate() {
            *v = srgb_to_linear_formula(c as u8);
        }
        let mut boundary = [0.0f32; 255];
        // Non-negative f32s are ordered as their bit patterns.
        let one = 1.0f32.to_bits();
        for (i, b) in boundary.iter_mut().enumerate() {
            let code = i as u8 + 1;
            let (mut lo, mut hi) = (0u32, one); // code(lo) < code <= code(hi)
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if linear_to_srgb8_formula(f32::from_bits(mid)) >= code {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *b = f32::from_bits(hi);
        }
        let bucket = (0..=one >> BUCKET_SHIFT)
            .map(|i| boundary.partition_point(|&b| b <= f32::from_bits(i << BUCKET_SHIFT)) as u8)
            .collect();
        Tables { to_linear, boundary, bucket }
    })
}

/// Encode linear RGB pixels (row-major) as 8-bit sRGB.
pub fn to_srgb8(colour: &[[f32; 3]]) -> Vec<u8> {
    colour.iter().flat_map(|c| c.map(linear_to_srgb8)).collect()
}

/// Write linear RGB pixels as an sRGB PNG (atomically).
pub fn write_png(path: &Path, width: u32, height: u32, colour: &[[f32; 3]]) -> anyhow::Result<()> {
    write_png_srgb8(path, width, height, to_srgb8(colour))
}

/// Write 8-bit sRGB RGB bytes as a PNG (atomically).
pub fn write_png_srgb8(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> anyhow::Result<()> {
    let img = image::RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| anyhow::anyhow!("{}: pixel buffer does not match {width}x{height}", path.display()))?;
    write_atomically(path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| anyhow::anyhow!("{}: cannot write PNG: {e}", path.display()))
    })
}

/// Average `ss x ss` blocks of a sample-resolution buffer into pixels.
pub fn box_filter(width: u32, height: u32, ss: u32, samples: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let (pw, ph) = (width / ss, height / ss);
    let n = (ss * ss) as f32;
    let mut out = vec![[0.0f32; 3]; pw as usize * ph as usize];
    for py in 0..ph {
        for px in 0..pw {
            let mut acc = [0.0f32; 3];
            for sy in 0..ss {
                for sx in 0..ss {
                    let s = samples[((py * ss + sy) * width + px * ss + sx) as usize];
                    for k in 0..3 {
                        acc[k] += s[k];
                    }
                }
            }
            out[(py * pw + px) as usize] = acc.map(|a| a / n);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_codes_round_trip_through_half_floats() {
        for code in 0..=255u8 {
            let l = srgb_to_linear(code);
            let h = exr::prelude::f16::from_f32(l).to_f32();
            assert_eq!(linear_to_srgb8(h), code, "code {code}");
        }
    }

    #[test]
    fn tables_match_the_formulas() {
        for code in 0..=255u8 {
            assert_eq!(srgb_to_linear(code).to_bits(), srgb_to_linear_formula(code).to_bits(), "code {code}");
        }
        // Around every code boundary, bit by bit.
        for &b in tables().boundary.iter() {
            let bits = b.to_bits();
            for x in bits.saturating_sub(4096)..=bits + 4096 {
                let l = f32::from_bits(x);
                assert_eq!(linear_to_srgb8(l), linear_to_srgb8_formula(l), "l = {l:e} ({x:#x})");
            }
        }
        // Both ends of every bucket of the table the count starts from.
        for i in 0..=1.0f32.to_bits() >> BUCKET_SHIFT {
            for x in [i << BUCKET_SHIFT, ((i + 1) << BUCKET_SHIFT) - 1] {
                let l = f32::from_bits(x);
                assert_eq!(linear_to_srgb8(l), linear_to_srgb8_formula(l), "l = {l:e} ({x:#x})");
            }
        }
        // A sweep of [0, 1] and beyond, and the special values.
        let one = 1.0f32.to_bits();
        for x in (0..one + 100_000).step_by(997) {
            let l = f32::from_bits(x);
            assert_eq!(linear_to_srgb8(l), linear_to_srgb8_formula(l), "l = {l:e}");
        }
        for l in [f32::NAN, -0.0, -1.0, f32::NEG_INFINITY, f32::INFINITY, 2.0, f32::MIN_POSITIVE, 1e-45] {
            assert_eq!(linear_to_srgb8(l), linear_to_srgb8_formula(l), "l = {l:e}");
        }
    }

    /// Every f32 from 0 to 1 (about 1.07e9 values; run by hand:
    /// `cargo test --release --lib picture -- --ignored`).
    #[test]
    #[ignore]
    fn linear_to_srgb8_matches_the_formula_on_every_f32_in_0_1() {
        use rayon::prelude::*;
        let bad = (0..=1.0f32.to_bits())
            .into_par_iter()
            .filter(|&x| linear_to_srgb8(f32::from_bits(x)) != linear_to_srgb8_formula(f32::from_bits(x)))
            .count();
        assert_eq!(bad, 0);
    }

    #[test]
    fn box_filter_averages_blocks() {
        let s = vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(box_filter(2, 2, 2, &s), vec![[0.5, 0.25, 0.5]]);
    }
}
