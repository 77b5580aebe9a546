//! Adaptive grid warping of Schollmeyer et al. (seed 000, TVCG 2017,
//! §4.1.4 and §5.1) as three reconstructions, one per quadtree reduction:
//! `schollmeyer-cross`, `schollmeyer-partial`, `schollmeyer-irregular`.
//!
//! Job: warp each reference's adaptive grid (the cells of its
//! surface-estimation quadtree, `quadtree`) into the derived
//! frame as Z-tested triangles, with vertex depths and texture filtering
//! chosen by connectedness, so that surfaces are stitched without cracks
//! and depth discontinuities are never bridged by a rubber sheet.
//!
//! Works on the sample grids of both cameras (`cmd.supersample`; the
//! paper's pixels are samples here). Sample `(x, y)` has its centre at
//! `(x, y)` and covers `[x − ½, x + ½]`.
//!
//! Rules:
//! 1. Per reference, once ([`Reconstruction::prepare`], timed apart): the
//!    quadtree with this method's reduction and its cells
//!    (`quadtree` rules 1–9), and every cell's four corner
//!    vertices (rules 2–3). Nothing here depends on the warp.
//! 2. Vertex position: always the cell's corner, the point between the
//!    four samples TL, TR, BL, BR around it (`(cx − ½, cy − ½)`).
//! 3. Vertex depth ("grid vertices fetch their depth between pixels if the
//!    adjacent cells form a connected surface, and directly from pixels if
//!    there is a depth discontinuity", §5.1): the corner's own sample (the
//!    cell's sample at that corner) and the samples around the corner
//!    joined to it through the six links among the four (two horizontal,
//!    two vertical, both diagonals: "the connectedness to diagonal
//!    neighbours is used as well") form its *component*. 1/Z is
//!    - the mean of all four, if the component holds all four;
//!    - the mean of a diagonal pair, if it holds one (any three do);
//!    - the mean of the pair, if it is a horizontal or vertical pair
//!      (fetched between the two samples, on the pixel row or column:
//!      across the discontinuity it sits on the pixel);
//!    - the own sample's 1/Z, if it is alone (fetched on the pixel).
//!
//!    Every cell whose corner sample lies in the same component gets the
//!    same vertex (same position, same 1/Z): connected cells are stitched.
//!    Cells on two sides of a discontinuity get different vertices at the
//!    same position, which separate when warped: no rubber sheet. On a
//!    plane every rule gives the exact 1/Z at the corner (1/Z is affine).
//! 4. Warp (per derived frame, `reconstruct`): each vertex by
//!    [`WarpSetup::warp`] (sample grids). A cell with a vertex behind the
//!    derived camera (`W <= 0`) or not finite is split into up to four
//!    halves (vertices by rule 3) until the parts are in front; a 1x1 part
//!    that is not is dropped (`culled_cells`).
//! 5. A cell with corners TL, TR, BL, BR is drawn as the triangles (TL, TR,
//!    BR) and (TL, BR, BL), positive winding, rasterized by the golden
//!    model's top-left-rule [`triangle`] (each derived sample centre
//!    covered once by a mesh without folds). A triangle whose warped
//!    winding is not positive (seen from behind, folded) is skipped
//!    (`folded_triangles`).
//! 6. Per covered derived sample: derived 1/Z is interpolated linearly in
//!    the derived image (exact on a planar triangle); the reference
//!    coordinates perspective-correctly (`x/W`, `y/W`, `1/W` linear), as a
//!    GPU interpolates texture coordinates.
//! 7. Z test: the larger derived 1/Z wins; on a tie the sample already
//!    there stays. References are drawn in warp order into one frame; the
//!    `source` plane records the reference.
//! 8. Texture filtering (§5.1): at reference coordinates `s`, the four
//!    samples around `s` are read bilinearly iff they are all in the image
//!    and joined along the four sides of their square ("a surface");
//!    otherwise ("in the vicinity of a depth discontinuity") the nearest
//!    sample, clamped into the cell's own samples, so a cell never shows a
//!    colour of another surface.
//!
//! Parameters: `quadtree::QuadtreeParams` (ε = 0.01, τ = 0.02,
//! tile 32 samples); nothing else.
//!
//! Counters (`extra`, per frame, summed over the references):
//! `grid_cells` (cells of this reduction's grids), `rect_cells` (2:1
//! cells), `single_sample_cells`, `surface_nodes`, `vertices` (warped),
//! `split_cells`, `culled_cells`, `folded_triangles`, `linear_fragments`,
//! `nearest_fragments`, `depth_lost`. `primitives` = cells drawn (grid
//! cells, or their parts after a split, whose vertices are all in front).
//!
//! Not modelled: the A-buffer ray casting of transparent fragments (§4.2,
//! §5.3); the GPU's near-plane clipping (rule 4 splits instead); MSAA;
//! T-junction cracks between a large cell and smaller neighbours are left
//! as they are (they open only on curved surfaces within τ, and the hole
//! fill closes them); the paper's single-reference stereo set-up (several
//! references are composited by the Z test, rule 7).

