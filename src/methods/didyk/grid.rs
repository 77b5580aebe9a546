//! Didyk et al.'s adaptive quad grid (seed 002, Didyk, Ritschel, Eisemann,
//! Myszkowski, Seidel, "Adaptive Image-space Stereo View Synthesis",
//! VMV 2010, §3.3 and §3.3.1): the reference image is cut into square
//! cells, a cell is split into four while the disparity inside it varies by
//! more than a threshold, and a min/max disparity MIP-map answers "how much
//! does it vary" in O(1) per cell.
//!
//! Job: from one reference (sample image + warp to the derived camera), the
//! list of leaf cells to draw as quads (`mod.rs` draws them).
//!
//! Rules:
//! 1. Disparity. The paper's disparity is the image-space displacement of a
//!    point between the two stereo views (§3.1); its cameras differ by a
//!    horizontal baseline only. Our cameras move and turn freely, so we
//!    generalise it to the *parallax* of a reference sample: its warped
//!    position minus the position of the same sample warped at infinite
//!    depth (`WarpSetup::warp(x, y, 1/Z) − WarpSetup::warp(x, y, 0)`), a 2D
//!    vector in derived samples. The depth-independent part of the warp (the
//!    rotation and change of intrinsics, a homography) is left out: it is the
//!    same for every scene and smooth, so it says nothing about depth
//!    discontinuities, and with the references' wider field of view it would
//!    otherwise split every cell. For the paper's rectified stereo pair the
//!    parallax is exactly the paper's (signed) disparity `(d, 0)`.
//! 2. Disparity range of a cell: the per-axis extent
//!    `max(max dx − min dx, max dy − min dy)` over the cell's samples (the
//!    Chebyshev diameter of the parallax vectors). With a horizontal baseline
//!    it is the paper's `max − min` of the disparity.
//! 3. A sample is *drawable* when it has a surface (`valid`), a positive
//!    finite depth, and warps in front of the derived camera (`W > 0`) to a
//!    finite position. A drawable sample whose direction at infinity lies
//!    behind the derived camera has no measurable parallax: its range is
//!    infinite, so it always ends in a 1x1 cell.
//! 4. MIP-map (§3.3.1): level 0 holds per sample the parallax as a min and a
//!    max (±∞ for rule 3's unmeasurable samples) and a count of drawable
//!    samples (0 or 1); level `k + 1` holds the component-wise min of the
//!    mins, max of the maxes and the sum of the counts of the (up to) four
//!    level-`k` entries below it. Level `k` entry `(i, j)` covers samples
//!    `[i·2^k, (i+1)·2^k) x [j·2^k, (j+1)·2^k)`, clipped to the image.
//! 5. Subdivision (§3.3): the grid starts from cells of `max_cell` samples
//!    (the top MIP level), in row-major order. A cell is split into its four
//!    children iff it is larger than 1x1 and either holds drawable and
//!    undrawable samples together, or all of it is drawable and its range
//!    exceeds `threshold` (strictly: "if this difference is larger than some
//!    threshold four subquads are produced"). Children are visited depth
//!    first in the order top-left, top-right, bottom-left, bottom-right.
//! 6. Leaves: a leaf with no drawable sample is dropped; every other leaf is
//!    entirely drawable (by rule 5 or because it is 1x1) and is emitted, in
//!    visiting order. The emitted cells cover every drawable sample exactly
//!    once.
//!
//! Parameters ([`GridParams`]):
//! - `threshold`: subdivision threshold, derived samples, default 3 (the
//!   paper's "3 pixels", §3.3.1; the paper's pixel is the unit its grid
//!   refines to, which for us is the super-sample).
//! - `max_cell`: side of the starting cells, samples, power of two, default
//!   64. The paper starts from a 32x32 grid on 2048x1024 images (64x32-pixel
//!   cells) "to achieve enough parallelism, in theory one could start with
//!   1x1"; we keep 64 because the quads interpolate the warp's homography
//!   part linearly, whose error grows with the square of the quad size.
//!
//! Not modelled: the GPU data flow (quad centres in vertex buffers,
//! transform feedback, one geometry-shader pass per level, the 10+10+4-bit
//! packing of position and level); the result is the same set of cells.

use glam::DVec3;
use postwarp_rtl::{SampleImage, WarpSetup};

/// Subdivision parameters (rule 5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridParams {
    /// Split a cell whose disparity range exceeds this (derived samples).
    pub threshold: f32,
    /// Side of the starting cells (samples, a power of two).
    pub max_cell: u32,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams { threshold: 3.0, max_cell: 64 }
    }
}

/// One reference sample's disparity (rules 1 and 3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelDisparity {
    /// Nothing to draw: no surface, or it warps behind the derived camera.
    None,
    /// A drawable sample whose parallax cannot be measured (rule 3).
    Unmeasured,
    /// A drawable sample's parallax `(dx, dy)` (derived samples).
    At([f32; 2]),
}

