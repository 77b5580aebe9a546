//! General reconstruction (TR98 §7.1, Fig. 8): the interior of each surface
//! is a triangle mesh whose vertices are the warped reference samples, with
//! colour and 1/Z interpolated in the derived image; samples at surface
//! edges add a flat *edge splat* so that the mesh's half-sample shave at
//! every edge (Plate 3a) does not happen. Selected by
//! [`Reconstruction::General`](super::config::Reconstruction::General);
//! works at any super-sampling factor (TR98 uses it without).
//!
//! Rules:
//! 1. Warp, culling, discontinuity test and 2x2 groups are those of the
//!    anti-aliased path (`transform`, `kernel_setup::group`): a group is
//!    *meshed* iff it is [`GroupState::Shared`] (all four samples warped,
//!    all six pairs one surface, not folded).
//! 2. Mesh: a meshed group with samples A (x, y), B (x+1, y), C (x, y+1),
//!    D (x+1, y+1) is split along the fixed diagonal A–D into triangles
//!    (A, B, D) and (A, D, C). Both keep the reference winding (positive
//!    `cross(v1 − v0, v2 − v0)` in derived coordinates, y down), since a
//!    meshed quad is convex and not folded.
//! 3. Triangle coverage, top-left rule: centre `p` is inside iff every edge
//!    function `E(u→v, p) = cross(v − u, p − u)` is positive, or zero on a
//!    *top-left* edge, i.e. one with direction `d = v − u` having `d.y < 0`,
//!    or `d.y = 0` and `d.x > 0`. Each edge function is evaluated from the
//!    edge's endpoints in a canonical order (lexicographic by (x, y)) and
//!    negated for the other direction, so the two triangles sharing an edge
//!    see exactly opposite values: a centre on a shared edge or vertex is
//!    covered exactly once, no cracks, no double coverage.
//! 4. Interpolation, in the derived image (screen space): barycentric
//!    weights `w_k = E_k / ΣE` of the three vertices give colour, 1/Z and
//!    the hole-fill colour (each vertex's own colour, or its forward-edge
//!    neighbour's, `frame` rule 4). The interpolation starts from the
//!    vertex with the largest weight (`c_b + Σ w_k·(c_k − c_b)`), so a
//!    centre on a vertex gets that vertex's values exactly. The candidate's
//!    slopes are the triangle's screen gradient of 1/Z; its better mask is
//!    the AND of the three vertices' masks (another reference is better for
//!    the triangle only if it is better for every vertex).
//! 5. Edge samples: a warped sample is an edge sample iff one of the four
//!    2x2 groups it belongs to is not meshed (outside the image, a sample
//!    missing or culled, a pair failing the discontinuity test, or folded).
//!    This contains TR98's definition (a discontinuity between the sample
//!    and one of its 8 neighbours, or a missing neighbour, including the
//!    image border) and adds samples next to a fold-over or to a
//!    discontinuity between two of their neighbours, so that every unmeshed
//!    quad is covered by its corners' splats.
//! 6. Edge splat: the quadrilateral of the sample's four exact splat
//!    corners (`WarpContext::edge_corner`; a corner behind the derived
//!    camera is replaced by the warped sample), in reference order A, B,
//!    D, C. If it is convex and keeps the reference winding it is
//!    rasterized as the two triangles (A, B, D), (A, D, C) under rule 3;
//!    otherwise (folded, degenerate) its axis-aligned bounding box is drawn
//!    half-open (`raster` rule 1). Flat colour, the sample's warped 1/Z and
//!    derived slopes, its better mask, its hole-fill colour.
//! 7. Splat size: the splat's centre ranges (before the image) form its
//!    kernel size, recorded in the kernel histogram; one wider or taller
//!    than `kernel_limit` is over limit (counted) and, with
//!    [`OverLimit::Clip`], drawn only inside the `kernel_limit`-wide window
//!    of centres around the warped sample (`raster::clip`). Mesh triangles
//!    are never clipped.
//! 8. Suppression (TR98 §7.1): an edge splat is not drawn (counted) when
//!    (a) the surface is poorly sampled, footprint `|det J| >`
//!    [`POOR_FOOTPRINT`] derived samples per reference sample (density
//!    below 1/2; `transform` rule 6), and (b) another reference samples it
//!    better (its better mask is not zero).
//! 9. Compositing: mesh candidates are [`Kind::Mesh`], splats
//!    [`Kind::Splat`]; `composite` rule 5 (a splat never overwrites a mesh
//!    sample at the same depth, a mesh sample replaces a splat) sets the
//!    mesh/splat bit. The bit is a memory plane kept across the frame's
//!    warps, but the A-buffer does not hold it: when the frame goes through
//!    the A-buffer at ss > 1 it is cleared (`frame` rule 3), and every
//!    stored sample then counts as mesh for the next reference.
//! 10. Order (ties): samples are visited in the warp order of the
//!     anti-aliased path (reverse eight-sheet by default). At each sample,
//!     first the meshed groups whose last vertex (in that order) it is, in
//!     the order of their top-left sample (x−1, y−1), (x, y−1), (x−1, y),
//!     (x, y), each as (A, B, D) then (A, D, C); then its edge splat. Within
//!     a primitive, centres are visited row by row.
//!
//! Not modelled: the back-projection check of a suppressed splat against
//! the better reference (TR98 leaves it out as too expensive: when that
//! reference does not see the surface, the edge is shaved); perspective-
//! correct interpolation (TR98 interpolates linearly in the derived image);
//! the hardware's rasterizer, vertex buffering and timing.

