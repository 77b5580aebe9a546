//! `smit-mesh` and `smit-mesh-connected`: Smit et al.'s mesh-based
//! reconstruction (seed 001, Smit et al., C&G 2010, §4.1: "similar to the
//! one proposed by Mark and McMillan [10]").
//!
//! Job: treat the reference's sample grid as a triangle mesh whose vertices
//! are the warped samples, and rasterize its triangles z-tested, with 1/Z
//! and colour interpolated.
//!
//! Rules:
//! 1. Warp, culling and depth test: `smit_warp` rules 1–4. A triangle with
//!    a vertex without a surface or culled is not drawn
//!    (`missing_triangles`).
//! 2. Mesh: each 2x2 group A (x, y), B (x+1, y), C (x, y+1), D (x+1, y+1)
//!    is split along the fixed diagonal A–D into (A, B, D) and (A, D, C).
//! 3. Depth discontinuities (`smit-mesh`): a triangle is drawn only if all
//!    three of its edges join one surface ([`connected`]): for the edge
//!    from `a` to `b` at reference offset `o`, the warped step
//!    `d = p'_b − p'_a` must agree with the step each endpoint's own
//!    surface plane predicts, `|d − J_a·o| <= τ·max(1, |J_a·o|)` and the
//!    same with `J_b`; τ = `tolerance`, default [`DEFAULT_TOLERANCE`] = 2
//!    (dimensionless: in predicted edge lengths, at least τ derived
//!    samples). A triangle failing it is not drawn (`broken_triangles`):
//!    the gap it would bridge stays empty for the other reference or the
//!    hole fill. The test is view-dependent: a depth step the derived view
//!    opens by at most τ derived samples (at unit magnification) stays
//!    bridged, so that features one sample thin, which have no triangle of
//!    their own, survive small motions.
//!    `smit-mesh-connected` skips the test (`tolerance` = none): the mesh
//!    is "completely connected", as the paper describes it, and its
//!    triangles across depth steps ("rubber sheets") are drawn and z-tested
//!    like any other.
//! 4. Triangles of either winding are drawn (face culling off: a fold of
//!    one surface is z-tested, `folded_triangles`), under the top-left rule
//!    (`golden::general::triangle`), so that the triangles of a surface
//!    cover each sample centre once.
//! 5. Interpolation from the barycentric weights `b_k` in the derived
//!    image: 1/Z linearly (`Σ b_k/Z_k`, exact on planes), colour
//!    perspective-correctly (`Σ b_k·(1/Z_k)·c_k / Σ b_k/Z_k`, the GPU's
//!    default for varyings).
//! 6. After drawing, the level-0 holes are classified (`smit_errors`).
//!
//! Parameters: `tolerance` τ (dimensionless, default 2, our choice: the
//! paper's mesh is completely connected and has none; 2 was the best of
//! 0.25, 0.5, 1, 2 and 4 on three of the five bundled traces, sweep in
//! `docs/methods/smit.md`).
//!
//! Primitives: triangles rasterized (drawn, non-degenerate, bounding box
//! on the image).
//!
//! Not modelled: Mark and McMillan's "low-confidence" treatment of bridging
//! triangles (losing every depth test, colour of the farthest vertex),
//! which Smit does not describe; the edge splats of Mark's later general
//! reconstruction (so a broken mesh loses up to half a sample spacing at
//! the right and bottom edges of a surface next to a gap, where the
//! top-left rule leaves the last centres to the missing triangles).

use super::smit_errors;
use super::smit_warp::{
    WarpedReference, WarpedSample, depth_write, triangle_any_winding, warp_counters, warp_frame, window_of,
};
use super::{Counters, Input, MethodInfo, Reconstruction};
use crate::golden::planes::DestPlanes;
use glam::DVec2;
use serde_json::json;

/// Rule 3's default tolerance τ (predicted edge lengths, at least τ
/// derived samples).
pub const DEFAULT_TOLERANCE: f64 = 2.0;

/// Rule 3: whether the edge from `a` to `b` (reference offset `o`) joins
/// one surface, at tolerance `tol`.
#[inline(always)]
pub fn connected(a: &WarpedSample, b: &WarpedSample, o: DVec2, tol: f64) -> bool {
    let d = b.pos - a.pos;
    let fits = |p: DVec2| (d - p).length_squared() <= tol * tol * p.length_squared().max(1.0);
    fits(a.jac * o) && fits(b.jac * o)
}

