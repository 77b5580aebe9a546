//! Colour encoding and PNG output for pictures people look at.
//!
//! Traces store linear RGB; PNG files hold 8-bit sRGB. [`srgb_to_linear`]
//! and [`linear_to_srgb8`] are exact inverses on the 256 sRGB codes, even
//! through half-float storage (tested), so an 8-bit photo survives a trace
//! round trip unchanged.

use crate::io_util::write_atomically;
use std::path::Path;

/// sRGB EOTF: an 8-bit code to linear intensity in [0, 1].
pub fn srgb_to_linear(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Inverse sRGB EOTF, rounded to the nearest 8-bit code (clamped to [0, 1];
/// NaN maps to 0).
pub fn linear_to_srgb8(l: f32) -> u8 {
    let l = if l.is_nan() { 0.0 } else { (l as f64).clamp(0.0, 1.0) };
    let c = if l <= 0.0031308 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (c * 255.0).round() as u8
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
    fn box_filter_averages_blocks() {
        let s = vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(box_filter(2, 2, 2, &s), vec![[0.5, 0.25, 0.5]]);
    }
}
