//! Pictures of a derived frame for people to look at: a difference heat-map
//! against ground truth and a hole mask.

use crate::picture::{linear_to_srgb8, write_png_srgb8};
use bitvec::vec::BitVec;
use std::path::Path;

/// Heat-map colour for `t` in [0, 1]: black → blue → magenta → yellow → white.
fn ramp(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] =
        [[0.0, 0.0, 0.0], [0.1, 0.1, 0.8], [0.85, 0.1, 0.6], [1.0, 0.85, 0.1], [1.0, 1.0, 1.0]];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mut out = [0u8; 3];
    for (k, o) in out.iter_mut().enumerate() {
        *o = ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0).round() as u8;
    }
    out
}

/// Per-pixel largest absolute difference of the 8-bit sRGB codes, mapped
/// through a heat ramp saturating at `full_scale` codes; unknown truth
/// pixels are drawn mid-grey.
pub fn write_diff_heatmap(
    path: &Path,
    width: u32,
    height: u32,
    image: &[[f32; 3]],
    truth: &[[f32; 3]],
    known: &BitVec,
    full_scale: f64,
) -> anyhow::Result<()> {
    let mut rgb = Vec::with_capacity(image.len() * 3);
    for (i, (a, b)) in image.iter().zip(truth).enumerate() {
        if !known[i] {
            rgb.extend([128, 128, 128]);
            continue;
        }
        let d = (0..3)
            .map(|k| (linear_to_srgb8(a[k]) as i32 - linear_to_srgb8(b[k]) as i32).unsigned_abs())
            .max()
            .unwrap_or(0);
        rgb.extend(ramp(d as f64 / full_scale));
    }
    write_png_srgb8(path, width, height, rgb)
}

/// Hole mask per pixel: black = every sample a real surface, grey = some
/// samples hole-filled, white = all samples hole-filled, red = some sample
/// reached by no surface and no fill.
pub fn write_hole_mask(
    path: &Path,
    width: u32,
    height: u32,
    ss: u32,
    real: &BitVec,
    hole: &BitVec,
) -> anyhow::Result<()> {
    let sw = width * ss;
    let mut rgb = Vec::with_capacity((width * height * 3) as usize);
    for py in 0..height {
        for px in 0..width {
            let (mut n_real, mut n_hole) = (0, 0);
            for j in 0..ss {
                for i in 0..ss {
                    let k = ((py * ss + j) * sw + px * ss + i) as usize;
                    n_real += real[k] as u32;
                    n_hole += hole[k] as u32;
                }
            }
            let n = ss * ss;
            rgb.extend(if n_real + n_hole < n {
                [255, 0, 0]
            } else if n_hole == 0 {
                [0, 0, 0]
            } else if n_real == 0 {
                [255, 255, 255]
            } else {
                [128, 128, 128]
            });
        }
    }
    write_png_srgb8(path, width, height, rgb)
}