/// Why a mesh triangle was or was not emitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleState {
    /// All three vertices warped and (with a tolerance) one surface.
    Drawn,
    /// A vertex has no surface or was culled.
    Missing,
    /// Rule 3 failed on an edge.
    Broken,
}

/// Rules 1–3 for the 2x2 group whose top-left reference sample is
/// `(gx, gy)` (both `< width − 1`, `< height − 1`): its triangles
/// (A, B, D) and (A, D, C), each with its state and the reference indices
/// of its vertices.
#[inline(always)]
pub fn group_triangles(
    r: &WarpedReference,
    gx: usize,
    gy: usize,
    tolerance: Option<f64>,
) -> [(TriangleState, [usize; 3]); 2] {
    let w = r.width as usize;
    let (ia, ib, ic, id) = (gy * w + gx, gy * w + gx + 1, (gy + 1) * w + gx, (gy + 1) * w + gx + 1);
    let (sa, sb, sc, sd) = (&r.samples[ia], &r.samples[ib], &r.samples[ic], &r.samples[id]);
    let joins = |p: &Option<WarpedSample>, q: &Option<WarpedSample>, o: DVec2| match (p, q) {
        (Some(p), Some(q)) => Some(tolerance.is_none_or(|t| connected(p, q, o, t))),
        _ => None,
    };
    let (right, down) = (DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0));
    let ad = joins(sa, sd, DVec2::new(1.0, 1.0));
    let state = |e1: Option<bool>, e2: Option<bool>| match (e1, e2, ad) {
        (Some(true), Some(true), Some(true)) => TriangleState::Drawn,
        (Some(_), Some(_), Some(_)) => TriangleState::Broken,
        _ => TriangleState::Missing,
    };
    [
        (state(joins(sa, sb, right), joins(sb, sd, down)), [ia, ib, id]),
        (state(joins(sc, sd, right), joins(sa, sc, down)), [ia, id, ic]),
    ]
}

/// Rules 1–3: visit the triangles of `r`'s mesh in order (groups in raster
/// order, (A, B, D) then (A, D, C)) with their state and their vertices'
/// reference indices.
pub fn for_each_triangle(r: &WarpedReference, tolerance: Option<f64>, mut f: impl FnMut(TriangleState, [usize; 3])) {
    let (w, h) = (r.width as usize, r.height as usize);
    for gy in 0..h.saturating_sub(1) {
        for gx in 0..w.saturating_sub(1) {
            for (state, tri) in group_triangles(r, gx, gy, tolerance) {
                f(state, tri);
            }
        }
    }
}

/// Smit's mesh.
#[derive(Clone, Copy, Debug)]
pub struct SmitMesh {
    /// Rule 3's τ; `None`: completely connected (`smit-mesh-connected`).
    pub tolerance: Option<f64>,
}

impl Default for SmitMesh {
    fn default() -> Self {
        SmitMesh { tolerance: Some(DEFAULT_TOLERANCE) }
    }
}

impl SmitMesh {
    /// The paper's completely connected mesh (`smit-mesh-connected`).
    pub fn connected() -> Self {
        SmitMesh { tolerance: None }
    }
}

/// Counters of one frame (units: triangles, except `fragments`: derived
/// samples rasterized, and `lost_fragments`: of those, failing the depth test).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshStats {
    /// Triangles rasterized.
    pub triangles: u64,
    /// Triangles with a vertex missing or culled.
    pub missing_triangles: u64,
    /// Triangles not drawn at a depth discontinuity (rule 3).
    pub broken_triangles: u64,
    /// Of the rasterized, those of negative winding.
    pub folded_triangles: u64,
    /// Drawn triangles of zero or non-finite area.
    pub degenerate_triangles: u64,
    /// Drawn triangles entirely off the image.
    pub off_image: u64,
    /// Fragments rasterized.
    pub fragments: u64,
    /// Fragments that lost the depth test.
    pub lost_fragments: u64,
}

