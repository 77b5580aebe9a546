//! The surface-estimation quadtree of Schollmeyer et al. (seed 000,
//! "Efficient Hybrid Image Warping for High Frame-Rate Stereoscopic
//! Rendering", TVCG 2017, §4.1): which neighbouring reference samples form
//! one connected, nearly flat surface, reduced bottom-up into a quadtree per
//! tile, and the adaptive grid cells read off it (§4.1.4). It depends only
//! on the reference's depth, never on a warp, so it is built once per
//! reference ([`Reconstruction::prepare`](crate::methods::Reconstruction::prepare),
//! timed apart) and reused for every derived frame.
//!
//! Job: turn a reference depth image into (a) per-sample connectedness
//! links to the 8 neighbours and (b) a set of rectangular cells covering
//! every sample with a surface exactly once, as few as the chosen reduction
//! allows, none of which spans a depth discontinuity.
//!
//! Works on the reference's **sample grid** (`cmd.supersample` samples per
//! pixel axis): the paper's "pixel" is one sample here, and its 32x32-pixel
//! tiles are 32x32 samples (16x16 display pixels at 2x2 samples).
//!
//! Rules:
//! 1. Depth value: `d = 1/Z` of each sample (a GPU depth buffer is affine in
//!    1/Z). A sample is *usable* iff it is `valid` with a finite `Z > 0`;
//!    every test touching an unusable or off-image sample fails.
//! 2. Collinearity (eq. 1–2): for three samples along a line,
//!    `f = |(d₀ − d₁) − (d₁ − d₂)| / max(d₀, d₁, d₂)` and `L = f < ε`.
//!    1/Z is affine in image position on any plane, so `f = 0` exactly on
//!    planes whatever their slant; dividing by the largest of the three
//!    makes ε a relative (scale-free) tolerance.
//! 3. Each sample has four tests, one per axis: horizontal, vertical,
//!    diagonal (↘) and anti-diagonal (↙), on the sample and its two
//!    neighbours along the axis. At the image border, where one neighbour
//!    is missing, the test uses the three in-image samples nearest along
//!    the axis (shifted one step inward); with fewer than three it fails.
//! 4. Links: two 8-neighbours `p`, `q` are *joined* iff the test along
//!    their axis centred on `p` or the one centred on `q` holds. (A step
//!    between `p` and `q` enters both tests, so a step is never joined.)
//! 5. Leaves are 2x2 sample blocks with samples a b / c d. Side tests:
//!    left = H(a), H(c); right = H(b), H(d); top = V(a), V(b);
//!    bottom = V(c), V(d) (H, V: rule 3's tests centred on the sample).
//!    - cross-kernel (§4.1.1, Fig. 5a): a leaf is a surface iff all eight
//!      hold;
//!    - partial cross-kernel and irregular (§4.1.2, Fig. 5b): iff the four
//!      tests of at least one pair of adjacent sides hold (left+top,
//!      top+right, right+bottom, bottom+left).
//!
//!    Either way the leaf's estimation error is the largest `f` among its
//!    passing side tests (§4.1.1: "for all positive tests, the maximum
//!    deviation from collinearity").
//! 6. Connectedness bits: every node keeps one bit per side (left, right,
//!    top, bottom): set iff every sample pair across that side is joined
//!    (rule 4). A single sample's bits are its links; an inner node's bits
//!    are the logical AND of its children's bits on that side. The
//!    paper's four diagonal bits are the corner samples' diagonal links,
//!    read from the per-sample links where they are used (vertex
//!    placement and filtering, `grid`).
//! 7. Inner nodes (levels 2 to log₂ tile), error = the sum of the four
//!    children's errors ("accumulated"; for a uniformly curved surface the
//!    sum is twice the chord deviation of the node):
//!    - cross-kernel: a surface iff all four children are surfaces (the
//!      paper's propagation: overlapping kernels already tested the pairs
//!      across children);
//!    - partial and irregular: iff all four children are surfaces and the
//!      four internal sides are connected (TL.right, BL.right, TL.bottom,
//!      TR.bottom).
//!
//!    A node reaching past the image is never a surface.
//! 8. Grid (§4.1.4): each tile root is visited top-down; a node that is a
//!    surface with error ≤ τ is one cell; otherwise its in-image children
//!    are visited; a single usable sample is always a 1x1 cell, an unusable
//!    one none.
//! 9. Irregular grid (§4.1.3, Fig. 6): a node that is not one cell first
//!    tries to pair its children into 2:1 cells. A child is *whole* if it
//!    would be one cell by rule 8 (a usable sample, at the lowest level);
//!    two side-by-side whole children form one rectangle iff the side
//!    between them is connected (rule 6) and their summed error is ≤ τ.
//!    The merge type is the set of pairs: horizontal (top, bottom, both)
//!    or vertical (left, right, both), whichever gives more pairs, the
//!    horizontal one on a tie; with the node itself as one cell and no
//!    merge, the eight types of Fig. 6. Unpaired children are visited as
//!    in rule 8.
//!
//! Consequences (tested): a cross-kernel surface is also a partial
//! surface with the same error, so the partial cells are a coarsening of
//! the cross-kernel cells and never more; the irregular cells are the
//! partial cells with some pairs merged, never more. Cells partition the
//! usable samples and never contain two samples that are not connected.
//!
//! Parameters ([`QuadtreeParams`]):
//! | name | unit | default | source |
//! |---|---|---|---|
//! | `epsilon` | relative second difference of 1/Z | 0.01 | ours (the paper names ε, no value): a 1 % change of slope in 1/Z; bridges at most a 1 % depth step (under 0.2 samples of parallax on the bundled traces), passes the curvature of the room's bunny and teapot (estimated ≈ 5·10⁻⁴) |
//! | `error_threshold` τ | accumulated relative deviation | 0.02 | ours (paper: "a certain estimation error threshold"): a cell's mid-point may deviate about 1 % in 1/Z from the true surface |
//! | `tile` | samples | 32 | paper §6 ("maximum node size ... 32x32 pixel") |
//!
//! Not modelled: the GPU mip-map layout and transform-feedback refinement
//! passes (the same tree, built and read on the CPU); the merge type is not
//! stored in the tree but derived while reading it (rule 9); Didyk et al.'s
//! min-max reduction (Fig. 4a); the A-buffer's min-max quadtree (§4.2).

