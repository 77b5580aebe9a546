//! Kernel setup: the reconstruction kernel of each reference sample
//! (TR98 §6, §7.2; `docs/warper-reference.md` §3).
//!
//! Rules:
//! 1. Discontinuity test (view-dependent): two reference samples at offset
//!    `o` (|o| = 1 or √2) are the same surface iff their warped distance is at
//!    most `threshold · |o| · (E_a + E_b)/2`.
//! 2. Each kernel corner is shared by the 2x2 group of samples around it.
//!    If all four are warped surfaces, all six pairs pass rule 1 and the
//!    warped quadrilateral (A, B, D, C in reference order) is convex and
//!    front-facing (all four edge cross products positive, the reference
//!    winding), the corner is the mean of the four warped positions: the
//!    mesh has no cracks.
//! 3. Otherwise (edge, fold-over, image border) the corner is the sample's
//!    own exact splat corner (`transform` rule 2); if even that is behind
//!    the derived camera, the sample's own position.
//! 4. The kernel is the axis-aligned bounding box of the four corners.
//!
//! Not modelled: the line buffer (the hardware's; here the whole
//! reference is at hand).

use super::transform::{Transformed, WarpContext};
use glam::DVec2;
use postwarp_rtl::SampleImage;

/// Why a group's corner is not shared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupState {
    /// All four samples are the same surface: shared corner.
    Shared,
    /// A sample is missing (no surface or culled).
    Missing,
    /// Some pair fails the discontinuity test.
    Discontinuous,
    /// The warped quadrilateral folds over.
    Folded,
}

/// Rule 1.
#[inline(always)]
pub fn same_surface(a: &Transformed, b: &Transformed, offset_len: f64, threshold: f64) -> bool {
    // Compared squared: no square root per pair.
    let limit = threshold * offset_len * 0.5 * (a.e + b.e);
    (a.pos - b.pos).length_squared() <= limit * limit
}

fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Fold-over test: quad A, B, D, C (reference order) must keep the
/// reference winding at all four corners.
#[inline(always)]
pub fn folded(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let q = [a, b, d, c];
    (0..4).any(|k| cross(q[(k + 1) % 4] - q[k], q[(k + 2) % 4] - q[(k + 1) % 4]) <= 0.0)
}

/// State and shared corner of the group whose top-left sample is `(gx, gy)`;
/// `at(x, y)` gives a sample's warp (`None`: no surface or culled).
#[inline(always)]
pub fn group(at: impl Fn(u32, u32) -> Option<Transformed>, gx: u32, gy: u32, threshold: f64) -> (GroupState, DVec2) {
    let (Some(a), Some(b), Some(c), Some(d)) = (at(gx, gy), at(gx + 1, gy), at(gx, gy + 1), at(gx + 1, gy + 1)) else {
        return (GroupState::Missing, DVec2::ZERO);
    };
    let s2 = std::f64::consts::SQRT_2;
    let pairs = [(&a, &b, 1.0), (&c, &d, 1.0), (&a, &c, 1.0), (&b, &d, 1.0), (&a, &d, s2), (&b, &c, s2)];
    if !pairs.iter().all(|(p, q, o)| same_surface(p, q, *o, threshold)) {
        return (GroupState::Discontinuous, DVec2::ZERO);
    }
    if folded(a.pos, b.pos, c.pos, d.pos) {
        return (GroupState::Folded, DVec2::ZERO);
    }
    (GroupState::Shared, (a.pos + b.pos + c.pos + d.pos) * 0.25)
}

/// The four corners of sample `(x, y)`'s kernel, and how many were edge
/// corners (rules 2–3). `group_at(gx, gy)` gives the state and shared corner
/// of the group whose top-left sample is `(gx, gy)`.
#[inline(always)]
pub fn corners(
    ctx: &WarpContext,
    img: &SampleImage,
    t: &Transformed,
    group_at: impl Fn(u32, u32) -> (GroupState, DVec2),
    x: u32,
    y: u32,
) -> ([DVec2; 4], u32) {
    let (w, h) = (img.width, img.height);
    let i = img.index(x, y);
    let mut out = [DVec2::ZERO; 4];
    let mut edges = 0;
    for (k, (sx, sy)) in [(-1i32, -1i32), (1, -1), (-1, 1), (1, 1)].into_iter().enumerate() {
        let gx = x as i64 + if sx < 0 { -1 } else { 0 };
        let gy = y as i64 + if sy < 0 { -1 } else { 0 };
        let shared = if gx >= 0 && gy >= 0 && (gx as u32) + 1 < w && (gy as u32) + 1 < h {
            let g = group_at(gx as u32, gy as u32);
            (g.0 == GroupState::Shared).then_some(g.1)
        } else {
            None
        };
        out[k] = match shared {
            Some(c) => c,
            None => {
                edges += 1;
                let inv_z = 1.0 / img.z[i] as f64;
                ctx.edge_corner(x as f64, y as f64, inv_z, img.inv_z_slopes[i], sx as f64, sy as f64).unwrap_or(t.pos)
            }
        };
    }
    (out, edges)
}

