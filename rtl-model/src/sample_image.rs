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

    /// Replace the slopes by central finite differences of 1/Z between valid
    /// neighbours (one-sided at borders and next to invalid samples; zero
    /// where a sample has no valid neighbour along an axis). Used when a
    /// producer supplies depth without slopes.
    pub fn slopes_from_depth(&mut self) {
        let (w, h) = (self.width as usize, self.height as usize);
        let inv = |s: &SampleImage, i: usize| {
            if s.valid[i] { Some(1.0 / s.z[i] as f64) } else { None }
        };
        let mut out = vec![[0.0f32; 2]; self.len()];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let Some(c) = inv(self, i) else { continue };
                let axis = |prev: Option<f64>, next: Option<f64>| match (prev, next) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_difference_slopes_are_exact_on_affine_inverse_depth() {
        // 1/Z = 0.1 + 0.01·x − 0.02·y: the slopes are exact everywhere,
        // including at borders and next to an invalid sample.
        let mut s = SampleImage::empty(5, 5);
        for y in 0..5 {
            for x in 0..5 {
                let i = s.index(x, y);
                s.z[i] = 1.0 / (0.1 + 0.01 * x as f32 - 0.02 * y as f32 + 0.1);
                s.valid.set(i, true);
            }
        }
        let hole = s.index(2, 2);
        s.valid.set(hole, false);
        s.slopes_from_depth();
        for i in s.valid.iter_ones() {
            assert!((s.inv_z_slopes[i][0] - 0.01).abs() < 1e-5, "{i}: {:?}", s.inv_z_slopes[i]);
            assert!((s.inv_z_slopes[i][1] + 0.02).abs() < 1e-5, "{i}: {:?}", s.inv_z_slopes[i]);
        }
        assert_eq!(s.depth_range().map(|(a, b)| a < b), Some(true));
    }
}
