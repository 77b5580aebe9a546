//! `smit-quad`: Smit et al.'s quadrilateral-splat reconstruction (seed 001,
//! Smit et al., C&G 2010, §4.1).
//!
//! Job: draw every warped reference sample as its footprint: the
//! parallelogram the warp's Jacobian makes of the sample's pixel square
//! (the geometry shader's quad), flat colour and depth, z-tested.
//!
//! Rules:
//! 1. Warp, Jacobian `J`, culling and depth test: `smit_warp` rules 1–4.
//! 2. Corners: `p' + J·(∓½, ∓½)`, in reference order A (−,−), B (+,−),
//!    D (+,+), C (−,+) ("post-multiplying the Jacobian matrix by half-pixel
//!    offsets (x ± 0.5, y ± 0.5) of the warped pixel's position").
//! 3. Cap: when the quad's axis-aligned extent (`smit_point` rule 2,
//!    before `ceil`) exceeds `max_size` (default `smit_point::MAX_SPLAT` =
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
//! 6. After drawing, the level-0 holes are classified (`smit_errors`).
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

use super::smit_errors;
use super::smit_point::{MAX_SPLAT, footprint_extent};
use super::smit_warp::{
    WarpedReference, WarpedSample, depth_write, triangle_any_winding, warp_counters, warp_frame, window_of,
};
use super::{Counters, Input, MethodInfo, Reconstruction};
use crate::golden::planes::DestPlanes;
use glam::DVec2;
use serde_json::json;

/// Rules 2–3: the quad's corners A, B, D, C and whether it was capped.
pub fn quad_corners(s: &WarpedSample, max_size: u32) -> ([DVec2; 4], bool) {
    let cap = max_size.max(1) as f64;
    let e = footprint_extent(&s.jac);
    let m = e.x.max(e.y);
    let offsets = [DVec2::new(-0.5, -0.5), DVec2::new(0.5, -0.5), DVec2::new(0.5, 0.5), DVec2::new(-0.5, 0.5)];
    if !m.is_finite() {
        return (offsets.map(|o| s.pos + o * cap), true);
    }
    let (j, clamped) = if m > cap { (s.jac * (cap / m), true) } else { (s.jac, false) };
    (offsets.map(|o| s.pos + j * o), clamped)
}

/// Rule 4: visit the sample centres of a `width x height` image inside the
/// quad A, B, D, C (corners as from [`quad_corners`]). Returns `None` when
/// its bounding box holds no centre of the image, else whether it is
/// degenerate (zero or non-finite area).
pub fn raster_quad(c: [DVec2; 4], width: u32, height: u32, mut f: impl FnMut(u32, u32)) -> Option<bool> {
    let win = window_of(&c, width, height)?;
    let [a, b, d, cc] = c;
    let (e1, e2) = (b - a, d - a);
    let area2 = e1.x * e2.y - e1.y * e2.x;
    if area2 == 0.0 || !area2.is_finite() {
        return Some(true);
    }
    triangle_any_winding([a, b, d], win, |x, y, _| f(x, y));
    triangle_any_winding([a, d, cc], win, |x, y, _| f(x, y));
    Some(false)
}

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
        smit_errors::classify(&warped, out, input.cmd.supersample).insert_into(&mut extra);
        Counters { primitives: st.quads, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat2;

    fn sample(pos: DVec2, jac: DMat2) -> WarpedSample {
        WarpedSample { pos, inv_z: 1.0, jac }
    }

    fn count(c: [DVec2; 4], w: u32, h: u32) -> Vec<u32> {
        let mut hits = vec![0; (w * h) as usize];
        raster_quad(c, w, h, |x, y| hits[(y * w + x) as usize] += 1);
        hits
    }

    #[test]
    fn quads_of_a_constant_jacobian_tile_exactly() {
        // A sheared, magnified lattice: every centre inside is hit once.
        let j = DMat2::from_cols(DVec2::new(1.7, 0.3), DVec2::new(-0.4, 1.3));
        let (w, h) = (24u32, 24u32);
        let mut hits = vec![0u32; (w * h) as usize];
        for gy in -12..24 {
            for gx in -12..24 {
                let p = DVec2::new(3.1, 2.7) + j * DVec2::new(gx as f64, gy as f64);
                let (c, clamped) = quad_corners(&sample(p, j), 16);
                assert!(!clamped);
                raster_quad(c, w, h, |x, y| hits[(y * w + x) as usize] += 1);
            }
        }
        assert!(hits.iter().all(|&n| n == 1), "{hits:?}");
    }

    #[test]
    fn mirrored_quads_draw_and_caps_scale() {
        let j = DMat2::from_cols(DVec2::new(-2.0, 0.0), DVec2::new(0.0, 2.0));
        let c = quad_corners(&sample(DVec2::new(5.2, 5.2), j), 16).0;
        assert_eq!(count(c, 12, 12).iter().sum::<u32>(), 4, "a 2x2 mirrored quad");
        let (c, clamped) = quad_corners(&sample(DVec2::new(5.2, 5.2), DMat2::IDENTITY * 100.0), 4);
        assert!(clamped);
        assert_eq!(count(c, 12, 12).iter().sum::<u32>(), 16, "scaled to 4x4");
        let (c, clamped) = quad_corners(&sample(DVec2::new(5.2, 5.2), DMat2::IDENTITY * f64::NAN), 2);
        assert!(clamped);
        assert_eq!(count(c, 12, 12).iter().sum::<u32>(), 4);
        let edge_on = DMat2::from_cols(DVec2::new(3.0, 0.0), DVec2::new(3.0, 0.0));
        let c = quad_corners(&sample(DVec2::new(5.2, 5.0), edge_on), 16).0;
        assert_eq!(raster_quad(c, 12, 12, |_, _| panic!("covers nothing")), Some(true));
        let far = quad_corners(&sample(DVec2::new(-50.0, 5.0), DMat2::IDENTITY), 16).0;
        assert_eq!(raster_quad(far, 12, 12, |_, _| ()), None);
    }
}
