//! Ground-truth visibility for rendered traces: which display pixels show
//! surfaces some reference sees (the truth's `seen` channel, the visibility
//! term of the common mask, `docs/metrics.md`).
//!
//! Rule: a truth sample is *seen* by a reference if the point it shows,
//! warped into the reference's sample grid with its exact depth
//! ([`postwarp_rtl::WarpSetup::warp`]), lies in front of the reference
//! camera and inside its image, and one of the reference samples of the
//! 3x3 neighbourhood of the nearest sample shows the same surface: 1/Z
//! within [`SAME_SURFACE_REL`] of the warped 1/Z (the reference's depth is
//! quantised; grazing surfaces change depth fast across a sample). A
//! sample with no surface (background) is seen if that neighbourhood holds
//! background too. A pixel is seen when every one of its samples is seen
//! by some reference: pixels at a disocclusion edge, partly unseen, are not.
//!
//! Not modelled: transparent and reflected layers (the first surface
//! decides).

use bitvec::vec::BitVec;
use postwarp_rtl::{Camera, SampleImage, WarpSetup};
use rayon::prelude::*;

/// Relative 1/Z difference within which a reference sample shows the same
/// surface as the warped truth sample.
pub const SAME_SURFACE_REL: f64 = 0.02;

/// The seen mask of a `width x height`-pixel truth rendered as `truth`
/// (`ss` samples per pixel along each axis) by camera `cam`, against the
/// references `(camera, samples)` (cameras at pixel resolution, as the
/// trace stores them).
pub fn seen_pixels(cam: &Camera, truth: &SampleImage, ss: u32, refs: &[(Camera, &SampleImage)]) -> BitVec {
    let (w, h) = (truth.width / ss, truth.height / ss);
    let src = cam.sample_grid(ss);
    let setups: Vec<(WarpSetup, &SampleImage)> =
        refs.iter().map(|(c, img)| (WarpSetup::new(&src, &c.sample_grid(ss)), *img)).collect();
    let sample_seen = |x: u32, y: u32| -> bool {
        let i = (y * truth.width + x) as usize;
        let surface = truth.valid[i];
        let inv_z = if surface { 1.0 / truth.z[i] as f64 } else { 0.0 };
        setups.iter().any(|(s, r)| {
            let p = s.warp(x as f64, y as f64, inv_z);
            if p.w <= 0.0 || !p.position.is_finite() {
                return false;
            }
            let (u, v) = (p.position.x.round(), p.position.y.round());
            if u < 0.0 || v < 0.0 || u >= r.width as f64 || v >= r.height as f64 {
                return false;
            }
            let (u, v) = (u as i64, v as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (a, b) = (u + dx, v + dy);
                    if a < 0 || b < 0 || a >= r.width as i64 || b >= r.height as i64 {
                        return false;
                    }
                    let j = (b as u32 * r.width + a as u32) as usize;
                    match (surface, r.valid[j]) {
                        (true, true) => {
                            let iz = 1.0 / r.z[j] as f64;
                            (iz - p.inv_z).abs() <= SAME_SURFACE_REL * iz.max(p.inv_z)
                        }
                        (false, false) => true,
                        _ => false,
                    }
                })
            })
        })
    };
    let rows: Vec<Vec<bool>> = (0..h)
        .into_par_iter()
        .map(|py| {
            (0..w).map(|px| (0..ss).all(|sy| (0..ss).all(|sx| sample_seen(px * ss + sx, py * ss + sy)))).collect()
        })
        .collect();
    rows.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use postwarp_rtl::camera::{Intrinsics, Pose};

    fn cam(x: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { width: 16, height: 8, fx: 10.0, fy: 10.0, cx: 7.5, cy: 3.5 },
            pose: Pose { position: DVec3::new(x, 0.0, 0.0), orientation: DQuat::IDENTITY },
        }
    }

    /// A wall at depth 10 with a near box at depth 2 over columns `near`.
    fn scene(near: std::ops::Range<u32>) -> SampleImage {
        let mut img = SampleImage::empty(16, 8);
        for y in 0..8 {
            for x in 0..16 {
                let i = (y * 16 + x) as usize;
                img.valid.set(i, true);
                img.z[i] = if near.contains(&x) { 2.0 } else { 10.0 };
            }
        }
        img
    }

    #[test]
    fn the_same_view_sees_everything_and_a_hidden_wall_is_not_seen() {
        let truth = scene(6..10);
        let all = seen_pixels(&cam(0.0), &truth, 1, &[(cam(0.0), &truth)]);
        assert_eq!(all.count_ones(), 16 * 8, "a reference at the truth's viewpoint sees every pixel");
        // The truth without the box: the reference's box (columns 6-9)
        // hides the wall behind it; the 3x3 look-up forgives one sample at
        // each edge, so columns 7 and 8 stay unseen, and nothing else.
        let wall = scene(0..0);
        let m = seen_pixels(&cam(0.0), &wall, 1, &[(cam(0.0), &truth)]);
        for y in 0..8 {
            for x in 0..16 {
                assert_eq!(m[y * 16 + x], !(7..9).contains(&x), "({x}, {y})");
            }
        }
        // A reference moved sideways sees the wall beside the box, not what
        // it moved out of its field of view.
        let moved = seen_pixels(&cam(0.0), &wall, 1, &[(cam(4.0), &wall)]);
        assert!(moved.count_ones() < 16 * 8 && moved.count_ones() > 0);
        assert!(moved[8 * 15], "the right edge stays in view of a camera moved right");
        assert!(!moved[0], "the left edge leaves it");
    }
}
