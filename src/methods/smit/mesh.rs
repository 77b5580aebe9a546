//! `smit-mesh` and `smit-mesh-connected`: Smit et al.'s mesh-based
//! reconstruction (seed 001, Smit et al., C&G 2010, §4.1: "similar to the
//! one proposed by Mark and McMillan [10]").
//!
//! Job: treat the reference's sample grid as a triangle mesh whose vertices
//! are the warped samples, and rasterize its triangles z-tested, with 1/Z
//! and colour interpolated.
//!
//! Rules:
//! 1. Warp, culling and depth test: `warp` rules 1–4. A triangle with
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
//! 6. After drawing, the level-0 holes are classified (`errors`).
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

use super::errors;
use super::geometry::{TriangleState, for_each_triangle};
use super::warp::{WarpedReference, depth_write, triangle_any_winding, warp_counters, warp_frame, window_of};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Reconstruction};
use serde_json::json;

/// Rule 3's default tolerance τ (predicted edge lengths, at least τ
/// derived samples).
pub const DEFAULT_TOLERANCE: f64 = 2.0;

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
        errors::classify(&warped, out, input.cmd.supersample).insert_into(&mut extra);
        Counters { primitives: st.triangles, extra }
    }
}