use super::composite::{Candidate, Kind, composite};
use super::config::{GoldenConfig, OverLimit, WarpOrder};
use super::frame::{GoldenStats, KERNEL_HIST_MAX, count_outcome, forward_edge_neighbour};
use super::kernel_setup::{GroupState, bounding_box, folded, group};
use super::planes::DestPlanes;
use super::raster::{clip, covered};
use super::transform::{BATCH, SampleBatch, Transformed, WarpContext};
use super::traversal;
use glam::DVec2;
use postwarp_rtl::SampleImage;

/// Rule 8: footprint (derived samples per reference sample) above which a
/// surface is poorly sampled (density below 1/2 of the nominal 1.0).
pub const POOR_FOOTPRINT: f64 = 2.0;

/// A group that is not meshed, in the table of which sample draws each.
const NOT_MESHED: u8 = u8::MAX;

/// Switches for experiments and tests; the model is both on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeneralOptions {
    /// Draw edge splats (rules 5–8); off: mesh only, TR98's earlier system.
    pub edge_splats: bool,
    /// Suppress edge splats on poorly sampled surfaces (rule 8).
    pub suppression: bool,
}

impl Default for GeneralOptions {
    fn default() -> Self {
        GeneralOptions { edge_splats: true, suppression: true }
    }
}

/// Inclusive ranges of sample centres `((x0, x1), (y0, y1))` to scan.
pub type Window = ((i64, i64), (i64, i64));

/// Warp one reference into `d` with the general reconstruction.
pub fn warp_reference_general(
    ctx: &WarpContext,
    img: &SampleImage,
    source: u8,
    cfg: &GoldenConfig,
    d: &mut DestPlanes,
    st: &mut GoldenStats,
) {
    warp_reference_general_with(ctx, img, source, cfg, &GeneralOptions::default(), d, st);
}

