//! Mean LDR-FLIP error.
//!
//! **Definition.** FLIP (Andersson, Nilsson, Akenine-Möller, Oskarsson,
//! Åström, Fairchild, "FLIP: A Difference Evaluator for Alternating Images",
//! Proc. ACM Comput. Graph. Interact. Tech. 3(2), HPG 2020) models what a
//! viewer flipping between a rendered image and its reference notices: a
//! colour pipeline (contrast sensitivity filters in a Yy·cx·cz opponent space,
//! Hunt-adjusted L\*a\*b\*, HyAB distance) combined with an edge and point
//! feature pipeline, giving a per-pixel error in [0, 1]. This module reports
//! the **mean of that error map over known pixels** (unitless; 0 = identical,
//! 1 = maximal error), the single number the FLIP authors recommend.
//!
//! **Conventions.**
//! * Implementation: NVIDIA's C++ reference code through the `nv-flip` crate
//!   (0.1.x), LDR-FLIP on **8-bit sRGB** input (the library decodes sRGB
//!   itself). The ground truth is FLIP's reference image, the warped image
//!   its test image.
//! * Viewing condition: the crate's default **67 pixels per degree**
//!   ([`PIXELS_PER_DEGREE`]: a 0.7 m wide, 3840-pixel monitor seen from
//!   0.7 m, FLIP's own default).
//! * The error map is computed on the whole image (the filters see every
//!   pixel) and averaged in `f64` over pixels whose `known` bit is set; none
//!   set gives NaN. `super::evaluate` first gives unknown image pixels the
//!   truth's codes, so unknown pixels add no difference to their neighbours.
//! * FLIP runs single-threaded (`nv-flip-sys`'s C++ is built at opt-level 3
//!   in the dev and test profiles too; see the root `Cargo.toml`).

use bitvec::vec::BitVec;

/// Pixels per degree of visual angle used for every FLIP score (the
/// `nv-flip` default, 67.0).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// FLIP error map (row-major, one value in [0, 1] per pixel) of `image`
/// against the reference `truth`, both 8-bit sRGB.
///
/// # Panics
/// If a slice's length is not `width·height`, or 3·width·height does not
/// fit in a `u32`.
pub fn flip_map(width: u32, height: u32, image: &[[u8; 3]], truth: &[[u8; 3]]) -> Vec<f32> {
    let n = width as u64 * height as u64;
    assert!(n * 3 <= u32::MAX as u64, "flip_map: image too large");
    assert!(image.len() as u64 == n && truth.len() as u64 == n, "flip_map: buffer lengths differ from width·height");
    if n == 0 {
        return Vec::new();
    }
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, truth.as_flattened());
    let test = nv_flip::FlipImageRgb8::with_data(width, height, image.as_flattened());
    nv_flip::flip(reference, test, PIXELS_PER_DEGREE).to_vec()
}

/// Mean FLIP error of `image` against `truth` (8-bit sRGB) over the pixels
/// whose `known` bit is set; NaN if none is.
///
/// # Panics
/// As [`flip_map`], or if `known` has the wrong length.
pub fn flip_mean(width: u32, height: u32, image: &[[u8; 3]], truth: &[[u8; 3]], known: &BitVec) -> f64 {
    assert_eq!(known.len() as u64, width as u64 * height as u64, "flip_mean: mask length differs from width·height");
    if known.not_any() {
        return f64::NAN;
    }
    let map = flip_map(width, height, image, truth);
    let (sum, count) = known.iter_ones().fold((0.0f64, 0u64), |(s, c), i| (s + map[i] as f64, c + 1));
    sum / count as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(n: usize) -> BitVec {
        BitVec::repeat(true, n)
    }

    /// A 32x32 test card: gradients and a few hard edges.
    fn card() -> Vec<[u8; 3]> {
        (0..32 * 32)
            .map(|i| {
                let (x, y) = (i % 32, i / 32);
                let edge = if (x / 8 + y / 8) % 2 == 0 { 40 } else { 0 };
                [(x * 6 + edge) as u8, (y * 6) as u8, (120 + edge) as u8]
            })
            .collect()
    }

    #[test]
    fn ppd_is_the_crate_default() {
        assert_eq!(PIXELS_PER_DEGREE, 67.0);
    }

    #[test]
    fn identical_is_zero() {
        let a = card();
        assert_eq!(flip_mean(32, 32, &a, &a, &all(a.len())), 0.0);
    }

    #[test]
    fn black_against_white_is_near_one() {
        let black = vec![[0u8; 3]; 32 * 32];
        let white = vec![[255u8; 3]; 32 * 32];
        // NVIDIA's FLIP gives 0.9674 here, not 1: colour errors are normalised
        // by the largest distance, between pure green and pure blue.
        let m = flip_mean(32, 32, &black, &white, &all(black.len()));
        assert!(m > 0.95 && m <= 1.0, "{m}");
        let back = flip_mean(32, 32, &white, &black, &all(black.len()));
        assert!((back - m).abs() < 1e-6, "{back} vs {m}");
    }

    #[test]
    fn grows_with_the_error() {
        let a = card();
        let mut last = 0.0;
        for k in [4u8, 16, 48, 96] {
            let b: Vec<[u8; 3]> = a.iter().map(|c| [c[0].saturating_add(k), c[1], c[2].saturating_sub(k)]).collect();
            let m = flip_mean(32, 32, &b, &a, &all(a.len()));
            assert!(m > last, "k = {k}: {m} !> {last}");
            last = m;
        }
        assert!(last > 0.2 && last < 1.0, "{last}");
    }

    #[test]
    fn mean_is_over_known_pixels_only() {
        let a = vec![[128u8; 3]; 16 * 16];
        let mut b = a.clone();
        // Left 4 columns very different.
        for y in 0..16 {
            for x in 0..4 {
                b[y * 16 + x] = [255, 0, 0];
            }
        }
        let map = flip_map(16, 16, &b, &a);
        let mut known = all(256);
        for y in 0..16 {
            for x in 0..8 {
                known.set(y * 16 + x, false);
            }
        }
        let want: f64 = known.iter_ones().map(|i| map[i] as f64).sum::<f64>() / 128.0;
        let got = flip_mean(16, 16, &b, &a, &known);
        assert_eq!(got, want);
        assert!(got < flip_mean(16, 16, &b, &a, &all(256)) / 4.0);
        assert!(flip_mean(16, 16, &b, &a, &BitVec::repeat(false, 256)).is_nan());
    }

    #[test]
    fn tiny_images_work() {
        for (w, h) in [(1u32, 1u32), (3, 1), (1, 5), (2, 2)] {
            let n = (w * h) as usize;
            let m = flip_mean(w, h, &vec![[0u8; 3]; n], &vec![[200u8, 10, 10]; n], &all(n));
            assert!(m.is_finite() && m > 0.1 && m <= 1.0, "{w}x{h}: {m}");
        }
    }
}
