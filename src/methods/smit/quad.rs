//! `smit-quad`: Smit et al.'s quadrilateral-splat reconstruction (seed 001,
//! Smit et al., C&G 2010, §4.1).
//!
//! Job: draw every warped reference sample as its footprint: the
//! parallelogram the warp's Jacobian makes of the sample's pixel square
//! (the geometry shader's quad), flat colour and depth, z-tested.
//!
//! Rules:
//! 1. Warp, Jacobian `J`, culling and depth test: `warp` rules 1–4.
//! 2. Corners: `p' + J·(∓½, ∓½)`, in reference order A (−,−), B (+,−),
//!    D (+,+), C (−,+) ("post-multiplying the Jacobian matrix by half-pixel
//!    offsets (x ± 0.5, y ± 0.5) of the warped pixel's position").
//! 3. Cap: when the quad's axis-aligned extent (`smit-point` rule 2,
//!    before `ceil`, `geometry::footprint_extent`) exceeds `max_size` (default `geometry::MAX_SPLAT` =
//!    16 derived samples), `J` is scaled down about the warped position
//!    until the larger extent equals `max_size` (counted, `clamped_quads`);
//!    a non-finite `J` gives the axis-aligned square of side `max_size`.
//! 4. Rasterization: the two triangles (A, B, D) and (A, D, C) under the
//!    top-left rule (`golden::general::triangle`), so that the quads of a
//!    surface whose Jacobian is locally constant tile without cracks or
//!    double coverage. A quad of negative orientation (`det J < 0`, the
//!    surface seen mirrored) is drawn too (face culling off); a degenerate
//!    one (`det J = 0`, edge-on) covers nothing (`degenerate_quads`).
//! 5. Every fragment carries the sample's colour and warped 1/Z (flat:
//!    the paper offsets only the quad's x and y; depth across the quad is
//!    not specified).
//! 6. After drawing, the level-0 holes are classified (`errors`).
//!
//! Parameters: `max_size` (derived samples, default 16, our choice; the
//! paper has no cap).
//!
//! Primitives: quads (two triangles each) with at least one sample centre
//! of their bounding box on the image.
//!
//! Not modelled: depth varying across the quad (the derived slopes of
//! 1/Z), GL's exact rasterization rules (our top-left rule is the same
//! idea), the geometry shader's cost.

use super::errors;
use super::geometry::{MAX_SPLAT, quad_corners, raster_quad};
use super::warp::{WarpedReference, depth_write, warp_counters, warp_frame};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Reconstruction};
use serde_json::json;

/// Smit's quad splats.
#[derive(Clone, Copy, Debug)]
pub struct SmitQuad {
    /// Rule 3's cap (derived samples, at least 1).
    pub max_size: u32,
}

impl Default for SmitQuad {
    fn default() -> Self {
        SmitQuad { max_size: MAX_SPLAT }
    }
}

/// Counters of one frame (units: quads, except `fragments`: derived samples
/// rasterized, and `lost_fragments`: of those, failing the depth test).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct QuadStats {
    /// Quads whose bounding box holds a centre of the image.
    pub quads: u64,
    /// Quads entirely off the image.
    pub off_image: u64,
    /// Quads scaled down to the cap.
    pub clamped_quads: u64,
    /// Quads of zero or non-finite area (nothing drawn).
    pub degenerate_quads: u64,
    /// Fragments rasterized.
    pub fragments: u64,
    /// Fragments that lost the depth test.
    pub lost_fragments: u64,
}

impl SmitQuad {
    /// Rules 2–5 for one warped reference into `d`.
    pub fn draw(&self, r: &WarpedReference, colour: &[[f32; 3]], d: &mut DestPlanes, st: &mut QuadStats) {
        let (w, h) = (d.width, d.height);
        for (i, s) in r.samples.iter().enumerate() {
            let Some(s) = s else { continue };
            let (c, clamped) = quad_corners(s, self.max_size);
            let iz = s.inv_z as f32;
            let (mut frags, mut lost) = (0u64, 0u64);
            match raster_quad(c, w, h, |x, y| {
                frags += 1;
                lost += !depth_write(d, y as usize * w as usize + x as usize, iz, colour[i], r.source) as u64;
            }) {
                None => st.off_image += 1,
                Some(degenerate) => {
                    st.quads += 1;
                    st.degenerate_quads += degenerate as u64;
                    st.clamped_quads += clamped as u64;
                }
            }
            st.fragments += frags;
            st.lost_fragments += lost;
        }
    }
}

impl Reconstruction for SmitQuad {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "smit-quad",
            description: "Smit et al.'s quad splats: each sample's Jacobian footprint parallelogram as two triangles, flat, z-tested",
            paper: "001 Smit et al. C&G 2010 §4.1",
            primitive: "quads",
            default_hole_fill: "none",
        }
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let warped = warp_frame(input);
        let mut st = QuadStats::default();
        for (r, img) in warped.iter().zip(input.refs) {
            self.draw(r, &img.colour, out, &mut st);
        }
        let mut extra = warp_counters(&warped);
        for (k, v) in [
            ("off_image", st.off_image),
            ("clamped_quads", st.clamped_quads),
            ("degenerate_quads", st.degenerate_quads),
            ("triangles", 2 * (st.quads - st.degenerate_quads)),
            ("fragments", st.fragments),
            ("lost_fragments", st.lost_fragments),
        ] {
            extra.insert(k.into(), json!(v));
        }
        errors::classify(&warped, out, input.cmd.supersample).insert_into(&mut extra);
        Counters { primitives: st.quads, extra }
    }
}