/// [`warp_reference_general`] with explicit switches.
pub fn warp_reference_general_with(
    ctx: &WarpContext,
    img: &SampleImage,
    source: u8,
    cfg: &GoldenConfig,
    opts: &GeneralOptions,
    d: &mut DestPlanes,
    st: &mut GoldenStats,
) {
    if st.kernel_sizes.len() <= KERNEL_HIST_MAX {
        st.kernel_sizes = vec![vec![0; KERNEL_HIST_MAX + 1]; KERNEL_HIST_MAX + 1];
    }
    let (w, h) = (img.width, img.height);
    let warped = warp_all(ctx, img);
    let valid = img.valid.count_ones() as u64;
    st.reference_samples += valid;
    st.culled_samples += valid - warped.iter().filter(|t| t.is_some()).count() as u64;

    // Rule 1: meshed groups, indexed by their top-left sample.
    let gw = w.saturating_sub(1);
    let mut meshed = vec![false; (gw * h.saturating_sub(1)) as usize];
    for gy in 0..h.saturating_sub(1) {
        for gx in 0..gw {
            let state = group(|x, y| warped[(y * w + x) as usize], gx, gy, cfg.threshold).0;
            match state {
                GroupState::Discontinuous => st.discontinuous_groups += 1,
                GroupState::Folded => st.folded_groups += 1,
                _ => {}
            }
            meshed[(gy * gw + gx) as usize] = state == GroupState::Shared;
        }
    }
    let is_meshed = |gx: i64, gy: i64| {
        gx >= 0 && gy >= 0 && gx < gw as i64 && gy + 1 < h as i64 && meshed[(gy as u32 * gw + gx as u32) as usize]
    };

    // Per warped sample: better mask and hole-fill colour (frame rule 4).
    let better = better_masks(ctx, img, &warped);
    let mut fill = vec![[0.0f32; 3]; img.len()];
    for (i, t) in warped.iter().enumerate() {
        let Some(t) = t else { continue };
        let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
        fill[i] = match forward_edge_neighbour(ctx, img, |x, y| warped[(y * w + x) as usize], t, x, y, cfg.threshold) {
            Some(k) => {
                st.forward_edges += 1;
                img.colour[k]
            }
            None => img.colour[i],
        };
    }

    let order = if cfg.warp_order == WarpOrder::Reverse {
        traversal::warp_order(w, h, &ctx.setup.epipole_reference)
    } else {
        traversal::order(w, h, &ctx.setup.epipole_reference)
    };
    let mut rank = vec![0u32; img.len()];
    for (k, &(x, y)) in order.iter().enumerate() {
        rank[img.index(x, y)] = k as u32;
    }
    // Rule 10: per meshed group, which of its samples (0–3: A, B, C, D)
    // comes last in the order and so draws it; [`NOT_MESHED`] otherwise.
    // Found in raster order here, so that the walk in warp order reads a
    // byte per group instead of four ranks.
    let mut last = vec![NOT_MESHED; meshed.len()];
    for gy in 0..h.saturating_sub(1) {
        for gx in 0..gw {
            let g = (gy * gw + gx) as usize;
            if meshed[g] {
                let quad = [img.index(gx, gy), img.index(gx + 1, gy), img.index(gx, gy + 1), img.index(gx + 1, gy + 1)];
                // Ranks are distinct: one sample is last.
                last[g] = (0..4).max_by_key(|&c| rank[quad[c]]).expect("four corners") as u8;
            }
        }
    }
    drop(rank);

    let size = (d.width, d.height);
    for &(x, y) in &order {
        let i = img.index(x, y);
        let Some(t) = warped[i] else { continue };
        let (xi, yi) = (x as i64, y as i64);
        // Rule 10: the meshed groups this sample completes (it is corner
        // D, C, B and A of these four).
        for (corner, (gx, gy)) in [(xi - 1, yi - 1), (xi, yi - 1), (xi - 1, yi), (xi, yi)].into_iter().enumerate() {
            if !is_meshed(gx, gy) || last[(gy as u32 * gw + gx as u32) as usize] != 3 - corner as u8 {
                continue;
            }
            let (gx, gy) = (gx as u32, gy as u32);
            let quad = [img.index(gx, gy), img.index(gx + 1, gy), img.index(gx, gy + 1), img.index(gx + 1, gy + 1)];
            let [a, b, c, dd] = quad;
            for tri in [[a, b, dd], [a, dd, c]] {
                st.mesh_triangles += 1;
                mesh_triangle(tri, &warped, img, &better, &fill, source, cfg, d, st);
            }
        }
        // Rules 5–8: the edge splat.
        let edge = [(xi - 1, yi - 1), (xi, yi - 1), (xi - 1, yi), (xi, yi)].iter().any(|&(gx, gy)| !is_meshed(gx, gy));
        if !(edge && opts.edge_splats) {
            continue;
        }
        let inv_z = 1.0 / img.z[i] as f64;
        let (xf, yf) = (x as f64, y as f64);
        if opts.suppression && better[i] != 0 && ctx.footprint(xf, yf, inv_z, img.inv_z_slopes[i]) > POOR_FOOTPRINT {
            st.suppressed_splats += 1;
            continue;
        }
        st.edge_splats += 1;
        st.edge_corners += 4;
        let corner = |sx: f64, sy: f64| ctx.edge_corner(xf, yf, inv_z, img.inv_z_slopes[i], sx, sy).unwrap_or(t.pos);
        let (ca, cb, cc, cd) = (corner(-1.0, -1.0), corner(1.0, -1.0), corner(-1.0, 1.0), corner(1.0, 1.0));
        let slopes = ctx.dest_slopes(xf, yf, inv_z, img.inv_z_slopes[i]);
        let cand = Candidate {
            colour: img.colour[i],
            inv_z: t.inv_z as f32,
            slopes: [slopes[0] as f32, slopes[1] as f32],
            source,
            better: better[i],
            fill_colour: fill[i],
            kind: Kind::Splat,
        };
        let quad_ok = !folded(ca, cb, cc, cd);
        let (x0, x1, y0, y1) = bounding_box(&[ca, cb, cc, cd]);
        // Rule 6: the quad's closed centre ranges, or the box's half-open ones.
        let (rx, ry) = if quad_ok {
            ((x0.ceil() as i64, x1.floor() as i64), (y0.ceil() as i64, y1.floor() as i64))
        } else {
            (covered(x0, x1), covered(y0, y1))
        };
        // Rule 7.
        let len = |r: (i64, i64)| (r.1 - r.0 + 1).max(0) as usize;
        let (kw, kh) = (len(rx), len(ry));
        st.kernel_sizes[kw.min(KERNEL_HIST_MAX)][kh.min(KERNEL_HIST_MAX)] += 1;
        let over = kw > cfg.kernel_limit as usize || kh > cfg.kernel_limit as usize;
        st.kernels_over_limit += over as u64;
        let (rx, ry) = match cfg.over_limit {
            OverLimit::Clip => (clip(rx, t.pos.x, cfg.kernel_limit), clip(ry, t.pos.y, cfg.kernel_limit)),
            OverLimit::Allow => (rx, ry),
        };
        let win = intersect((rx, ry), size);
        let mut put = |sx: u32, sy: u32| {
            let k = (sy * d.width + sx) as usize;
            count_outcome(st, composite(d, k, &cand, cfg.slope_tol, cfg.rel_tol));
        };
        if quad_ok {
            for tri in [[ca, cb, cd], [ca, cd, cc]] {
                triangle(tri, win, |sx, sy, _| put(sx, sy));
            }
        } else {
            for sy in win.1.0..=win.1.1 {
                for sx in win.0.0..=win.0.1 {
                    put(sx as u32, sy as u32);
                }
            }
        }
    }
}