use postwarp_rtl::SampleImage;

/// Which reduction builds the quadtree (§4.1.1–4.1.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reduction {
    /// Cross-kernel surface reduction (§4.1.1).
    Cross,
    /// Partial cross-kernel surface reduction (§4.1.2).
    Partial,
    /// Irregular grid reduction: partial plus 2:1 cells (§4.1.3).
    Irregular,
}

impl Reduction {
    /// Every reduction, coarsest last.
    pub const ALL: [Reduction; 3] = [Reduction::Cross, Reduction::Partial, Reduction::Irregular];

    /// Short name (`cross`, `partial`, `irregular`).
    pub fn name(self) -> &'static str {
        match self {
            Reduction::Cross => "cross",
            Reduction::Partial => "partial",
            Reduction::Irregular => "irregular",
        }
    }
}

/// Knobs of the quadtree (module doc, table of parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadtreeParams {
    /// Collinearity tolerance ε (relative second difference of 1/Z).
    pub epsilon: f64,
    /// Split threshold τ on the accumulated error.
    pub error_threshold: f64,
    /// Tile (largest cell) size in samples; a power of two, at least 2.
    pub tile: u32,
}

impl Default for QuadtreeParams {
    fn default() -> Self {
        QuadtreeParams { epsilon: 0.01, error_threshold: 0.02, tile: 32 }
    }
}