/// [`corners`] with the reference's 1/Z `inv_z` at the sample (rounded in
/// fixed mode) and the fixed mode's saturations: those of the edge
/// corners' warps (the transform's) and of the shared corners used
/// (`group_sat(gx, gy)`: kernel setup's), `[transform, kernel_setup]`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn corners_counted(
    ctx: &WarpContext,
    img: &SampleImage,
    inv_z: f64,
    t: &Transformed,
    group_at: impl Fn(u32, u32) -> (GroupState, DVec2),
    group_sat: impl Fn(u32, u32) -> bool,
    x: u32,
    y: u32,
) -> ([DVec2; 4], u32, [u32; 2]) {
    let (w, h) = (img.width, img.height);
    let i = img.index(x, y);
    let mut out = [DVec2::ZERO; 4];
    let mut edges = 0;
    let mut sat = [0; 2];
    for (k, (sx, sy)) in [(-1i32, -1i32), (1, -1), (-1, 1), (1, 1)].into_iter().enumerate() {
        let gx = x as i64 + if sx < 0 { -1 } else { 0 };
        let gy = y as i64 + if sy < 0 { -1 } else { 0 };
        let shared = if gx >= 0 && gy >= 0 && (gx as u32) + 1 < w && (gy as u32) + 1 < h {
            let g = group_at(gx as u32, gy as u32);
            (g.0 == GroupState::Shared).then(|| (g.1, group_sat(gx as u32, gy as u32)))
        } else {
            None
        };
        out[k] = match shared {
            Some((c, s)) => {
                sat[1] += s as u32;
                c
            }
            None => {
                edges += 1;
                let (c, n) =
                    ctx.edge_corner_counted(x as f64, y as f64, inv_z, img.inv_z_slopes[i], sx as f64, sy as f64);
                sat[0] += n;
                c.unwrap_or(t.pos)
            }
        };
    }
    (out, edges, sat)
}

/// Rule 4: `(x0, x1, y0, y1)`.
#[inline(always)]
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

#[cfg(test)]
mod tests {
    use super::*;

    fn t(x: f64, y: f64) -> Transformed {
        Transformed { pos: DVec2::new(x, y), inv_z: 1.0, e: 1.0, sat: 0 }
    }

    #[test]
    fn discontinuity_threshold() {
        assert!(same_surface(&t(0.0, 0.0), &t(1.4, 0.0), 1.0, 1.4));
        assert!(!same_surface(&t(0.0, 0.0), &t(1.41, 0.0), 1.0, 1.4));
        assert!(same_surface(&t(0.0, 0.0), &t(1.4, 1.4), std::f64::consts::SQRT_2, 1.4));
    }

    #[test]
    fn fold_over_detection() {
        let (a, b, c, d) = (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0), DVec2::new(1.0, 1.0));
        assert!(!folded(a, b, c, d));
        // B moved past A: back-facing.
        assert!(folded(a, DVec2::new(-0.5, 0.0), c, d));
        // D pulled inside: non-convex.
        assert!(folded(a, b, c, DVec2::new(0.2, 0.2)));
    }

    #[test]
    fn group_shares_the_mean_corner() {
        let warped = vec![Some(t(0.0, 0.0)), Some(t(1.0, 0.0)), Some(t(0.0, 1.0)), Some(t(1.0, 1.0))];
        fn at(w: &[Option<Transformed>]) -> impl Fn(u32, u32) -> Option<Transformed> + '_ {
            move |x, y| w[(y * 2 + x) as usize]
        }
        let (s, c) = group(at(&warped), 0, 0, 1.4);
        assert_eq!((s, c), (GroupState::Shared, DVec2::new(0.5, 0.5)));
        let mut gap = warped.clone();
        gap[3] = Some(t(3.0, 1.0));
        assert_eq!(group(at(&gap), 0, 0, 1.4).0, GroupState::Discontinuous);
        gap[3] = None;
        assert_eq!(group(at(&gap), 0, 0, 1.4).0, GroupState::Missing);
    }
}