use super::quadtree::{Cell, GridCounts, Links, QuadtreeParams, Reduction, dir, estimate};
use crate::golden::general::{Window, triangle};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Prepared, Reconstruction};
use glam::DVec2;
use postwarp_rtl::{SampleImage, WarpSetup};
use serde_json::{Map, Value};
use std::collections::HashMap;

/// A grid vertex in reference sample coordinates (rules 2–3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridVertex {
    /// Position: a cell corner, between four samples.
    pub pos: DVec2,
    /// Reference 1/Z.
    pub inv_z: f64,
    /// Where the depth was fetched: the corner (between four samples), the
    /// middle of a pair, or a sample centre.
    pub fetch: DVec2,
    /// Bit k set: sample k of the corner (0 TL, 1 TR, 2 BL, 3 BR) is in the
    /// vertex's component.
    pub component: u8,
}

impl GridVertex {
    /// True if the depth was fetched on a sample (the component is one
    /// sample: a discontinuity on every side of the corner).
    pub fn on_pixel(&self) -> bool {
        self.component.count_ones() == 1
    }
}

/// One grid cell and its corner vertices (indices into [`Grid::vertices`],
/// TL, TR, BL, BR).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridCell {
    /// The samples it covers.
    pub cell: Cell,
    /// Corner vertices TL, TR, BL, BR.
    pub v: [u32; 4],
}

/// A reference's adaptive grid (rule 1): what `prepare` makes.
#[derive(Clone, Debug)]
pub struct Grid {
    /// The reduction that built it.
    pub reduction: Reduction,
    /// Per-sample links.
    pub links: Links,
    /// Cells in quadtree order.
    pub cells: Vec<GridCell>,
    /// Distinct vertices.
    pub vertices: Vec<GridVertex>,
    /// Grid counters.
    pub counts: GridCounts,
}

impl Grid {
    /// Rule 1 for `img`.
    pub fn new(img: &SampleImage, reduction: Reduction, params: &QuadtreeParams) -> Grid {
        let est = estimate(img, reduction, params);
        let mut index: HashMap<(u32, u32, u8), u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut cells = Vec::with_capacity(est.cells.len());
        for c in &est.cells {
            let v = corners(c).map(|(cx, cy, own)| {
                let vx = vertex(&est.links, cx, cy, own);
                *index.entry((cx, cy, vx.component)).or_insert_with(|| {
                    vertices.push(vx);
                    (vertices.len() - 1) as u32
                })
            });
            cells.push(GridCell { cell: *c, v });
        }
        Grid { reduction, links: est.links, cells, vertices, counts: est.counts }
    }
}

/// The corners of `c` as (corner column, corner row, own quadrant) for TL,
/// TR, BL, BR; corner `(cx, cy)` is the point `(cx − ½, cy − ½)`.
fn corners(c: &Cell) -> [(u32, u32, usize); 4] {
    [(c.x0, c.y0, 3), (c.x1, c.y0, 2), (c.x0, c.y1, 1), (c.x1, c.y1, 0)]
}

