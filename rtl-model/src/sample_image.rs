//! A frame as the warper sees it: one record per super-sample.
//!
//! Plain data shared by the golden model, the hardware model and the trace
//! loader. Row-major, `index = y·width + x`, sample coordinates as in
//! [`crate::camera::Intrinsics::sample_grid`].

use bitvec::vec::BitVec;

/// Per-sample planes of a reference frame (or a rendered view).
#[derive(Clone, Debug, PartialEq)]
pub struct SampleImage {
    /// Width in samples.
    pub width: u32,
    /// Height in samples.
    pub height: u32,
    /// Linear RGB colour, each channel nominally in [0, 1].
    pub colour: Vec<[f32; 3]>,
    /// Depth `Z` along the optical axis (scene units). Meaningful only where
    /// `valid` is set.
    pub z: Vec<f32>,
    /// Screen-space slopes of 1/Z: `(∂(1/Z)/∂x, ∂(1/Z)/∂y)` per sample step
    /// (1/scene unit per sample). Meaningful only where `valid` is set.
    pub inv_z_slopes: Vec<[f32; 2]>,
    /// Object id of the surface seen (0 when unknown or no surface).
    pub object_id: Vec<u32>,
    /// Set where the sample sees a surface; clear for "no surface" (sky,
    /// unknown depth in captured data).
    pub valid: BitVec,
}

impl SampleImage {
    /// An image of `width x height` samples with no surface anywhere.
    pub fn empty(width: u32, height: u32) -> SampleImage {
        let n = width as usize * height as usize;
        SampleImage {
            width,
            height,
            colour: vec![[0.0; 3]; n],
            z: vec![0.0; n],
            inv_z_slopes: vec![[0.0; 2]; n],
            object_id: vec![0; n],
            valid: BitVec::repeat(false, n),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// True if the image has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Linear index of sample `(x, y)`.
    pub fn index(&self, x: u32, y: u32) -> usize {
        debug_assert!(x < self.width && y < self.height);
        y as usize * self.width as usize + x as usize
    }

    /// Smallest and largest valid depth, `None` if no sample is valid.
    pub fn depth_range(&self) -> Option<(f32, f32)> {
        self.valid.iter_ones().fold(None, |acc, i| {
            let z = self.z[i];
            Some(match acc {
                None => (z, z),
                Some((lo, hi)) => (lo.min(z), hi.max(z)),
            })
        })
    }

    /// Replace the slopes by edge-aware finite differences of 1/Z
    /// ([`SAME_SURFACE_REL`]); see [`SampleImage::slopes_from_depth_with`].
    /// Used when a producer supplies depth without slopes.
    pub fn slopes_from_depth(&mut self) {
        self.slopes_from_depth_with(SAME_SURFACE_REL);
    }

    /// Replace the slopes by edge-aware finite differences of 1/Z, per axis
    /// and per sample `c` with neighbours `p` (before) and `n` (after):
    ///
    /// 1. A neighbour counts only if it is inside the image, valid, and on
    ///    the same surface as `c`: `|1/Z_n − 1/Z_c| ≤ rel · max(1/Z_n,
    ///    1/Z_c)` ([`same_surface`]).
    /// 2. Both count: the central difference `(n − p)/2`. One counts: the
    ///    one-sided difference with it (`n − c` or `c − p`). None counts
    ///    (a one-sample-wide line, an isolated sample): 0.
    ///
    /// So a central difference never spans a depth step: across a step the
    /// slope is the sample's own surface's, and a kernel built from it does
    /// not grow by a share of the step.
    pub fn slopes_from_depth_with(&mut self, rel: f64) {
        let (w, h) = (self.width as usize, self.height as usize);
        let inv = |s: &SampleImage, i: usize| {
            if s.valid[i] { Some(1.0 / s.z[i] as f64) } else { None }
        };
        let mut out = vec![[0.0f32; 2]; self.len()];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let Some(c) = inv(self, i) else { continue };
                let near = |v: Option<f64>| v.filter(|&v| same_surface(c, v, rel));
                let axis = |prev: Option<f64>, next: Option<f64>| match (near(prev), near(next)) {
                    (Some(p), Some(n)) => (n - p) / 2.0,
                    (Some(p), None) => c - p,
                    (None, Some(n)) => n - c,
                    (None, None) => 0.0,
                };
                let gx =
                    axis(if x > 0 { inv(self, i - 1) } else { None }, if x + 1 < w { inv(self, i + 1) } else { None });
                let gy =
                    axis(if y > 0 { inv(self, i - w) } else { None }, if y + 1 < h { inv(self, i + w) } else { None });
                out[i] = [gx as f32, gy as f32];
            }
        }
        self.inv_z_slopes = out;
    }
}

/// Threshold of the finite-difference slopes' same-surface test
/// ([`same_surface`]), as a fraction of the larger 1/Z: neighbours whose
/// 1/Z differ by more than this share are taken to lie on different
/// surfaces. Chosen on the Middlebury Motorcycle pair (`docs/real-data.md`).
pub const SAME_SURFACE_REL: f64 = 0.015;

