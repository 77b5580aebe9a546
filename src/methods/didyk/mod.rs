//! Didyk et al.'s adaptive grid warping (seed 002, Didyk, Ritschel,
//! Eisemann, Myszkowski, Seidel, "Adaptive Image-space Stereo View
//! Synthesis", VMV 2010, §3.2–3.4) as two reconstructions:
//!
//! - `didyk`: the single-image form (§3.2–3.3): one reference, the first of
//!   the frame's warps, warped as an adaptive grid of textured quads.
//! - `didyk-2ref`: the multiple-image form (§3.4): every reference of the
//!   frame is warped on its own, and the results are blended per derived
//!   sample with the paper's preference weights.
//!
//! Job: turn the leaf cells of the adaptive grid (`grid.rs`) into
//! quads, warp their corners with the 3D warp, draw them textured from the
//! reference with a depth test, and (second form) merge the references.
//!
//! Rules:
//! 1. Grid vertices lie between samples (§3.3): vertex `(vx, vy)`, for
//!    `0 <= vx <= width`, `0 <= vy <= height`, sits at reference position
//!    `(vx − 0.5, vy − 0.5)`, the corner shared by samples `(vx−1 | vx,
//!    vy−1 | vy)`. Its depth is that of the *nearest* of those (up to four)
//!    samples with a surface, i.e. the largest 1/Z ("use depth and disparity
//!    from the pixel with the smallest depth"), so quads next to a
//!    disocclusion stretch across it. This depends on the reference only and
//!    is [`Reconstruction::prepare`]'s job ([`VertexDepths`]).
//! 2. The min/max disparity MIP-map and the subdivision depend on the
//!    derived camera too, so they are built per frame and per reference
//!    inside the timed reconstruction (the paper excludes computing the
//!    disparity map from its timings; we do not).
//! 3. Each leaf cell `[x0, x1) x [y0, y1)` becomes the quad of vertices
//!    `(x0, y0)`, `(x1, y0)`, `(x0, y1)`, `(x1, y1)`. Each vertex is warped
//!    with `WarpSetup::warp` at its position and depth. A quad with a vertex
//!    behind the derived camera (`W <= 0`) or at a non-finite position is
//!    culled (near-plane clipping is not modelled); every other quad is
//!    drawn and counted as a primitive.
//! 4. A quad is drawn as the two triangles `(x0,y0)(x1,y0)(x1,y1)` and
//!    `(x0,y0)(x1,y1)(x0,y1)` with `golden::general::triangle` (sample
//!    centres, top-left rule), back-facing triangles included (their vertex
//!    order is reversed; a GPU drawing the warped grid does not cull).
//!    Texture coordinates (reference sample position) and derived 1/Z are
//!    interpolated linearly in derived image space with the barycentric
//!    weights (the affine interpolation of a 2D quad drawn with `w = 1`;
//!    1/Z is exact on planes).
//! 5. Texture lookup ([`TextureFilter`], default bilinear, the GPU's
//!    filtered fetch of `I_left`): the four reference samples around the
//!    texture coordinate, clamped to the image, with the fractional
//!    weights rounded to 1/256 (the 8 bits of sub-texel precision of GPU
//!    filtering; it also makes an exact integer shift exact); samples
//!    without a surface get weight 0 and the others are renormalised (the
//!    paper's images have a surface everywhere). Nearest: the sample
//!    nearest the coordinate, clamped to the quad's own cell.
//! 6. Depth test within one reference (§3.2, "standard GPU depth
//!    buffering"): a sample is written when nothing of this reference is
//!    there yet or its 1/Z is strictly larger; cells are drawn in the grid's
//!    order (which decides exact ties only).
//! 7. `didyk` writes the first reference's result into the derived frame
//!    (source 0).
//! 8. `didyk-2ref` (§3.4): every reference `j` is drawn into a layer of its
//!    own (rules 3–6). Each quad carries the preference `w` of its warp: the
//!    paper prefers a mapping whose quad does not "undergo varying
//!    stretching" but gives no formula; ours is `w = (r_min / r_max)^p`
//!    where `r` is the ratio warped length / reference length of each of the
//!    quad's four edges and `p` = `preference_power`. An unstretched (or
//!    uniformly scaled, or rotated) quad has `w = 1`; a quad torn across a
//!    disocclusion has `w` near 0. A derived sample covered by several
//!    layers takes `Σ w_j·colour_j / Σ w_j` (the paper's
//!    `I = (w(f)·I_f + w(g)·I_g) / (w(f) + w(g))`, generalised to every
//!    reference of the frame; equal weights if all are 0); its 1/Z and
//!    source are those of the layer with the largest `w` (the earlier on
//!    ties). Layers are blended regardless of their depths, as in the paper.
//!    A sample covered by one layer takes it. With one reference the form
//!    equals `didyk`.
//!
//! Parameters ([`DidykParams`]):
//! - `grid.threshold`: 3 derived samples (paper §3.3.1: 3 pixels).
//! - `grid.max_cell`: 64 samples (`grid.rs`).
//! - `filter`: bilinear (paper silent).
//! - `preference_power`: 4, dimensionless (paper silent; rule 8).
//!
//! Default hole fill: `didyk-inpaint` (`inpaint.rs`), the paper's
//! fill of the single-sample T-junction holes (§3.3.1).
//!
//! Not modelled: the GPU pipeline (geometry shaders, transform feedback),
//! the disparity map as a scale and bias of depth (we use the exact 3D
//! warp), perspective-correct texture interpolation, §3.5's swapping of eye
//! roles and choice of which view to render (the trace fixes the
//! references), the temporal mapping `g` from a *previously derived* frame
//! (our second image is the trace's other reference, already rendered).