/// Rules 2–3: the vertex at corner `(cx, cy)` for the cell whose sample
/// at that corner is quadrant `own` (0 TL `(cx−1, cy−1)`, 1 TR, 2 BL, 3 BR
/// `(cx, cy)`). The own sample must be usable.
pub fn vertex(links: &Links, cx: u32, cy: u32, own: usize) -> GridVertex {
    let (x, y) = (cx as i64, cy as i64);
    let px = [(x - 1, y - 1), (x, y - 1), (x - 1, y), (x, y)];
    let edges = [
        (0, 1, links.joined(x - 1, y - 1, dir::E)),
        (2, 3, links.joined(x - 1, y, dir::E)),
        (0, 2, links.joined(x - 1, y - 1, dir::S)),
        (1, 3, links.joined(x, y - 1, dir::S)),
        (0, 3, links.joined(x - 1, y - 1, dir::SE)),
        (1, 2, links.joined(x, y - 1, dir::SW)),
    ];
    let mut comp = 1u8 << own;
    loop {
        let before = comp;
        for &(a, b, j) in &edges {
            if j && ((comp >> a) & 1 != 0 || (comp >> b) & 1 != 0) {
                comp |= (1 << a) | (1 << b);
            }
        }
        if comp == before {
            break;
        }
    }
    let has = |k: usize| (comp >> k) & 1 != 0;
    let d = |k: usize| links.inv_z[(px[k].1 * links.width as i64 + px[k].0) as usize];
    let centre = |k: usize| DVec2::new(px[k].0 as f64, px[k].1 as f64);
    let corner = DVec2::new(x as f64 - 0.5, y as f64 - 0.5);
    let (inv_z, fetch) = if has(0) && has(3) && has(1) && has(2) {
        (0.25 * (d(0) + d(1) + d(2) + d(3)), corner)
    } else if has(0) && has(3) {
        (0.5 * (d(0) + d(3)), corner)
    } else if has(1) && has(2) {
        (0.5 * (d(1) + d(2)), corner)
    } else if comp.count_ones() == 2 {
        let a = comp.trailing_zeros() as usize;
        let b = 7 - comp.leading_zeros() as usize;
        (0.5 * (d(a) + d(b)), 0.5 * (centre(a) + centre(b)))
    } else {
        (d(own), centre(own))
    };
    GridVertex { pos: corner, inv_z, fetch, component: comp }
}

/// A warped vertex (rule 4).
#[derive(Clone, Copy, Debug)]
struct WarpedVertex {
    pos: DVec2,
    inv_z: f64,
    /// 1/W, and reference coordinates divided by W.
    rw: f64,
    src_w: DVec2,
}

fn warp_vertex(setup: &WarpSetup, v: &GridVertex) -> Option<WarpedVertex> {
    let t = setup.warp(v.pos.x, v.pos.y, v.inv_z);
    let ok = t.w > 0.0 && t.position.is_finite() && t.inv_z.is_finite();
    ok.then(|| {
        let rw = 1.0 / t.w;
        WarpedVertex { pos: t.position, inv_z: t.inv_z, rw, src_w: v.pos * rw }
    })
}

/// Per-frame counters.
#[derive(Clone, Copy, Debug, Default)]
struct Stats {
    drawn: u64,
    vertices: u64,
    split: u64,
    culled: u64,
    folded: u64,
    linear: u64,
    nearest: u64,
    lost: u64,
}

/// What one reference's drawing needs.
struct Ctx<'a> {
    img: &'a SampleImage,
    links: &'a Links,
    setup: &'a WarpSetup,
    source: u8,
}

fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Rule 8: colour at reference coordinates `s` for a fragment of `cell`;
/// true if bilinear.
fn texel(ctx: &Ctx, cell: &Cell, s: DVec2) -> ([f32; 3], bool) {
    let (w, h) = (ctx.links.width as f64, ctx.links.height as f64);
    let (fx, fy) = (s.x.floor(), s.y.floor());
    if fx >= 0.0 && fy >= 0.0 && fx + 1.0 < w && fy + 1.0 < h {
        let (ix, iy) = (fx as i64, fy as i64);
        let l = ctx.links;
        if l.joined(ix, iy, dir::E)
            && l.joined(ix, iy + 1, dir::E)
            && l.joined(ix, iy, dir::S)
            && l.joined(ix + 1, iy, dir::S)
        {
            let (tx, ty) = (s.x - fx, s.y - fy);
            let i = l.index(ix as u32, iy as u32);
            let wd = l.width as usize;
            let c = |k: usize| ctx.img.colour[k].map(|v| v as f64);
            let (c00, c10, c01, c11) = (c(i), c(i + 1), c(i + wd), c(i + wd + 1));
            let mut out = [0.0f32; 3];
            for ch in 0..3 {
                let top = c00[ch] + tx * (c10[ch] - c00[ch]);
                let bottom = c01[ch] + tx * (c11[ch] - c01[ch]);
                out[ch] = (top + ty * (bottom - top)) as f32;
            }
            return (out, true);
        }
    }
    let near =
        |v: f64, lo: u32, hi: u32| if v.is_finite() { v.round().clamp(lo as f64, (hi - 1) as f64) as u32 } else { lo };
    let (nx, ny) = (near(s.x, cell.x0, cell.x1), near(s.y, cell.y0, cell.y1));
    (ctx.img.colour[ctx.links.index(nx, ny)], false)
}

