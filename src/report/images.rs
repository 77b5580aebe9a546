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

/// Legend strip under a heat-map (pixels).
pub const LEGEND_HEIGHT: u32 = 40;
/// Narrowest heat-map picture, so the legend's text fits (pixels).
pub const LEGEND_MIN_WIDTH: u32 = 190;

/// The heat-map colours of a frame: per pixel, the largest absolute
/// difference of the 8-bit sRGB codes through the ramp saturating at
/// `full_scale` codes; unknown truth pixels mid-grey.
pub fn diff_colours(image: &[[f32; 3]], truth: &[[f32; 3]], known: &BitVec, full_scale: f64) -> Vec<[u8; 3]> {
    image
        .iter()
        .zip(truth)
        .enumerate()
        .map(|(i, (a, b))| {
            if !known[i] {
                return [128, 128, 128];
            }
            let d = (0..3)
                .map(|k| (linear_to_srgb8(a[k]) as i32 - linear_to_srgb8(b[k]) as i32).unsigned_abs())
                .max()
                .unwrap_or(0);
            ramp(d as f64 / full_scale)
        })
        .collect()
}

/// The heat-map picture: the frame's [`diff_colours`] at the top left, one
/// picture pixel per frame pixel, and below it a legend: the colour ramp
/// from 0 to `full_scale` codes with its scale, and what grey means. The
/// picture is `max(width, LEGEND_MIN_WIDTH)` x `height + LEGEND_HEIGHT`.
pub fn diff_heatmap_picture(
    width: u32,
    height: u32,
    colours: &[[u8; 3]],
    full_scale: f64,
) -> Result<(u32, u32, Vec<u8>), String> {
    use plotters::prelude::*;
    let (w, h) = (width.max(LEGEND_MIN_WIDTH), height + LEGEND_HEIGHT);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    for y in 0..height {
        for x in 0..width {
            let o = ((y * w + x) * 3) as usize;
            rgb[o..o + 3].copy_from_slice(&colours[(y * width + x) as usize]);
        }
    }
    crate::chart::font::register()?;
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let e = |err: DrawingAreaErrorKind<_>| format!("drawing the heat-map legend: {err}");
        let (x0, x1) = (6i32, w as i32 - 30);
        let top = height as i32 + 4;
        for x in x0..x1 {
            let c = ramp((x - x0) as f64 / (x1 - x0 - 1).max(1) as f64);
            root.draw(&PathElement::new(vec![(x, top), (x, top + 8)], RGBColor(c[0], c[1], c[2]))).map_err(e)?;
        }
        root.draw(&Rectangle::new([(x1 + 6, top), (x1 + 20, top + 8)], RGBColor(128, 128, 128).filled())).map_err(e)?;
        let font = ("sans-serif", 10).into_font().color(&BLACK);
        // Scale under the ramp: 0 at its left end, the middle, and the
        // saturation at its right end (right-aligned).
        let marks = [(0.0, "0".to_string()), (0.5, format!("{}", full_scale / 2.0)), (1.0, format!(">={full_scale}"))];
        for (t, text) in marks {
            let x = x0 + (t * (x1 - x0) as f64) as i32;
            let (tw, _) = root.estimate_text_size(&text, &font).map_err(e)?;
            let x = (x - (t * tw as f64) as i32).clamp(0, w as i32 - tw as i32);
            root.draw(&Text::new(text, (x, top + 10), font.clone())).map_err(e)?;
        }
        root.draw(&Text::new("|diff| of 8-bit sRGB codes; grey: unknown", (x0, top + 22), font)).map_err(e)?;
        root.present().map_err(e)?;
    }
    Ok((w, h, rgb))
}

/// Write the heat-map picture of a frame against its truth
/// ([`diff_heatmap_picture`]) as a PNG.
pub fn write_diff_heatmap(
    path: &Path,
    width: u32,
    height: u32,
    image: &[[f32; 3]],
    truth: &[[f32; 3]],
    known: &BitVec,
    full_scale: f64,
) -> anyhow::Result<()> {
    let colours = diff_colours(image, truth, known, full_scale);
    let (w, h, rgb) = diff_heatmap_picture(width, height, &colours, full_scale)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    write_png_srgb8(path, w, h, rgb)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_heat_map_keeps_one_pixel_per_frame_pixel_and_adds_a_legend() {
        let (w, h) = (8u32, 4u32);
        let colours: Vec<[u8; 3]> = (0..w * h).map(|i| ramp(i as f64 / 31.0)).collect();
        let (pw, ph, rgb) = diff_heatmap_picture(w, h, &colours, 64.0).unwrap();
        assert_eq!((pw, ph), (LEGEND_MIN_WIDTH, h + LEGEND_HEIGHT));
        for y in 0..h {
            for x in 0..w {
                let o = ((y * pw + x) * 3) as usize;
                assert_eq!(rgb[o..o + 3], colours[(y * w + x) as usize], "({x}, {y})");
            }
        }
        // The ramp's both ends and the grey swatch are in the legend.
        let legend = &rgb[(h * pw * 3) as usize..];
        let has = |c: [u8; 3]| legend.chunks(3).any(|p| p == c);
        assert!(has(ramp(0.0)) && has(ramp(1.0)) && has([128, 128, 128]));
        // Some text was drawn (dark pixels besides the ramp's black end).
        let dark = legend.chunks(3).filter(|p| p[0] < 60 && p[1] < 60 && p[2] < 60).count();
        assert!(dark > 50, "{dark}");
        assert_eq!(diff_heatmap_picture(w, h, &colours, 64.0).unwrap().2, rgb, "deterministic");
    }
}