pub mod grid;
pub mod inpaint;

use crate::golden::general::{Window, triangle};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Prepared, Reconstruction};
use bitvec::vec::BitVec;
use glam::DVec2;
use grid::{Cell, DisparityMipMap, GridParams, GridStats, adaptive_grid, top_level};
use postwarp_rtl::{SampleImage, WarpSetup};
use serde_json::{Map, Value};
use std::borrow::Cow;

/// Rule 1: the depth of every grid vertex of one reference.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexDepths {
    /// Vertices per row (`width + 1`).
    pub columns: u32,
    /// Vertex rows (`height + 1`).
    pub rows: u32,
    /// Reference 1/Z of each vertex, row-major; negative: no adjacent
    /// sample has a surface.
    pub inv_z: Vec<f32>,
}

impl VertexDepths {
    /// Rule 1 for `img`.
    pub fn new(img: &SampleImage) -> VertexDepths {
        let (w, h) = (img.width as i64, img.height as i64);
        let (columns, rows) = (img.width + 1, img.height + 1);
        let mut inv_z = vec![-1.0f32; columns as usize * rows as usize];
        for vy in 0..rows as i64 {
            for vx in 0..columns as i64 {
                let mut best = -1.0f32;
                for (x, y) in [(vx - 1, vy - 1), (vx, vy - 1), (vx - 1, vy), (vx, vy)] {
                    if x < 0 || y < 0 || x >= w || y >= h {
                        continue;
                    }
                    let i = (y * w + x) as usize;
                    let z = img.z[i];
                    if img.valid[i] && z.is_finite() && z > 0.0 {
                        best = best.max(1.0 / z);
                    }
                }
                inv_z[(vy * columns as i64 + vx) as usize] = best;
            }
        }
        VertexDepths { columns, rows, inv_z }
    }

    /// Reference 1/Z of vertex `(vx, vy)`, `None` if it has no surface.
    pub fn at(&self, vx: u32, vy: u32) -> Option<f32> {
        let v = self.inv_z[vy as usize * self.columns as usize + vx as usize];
        (v >= 0.0).then_some(v)
    }
}

/// Rule 5's texture lookup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureFilter {
    /// Nearest sample, inside the quad's cell.
    Nearest,
    /// Bilinear over the image, surfaces only.
    Bilinear,
}

/// Parameters (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DidykParams {
    /// Adaptive grid.
    pub grid: GridParams,
    /// Texture lookup.
    pub filter: TextureFilter,
    /// Exponent `p` of the preference `w = (r_min / r_max)^p` (rule 8).
    pub preference_power: f64,
}

impl Default for DidykParams {
    fn default() -> Self {
        DidykParams { grid: GridParams::default(), filter: TextureFilter::Bilinear, preference_power: 4.0 }
    }
}

/// One reference drawn on its own (rules 3–6), on the derived sample grid.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpedLayer {
    /// Width (derived samples).
    pub width: u32,
    /// Height (derived samples).
    pub height: u32,
    /// Linear RGB.
    pub colour: Vec<[f32; 3]>,
    /// Derived 1/Z.
    pub inv_z: Vec<f32>,
    /// Preference `w` of the quad that wrote the sample (rule 8).
    pub weight: Vec<f32>,
    /// A quad wrote the sample.
    pub covered: BitVec,
}

