//! Peak signal-to-noise ratio on 8-bit sRGB codes.
//!
//! **Definition.** PSNR = 10·log10(255² / MSE) in **dB**, where MSE is the
//! mean squared difference of 8-bit sRGB codes (both images encoded with
//! [`crate::picture::linear_to_srgb8`]; peak 255):
//!
//! * **RGB** ([`psnr_rgb`]): MSE averaged over the three channels and the
//!   scored pixels, MSE = Σ_pixels Σ_c (a_c − b_c)² / (3·N).
//! * **Luma** ([`psnr_plane`] on [`luma`]): Y' = 0.299·R' + 0.587·G' +
//!   0.114·B' (ITU-R BT.601 weights applied to the gamma-encoded sRGB codes,
//!   not rounded), which is what image and video papers report as
//!   "luminance PSNR".
//!
//! **Conventions.** Only pixels whose mask bit is set are scored. MSE = 0
//! (identical on every scored pixel) gives +∞; no scored pixel gives NaN
//! (see [`crate::metrics`] for how both are serialized). Sums are in `f64`
//! in pixel order, so results are deterministic.
//!
//! **References.** ITU-R BT.601-7 (luma weights); IEC 61966-2-1 (sRGB).

use bitvec::vec::BitVec;

/// Peak code value of 8-bit images.
pub const PEAK: f64 = 255.0;

/// BT.601 luma weights for R', G', B'.
pub const LUMA_WEIGHTS: [f64; 3] = [0.299, 0.587, 0.114];

/// BT.601 luma Y' of an 8-bit sRGB pixel, in code units (0–255, not rounded).
pub fn luma(c: [u8; 3]) -> f64 {
    LUMA_WEIGHTS[0] * c[0] as f64 + LUMA_WEIGHTS[1] * c[1] as f64 + LUMA_WEIGHTS[2] * c[2] as f64
}

/// PSNR (dB) for a mean squared error in code units² with peak 255: +∞ for
/// MSE = 0, NaN for NaN.
pub fn psnr_from_mse(mse: f64) -> f64 {
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (PEAK * PEAK / mse).log10() }
}

/// RGB PSNR (dB) of 8-bit sRGB pixels over the pixels whose `mask` bit is set.
/// NaN if none is; +∞ if they are all equal.
///
/// # Panics
/// If the slices and the mask differ in length.
pub fn psnr_rgb(image: &[[u8; 3]], truth: &[[u8; 3]], mask: &BitVec) -> f64 {
    assert!(image.len() == truth.len() && image.len() == mask.len(), "psnr_rgb: buffer lengths differ");
    let mut sum = 0.0f64;
    let mut n = 0u64;
    for i in mask.iter_ones() {
        for c in 0..3 {
            let d = image[i][c] as f64 - truth[i][c] as f64;
            sum += d * d;
        }
        n += 1;
    }
    if n == 0 { f64::NAN } else { psnr_from_mse(sum / (3 * n) as f64) }
}

/// PSNR (dB) of one plane in code units (e.g. [`luma`]) over the pixels whose
/// `mask` bit is set. NaN if none is; +∞ if they are all equal.
///
/// # Panics
/// If the slices and the mask differ in length.
pub fn psnr_plane(image: &[f64], truth: &[f64], mask: &BitVec) -> f64 {
    assert!(image.len() == truth.len() && image.len() == mask.len(), "psnr_plane: buffer lengths differ");
    let mut sum = 0.0f64;
    let mut n = 0u64;
    for i in mask.iter_ones() {
        let d = image[i] - truth[i];
        sum += d * d;
        n += 1;
    }
    if n == 0 { f64::NAN } else { psnr_from_mse(sum / n as f64) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lumas(px: &[[u8; 3]]) -> Vec<f64> {
        px.iter().map(|&c| luma(c)).collect()
    }

    #[test]
    fn identical_is_infinite() {
        let a: Vec<[u8; 3]> = (0..64u8).map(|i| [i, i.wrapping_mul(3), 255 - i]).collect();
        let m = BitVec::repeat(true, a.len());
        assert_eq!(psnr_rgb(&a, &a, &m), f64::INFINITY);
        assert_eq!(psnr_plane(&lumas(&a), &lumas(&a), &m), f64::INFINITY);
    }

    #[test]
    fn constant_error_in_one_channel_gives_the_closed_form() {
        for k in [1u8, 2, 5, 17, 100] {
            let a = vec![[100u8, 50, 20]; 30];
            let b = vec![[100u8, 50, 20 + k]; 30];
            let m = BitVec::repeat(true, a.len());
            let kf = k as f64;
            let want = 10.0 * (255.0f64 * 255.0 / (kf * kf / 3.0)).log10();
            assert!((psnr_rgb(&a, &b, &m) - want).abs() < 1e-12, "k = {k}");
        }
    }

    #[test]
    fn luma_weights_on_a_pure_green_error() {
        let a = vec![[10u8, 10, 10]; 16];
        let b = vec![[10u8, 30, 10]; 16];
        let m = BitVec::repeat(true, a.len());
        let d = 0.587 * 20.0;
        let want = 10.0 * (255.0f64 * 255.0 / (d * d)).log10();
        let got = psnr_plane(&lumas(&a), &lumas(&b), &m);
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        // Red and blue weigh less than green: the same error in blue scores higher.
        let c = vec![[10u8, 10, 30]; 16];
        assert!(psnr_plane(&lumas(&a), &lumas(&c), &m) > got + 10.0);
    }

    #[test]
    fn masked_pixels_do_not_count() {
        let a = vec![[0u8; 3]; 10];
        let mut b = a.clone();
        b[3] = [255, 255, 255];
        b[7] = [255, 0, 255];
        b[0] = [0, 0, 1];
        let mut m = BitVec::repeat(true, 10);
        m.set(3, false);
        m.set(7, false);
        // Only pixel 0 differs among the 8 scored: MSE = 1 / (3·8).
        let want = 10.0 * (255.0f64 * 255.0 * 24.0).log10();
        assert!((psnr_rgb(&a, &b, &m) - want).abs() < 1e-12);
    }

    #[test]
    fn nothing_scored_is_nan() {
        let a = vec![[0u8; 3]; 4];
        let m = BitVec::repeat(false, 4);
        assert!(psnr_rgb(&a, &a, &m).is_nan());
        assert!(psnr_plane(&[0.0; 4], &[1.0; 4], &m).is_nan());
    }
}