/// Neighbour directions, in link-bit order: E, W, S, N, SE, NW, SW, NE.
pub const DIRS: [(i64, i64); 8] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (-1, 1), (1, -1)];

/// Link bit of each direction (index into [`DIRS`]).
pub mod dir {
    /// +x.
    pub const E: usize = 0;
    /// −x.
    pub const W: usize = 1;
    /// +y (down).
    pub const S: usize = 2;
    /// −y (up).
    pub const N: usize = 3;
    /// +x +y.
    pub const SE: usize = 4;
    /// −x −y.
    pub const NW: usize = 5;
    /// −x +y.
    pub const SW: usize = 6;
    /// +x −y.
    pub const NE: usize = 7;
}

/// Rule 2's deviation `f` of three depth values (1/Z).
pub fn deviation(d0: f64, d1: f64, d2: f64) -> f64 {
    ((d0 - d1) - (d1 - d2)).abs() / d0.max(d1).max(d2)
}

/// Rules 1–4: per-sample depth, tests and links of one reference.
#[derive(Clone, Debug)]
pub struct Links {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// 1/Z per sample (0 where not usable).
    pub inv_z: Vec<f64>,
    /// Usable samples (rule 1).
    pub usable: Vec<bool>,
    /// Per sample, the deviation `f` of its horizontal and vertical tests
    /// (infinite where the test cannot be made).
    pub dev: Vec<[f64; 2]>,
    /// Per sample, bits 0..4: horizontal, vertical, diagonal, anti-diagonal
    /// test holds.
    pub tests: Vec<u8>,
    /// Per sample, bit k: joined to the neighbour in direction `DIRS[k]`.
    pub links: Vec<u8>,
}

impl Links {
    /// Rules 1–4 for `img` with tolerance `epsilon`.
    pub fn new(img: &SampleImage, epsilon: f64) -> Links {
        let (w, h) = (img.width, img.height);
        let n = img.len();
        let usable: Vec<bool> = (0..n).map(|i| img.valid[i] && img.z[i].is_finite() && img.z[i] > 0.0).collect();
        let inv_z: Vec<f64> = (0..n).map(|i| if usable[i] { 1.0 / img.z[i] as f64 } else { 0.0 }).collect();
        let mut dev = vec![[f64::INFINITY; 2]; n];
        let mut tests = vec![0u8; n];
        let at = |x: i64, y: i64| -> Option<f64> {
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                return None;
            }
            let i = y as usize * w as usize + x as usize;
            usable[i].then_some(inv_z[i])
        };
        let inside = |x: i64, y: i64| x >= 0 && y >= 0 && x < w as i64 && y < h as i64;
        // Axes of rule 3: H, V, diagonal ↘, anti-diagonal ↙.
        let axes: [(i64, i64); 4] = [(1, 0), (0, 1), (1, 1), (-1, 1)];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let i = y as usize * w as usize + x as usize;
                if !usable[i] {
                    continue;
                }
                for (a, &(dx, dy)) in axes.iter().enumerate() {
                    // Centre of the three taps: shifted inward at the border.
                    let (cx, cy) = if !inside(x - dx, y - dy) {
                        (x + dx, y + dy)
                    } else if !inside(x + dx, y + dy) {
                        (x - dx, y - dy)
                    } else {
                        (x, y)
                    };
                    let taps = (at(cx - dx, cy - dy), at(cx, cy), at(cx + dx, cy + dy));
                    let f = match taps {
                        (Some(d0), Some(d1), Some(d2)) => deviation(d0, d1, d2),
                        _ => f64::INFINITY,
                    };
                    if a < 2 {
                        dev[i][a] = f;
                    }
                    if f < epsilon {
                        tests[i] |= 1 << a;
                    }
                }
            }
        }
        let mut links = vec![0u8; n];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let i = y as usize * w as usize + x as usize;
                for (k, &(dx, dy)) in DIRS.iter().enumerate() {
                    let (qx, qy) = (x + dx, y + dy);
                    if !inside(qx, qy) {
                        continue;
                    }
                    let q = qy as usize * w as usize + qx as usize;
                    let axis = k / 2;
                    if (tests[i] | tests[q]) & (1 << axis) != 0 {
                        links[i] |= 1 << k;
                    }
                }
            }
        }
        Links { width: w, height: h, inv_z, usable, dev, tests, links }
    }

    /// Linear index of sample `(x, y)`.
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// True if `(x, y)` is in the image and usable.
    pub fn usable_at(&self, x: i64, y: i64) -> bool {
        x >= 0
            && y >= 0
            && x < self.width as i64
            && y < self.height as i64
            && self.usable[y as usize * self.width as usize + x as usize]
    }

    /// True if `(x, y)` (in the image) is joined to its neighbour in
    /// direction `DIRS[k]` (rule 4; false off the image).
    pub fn joined(&self, x: i64, y: i64, k: usize) -> bool {
        self.usable_at(x, y) && self.links[y as usize * self.width as usize + x as usize] & (1 << k) != 0
    }
}