/// Every sample warped ([`WarpContext::transform`]; `None` where invalid,
/// behind the derived camera or not finite), a row at a time in batches
/// (`transform_batch`: the same operations; the fixed mode's warp one
/// sample at a time).
fn warp_all(ctx: &WarpContext, img: &SampleImage) -> Vec<Option<Transformed>> {
    let (w, h) = (img.width as usize, img.height as usize);
    if ctx.fixed().is_some() {
        return (0..img.len())
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                img.valid[i].then(|| ctx.transform(x, y, 1.0 / img.z[i] as f64)).flatten()
            })
            .collect();
    }
    let mut out = Vec::with_capacity(img.len());
    let (mut inv_z, mut warp, mut ok) = ([0.0; BATCH], [[0.0; 4]; BATCH], [false; BATCH]);
    for y in 0..h {
        for x0 in (0..w).step_by(BATCH) {
            let (i0, m) = (y * w + x0, (w - x0).min(BATCH));
            for (v, &z) in inv_z[..m].iter_mut().zip(&img.z[i0..i0 + m]) {
                *v = 1.0 / z as f64;
            }
            ctx.transform_batch(x0 as f64, y as f64, &inv_z[..m], &mut warp[..m], &mut ok[..m]);
            for k in 0..m {
                let [px, py, inv_z, e] = warp[k];
                let t = Transformed { pos: DVec2::new(px, py), inv_z, e, sat: 0 };
                out.push((img.valid[i0 + k] & ok[k]).then_some(t));
            }
        }
    }
    out
}