/// Rules 5–8 for one triangle of `cell`.
fn draw_triangle(ctx: &Ctx, cell: &Cell, t: [WarpedVertex; 3], d: &mut DestPlanes, st: &mut Stats) {
    let p = t.map(|v| v.pos);
    let area2 = cross(p[1] - p[0], p[2] - p[0]);
    if !(area2 > 0.0 && area2.is_finite()) {
        st.folded += 1;
        return;
    }
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let clamp = |v: f64, n: u32| v.clamp(-1.0, n as f64) as i64;
    let win: Window = (
        (clamp(lo.x.ceil(), d.width).max(0), clamp(hi.x.floor(), d.width).min(d.width as i64 - 1)),
        (clamp(lo.y.ceil(), d.height).max(0), clamp(hi.y.floor(), d.height).min(d.height as i64 - 1)),
    );
    if win.0.0 > win.0.1 || win.1.0 > win.1.1 {
        return;
    }
    let width = d.width as usize;
    triangle(p, win, |sx, sy, b| {
        let k = sy as usize * width + sx as usize;
        let inv_z = b[0] * t[0].inv_z + b[1] * t[1].inv_z + b[2] * t[2].inv_z;
        let inv_z = inv_z as f32;
        if d.real[k] && inv_z <= d.inv_z[k] {
            st.lost += 1;
            return;
        }
        let rw = b[0] * t[0].rw + b[1] * t[1].rw + b[2] * t[2].rw;
        let s = (t[0].src_w * b[0] + t[1].src_w * b[1] + t[2].src_w * b[2]) / rw;
        let (colour, linear) = texel(ctx, cell, s);
        if linear {
            st.linear += 1;
        } else {
            st.nearest += 1;
        }
        d.real.set(k, true);
        d.colour[k] = colour;
        d.inv_z[k] = inv_z;
        d.source[k] = ctx.source;
    });
}

/// Rules 4–5 for one cell with corner vertices `v` (TL, TR, BL, BR).
fn draw_cell(ctx: &Ctx, cell: &Cell, v: [Option<WarpedVertex>; 4], d: &mut DestPlanes, st: &mut Stats) {
    if let [Some(a), Some(b), Some(c), Some(dd)] = v {
        st.drawn += 1;
        draw_triangle(ctx, cell, [a, b, dd], d, st);
        draw_triangle(ctx, cell, [a, dd, c], d, st);
        return;
    }
    let (w, h) = (cell.x1 - cell.x0, cell.y1 - cell.y0);
    if w == 1 && h == 1 {
        st.culled += 1;
        return;
    }
    st.split += 1;
    let xs =
        if w >= 2 { vec![(cell.x0, cell.x0 + w / 2), (cell.x0 + w / 2, cell.x1)] } else { vec![(cell.x0, cell.x1)] };
    let ys =
        if h >= 2 { vec![(cell.y0, cell.y0 + h / 2), (cell.y0 + h / 2, cell.y1)] } else { vec![(cell.y0, cell.y1)] };
    for &(y0, y1) in &ys {
        for &(x0, x1) in &xs {
            let part = Cell { x0, y0, x1, y1 };
            let v = corners(&part).map(|(cx, cy, own)| {
                st.vertices += 1;
                warp_vertex(ctx.setup, &vertex(ctx.links, cx, cy, own))
            });
            draw_cell(ctx, &part, v, d, st);
        }
    }
}