/// Side bits of a node (rule 6).
const LEFT: u8 = 1;
const RIGHT: u8 = 2;
const TOP: u8 = 4;
const BOTTOM: u8 = 8;

/// One level of the quadtree: nodes of `2^level x 2^level` samples.
#[derive(Clone, Debug)]
struct Level {
    /// Nodes per row and column.
    w: u32,
    h: u32,
    surface: Vec<bool>,
    sides: Vec<u8>,
    error: Vec<f64>,
}

/// A rectangle of reference samples `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Cell {
    /// Samples covered.
    pub fn area(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}

/// The surface-estimation quadtree of one reference (rules 5–7).
#[derive(Clone, Debug)]
pub struct Quadtree {
    /// The reduction that built it.
    pub reduction: Reduction,
    /// Its parameters.
    pub params: QuadtreeParams,
    levels: Vec<Level>,
    width: u32,
    height: u32,
}

/// Counters of one reference's grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GridCounts {
    /// Cells in the grid.
    pub cells: u64,
    /// Of which 2:1 rectangles (irregular reduction only).
    pub rects: u64,
    /// Of which single samples.
    pub single_samples: u64,
    /// Quadtree nodes (levels 1 and up) that are surfaces.
    pub surface_nodes: u64,
}

impl Quadtree {
    /// Build the quadtree of `links` with `reduction` (rules 5–7).
    ///
    /// # Panics
    /// If `params.tile` is not a power of two at least 2.
    pub fn new(links: &Links, reduction: Reduction, params: &QuadtreeParams) -> Quadtree {
        assert!(params.tile >= 2 && params.tile.is_power_of_two(), "tile must be a power of two >= 2");
        let (w, h) = (links.width, links.height);
        let top = params.tile.trailing_zeros() as usize;
        // Level 0: samples.
        let n = links.usable.len();
        let mut sides0 = vec![0u8; n];
        for y in 0..h {
            for x in 0..w {
                let i = links.index(x, y);
                let l = links.links[i];
                let bit = |k: usize| l & (1 << k) != 0;
                sides0[i] = (bit(dir::W) as u8 * LEFT)
                    | (bit(dir::E) as u8 * RIGHT)
                    | (bit(dir::N) as u8 * TOP)
                    | (bit(dir::S) as u8 * BOTTOM);
            }
        }
        let mut levels =
            vec![Level { w, h, surface: links.usable.clone(), sides: sides0, error: vec![0.0; links.usable.len()] }];
        for k in 1..=top {
            let prev = &levels[k - 1];
            let (lw, lh) = (prev.w.div_ceil(2), prev.h.div_ceil(2));
            let size = 1u64 << k;
            let mut lvl = Level {
                w: lw,
                h: lh,
                surface: vec![false; (lw * lh) as usize],
                sides: vec![0; (lw * lh) as usize],
                error: vec![0.0; (lw * lh) as usize],
            };
            for j in 0..lh {
                for i in 0..lw {
                    let o = (j * lw + i) as usize;
                    let inside = (i as u64 + 1) * size <= w as u64 && (j as u64 + 1) * size <= h as u64;
                    if !inside {
                        continue;
                    }
                    // Children TL, TR, BL, BR (all exist: the node is inside).
                    let c = [(2 * i, 2 * j), (2 * i + 1, 2 * j), (2 * i, 2 * j + 1), (2 * i + 1, 2 * j + 1)]
                        .map(|(ci, cj)| (cj * prev.w + ci) as usize);
                    let s = c.map(|ci| prev.sides[ci]);
                    lvl.sides[o] =
                        (s[0] & s[2] & LEFT) | (s[1] & s[3] & RIGHT) | (s[0] & s[1] & TOP) | (s[2] & s[3] & BOTTOM);
                    let (surface, error) = if k == 1 {
                        leaf(links, 2 * i, 2 * j, reduction)
                    } else {
                        let all = c.iter().all(|&ci| prev.surface[ci]);
                        let joined = match reduction {
                            Reduction::Cross => true,
                            Reduction::Partial | Reduction::Irregular => {
                                s[0] & RIGHT != 0 && s[2] & RIGHT != 0 && s[0] & BOTTOM != 0 && s[1] & BOTTOM != 0
                            }
                        };
                        (all && joined, c.iter().map(|&ci| prev.error[ci]).sum())
                    };
                    lvl.surface[o] = surface;
                    lvl.error[o] = error;
                }
            }
            levels.push(lvl);
        }
        Quadtree { reduction, params: *params, levels, width: w, height: h }
    }