/// Rules 1 and 3 for reference sample `(x, y)` with depth `z` (`None`: no
/// surface).
pub fn pixel_disparity(setup: &WarpSetup, x: u32, y: u32, z: Option<f32>) -> PixelDisparity {
    let Some(z) = z.filter(|z| z.is_finite() && *z > 0.0) else {
        return PixelDisparity::None;
    };
    // `WarpSetup::warp` at 1/Z and at 0, sharing `H·(x, y, 1)`.
    let n0 = setup.h * DVec3::new(x as f64, y as f64, 1.0);
    let n = n0 + setup.e_hat * (setup.s1 / z as f64);
    let (near, far) = (n.truncate() / n.z, n0.truncate() / n0.z);
    if !(n.z > 0.0 && near.is_finite()) {
        return PixelDisparity::None;
    }
    if !(n0.z > 0.0 && far.is_finite()) {
        return PixelDisparity::Unmeasured;
    }
    let d = near - far;
    let d = [d.x as f32, d.y as f32];
    if d.iter().all(|c| c.is_finite()) { PixelDisparity::At(d) } else { PixelDisparity::Unmeasured }
}

/// One MIP level (rule 4).
#[derive(Clone, Debug)]
struct Level {
    w: u32,
    h: u32,
    lo: Vec<[f32; 2]>,
    hi: Vec<[f32; 2]>,
    count: Vec<u32>,
}

/// The min/max disparity MIP-map of one reference under one warp (rule 4).
#[derive(Clone, Debug)]
pub struct DisparityMipMap {
    width: u32,
    height: u32,
    levels: Vec<Level>,
}

/// What the MIP-map knows of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellStats {
    /// Samples of the cell inside the image.
    pub area: u32,
    /// Drawable samples.
    pub drawable: u32,
    /// Rule 2's range over the drawable samples (0 when there are none).
    pub range: f32,
}

impl DisparityMipMap {
    /// Build levels `0..=top` over a `width x height` sample image whose
    /// sample `(x, y)` has disparity `pixel(x, y)`.
    pub fn build(width: u32, height: u32, top: u32, pixel: impl Fn(u32, u32) -> PixelDisparity) -> DisparityMipMap {
        let n = width as usize * height as usize;
        let mut l0 = Level {
            w: width,
            h: height,
            lo: vec![[f32::INFINITY; 2]; n],
            hi: vec![[f32::NEG_INFINITY; 2]; n],
            count: vec![0; n],
        };
        for y in 0..height {
            for x in 0..width {
                let i = y as usize * width as usize + x as usize;
                match pixel(x, y) {
                    PixelDisparity::None => {}
                    PixelDisparity::Unmeasured => {
                        l0.lo[i] = [f32::NEG_INFINITY; 2];
                        l0.hi[i] = [f32::INFINITY; 2];
                        l0.count[i] = 1;
                    }
                    PixelDisparity::At(d) => {
                        l0.lo[i] = d;
                        l0.hi[i] = d;
                        l0.count[i] = 1;
                    }
                }
            }
        }
        let mut levels = vec![l0];
        for _ in 0..top {
            let below = levels.last().expect("level 0 exists");
            let (w, h) = (below.w.div_ceil(2), below.h.div_ceil(2));
            let m = w as usize * h as usize;
            let mut l =
                Level { w, h, lo: vec![[f32::INFINITY; 2]; m], hi: vec![[f32::NEG_INFINITY; 2]; m], count: vec![0; m] };
            for j in 0..h {
                for i in 0..w {
                    let k = j as usize * w as usize + i as usize;
                    for (ci, cj) in [(2 * i, 2 * j), (2 * i + 1, 2 * j), (2 * i, 2 * j + 1), (2 * i + 1, 2 * j + 1)] {
                        if ci < below.w && cj < below.h {
                            let c = cj as usize * below.w as usize + ci as usize;
                            for a in 0..2 {
                                l.lo[k][a] = l.lo[k][a].min(below.lo[c][a]);
                                l.hi[k][a] = l.hi[k][a].max(below.hi[c][a]);
                            }
                            l.count[k] += below.count[c];
                        }
                    }
                }
            }
            levels.push(l);
        }
        DisparityMipMap { width, height, levels }
    }

    /// Rules 1, 3 and 4 for reference `img` under `setup`.
    pub fn from_reference(setup: &WarpSetup, img: &SampleImage, top: u32) -> DisparityMipMap {
        let w = img.width as usize;
        DisparityMipMap::build(img.width, img.height, top, |x, y| {
            let i = y as usize * w + x as usize;
            pixel_disparity(setup, x, y, img.valid[i].then_some(img.z[i]))
        })
    }

    /// Image width (samples).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height (samples).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Highest level.
    pub fn top(&self) -> u32 {
        self.levels.len() as u32 - 1
    }

