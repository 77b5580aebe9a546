//! The destination cache's working-set model of one warp
//! (`docs/warper-reference.md` §5), evaluated with the warp's own
//! geometry so that reports can set the measured peak occupancy beside it.
//!
//! Job: `WS ≈ Wsheet × (k + t + Δtilt + Δpar + Δring) × Bcache`, in tiles,
//! where
//! - `Wsheet` is the width of the fill's front in the derived image
//!   (samples): per ring band of the fill's order (`traversal.rs` rule 6),
//!   the longest line of each sweep in it, summed over the sweeps, and
//!   the largest such sum (one sweep: its longest line; the epipole inside
//!   the image: the ring's perimeter);
//! - `Δring` is [`crate::traversal::RING_BAND`] when that band holds more
//!   than one sweep (the warp runs a band of one sweep before the next, so
//!   the fill lags up to a band), else 0;
//! - `k` is the kernel limit and `t` the tile side (samples);
//! - `Δtilt = L·|sin θ|`, `L` the fill's longest line, `θ` the roll of the derived camera about its
//!   view axis relative to the reference (the angle of the reference's x
//!   axis in the derived image plane);
//! - `Δpar` is the parallax spread along the sweep: how far the derived
//!   position of the reference's centre sample moves, across the fill's
//!   lines, between the reference's nearest and farthest 1/Z (its coarse
//!   depth range); 0 if either lies behind the derived camera.
//!
//! Rules: a pure function of the warp's cameras, its coarse depth and the
//! fill's lines; it changes no timing and no value.
//!
//! Not modelled: everything the formula leaves out — the fill's lag behind
//! the warp's front beyond one ring band, release after the last tap
//! reader, the conservative chunk bounds of the schedule, and rings of the
//! reference and of the derived image that do not correspond.

use crate::camera::{Camera, WarpSetup};
use crate::schedule::CoarseDepth;
use crate::traversal::{Line, Major, RING_BAND, line_ring, sweep_of};
use glam::DVec3;
use std::collections::BTreeMap;

/// The model's terms for one warp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkingSet {
    /// `Wsheet` (samples).
    pub sheet_width: f64,
    /// `Δtilt` (samples).
    pub tilt: f64,
    /// `Δpar` (samples).
    pub parallax: f64,
    /// The prediction (tiles, rounded up).
    pub tiles: u64,
}

/// The model for the warp `setup` from camera `src` to `dst` of a
/// reference of `ref_size` samples with coarse depth `depth`, whose hole
/// fill visits
/// `fill_lines`, with kernels up to `kernel_limit` and `tile`-sample tiles.
pub fn predict(
    setup: &WarpSetup,
    (src, dst): (&Camera, &Camera),
    ref_size: (u32, u32),
    depth: &CoarseDepth,
    fill_lines: &[Line],
    kernel_limit: u32,
    tile: u32,
) -> WorkingSet {
    let Some(longest) = fill_lines.iter().max_by_key(|l| l.len()) else {
        return WorkingSet { sheet_width: 0.0, tilt: 0.0, parallax: 0.0, tiles: 0 };
    };
    // The front: per ring band, the longest line of each sweep, summed.
    let (dw, dh) = (dst.intrinsics.width, dst.intrinsics.height);
    let mut rings: BTreeMap<u64, [u32; 4]> = BTreeMap::new();
    for l in fill_lines {
        let w =
            &mut rings.entry(line_ring(dw, dh, &setup.epipole_derived, l)).or_default()[sweep_of(l.sheet).0 as usize];
        *w = (*w).max(l.len());
    }
    let (front, sweeps) = rings
        .values()
        .map(|w| (w.iter().map(|&v| v as u64).sum::<u64>(), w.iter().filter(|&&v| v > 0).count()))
        .max()
        .unwrap_or((0, 0));
    let sheet_width = front as f64;
    let ring = if sweeps > 1 { RING_BAND as f64 } else { 0.0 };
    // Roll: the reference's x axis seen in the derived camera's frame.
    let x_ref = src.pose.orientation * DVec3::X;
    let v = dst.pose.orientation.inverse() * x_ref;
    let roll = v.y.atan2(v.x);
    let tilt = longest.len() as f64 * roll.sin().abs();
    let parallax = match depth.overall() {
        Some((lo, hi)) => {
            let (cx, cy) = (ref_size.0 as f64 / 2.0, ref_size.1 as f64 / 2.0);
            let (a, b) = (setup.warp(cx, cy, lo), setup.warp(cx, cy, hi));
            if a.w > 0.0 && b.w > 0.0 && a.position.is_finite() && b.position.is_finite() {
                let d = b.position - a.position;
                match longest.major {
                    // Rows: the front moves across rows, along y.
                    Major::Row => d.y.abs(),
                    Major::Column => d.x.abs(),
                }
            } else {
                0.0
            }
        }
        None => 0.0,
    };
    let band = kernel_limit as f64 + tile as f64 + tilt + parallax + ring;
    let tiles = (sheet_width * band / (tile as f64 * tile as f64)).ceil() as u64;
    WorkingSet { sheet_width, tilt, parallax, tiles }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Pose};
    use crate::sample_image::SampleImage;
    use crate::traversal::forward_lines;
    use glam::DQuat;

    fn cam(pos: DVec3, roll: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { width: 64, height: 48, fx: 40.0, fy: 40.0, cx: 31.5, cy: 23.5 },
            pose: Pose { position: pos, orientation: DQuat::from_rotation_z(roll) },
        }
    }

    /// A fronto-parallel plane at depth `z` and one nearer block.
    fn depth(z: f32, near: f32) -> CoarseDepth {
        let mut img = SampleImage::empty(64, 48);
        for i in 0..64 * 48 {
            img.valid.set(i, true);
            img.z[i] = if i % 64 < 16 && i / 64 < 16 { near } else { z };
        }
        CoarseDepth::new(&img)
    }

    fn model(dst: &Camera, d: &CoarseDepth) -> WorkingSet {
        let src = cam(DVec3::ZERO, 0.0);
        let setup = WarpSetup::new(&src, dst);
        let lines = forward_lines(64, 48, &setup.epipole_derived);
        predict(&setup, (&src, dst), (64, 48), d, &lines, 4, 8)
    }

    #[test]
    fn terms_follow_roll_and_parallax() {
        // A small sideways step, no roll, one depth: only k + t remain.
        let flat = depth(10.0, 10.0);
        let w = model(&cam(DVec3::new(0.1, 0.0, 0.0), 0.0), &flat);
        assert_eq!((w.sheet_width, w.tilt, w.parallax), (48.0, 0.0, 0.0), "columns of 48 samples");
        assert_eq!(w.tiles, (48.0f64 * 12.0 / 64.0).ceil() as u64);
        // Rolled by 30 degrees: Δtilt = Wsheet / 2.
        let r = model(&cam(DVec3::new(0.1, 0.0, 0.0), 30f64.to_radians()), &flat);
        assert!((r.tilt - r.sheet_width * 0.5).abs() < 1e-9, "{r:?}");
        assert!(r.tiles > w.tiles);
        // A nearer block spreads the parallax along the sweep (x for columns):
        // 40 px focal × 0.1 step × (1/2 − 1/10) = 1.6 samples.
        let p = model(&cam(DVec3::new(0.1, 0.0, 0.0), 0.0), &depth(10.0, 2.0));
        assert!((p.parallax - 1.6).abs() < 0.2, "{p:?}");
    }
}