/// Every warped sample's better-reference mask
/// ([`WarpContext::better_mask`]; 0 where not warped), a row at a time in
/// batches (`better_mask_batch`: the same operations).
fn better_masks(ctx: &WarpContext, img: &SampleImage, warped: &[Option<Transformed>]) -> Vec<u32> {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut out = vec![0u32; img.len()];
    let mut batch = Box::<SampleBatch>::default();
    for y in 0..h {
        for x0 in (0..w).step_by(BATCH) {
            let (i0, m) = (y * w + x0, (w - x0).min(BATCH));
            for k in 0..m {
                let i = i0 + k;
                batch.x[k] = (x0 + k) as f64;
                batch.y[k] = y as f64;
                batch.inv_z[k] = 1.0 / img.z[i] as f64;
                batch.sx[k] = img.inv_z_slopes[i][0] as f64;
                batch.sy[k] = img.inv_z_slopes[i][1] as f64;
            }
            let masks = &mut out[i0..i0 + m];
            ctx.better_mask_batch(&mut batch, masks);
            for (mask, t) in masks.iter_mut().zip(&warped[i0..i0 + m]) {
                *mask = if t.is_some() { *mask } else { 0 };
            }
        }
    }
    out
}

/// Rasterize and composite one mesh triangle (rules 2–4); `tri` holds the
/// reference sample indices of its vertices.
#[allow(clippy::too_many_arguments)]
fn mesh_triangle(
    tri: [usize; 3],
    warped: &[Option<Transformed>],
    img: &SampleImage,
    better: &[u32],
    fill: &[[f32; 3]],
    source: u8,
    cfg: &GoldenConfig,
    d: &mut DestPlanes,
    st: &mut GoldenStats,
) {
    let t = tri.map(|k| warped[k].expect("meshed groups have warped vertices"));
    let p = t.map(|t| t.pos);
    let z = t.map(|t| t.inv_z);
    let area2 = cross(p[1] - p[0], p[2] - p[0]);
    if !(area2 > 0.0 && area2.is_finite()) {
        return;
    }
    let (x0, x1, y0, y1) = bounding_box(&[p[0], p[1], p[2], p[2]]);
    let win =
        intersect(((x0.ceil() as i64, x1.floor() as i64), (y0.ceil() as i64, y1.floor() as i64)), (d.width, d.height));
    if win.0.0 > win.0.1 || win.1.0 > win.1.1 {
        return; // no centre in the box (most triangles of a minified surface)
    }
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let grad =
        DVec2::new((z[1] - z[0]) * e2.y - (z[2] - z[0]) * e1.y, (z[2] - z[0]) * e1.x - (z[1] - z[0]) * e2.x) / area2;
    let slopes = [grad.x as f32, grad.y as f32];
    let mask = better[tri[0]] & better[tri[1]] & better[tri[2]];
    let colour = tri.map(|k| img.colour[k]);
    let fills = tri.map(|k| fill[k]);
    triangle(p, win, |sx, sy, wts| {
        // The vertex of largest weight (the first of equals), then the
        // other two in index order.
        let mut b = 0;
        if wts[1] > wts[0] {
            b = 1;
        }
        if wts[2] > wts[b] {
            b = 2;
        }
        let (k1, k2) = match b {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let lerp3 = |v: [f64; 3]| v[b] + [wts[k1] * (v[k1] - v[b]), wts[k2] * (v[k2] - v[b])].into_iter().sum::<f64>();
        let rgb = |c: [[f32; 3]; 3]| {
            let channel = |i: usize| lerp3([c[0][i] as f64, c[1][i] as f64, c[2][i] as f64]) as f32;
            [channel(0), channel(1), channel(2)]
        };
        let cand = Candidate {
            colour: rgb(colour),
            inv_z: lerp3(z) as f32,
            slopes,
            source,
            better: mask,
            fill_colour: rgb(fills),
            kind: Kind::Mesh,
        };
        let k = (sy * d.width + sx) as usize;
        count_outcome(st, composite(d, k, &cand, cfg.slope_tol, cfg.rel_tol));
    });
}

fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Clip a window to a `width x height` image (may become empty).
fn intersect(win: Window, size: (u32, u32)) -> Window {
    let ((x0, x1), (y0, y1)) = win;
    ((x0.max(0), x1.min(size.0 as i64 - 1)), (y0.max(0), y1.min(size.1 as i64 - 1)))
}

/// Rule 3's tie-break: the edge `u→v` owns the centres on it.
fn top_left(u: DVec2, v: DVec2) -> bool {
    let d = v - u;
    d.y < 0.0 || (d.y == 0.0 && d.x > 0.0)
}

/// Visit the sample centres of `win` inside triangle `v` (positive
/// winding, rule 2) under the top-left rule (rule 3), with their
/// barycentric weights (rule 4). Triangles of zero, negative or non-finite
/// area cover nothing.
pub fn triangle(v: [DVec2; 3], win: Window, mut f: impl FnMut(u32, u32, [f64; 3])) {
    let area2 = cross(v[1] - v[0], v[2] - v[0]);
    if !(area2 > 0.0 && area2.is_finite()) {
        return;
    }
    // Edge k is opposite vertex k: (v1→v2), (v2→v0), (v0→v1).
    let edges = [(v[1], v[2]), (v[2], v[0]), (v[0], v[1])];
    let owns = edges.map(|(u, w)| top_left(u, w));
    // An edge's canonical order depends on its endpoints only: chosen once.
    let [e0, e1, e2] = edges.map(|(u, w)| Edge::new(u, w));
    let inside = |e: f64, owns: bool| e > 0.0 || (e == 0.0 && owns);
    let ((x0, x1), (y0, y1)) = win;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let p = DVec2::new(x as f64, y as f64);
            let (a, b, c) = (e0.at(p), e1.at(p), e2.at(p));
            if inside(a, owns[0]) && inside(b, owns[1]) && inside(c, owns[2]) {
                let sum = a + b + c;
                f(x as u32, y as u32, [a / sum, b / sum, c / sum]);
            }
        }
    }
}

