//! Kernel setup ("neighbourhood" unit): the reconstruction kernel of each
//! reference sample from its warped 3x3 neighbourhood (TR98 §6, §7.2;
//! `docs/warper-reference.md` §3).
//!
//! Job: run the discontinuity and fold-over tests on the 2x2 groups
//! around a sample, produce its four kernel corners and their bounding
//! box, and tag forward edges (TR98 App. B.1).
//!
//! Ports: in, warped samples from the transform unit into a line buffer of
//! three traversal lines (the previous, current and next row of a
//! row-major sheet, or columns of a column-major one), each one sample
//! wider than the current line at both ends; out, one kernel per sample to
//! the rasterizer.
//!
//! Throughput: one kernel per cycle per transform lane
//! (`transform_throughput`); a line's kernels start once the next line of
//! its sheet has been transformed (the engine enforces this).
//!
//! Rules:
//! 1. Two samples at offset `o` (|o| = 1 or √2) are one surface iff their
//!    warped distance is at most `threshold · |o| · (E_a + E_b)/2`
//!    (compared squared).
//! 2. A corner is shared by the 2x2 group around it: if the four samples
//!    are warped surfaces, all six pairs pass rule 1 and the quadrilateral
//!    A, B, D, C keeps the reference winding (all four edge cross products
//!    strictly positive), the corner is the mean of the four positions.
//! 3. Otherwise the corner is the sample's exact edge corner, or its own
//!    position if that corner is behind the derived camera.
//! 4. The kernel is the axis-aligned box of the corners.
//! 5. Forward edge: the backward neighbour is the 8-neighbour nearest the
//!    direction `−D(p)` in the reference (`D` toward the reference-image
//!    epipole); if it is a deeper, warped surface failing rule 1, its
//!    colour goes to the hole-fill plane instead of the sample's own.
//!
//! Not modelled: line-buffer capacity stalls (the buffer is sized for the
//! longest line of the reference).

use super::transform::{TransformUnit, Warped};
use crate::camera::Epipole;
use glam::DVec2;

/// Why a 2x2 group's corner is not shared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Group {
    /// Rule 2 holds: shared corner at the mean.
    Shared(DVec2),
    /// A sample is missing (no surface, culled, or off the image).
    Missing,
    /// Some pair fails rule 1.
    Discontinuous,
    /// The warped quadrilateral folds over.
    Folded,
}

/// Rule 1.
#[inline]
pub fn one_surface(a: &Warped, b: &Warped, offset_len: f64, threshold: f64) -> bool {
    let limit = threshold * offset_len * 0.5 * (a.e + b.e);
    (a.pos - b.pos).length_squared() <= limit * limit
}

#[inline]
fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The 2x2 group with samples `a` (top left), `b` (top right), `c` (bottom
/// left), `d` (bottom right), rule 2.
#[inline]
pub fn group(a: Option<Warped>, b: Option<Warped>, c: Option<Warped>, d: Option<Warped>, threshold: f64) -> Group {
    let (Some(a), Some(b), Some(c), Some(d)) = (a, b, c, d) else { return Group::Missing };
    let r2 = std::f64::consts::SQRT_2;
    let pairs = [(&a, &b, 1.0), (&c, &d, 1.0), (&a, &c, 1.0), (&b, &d, 1.0), (&a, &d, r2), (&b, &c, r2)];
    if !pairs.iter().all(|(p, q, o)| one_surface(p, q, *o, threshold)) {
        return Group::Discontinuous;
    }
    let q = [a.pos, b.pos, d.pos, c.pos];
    if (0..4).any(|k| cross(q[(k + 1) % 4] - q[k], q[(k + 2) % 4] - q[(k + 1) % 4]) <= 0.0) {
        return Group::Folded;
    }
    Group::Shared((a.pos + b.pos + c.pos + d.pos) * 0.25)
}

/// Corners of sample `(x, y)` (warped `t`, 1/Z `inv_z`, reference slopes
/// `slopes`) given the four groups around it, in the order top-left,
/// top-right, bottom-left, bottom-right (`None`: off the image). Returns the
/// corners and how many were edge corners (rules 2–3).
#[inline]
pub fn corners(
    tu: &TransformUnit,
    t: &Warped,
    x: u32,
    y: u32,
    inv_z: f64,
    slopes: [f32; 2],
    groups: [Option<Group>; 4],
) -> ([DVec2; 4], u32) {
    let mut out = [DVec2::ZERO; 4];
    let mut edges = 0;
    for (k, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)].into_iter().enumerate() {
        out[k] = match groups[k] {
            Some(Group::Shared(c)) => c,
            _ => {
                edges += 1;
                tu.edge_corner(x as f64, y as f64, inv_z, slopes, sx, sy).unwrap_or(t.pos)
            }
        };
    }
    (out, edges)
}

/// Rule 4: `(x0, x1, y0, y1)`.
#[inline]
pub fn bounding_box(c: &[DVec2; 4]) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (c[0].x, c[0].x, c[0].y, c[0].y);
    for p in &c[1..] {
        x0 = x0.min(p.x);
        x1 = x1.max(p.x);
        y0 = y0.min(p.y);
        y1 = y1.max(p.y);
    }
    (x0, x1, y0, y1)
}

/// Rule 5's direction: the 8-neighbour offset nearest `−D(x, y)` for the
/// reference-image epipole `e`; `None` where `D` vanishes.
#[inline]
pub fn backward_step(e: &Epipole, x: u32, y: u32) -> Option<(i32, i32)> {
    let d = -e.direction_at(DVec2::new(x as f64, y as f64));
    if d.length_squared() == 0.0 || !d.is_finite() {
        return None;
    }
    // 45° sectors split at tan(22.5°) = √2 − 1.
    const T: f64 = std::f64::consts::SQRT_2 - 1.0;
    let (ax, ay) = (d.x.abs(), d.y.abs());
    let sx = if d.x < 0.0 { -1 } else { 1 };
    let sy = if d.y < 0.0 { -1 } else { 1 };
    Some(if ay <= T * ax {
        (sx, 0)
    } else if ax <= T * ay {
        (0, sy)
    } else {
        (sx, sy)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(x: f64, y: f64) -> Option<Warped> {
        Some(Warped { pos: DVec2::new(x, y), inv_z: 1.0, e: 1.0 })
    }

    #[test]
    fn groups_share_the_mean_or_say_why_not() {
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(1.0, 1.0), 1.4), Group::Shared(DVec2::splat(0.5)));
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(3.0, 1.0), 1.4), Group::Discontinuous);
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), None, 1.4), Group::Missing);
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(0.2, 0.2), 1.4), Group::Folded);
    }

    #[test]
    fn backward_step_points_away_from_a_front_epipole() {
        let e = Epipole { h: glam::DVec3::new(10.0, 10.0, 1.0) };
        assert_eq!(backward_step(&e, 20, 10), Some((1, 0)));
        assert_eq!(backward_step(&e, 0, 0), Some((-1, -1)));
        assert_eq!(backward_step(&e, 10, 10), None);
    }
}
