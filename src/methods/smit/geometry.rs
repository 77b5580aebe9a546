//! The geometry the Smit variants share (seed 001, Smit et al., C&G 2010,
//! §3): the footprint of a warped sample (`smit-point` rules 2–3,
//! `smit-quad` rules 2–4) and the 2x2-group triangles of the warped mesh
//! (`smit-mesh` rules 1–3). `point`, `quad`, `mesh` and the hole
//! classification (`errors`) all build on it; it depends only on the
//! shared warp (`warp`), so none of them depends on another.
//!
//! Not modelled: anything beyond these shapes (each variant's module doc
//! lists what it leaves out).

use super::warp::{WarpedReference, WarpedSample, ceil, triangle_any_winding, window_of};
use glam::{DMat2, DVec2};

/// Rule 3's default cap on the splat side (derived samples).
pub const MAX_SPLAT: u32 = 16;

/// Rule 2's allowance for rounding (derived samples).
pub const SIZE_EPS: f64 = 1e-6;

/// Extent of the footprint parallelogram `J·[±½, ±½]` along the derived x
/// and y axes (derived samples): `(|J₀₀| + |J₀₁|, |J₁₀| + |J₁₁|)`.
pub fn footprint_extent(j: &DMat2) -> DVec2 {
    DVec2::new(j.x_axis.x.abs() + j.y_axis.x.abs(), j.x_axis.y.abs() + j.y_axis.y.abs())
}

/// Rules 2–3: the splat side (derived samples) and whether it was capped.
pub fn splat_side(j: &DMat2, max_size: u32) -> (u32, bool) {
    let e = footprint_extent(j);
    let m = e.x.max(e.y);
    if !m.is_finite() {
        return (max_size, true);
    }
    let m = m - SIZE_EPS;
    if m > max_size as f64 { (max_size, true) } else { (ceil(m).max(1.0) as u32, false) }
}

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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn splat_side_is_the_covering_square() {
        let j = |a: f64, b: f64, c: f64, d: f64| DMat2::from_cols(DVec2::new(a, c), DVec2::new(b, d));
        assert_eq!(splat_side(&DMat2::IDENTITY, 16), (1, false));
        assert_eq!(splat_side(&(DMat2::IDENTITY * (1.0 + 1e-12)), 16), (1, false), "rounding");
        assert_eq!(splat_side(&(DMat2::IDENTITY * 2.6), 16), (3, false));
        // Rows are derived axes: x' = 2x, y' = x + 0.5y covers 2 x 1.5.
        assert_eq!(footprint_extent(&j(2.0, 0.0, 1.0, 0.5)), DVec2::new(2.0, 1.5));
        assert_eq!(splat_side(&j(2.0, 0.0, 1.0, 0.5), 16), (2, false));
        // Negative entries count by magnitude (a mirror keeps the size).
        assert_eq!(splat_side(&j(-1.2, 0.0, 0.0, -0.3), 16), (2, false));
        assert_eq!(splat_side(&(DMat2::IDENTITY * 40.0), 16), (16, true));
        assert_eq!(splat_side(&(DMat2::IDENTITY * f64::NAN), 16), (16, true));
        assert_eq!(splat_side(&(DMat2::IDENTITY * f64::INFINITY), 4), (4, true));
        assert_eq!(splat_side(&DMat2::ZERO, 16), (1, false), "at least one sample");
    }

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