impl WarpedLayer {
    /// An empty layer.
    pub fn new(width: u32, height: u32) -> WarpedLayer {
        let n = width as usize * height as usize;
        WarpedLayer {
            width,
            height,
            colour: vec![[0.0; 3]; n],
            inv_z: vec![0.0; n],
            weight: vec![0.0; n],
            covered: BitVec::repeat(false, n),
        }
    }
}

/// Counters of drawing one or more references.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DrawStats {
    /// The grid's counters.
    pub grid: GridStats,
    /// Quads drawn (rule 3).
    pub quads: u64,
    /// Quads culled because a vertex is behind the derived camera.
    pub culled_quads: u64,
    /// Derived samples written (depth-test passes, overwrites included).
    pub samples_written: u64,
}

impl DrawStats {
    fn add(&mut self, o: &DrawStats) {
        self.grid.leaves += o.grid.leaves;
        self.grid.leaves_1x1 += o.grid.leaves_1x1;
        self.grid.empty_leaves += o.grid.empty_leaves;
        self.grid.splits += o.grid.splits;
        self.quads += o.quads;
        self.culled_quads += o.culled_quads;
        self.samples_written += o.samples_written;
    }
}

/// Rule 8's preference of a quad: corners in the order `(x0,y0)`,
/// `(x1,y0)`, `(x0,y1)`, `(x1,y1)`, in the reference (`src`) and warped
/// (`dst`).
pub fn preference(src: &[DVec2; 4], dst: &[DVec2; 4], power: f64) -> f64 {
    let edges = [(0, 1), (1, 3), (2, 3), (0, 2)];
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (a, b) in edges {
        let r = (dst[b] - dst[a]).length() / (src[b] - src[a]).length();
        lo = lo.min(r);
        hi = hi.max(r);
    }
    let w = (lo / hi).powf(power);
    if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.0 }
}

/// Rule 5.
fn texel(img: &SampleImage, cell: &Cell, u: f64, v: f64, filter: TextureFilter) -> [f32; 3] {
    let w = img.width as usize;
    let nearest = || {
        let x = (u + 0.5).floor().clamp(cell.x0 as f64, (cell.x1 - 1) as f64) as usize;
        let y = (v + 0.5).floor().clamp(cell.y0 as f64, (cell.y1 - 1) as f64) as usize;
        img.colour[y * w + x]
    };
    match filter {
        TextureFilter::Nearest => nearest(),
        TextureFilter::Bilinear => {
            let (mx, my) = ((img.width - 1) as f64, (img.height - 1) as f64);
            let (u, v) = (u.clamp(0.0, mx), v.clamp(0.0, my));
            // Non-negative after the clamp: the casts floor.
            let (x0, y0) = (u as usize, v as usize);
            // Rule 5: weights to the GPU's 8 bits of sub-texel precision.
            let q = |t: f64| ((t * 256.0 + 0.5) as u32) as f64 / 256.0;
            let (tx, ty) = (q(u - x0 as f64), q(v - y0 as f64));
            let (x1, y1) = ((x0 + 1).min(img.width as usize - 1), (y0 + 1).min(img.height as usize - 1));
            let mut acc = [0.0f64; 3];
            let mut wsum = 0.0;
            for (x, y, wt) in [
                (x0, y0, (1.0 - tx) * (1.0 - ty)),
                (x1, y0, tx * (1.0 - ty)),
                (x0, y1, (1.0 - tx) * ty),
                (x1, y1, tx * ty),
            ] {
                let i = y * w + x;
                if wt > 0.0 && img.valid[i] {
                    wsum += wt;
                    for (a, c) in acc.iter_mut().zip(img.colour[i]) {
                        *a += wt * c as f64;
                    }
                }
            }
            if wsum > 0.0 { acc.map(|a| (a / wsum) as f32) } else { nearest() }
        }
    }
}

/// The samples `triangle` should scan for triangle `v` on a `w x h` grid.
fn window(v: &[DVec2; 3], w: u32, h: u32) -> Window {
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let x0 = lo.x.ceil().max(0.0);
    let y0 = lo.y.ceil().max(0.0);
    let x1 = hi.x.floor().min(w as f64 - 1.0);
    let y1 = hi.y.floor().min(h as f64 - 1.0);
    ((x0 as i64, x1 as i64), (y0 as i64, y1 as i64))
}