/// The adaptive grid warp with one reduction (module doc).
#[derive(Clone, Copy, Debug)]
pub struct Schollmeyer {
    /// The quadtree reduction.
    pub reduction: Reduction,
    /// Quadtree knobs.
    pub params: QuadtreeParams,
}

impl Schollmeyer {
    /// The method with `reduction` and the default parameters.
    pub fn new(reduction: Reduction) -> Schollmeyer {
        Schollmeyer { reduction, params: QuadtreeParams::default() }
    }

    /// Rules 4–8: draw `grid` of reference `img` through `setup` into `d`.
    fn draw(&self, grid: &Grid, img: &SampleImage, setup: &WarpSetup, source: u8, d: &mut DestPlanes, st: &mut Stats) {
        let ctx = Ctx { img, links: &grid.links, setup, source };
        let warped: Vec<Option<WarpedVertex>> = grid.vertices.iter().map(|v| warp_vertex(setup, v)).collect();
        st.vertices += warped.len() as u64;
        for gc in &grid.cells {
            let v = gc.v.map(|k| warped[k as usize]);
            draw_cell(&ctx, &gc.cell, v, d, st);
        }
    }
}

impl Reconstruction for Schollmeyer {
    fn info(&self) -> MethodInfo {
        let (name, description, paper) = match self.reduction {
            Reduction::Cross => (
                "schollmeyer-cross",
                "Schollmeyer adaptive grid warp, cross-kernel quadtree: cells as two Z-tested triangles, vertex depth and texture filter by connectedness",
                "000 Schollmeyer et al. TVCG 2017 §4.1.1, §4.1.4, §5.1",
            ),
            Reduction::Partial => (
                "schollmeyer-partial",
                "Schollmeyer adaptive grid warp, partial cross-kernel quadtree (per-side connectedness bits)",
                "000 Schollmeyer et al. TVCG 2017 §4.1.2, §4.1.4, §5.1",
            ),
            Reduction::Irregular => (
                "schollmeyer-irregular",
                "Schollmeyer adaptive grid warp, irregular quadtree (partial cross-kernel plus 2:1 cells)",
                "000 Schollmeyer et al. TVCG 2017 §4.1.3, §4.1.4, §5.1",
            ),
        };
        MethodInfo { name, description, paper, primitive: "cells", default_hole_fill: "low-pass" }
    }