    /// Rules 8–9: the grid's cells, tile by tile in raster order, each
    /// tile top-down (children TL, TR, BL, BR).
    pub fn cells(&self) -> (Vec<Cell>, GridCounts) {
        let mut out = Vec::new();
        let mut counts = GridCounts {
            surface_nodes: self.levels[1..].iter().map(|l| l.surface.iter().filter(|&&s| s).count() as u64).sum(),
            ..GridCounts::default()
        };
        let top = self.levels.len() - 1;
        let roots = &self.levels[top];
        for j in 0..roots.h {
            for i in 0..roots.w {
                self.visit(top, i, j, &mut out, &mut counts);
            }
        }
        counts.cells = out.len() as u64;
        (out, counts)
    }

    /// The samples of node `(i, j)` at level `k`, clipped to the image.
    fn rect(&self, k: usize, i: u32, j: u32) -> Cell {
        let s = 1u64 << k;
        let c = |v: u32, lim: u32| ((v as u64 * s).min(lim as u64) as u32, ((v as u64 + 1) * s).min(lim as u64) as u32);
        let (x0, x1) = c(i, self.width);
        let (y0, y1) = c(j, self.height);
        Cell { x0, y0, x1, y1 }
    }

    /// Rule 8's "one cell" test (a usable sample at level 0).
    fn whole(&self, k: usize, i: u32, j: u32) -> bool {
        let l = &self.levels[k];
        if i >= l.w || j >= l.h {
            return false;
        }
        let o = (j * l.w + i) as usize;
        l.surface[o] && (k == 0 || l.error[o] <= self.params.error_threshold)
    }

    fn node(&self, k: usize, i: u32, j: u32) -> usize {
        (j * self.levels[k].w + i) as usize
    }