/// Rules 2–6: draw reference `img` (with its vertex depths) into `out`.
pub fn warp_reference(
    setup: &WarpSetup,
    img: &SampleImage,
    verts: &VertexDepths,
    params: &DidykParams,
    out: &mut WarpedLayer,
) -> DrawStats {
    let mut st = DrawStats::default();
    if img.width == 0 || img.height == 0 {
        return st;
    }
    let mip = DisparityMipMap::from_reference(setup, img, top_level(params.grid.max_cell));
    let mut cells = Vec::new();
    st.grid = adaptive_grid(&mip, params.grid.threshold, &mut cells);
    let (dw, dh) = (out.width, out.height);
    for cell in &cells {
        let corners = [(cell.x0, cell.y0), (cell.x1, cell.y0), (cell.x0, cell.y1), (cell.x1, cell.y1)];
        let mut src = [DVec2::ZERO; 4];
        let mut dst = [DVec2::ZERO; 4];
        let mut iz = [0.0f64; 4];
        let mut ok = true;
        for (k, &(vx, vy)) in corners.iter().enumerate() {
            src[k] = DVec2::new(vx as f64 - 0.5, vy as f64 - 0.5);
            // Every corner touches a sample of the (drawable) cell.
            let Some(inv_z) = verts.at(vx, vy) else {
                ok = false;
                break;
            };
            let t = setup.warp(src[k].x, src[k].y, inv_z as f64);
            if !(t.w > 0.0 && t.position.is_finite() && t.inv_z.is_finite()) {
                ok = false;
                break;
            }
            dst[k] = t.position;
            iz[k] = t.inv_z;
        }
        if !ok {
            st.culled_quads += 1;
            continue;
        }
        st.quads += 1;
        let weight = preference(&src, &dst, params.preference_power) as f32;
        for tri in [[0usize, 1, 3], [0, 3, 2]] {
            let mut t = tri;
            let area2 = (dst[t[1]] - dst[t[0]]).perp_dot(dst[t[2]] - dst[t[0]]);
            if area2 < 0.0 {
                t.swap(1, 2);
            }
            let v = [dst[t[0]], dst[t[1]], dst[t[2]]];
            triangle(v, window(&v, dw, dh), |x, y, b| {
                let k = y as usize * dw as usize + x as usize;
                let z = (b[0] * iz[t[0]] + b[1] * iz[t[1]] + b[2] * iz[t[2]]) as f32;
                if out.covered[k] && z <= out.inv_z[k] {
                    return;
                }
                let u = b[0] * src[t[0]].x + b[1] * src[t[1]].x + b[2] * src[t[2]].x;
                let v = b[0] * src[t[0]].y + b[1] * src[t[1]].y + b[2] * src[t[2]].y;
                out.colour[k] = texel(img, cell, u, v, params.filter);
                out.inv_z[k] = z;
                out.weight[k] = weight;
                out.covered.set(k, true);
                st.samples_written += 1;
            });
        }
    }
    st
}

/// Rule 8's merge of `layers` into `d`; returns the samples covered by more
/// than one layer.
pub fn merge(layers: &[WarpedLayer], d: &mut DestPlanes) -> u64 {
    let mut blended = 0;
    for k in 0..d.len() {
        let mut acc = [0.0f64; 3];
        let mut plain = [0.0f64; 3];
        let (mut wsum, mut n) = (0.0f64, 0u32);
        let mut best: Option<(usize, f32)> = None;
        for (j, l) in layers.iter().enumerate() {
            if !l.covered[k] {
                continue;
            }
            n += 1;
            let w = l.weight[k] as f64;
            wsum += w;
            for c in 0..3 {
                acc[c] += w * l.colour[k][c] as f64;
                plain[c] += l.colour[k][c] as f64;
            }
            if best.is_none_or(|(_, bw)| l.weight[k] > bw) {
                best = Some((j, l.weight[k]));
            }
        }
        let Some((j, _)) = best else { continue };
        blended += (n > 1) as u64;
        d.colour[k] = if n == 1 {
            layers[j].colour[k]
        } else if wsum > 0.0 {
            acc.map(|a| (a / wsum) as f32)
        } else {
            plain.map(|a| (a / n as f64) as f32)
        };
        d.inv_z[k] = layers[j].inv_z[k];
        d.source[k] = j as u8;
        d.real.set(k, true);
    }
    blended
}

/// Which form of the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// `didyk`: the first reference only (rule 7).
    Single,
    /// `didyk-2ref`: every reference, blended by preference (rule 8).
    Multi,
}

/// Didyk et al.'s adaptive grid warping as a [`Reconstruction`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Didyk {
    /// Parameters.
    pub params: DidykParams,
    /// Form.
    pub form: Form,
}

impl Didyk {
    /// `didyk` with the default parameters.
    pub fn single() -> Didyk {
        Didyk { params: DidykParams::default(), form: Form::Single }
    }