    /// Entries `(columns, rows)` of `level`.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        let l = &self.levels[level as usize];
        (l.w, l.h)
    }

    /// The cell of `level` at entry `(i, j)`.
    pub fn cell(&self, level: u32, i: u32, j: u32) -> Cell {
        let s = 1u32 << level;
        Cell { x0: i * s, y0: j * s, x1: ((i + 1) * s).min(self.width), y1: ((j + 1) * s).min(self.height), level }
    }

    /// Area, drawable samples and range of entry `(i, j)` of `level`.
    pub fn stats(&self, level: u32, i: u32, j: u32) -> CellStats {
        let l = &self.levels[level as usize];
        let k = j as usize * l.w as usize + i as usize;
        let c = self.cell(level, i, j);
        let drawable = l.count[k];
        let range = if drawable == 0 { 0.0 } else { (l.hi[k][0] - l.lo[k][0]).max(l.hi[k][1] - l.lo[k][1]) };
        CellStats { area: (c.x1 - c.x0) * (c.y1 - c.y0), drawable, range }
    }
}

/// A cell of the grid: reference samples `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    /// First column (samples).
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
    /// MIP level (side `2^level` before clipping to the image).
    pub level: u32,
}

/// Counters of one subdivision (units: cells).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GridStats {
    /// Leaves emitted (entirely drawable).
    pub leaves: u64,
    /// Of those, 1x1 cells.
    pub leaves_1x1: u64,
    /// Leaves dropped because nothing in them is drawable.
    pub empty_leaves: u64,
    /// Cells split into four.
    pub splits: u64,
}

/// The level whose cells are `max_cell` samples wide (`max_cell` rounded
/// up to a power of two, at least 1).
pub fn top_level(max_cell: u32) -> u32 {
    max_cell.max(1).next_power_of_two().trailing_zeros()
}

/// Rules 5 and 6: append the leaf cells to `out` (cleared first).
pub fn adaptive_grid(mip: &DisparityMipMap, threshold: f32, out: &mut Vec<Cell>) -> GridStats {
    out.clear();
    let mut st = GridStats::default();
    let top = mip.top();
    let (cw, ch) = mip.level_size(top);
    let mut stack: Vec<(u32, u32, u32)> = Vec::new();
    for j in 0..ch {
        for i in 0..cw {
            stack.push((top, i, j));
            while let Some((level, i, j)) = stack.pop() {
                let s = mip.stats(level, i, j);
                let split = level > 0 && s.drawable > 0 && (s.drawable < s.area || s.range > threshold);
                if split {
                    st.splits += 1;
                    let (lw, lh) = mip.level_size(level - 1);
                    // Pushed in reverse so that they are visited TL, TR, BL, BR.
                    for (ci, cj) in [(2 * i + 1, 2 * j + 1), (2 * i, 2 * j + 1), (2 * i + 1, 2 * j), (2 * i, 2 * j)] {
                        if ci < lw && cj < lh {
                            stack.push((level - 1, ci, cj));
                        }
                    }
                } else if s.drawable == 0 {
                    st.empty_leaves += 1;
                } else {
                    st.leaves += 1;
                    st.leaves_1x1 += (s.area == 1) as u64;
                    out.push(mip.cell(level, i, j));
                }
            }
        }
    }
    st
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_levels_combine_min_max_and_counts() {
        // 3x3 image: clipped cells at the right and bottom.
        let d = |x: u32, y: u32| match (x, y) {
            (1, 1) => PixelDisparity::None,
            (2, 2) => PixelDisparity::Unmeasured,
            _ => PixelDisparity::At([x as f32, -(y as f32)]),
        };
        let m = DisparityMipMap::build(3, 3, 2, d);
        assert_eq!(m.level_size(1), (2, 2));
        assert_eq!(m.level_size(2), (1, 1));
        assert_eq!(m.stats(1, 0, 0), CellStats { area: 4, drawable: 3, range: 1.0 });
        assert_eq!(m.stats(1, 1, 0), CellStats { area: 2, drawable: 2, range: 1.0 });
        assert_eq!(m.stats(1, 0, 1), CellStats { area: 2, drawable: 2, range: 1.0 });
        assert_eq!(m.stats(1, 1, 1).range, f32::INFINITY);
        assert_eq!(m.stats(2, 0, 0).drawable, 8);
        assert_eq!(m.cell(1, 1, 1), Cell { x0: 2, y0: 2, x1: 3, y1: 3, level: 1 });
    }

    #[test]
    fn constant_disparity_gives_the_starting_cells() {
        let m = DisparityMipMap::build(100, 70, top_level(64), |_, _| PixelDisparity::At([2.5, 0.0]));
        let mut cells = Vec::new();
        let st = adaptive_grid(&m, 3.0, &mut cells);
        assert_eq!(cells.len(), 4);
        assert_eq!(st, GridStats { leaves: 4, leaves_1x1: 0, empty_leaves: 0, splits: 0 });
        assert_eq!(cells[3], Cell { x0: 64, y0: 64, x1: 100, y1: 70, level: 6 });
    }
}