    fn prepare(&self, img: &SampleImage, _ss: u32) -> Prepared {
        Box::new(Grid::new(img, self.reduction, &self.params))
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let mut st = Stats::default();
        let mut grid_counts = GridCounts::default();
        for (j, warp) in input.cmd.warps.iter().enumerate() {
            let grid = input.prepared[j].downcast_ref::<Grid>().expect("prepared by a Schollmeyer reconstruction");
            let c = grid.counts;
            grid_counts.cells += c.cells;
            grid_counts.rects += c.rects;
            grid_counts.single_samples += c.single_samples;
            grid_counts.surface_nodes += c.surface_nodes;
            self.draw(grid, input.refs[j], &warp.setup, j as u8, out, &mut st);
        }
        let mut extra = Map::new();
        for (k, v) in [
            ("grid_cells", grid_counts.cells),
            ("rect_cells", grid_counts.rects),
            ("single_sample_cells", grid_counts.single_samples),
            ("surface_nodes", grid_counts.surface_nodes),
            ("vertices", st.vertices),
            ("split_cells", st.split),
            ("culled_cells", st.culled),
            ("folded_triangles", st.folded),
            ("linear_fragments", st.linear),
            ("nearest_fragments", st.nearest),
            ("depth_lost", st.lost),
        ] {
            extra.insert(k.into(), Value::from(v));
        }
        Counters { primitives: st.drawn, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::test_frames::cam;
    use crate::methods::{Input, NoFill, render};
    use postwarp_rtl::FrameCommands;

    fn image(w: u32, h: u32, depth: impl Fn(u32, u32) -> Option<f32>) -> SampleImage {
        crate::methods::test_frames::image(w, h, |x, y| ((x * 7 + y * 3) % 5) as f32 / 5.0, depth)
    }

    fn run(m: &Schollmeyer, cmd: &FrameCommands, refs: &[&SampleImage]) -> crate::methods::MethodFrame {
        run_with(m, &NoFill, cmd, refs)
    }

    fn run_with(
        m: &Schollmeyer,
        fill: &dyn crate::methods::HoleFill,
        cmd: &FrameCommands,
        refs: &[&SampleImage],
    ) -> crate::methods::MethodFrame {
        let prepared: Vec<Prepared> = refs.iter().map(|r| m.prepare(r, cmd.supersample)).collect();
        let p: Vec<&Prepared> = prepared.iter().collect();
        let input = Input { cmd, refs, prepared: &p };
        render(m, fill, &input, input.empty_frame())
    }

    #[test]
    fn identity_warp_reproduces_the_reference() {
        // Two layers and a slanted region, some samples without a surface.
        let c = cam(16, 12, 0.0);
        let img = image(32, 24, |x, y| {
            if (x * 5 + y * 11) % 37 == 0 {
                None
            } else if (8..14).contains(&x) {
                Some(2.0)
            } else {
                Some(1.0 / (0.1 + 0.002 * x as f32 + 0.001 * y as f32))
            }
        });
        let cmd = FrameCommands::new(0, c, 2, &[(0, c)]);
        for r in Reduction::ALL {
            let f = run(&Schollmeyer::new(r), &cmd, &[&img]);
            assert_eq!(f.samples.real, img.valid, "{r:?}");
            for i in img.valid.iter_ones() {
                for ch in 0..3 {
                    assert!((f.samples.colour[i][ch] - img.colour[i][ch]).abs() < 1e-5, "{r:?} sample {i}");
                }
                // Exact inside surfaces; next to a missing sample a corner
                // fetches its depth half a sample away (rule 3): at most
                // half a sample's change of 1/Z (1 % here).
                assert!((f.samples.inv_z[i] * img.z[i] - 1.0).abs() < 0.011, "{r:?} sample {i}");
            }
        }
    }

    #[test]
    fn vertices_are_shared_inside_a_surface() {
        let img = image(8, 8, |x, y| Some(1.0 / (0.2 + 0.01 * x as f32 + 0.02 * y as f32)));
        let links = Links::new(&img, 0.01);
        // Corner (3, 3): all four joined, every quadrant gets the same vertex.
        let v = (0..4).map(|q| vertex(&links, 3, 3, q)).collect::<Vec<_>>();
        assert!(v.iter().all(|x| *x == v[0]) && v[0].component == 15);
        let want = 0.2 + 0.01 * 2.5 + 0.02 * 2.5;
        assert!((v[0].inv_z - want).abs() < 1e-6, "{}", v[0].inv_z);
        // Image corner: a single sample.
        assert!(vertex(&links, 0, 0, 3).on_pixel());
    }

    #[test]
    fn behind_the_camera_and_tiny_images_do_not_panic() {
        // Derived camera 3 units ahead: the layer at Z = 2 is behind it.
        let c = cam(4, 3, 0.0);
        let mut ahead = c;
        ahead.pose.position.z = 3.0;
        for (w, h) in [(1, 1), (1, 3), (3, 1), (4, 3)] {
            let c = cam(w, h, 0.0);
            let img = image(w, h, |x, _| (x % 2 == 0).then_some(if x == 0 { 2.0 } else { 5.0 }));
            for derived in [c, ahead, cam(w, h, 0.3)] {
                let cmd = FrameCommands::new(0, derived, 1, &[(0, c), (1, c)]);
                for r in Reduction::ALL {
                    let _ = run(&Schollmeyer::new(r), &cmd, &[&img, &img]);
                    let f = run_with(
                        &Schollmeyer::new(r),
                        &crate::methods::schollmeyer::low_pass_fill::LowPass,
                        &cmd,
                        &[&img, &img],
                    );
                    // Every hole is filled unless nothing real was drawn.
                    let empty = (0..f.samples.len()).filter(|&i| !f.samples.real[i] && !f.samples.hole[i]).count();
                    assert!(empty == 0 || f.samples.real.not_any(), "{r:?} {w}x{h}: {empty} empty");
                }
            }
        }
    }
}