    /// `didyk-2ref` with the default parameters.
    pub fn two_ref() -> Didyk {
        Didyk { params: DidykParams::default(), form: Form::Multi }
    }

    /// Draw reference `j` of `input` into a fresh `w x h` layer.
    fn layer(&self, input: &Input, j: usize, (w, h): (u32, u32), st: &mut DrawStats) -> WarpedLayer {
        let mut l = WarpedLayer::new(w, h);
        let img = input.refs[j];
        let verts = match input.prepared.get(j).and_then(|p| p.downcast_ref::<VertexDepths>()) {
            Some(v) if (v.columns, v.rows) == (img.width + 1, img.height + 1) => Cow::Borrowed(v),
            _ => Cow::Owned(VertexDepths::new(img)),
        };
        st.add(&warp_reference(&input.cmd.warps[j].setup, img, &verts, &self.params, &mut l));
        l
    }
}

impl Reconstruction for Didyk {
    fn info(&self) -> MethodInfo {
        match self.form {
            Form::Single => MethodInfo {
                name: "didyk",
                description: "Didyk et al.'s adaptive grid: the first reference as textured quads, split where disparity varies by more than 3 samples (min/max MIP-map), vertices at the nearest of four samples",
                paper: "002 Didyk et al. VMV 2010 §3.2-3.3",
                primitive: "quads",
                default_hole_fill: "didyk-inpaint",
            },
            Form::Multi => MethodInfo {
                name: "didyk-2ref",
                description: "Didyk et al.'s adaptive grid on every reference, blended per sample by the preference for the less stretched quad",
                paper: "002 Didyk et al. VMV 2010 §3.4",
                primitive: "quads",
                default_hole_fill: "didyk-inpaint",
            },
        }
    }

    fn prepare(&self, img: &SampleImage, _ss: u32) -> Prepared {
        Box::new(VertexDepths::new(img))
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let n = input.cmd.warps.len().min(input.refs.len());
        let used = match self.form {
            Form::Single => n.min(1),
            Form::Multi => n,
        };
        let mut st = DrawStats::default();
        let size = (out.width, out.height);
        let layers: Vec<WarpedLayer> = (0..used).map(|j| self.layer(input, j, size, &mut st)).collect();
        let blended = merge(&layers, out);
        let mut extra = Map::new();
        for (k, v) in [
            ("references_warped", used as u64),
            ("leaf_cells", st.grid.leaves),
            ("leaf_cells_1x1", st.grid.leaves_1x1),
            ("empty_cells", st.grid.empty_leaves),
            ("splits", st.grid.splits),
            ("culled_quads", st.culled_quads),
            ("samples_written", st.samples_written),
            ("blended_samples", blended),
        ] {
            extra.insert(k.into(), Value::from(v));
        }
        Counters { primitives: st.quads, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_takes_the_nearest_of_its_samples() {
        let mut img = SampleImage::empty(2, 2);
        for (i, z) in [(0, 4.0), (1, 2.0), (3, 8.0)] {
            img.z[i] = z;
            img.valid.set(i, true);
        }
        let v = VertexDepths::new(&img);
        assert_eq!((v.columns, v.rows), (3, 3));
        assert_eq!(v.at(1, 1), Some(0.5)); // min Z of 4, 2, 8 (sample 2 has none)
        assert_eq!(v.at(0, 0), Some(0.25));
        assert_eq!(v.at(0, 2), None); // only sample 2 touches it
        assert_eq!(v.at(2, 2), Some(0.125));
    }

    #[test]
    fn preference_is_one_for_rigid_motion_and_small_for_tears() {
        let src = [DVec2::new(0.0, 0.0), DVec2::new(2.0, 0.0), DVec2::new(0.0, 2.0), DVec2::new(2.0, 2.0)];
        let moved = src.map(|p| DVec2::new(1.5 * p.y + 7.0, -1.5 * p.x + 3.0));
        assert!((preference(&src, &moved, 4.0) - 1.0).abs() < 1e-12);
        // The right edge torn 6 samples away: top and bottom edges 8/2 = 4x.
        let torn = [src[0], src[1] + DVec2::new(6.0, 0.0), src[2], src[3] + DVec2::new(6.0, 0.0)];
        assert!((preference(&src, &torn, 1.0) - 0.25).abs() < 1e-12);
        assert!((preference(&src, &torn, 4.0) - 0.25f64.powi(4)).abs() < 1e-12);
        let collapsed = [src[0]; 4];
        assert_eq!(preference(&src, &collapsed, 4.0), 0.0);
    }
}