impl SmitMesh {
    /// Rules 2–5 for one warped reference into `d`.
    pub fn draw(&self, r: &WarpedReference, colour: &[[f32; 3]], d: &mut DestPlanes, st: &mut MeshStats) {
        let (w, h) = (d.width, d.height);
        for_each_triangle(r, self.tolerance, |state, tri| {
            match state {
                TriangleState::Drawn => {}
                TriangleState::Broken => return st.broken_triangles += 1,
                TriangleState::Missing => return st.missing_triangles += 1,
            }
            let v = tri.map(|k| r.samples[k].as_ref().expect("drawn triangles have warped vertices"));
            let p = v.map(|s| s.pos);
            let Some(win) = window_of(&p, w, h) else { return st.off_image += 1 };
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let area2 = e1.x * e2.y - e1.y * e2.x;
            if area2 == 0.0 || !area2.is_finite() {
                return st.degenerate_triangles += 1;
            }
            st.triangles += 1;
            let iz = v.map(|s| s.inv_z);
            let c = tri.map(|k| colour[k]);
            let (mut frags, mut lost) = (0u64, 0u64);
            let folded = triangle_any_winding(p, win, |x, y, b| {
                let wz = [b[0] * iz[0], b[1] * iz[1], b[2] * iz[2]];
                let z = wz[0] + wz[1] + wz[2];
                let rgb = std::array::from_fn(|ch| {
                    ((wz[0] * c[0][ch] as f64 + wz[1] * c[1][ch] as f64 + wz[2] * c[2][ch] as f64) / z) as f32
                });
                frags += 1;
                lost += !depth_write(d, y as usize * w as usize + x as usize, z as f32, rgb, r.source) as u64;
            });
            st.folded_triangles += folded as u64;
            st.fragments += frags;
            st.lost_fragments += lost;
        });
    }
}

impl Reconstruction for SmitMesh {
    fn info(&self) -> MethodInfo {
        match self.tolerance {
            Some(_) => MethodInfo {
                name: "smit-mesh",
                description: "Smit et al.'s mesh: triangles between warped neighbours, broken where the warp opens a depth step, z-tested",
                paper: "001 Smit et al. C&G 2010 §4.1 (discontinuity test ours)",
                primitive: "triangles",
                default_hole_fill: "none",
            },
            None => MethodInfo {
                name: "smit-mesh-connected",
                description: "Smit et al.'s mesh as printed: completely connected, rubber sheets across depth steps, z-tested",
                paper: "001 Smit et al. C&G 2010 §4.1",
                primitive: "triangles",
                default_hole_fill: "none",
            },
        }
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let warped = warp_frame(input);
        let mut st = MeshStats::default();
        for (r, img) in warped.iter().zip(input.refs) {
            self.draw(r, &img.colour, out, &mut st);
        }
        let mut extra = warp_counters(&warped);
        for (k, v) in [
            ("missing_triangles", st.missing_triangles),
            ("broken_triangles", st.broken_triangles),
            ("folded_triangles", st.folded_triangles),
            ("degenerate_triangles", st.degenerate_triangles),
            ("off_image", st.off_image),
            ("fragments", st.fragments),
            ("lost_fragments", st.lost_fragments),
        ] {
            extra.insert(k.into(), json!(v));
        }
        smit_errors::classify(&warped, out, input.cmd.supersample).insert_into(&mut extra);
        Counters { primitives: st.triangles, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat2;

    fn s(x: f64, y: f64, j: f64) -> WarpedSample {
        WarpedSample { pos: DVec2::new(x, y), inv_z: 1.0, jac: DMat2::IDENTITY * j }
    }

    #[test]
    fn connected_follows_the_planes_of_both_ends() {
        let o = DVec2::new(1.0, 0.0);
        assert!(connected(&s(0.0, 0.0, 1.0), &s(1.0, 0.0, 1.0), o, 0.5));
        assert!(connected(&s(0.0, 0.0, 1.0), &s(1.45, 0.0, 1.0), o, 0.5));
        assert!(!connected(&s(0.0, 0.0, 1.0), &s(1.6, 0.0, 1.0), o, 0.5), "a 0.6-sample gap opens");
        assert!(!connected(&s(0.0, 0.0, 1.0), &s(0.4, 0.0, 1.0), o, 0.5), "an overlap of 0.6");
        // Magnified by 4: a step of 5 is within half a predicted edge.
        assert!(connected(&s(0.0, 0.0, 4.0), &s(5.0, 0.0, 4.0), o, 0.5));
        assert!(!connected(&s(0.0, 0.0, 4.0), &s(7.0, 0.0, 4.0), o, 0.5));
        // One grazing end predicts far more than the step: not one surface.
        assert!(!connected(&s(0.0, 0.0, 1.0), &s(1.0, 0.0, 40.0), o, 0.5));
        let nan = WarpedSample { jac: DMat2::IDENTITY * f64::NAN, ..s(1.0, 0.0, 1.0) };
        assert!(!connected(&s(0.0, 0.0, 1.0), &nan, o, 0.5));
    }
}
