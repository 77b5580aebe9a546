//! `smit-point`: Smit et al.'s point-splat reconstruction (seed 001, Smit
//! et al., C&G 2010, §4.1; the one their system uses throughout, §6.1).
//!
//! Job: draw every warped reference sample as a screen-aligned square
//! (`gl_PointSize`) whose side follows the warp's local magnification,
//! flat colour and depth, z-tested.
//!
//! Rules:
//! 1. Warp, Jacobian `J`, culling and depth test: `warp` rules 1–4.
//! 2. Splat side `s = ceil(max(|J₀₀| + |J₀₁|, |J₁₀| + |J₁₁|))` derived
//!    samples, at least 1: the side of the smallest axis-aligned square
//!    covering the sample's footprint parallelogram `J·[±½, ±½]` (row `i`
//!    of `J` is derived axis `i`). The paper prints
//!    `s = ceil(max(J11 + J12, J21 + J22))` and says it equals "the
//!    smallest square completely covering" the quad splat; we use that
//!    statement (absolute values, rows = derived axes), which the printed
//!    formula matches only when `J` has no negative entries. `ceil` applies
//!    to the size less [`SIZE_EPS`], so that `J = I` up to rounding gives 1.
//! 3. Cap: `s <= max_size` (default [`MAX_SPLAT`] derived samples); a
//!    non-finite `J` (near `W = 0`) gives `max_size`. Capped splats are
//!    counted (`clamped_splats`); a surface magnified beyond the cap shows
//!    gaps (sampling errors).
//! 4. Coverage: the `s x s` derived samples whose centres lie in the
//!    half-open square `[x' − s/2, x' + s/2) x [y' − s/2, y' + s/2)`
//!    around the warped position (GL's square point, exactly `s` centres
//!    per axis), clipped to the image.
//! 5. Every fragment carries the sample's colour and warped 1/Z (flat, as
//!    a GL point).
//! 6. After drawing, the level-0 holes are classified (`errors`).
//!
//! Parameters: `max_size` (derived samples, default 16; our choice: the
//! paper gives no cap, a GPU's point-size range has one; 16 bounds a
//! splat at 256 fragments).
//!
//! Primitives: splats with at least one centre on the image.
//!
//! Not modelled: GL's exact point-rasterization rounding for odd and even
//! sizes (we use the half-open square), point sprites and anti-aliased
//! points.

use super::errors;
use super::geometry::{MAX_SPLAT, splat_side};
use super::warp::{WarpedReference, centres, depth_write, warp_counters, warp_frame};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Reconstruction};
use serde_json::json;

/// Smit's point splats.
#[derive(Clone, Copy, Debug)]
pub struct SmitPoint {
    /// Rule 3's cap (derived samples, at least 1).
    pub max_size: u32,
}

impl Default for SmitPoint {
    fn default() -> Self {
        SmitPoint { max_size: MAX_SPLAT }
    }
}

/// Counters of one frame (units: splats, except `fragments`: derived
/// samples rasterized, and `lost_fragments`: of those, failing the depth test).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PointStats {
    /// Splats with at least one centre on the image.
    pub splats: u64,
    /// Splats entirely off the image.
    pub off_image: u64,
    /// Splats capped at `max_size`.
    pub clamped_splats: u64,
    /// Sum of the sides of the drawn splats (derived samples).
    pub side_sum: u64,
    /// Fragments rasterized.
    pub fragments: u64,
    /// Fragments that lost the depth test.
    pub lost_fragments: u64,
}

impl SmitPoint {
    /// Rules 2–5 for one warped reference into `d`.
    pub fn draw(&self, r: &WarpedReference, colour: &[[f32; 3]], d: &mut DestPlanes, st: &mut PointStats) {
        let cap = self.max_size.max(1);
        for (i, s) in r.samples.iter().enumerate() {
            let Some(s) = s else { continue };
            let (side, clamped) = splat_side(&s.jac, cap);
            let h = 0.5 * side as f64;
            let (Some((x0, x1)), Some((y0, y1))) =
                (centres(s.pos.x - h, s.pos.x + h, d.width), centres(s.pos.y - h, s.pos.y + h, d.height))
            else {
                st.off_image += 1;
                continue;
            };
            st.splats += 1;
            st.clamped_splats += clamped as u64;
            st.side_sum += side as u64;
            let iz = s.inv_z as f32;
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let k = y as usize * d.width as usize + x as usize;
                    st.fragments += 1;
                    st.lost_fragments += !depth_write(d, k, iz, colour[i], r.source) as u64;
                }
            }
        }
    }
}

impl Reconstruction for SmitPoint {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "smit-point",
            description: "Smit et al.'s point splats: screen-aligned squares sized from the warp's Jacobian, z-tested",
            paper: "001 Smit et al. C&G 2010 §4.1",
            primitive: "splats",
            default_hole_fill: "none",
        }
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let warped = warp_frame(input);
        let mut st = PointStats::default();
        for (r, img) in warped.iter().zip(input.refs) {
            self.draw(r, &img.colour, out, &mut st);
        }
        let mut extra = warp_counters(&warped);
        for (k, v) in [
            ("off_image", st.off_image),
            ("clamped_splats", st.clamped_splats),
            ("fragments", st.fragments),
            ("lost_fragments", st.lost_fragments),
        ] {
            extra.insert(k.into(), json!(v));
        }
        let mean = if st.splats > 0 { st.side_sum as f64 / st.splats as f64 } else { 0.0 };
        extra.insert("mean_splat_side".into(), json!(mean));
        errors::classify(&warped, out, input.cmd.supersample).insert_into(&mut extra);
        Counters { primitives: st.splats, extra }
    }
}