/// Edge function `cross(v − u, p − u)`, evaluated from the endpoints in
/// canonical order so that the edge `u→v` gives exactly the negation of
/// `v→u` (rule 3); the order is fixed once per triangle.
#[derive(Clone, Copy)]
struct Edge {
    a: DVec2,
    b: DVec2,
    sign: f64,
}

impl Edge {
    fn new(u: DVec2, v: DVec2) -> Edge {
        let (a, b, sign) = if (u.x, u.y) <= (v.x, v.y) { (u, v, 1.0) } else { (v, u, -1.0) };
        Edge { a, b, sign }
    }

    /// The edge function at `p`.
    #[inline(always)]
    fn at(&self, p: DVec2) -> f64 {
        let (a, b) = (self.a, self.b);
        self.sign * ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batched_warps_and_masks_give_the_per_sample_forms_bits() {
        use crate::golden::transform::{scrambled_context, unit_random};
        use glam::{DQuat, DVec3};
        use postwarp_rtl::{Camera, Intrinsics, Pose};
        // Rows wider than a batch (a whole one and a partial one), a
        // rotated and shifted derived camera, three centres; some samples
        // invalid, some behind the derived camera, some at infinity.
        let (w, h) = (300u32, 7u32);
        let ctx = scrambled_context(Camera {
            intrinsics: Intrinsics { width: w, height: h, fx: 180.0, fy: 180.0, cx: 149.5, cy: 3.5 },
            pose: Pose { position: DVec3::ZERO, orientation: DQuat::IDENTITY },
        });
        let mut img = SampleImage::empty(w, h);
        let mut next = unit_random(0x9e3779b97f4a7c15);
        for i in 0..img.len() {
            img.valid.set(i, next() > 0.1);
            img.z[i] = if next() < 0.03 { f32::INFINITY } else { (0.3 + next() * 20.0) as f32 };
            img.inv_z_slopes[i] = [((next() - 0.5) * 0.2) as f32, ((next() - 0.5) * 0.2) as f32];
        }
        let warped = warp_all(&ctx, &img);
        let masks = better_masks(&ctx, &img, &warped);
        let bits = |t: &Option<Transformed>| t.map(|t| [t.pos.x, t.pos.y, t.inv_z, t.e].map(f64::to_bits));
        let (mut some, mut set) = (0, 0);
        for i in 0..img.len() {
            let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
            let want = if img.valid[i] { ctx.transform(x, y, 1.0 / img.z[i] as f64) } else { None };
            assert_eq!(bits(&warped[i]), bits(&want), "sample {i}");
            let mask = want.map_or(0, |_| ctx.better_mask(x, y, 1.0 / img.z[i] as f64, img.inv_z_slopes[i]));
            assert_eq!(masks[i], mask, "sample {i}");
            some += want.is_some() as usize;
            set += (mask != 0) as usize;
        }
        assert!(some > img.len() / 2 && some < img.len(), "samples warped and not: {some}");
        assert!(set > 0 && set < some, "masks set and clear: {set}");
    }

    fn cover(tris: &[[DVec2; 3]], n: i64) -> Vec<u32> {
        let mut hits = vec![0u32; (n * n) as usize];
        for &t in tris {
            triangle(t, ((0, n - 1), (0, n - 1)), |x, y, w| {
                assert!(w.iter().all(|&c| c >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{w:?}");
                hits[(y as i64 * n + x as i64) as usize] += 1;
            });
        }
        hits
    }

    fn v(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    #[test]
    fn top_left_rule_on_a_unit_grid() {
        // Quads on the sample centres themselves: every shared edge and
        // vertex passes through centres. Split per rule 2, each centre of
        // the mesh's interior is covered exactly once; the top and left
        // borders are owned, the bottom and right ones are not.
        let n = 6;
        let mut tris = Vec::new();
        for gy in 0..n - 1 {
            for gx in 0..n - 1 {
                let (a, b, c, d) = (
                    v(gx as f64, gy as f64),
                    v(gx as f64 + 1.0, gy as f64),
                    v(gx as f64, gy as f64 + 1.0),
                    v(gx as f64 + 1.0, gy as f64 + 1.0),
                );
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        let hits = cover(&tris, n);
        for y in 0..n {
            for x in 0..n {
                let want = (x < n - 1 && y < n - 1) as u32;
                assert_eq!(hits[(y * n + x) as usize], want, "({x},{y})");
            }
        }
    }

    #[test]
    fn a_perturbed_mesh_has_no_cracks_and_no_double_coverage() {
        // A 9x9 vertex grid with spacing 1.3, jittered deterministically;
        // centres strictly inside the mesh's outline are covered once.
        let n = 9usize;
        let jitter = |k: usize| (((k * 7919 + 13) % 101) as f64 / 101.0 - 0.5) * 0.5;
        let p: Vec<DVec2> =
            (0..n * n).map(|k| v((k % n) as f64 * 1.3 + jitter(k), (k / n) as f64 * 1.3 + jitter(k + 57))).collect();
        let mut tris = Vec::new();
        for gy in 0..n - 1 {
            for gx in 0..n - 1 {
                let (a, b, c, d) = (p[gy * n + gx], p[gy * n + gx + 1], p[(gy + 1) * n + gx], p[(gy + 1) * n + gx + 1]);
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        let size = 12;
        let hits = cover(&tris, size);
        assert!(hits.iter().all(|&h| h <= 1), "double coverage");
        // Inside the outline: from the largest jittered border coordinate in
        // to the smallest far one.
        for y in 1..10 {
            for x in 1..10 {
                assert_eq!(hits[(y * size + x) as usize], 1, "crack at ({x},{y})");
            }
        }
    }

    #[test]
    fn shared_edge_between_triangles_from_floating_point_positions() {
        // A diagonal through centres, computed from inexact coordinates: the
        // two triangles on either side share the centres exactly once.
        let (a, b) = (v(0.1 * 3.0 - 1.3, -1.0), v(5.000000000000001, 5.0));
        let tris = [[a, v(5.5, -1.5), b], [a, b, v(-1.5, 5.5)]];
        let hits = cover(&tris, 5);
        for y in 0..5 {
            for x in 0..5 {
                assert_eq!(hits[y * 5 + x], 1, "({x},{y})");
            }
        }
    }

    #[test]
    fn barycentric_weights_interpolate_linearly() {
        let mut seen = 0;
        triangle([v(0.0, 0.0), v(4.0, 0.0), v(0.0, 4.0)], ((0, 4), (0, 4)), |x, y, w| {
            // Weight of vertex 1 is x/4, vertex 2 is y/4.
            assert!((w[1] - x as f64 / 4.0).abs() < 1e-12 && (w[2] - y as f64 / 4.0).abs() < 1e-12);
            seen += 1;
        });
        // Centres with x + y < 4, plus the owned part of the hypotenuse (none: it is a bottom-right edge).
        assert_eq!(seen, 10);
        let mut none = 0;
        triangle([v(0.0, 0.0), v(0.0, 4.0), v(4.0, 0.0)], ((0, 4), (0, 4)), |_, _, _| none += 1);
        assert_eq!(none, 0, "a back-facing triangle covers nothing");
    }
}