/// Two samples with inverse depths `a` and `b` (> 0) lie on one surface for
/// the finite-difference slopes: `|a − b| ≤ rel · max(a, b)`.
pub fn same_surface(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.max(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_difference_slopes_are_exact_on_affine_inverse_depth() {
        // 1/Z = 1 + 0.001·x − 0.002·y (one surface: well under 1.5 % per
        // step): the slopes are exact everywhere, including at borders and
        // next to an invalid sample.
        let mut s = SampleImage::empty(5, 5);
        for y in 0..5 {
            for x in 0..5 {
                let i = s.index(x, y);
                s.z[i] = 1.0 / (1.0 + 0.001 * x as f32 - 0.002 * y as f32);
                s.valid.set(i, true);
            }
        }
        let hole = s.index(2, 2);
        s.valid.set(hole, false);
        s.slopes_from_depth();
        for i in s.valid.iter_ones() {
            assert!((s.inv_z_slopes[i][0] - 0.001).abs() < 1e-5, "{i}: {:?}", s.inv_z_slopes[i]);
            assert!((s.inv_z_slopes[i][1] + 0.002).abs() < 1e-5, "{i}: {:?}", s.inv_z_slopes[i]);
        }
        assert_eq!(s.depth_range().map(|(a, b)| a < b), Some(true));
    }

    /// A `w x 1` row with inverse depth `inv(x)` everywhere.
    fn row(w: u32, inv: impl Fn(u32) -> f64) -> SampleImage {
        let mut s = SampleImage::empty(w, 1);
        for x in 0..w {
            s.z[x as usize] = (1.0 / inv(x)) as f32;
            s.valid.set(x as usize, true);
        }
        s.slopes_from_depth();
        s
    }

    fn dx(s: &SampleImage) -> Vec<f32> {
        s.inv_z_slopes.iter().map(|g| g[0]).collect()
    }

    #[test]
    fn a_slanted_plane_gets_its_slope_everywhere() {
        // 1/Z = 0.5 + 0.004·x: 0.8 % per sample, one surface.
        let s = row(8, |x| 0.5 + 0.004 * x as f64);
        for (x, g) in dx(&s).into_iter().enumerate() {
            assert!((g - 0.004).abs() < 1e-6, "x = {x}: {g}");
        }
    }

    #[test]
    fn a_step_edge_keeps_each_side_its_own_slope() {
        // Background 1/Z = 0.2 + 0.001·x (x < 4), foreground 1/Z = 0.5 (x ≥ 4):
        // a central difference across the step would give ≈ 0.15 at x = 3, 4.
        let s = row(8, |x| if x < 4 { 0.2 + 0.001 * x as f64 } else { 0.5 });
        let g = dx(&s);
        for (x, v) in g.iter().enumerate() {
            let want = if x < 4 { 0.001 } else { 0.0 };
            assert!((v - want).abs() < 1e-6, "x = {x}: {v}, expected {want}");
        }
        assert!(!same_surface(0.203, 0.5, SAME_SURFACE_REL));
    }

    #[test]
    fn a_one_sample_wide_line_is_flat_across_and_sloped_along() {
        // A vertical line at x = 2 in front of a plane: across it (x) both
        // neighbours are another surface, so its x slope is 0; along it (y)
        // both are the line, so the central difference holds.
        let (w, h) = (5u32, 4u32);
        let mut s = SampleImage::empty(w, h);
        for y in 0..h {
            for x in 0..w {
                let i = s.index(x, y);
                let inv = if x == 2 { 1.0 + 0.005 * y as f64 } else { 0.25 };
                s.z[i] = (1.0 / inv) as f32;
                s.valid.set(i, true);
            }
        }
        s.slopes_from_depth();
        for y in 0..h {
            let [gx, gy] = s.inv_z_slopes[s.index(2, y)];
            assert_eq!(gx, 0.0, "y = {y}");
            assert!((gy - 0.005).abs() < 1e-6, "y = {y}: {gy}");
            // The plane beside the line: one-sided away from it, flat.
            assert_eq!(s.inv_z_slopes[s.index(1, y)][0], 0.0);
            assert_eq!(s.inv_z_slopes[s.index(3, y)][0], 0.0);
        }
    }

    #[test]
    fn the_same_surface_test_is_relative_to_the_larger_inverse_depth() {
        assert!(same_surface(1.0, 0.986, 0.015));
        assert!(!same_surface(1.0, 0.98, 0.015));
        assert!(same_surface(0.986, 1.0, 0.015), "symmetric");
        // An unbounded threshold is the old central difference.
        let mut s = row(3, |x| [0.2, 0.2, 0.8][x as usize]);
        s.slopes_from_depth_with(f64::INFINITY);
        assert!((dx(&s)[1] - 0.3).abs() < 1e-6);
    }
}