    fn visit(&self, k: usize, i: u32, j: u32, out: &mut Vec<Cell>, counts: &mut GridCounts) {
        let l = &self.levels[k];
        if i >= l.w || j >= l.h {
            return;
        }
        let r = self.rect(k, i, j);
        if r.x0 >= r.x1 || r.y0 >= r.y1 {
            return;
        }
        if k == 0 {
            if l.surface[self.node(0, i, j)] {
                counts.single_samples += 1;
                out.push(r);
            }
            return;
        }
        if self.whole(k, i, j) {
            out.push(r);
            return;
        }
        let c = [(2 * i, 2 * j), (2 * i + 1, 2 * j), (2 * i, 2 * j + 1), (2 * i + 1, 2 * j + 1)];
        let mut done = [false; 4];
        if self.reduction == Reduction::Irregular {
            let cl = &self.levels[k - 1];
            let whole = c.map(|(ci, cj)| self.whole(k - 1, ci, cj));
            let err = |a: usize| if k == 1 { 0.0 } else { cl.error[self.node(k - 1, c[a].0, c[a].1)] };
            let side = |a: usize, bit: u8| cl.sides[self.node(k - 1, c[a].0, c[a].1)] & bit != 0;
            let tau = self.params.error_threshold;
            let pair = |a: usize, b: usize, bit: u8| whole[a] && whole[b] && side(a, bit) && err(a) + err(b) <= tau;
            // (first, second) children of each candidate pair.
            let horizontal = [(0, 1, pair(0, 1, RIGHT)), (2, 3, pair(2, 3, RIGHT))];
            let vertical = [(0, 2, pair(0, 2, BOTTOM)), (1, 3, pair(1, 3, BOTTOM))];
            let count = |p: &[(usize, usize, bool); 2]| p.iter().filter(|q| q.2).count();
            let chosen = if count(&horizontal) >= count(&vertical) { horizontal } else { vertical };
            for (a, b, ok) in chosen {
                if ok {
                    let (ra, rb) = (self.rect(k - 1, c[a].0, c[a].1), self.rect(k - 1, c[b].0, c[b].1));
                    out.push(Cell { x0: ra.x0, y0: ra.y0, x1: rb.x1, y1: rb.y1 });
                    counts.rects += 1;
                    done[a] = true;
                    done[b] = true;
                }
            }
        }
        for (n, &(ci, cj)) in c.iter().enumerate() {
            if !done[n] {
                self.visit(k - 1, ci, cj, out, counts);
            }
        }
    }
}

/// Rule 5: is the 2x2 leaf with top-left sample `(x, y)` a surface, and its
/// error.
fn leaf(links: &Links, x: u32, y: u32, reduction: Reduction) -> (bool, f64) {
    let s = [links.index(x, y), links.index(x + 1, y), links.index(x, y + 1), links.index(x + 1, y + 1)];
    let h = |k: usize| links.tests[s[k]] & 1 != 0;
    let v = |k: usize| links.tests[s[k]] & 2 != 0;
    let left = h(0) && h(2);
    let right = h(1) && h(3);
    let top = v(0) && v(1);
    let bottom = v(2) && v(3);
    let surface = match reduction {
        Reduction::Cross => left && right && top && bottom,
        Reduction::Partial | Reduction::Irregular => {
            // Two adjacent sides: one of left/right and one of top/bottom.
            (left || right) && (top || bottom)
        }
    };
    let mut error: f64 = 0.0;
    for &i in &s {
        for (a, bit) in [(0, 1u8), (1, 2u8)] {
            if links.tests[i] & bit != 0 {
                error = error.max(links.dev[i][a]);
            }
        }
    }
    (surface, error)
}

/// Rules 1–9 on one reference: its links and its grid's cells.
#[derive(Clone, Debug)]
pub struct SurfaceEstimate {
    /// Per-sample links.
    pub links: Links,
    /// The grid's cells.
    pub cells: Vec<Cell>,
    /// Counters.
    pub counts: GridCounts,
}

/// Build the links, the quadtree with `reduction` and its cells.
pub fn estimate(img: &SampleImage, reduction: Reduction, params: &QuadtreeParams) -> SurfaceEstimate {
    let links = Links::new(img, params.epsilon);
    let tree = Quadtree::new(&links, reduction, params);
    let (cells, counts) = tree.cells();
    SurfaceEstimate { links, cells, counts }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, inv_z: impl Fn(u32, u32) -> Option<f64>) -> SampleImage {
        let mut img = SampleImage::empty(w, h);
        for y in 0..h {
            for x in 0..w {
                if let Some(d) = inv_z(x, y) {
                    let i = img.index(x, y);
                    img.z[i] = (1.0 / d) as f32;
                    img.valid.set(i, true);
                }
            }
        }
        img
    }

    fn covered_once(img: &SampleImage, cells: &[Cell]) {
        let mut hits = vec![0u32; img.len()];
        for c in cells {
            for y in c.y0..c.y1 {
                for x in c.x0..c.x1 {
                    hits[img.index(x, y)] += 1;
                }
            }
        }
        for (i, &n) in hits.iter().enumerate() {
            assert_eq!(n, img.valid[i] as u32, "sample {i}");
        }
    }

    #[test]
    fn deviation_is_zero_on_a_line_and_relative() {
        assert!(deviation(0.1, 0.2, 0.3) < 1e-15);
        assert_eq!(deviation(0.25, 0.5, 0.75), 0.0);
        assert!((deviation(1.0, 1.0, 2.0) - 0.5).abs() < 1e-12);
        assert!((deviation(10.0, 10.0, 20.0) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_slanted_plane_is_one_cell_per_tile_in_every_reduction() {
        let img = image(64, 32, |x, y| Some(0.2 + 0.003 * x as f64 + 0.001 * y as f64));
        for r in Reduction::ALL {
            let e = estimate(&img, r, &QuadtreeParams::default());
            assert_eq!(e.cells.len(), 2, "{r:?}: {:?}", e.cells);
            covered_once(&img, &e.cells);
        }
    }

    #[test]
    fn a_step_splits_and_links_stop_at_it() {
        // Step between columns 9 and 10.
        let img = image(32, 32, |x, _| Some(if x < 10 { 0.5 } else { 0.1 }));
        let l = Links::new(&img, 0.01);
        assert!(l.joined(8, 4, dir::E) && !l.joined(9, 4, dir::E) && !l.joined(10, 4, dir::W));
        assert!(!l.joined(9, 4, dir::SE) && !l.joined(9, 4, dir::NE) && l.joined(10, 4, dir::E));
        for r in Reduction::ALL {
            let e = estimate(&img, r, &QuadtreeParams::default());
            covered_once(&img, &e.cells);
            for c in &e.cells {
                assert!(c.x1 <= 10 || c.x0 >= 10, "{r:?} cell {c:?} spans the step");
            }
        }
    }

    #[test]
    fn tiny_and_empty_images_do_not_panic() {
        for (w, h) in [(1, 1), (1, 5), (5, 1), (2, 2), (3, 3), (0, 0)] {
            let img = image(w, h, |x, y| ((x + y) % 3 != 1).then_some(0.5));
            for r in Reduction::ALL {
                let e = estimate(&img, r, &QuadtreeParams::default());
                covered_once(&img, &e.cells);
            }
        }
    }

    #[test]
    fn irregular_pairs_whole_children() {
        // An 8x4 plane above a different plane: the top strip is two whole
        // 4x4 nodes, paired into one 2:1 cell by the irregular reduction
        // only; likewise the bottom strip.
        let img = image(8, 8, |x, y| Some(if y < 4 { 0.5 + 0.01 * x as f64 } else { 0.1 }));
        let p = QuadtreeParams { tile: 8, ..QuadtreeParams::default() };
        let part = estimate(&img, Reduction::Partial, &p);
        let irr = estimate(&img, Reduction::Irregular, &p);
        let cross = estimate(&img, Reduction::Cross, &p);
        assert_eq!(part.cells.len(), 4, "{:?}", part.cells);
        assert_eq!(irr.cells.len(), 2, "{:?}", irr.cells);
        assert_eq!(irr.counts.rects, 2);
        assert!(cross.cells.len() > 4, "the cross kernel splits next to the step: {:?}", cross.cells);
    }
}
