//! Structural similarity (SSIM) of the luma plane.
//!
//! **Definition** (Wang, Bovik, Sheikh, Simoncelli, "Image quality assessment:
//! from error visibility to structural similarity", IEEE TIP 13(4), 2004):
//! for each window position,
//!
//! ```text
//! SSIM = (2·μx·μy + C1)(2·σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2)),
//! C1 = (K1·L)², C2 = (K2·L)², K1 = 0.01, K2 = 0.03, L = 255
//! ```
//!
//! where μ, σ² and σxy are Gaussian-weighted means, variances and covariance
//! over the window (σ² = E\[x²\] − μ², as in the reference MATLAB code). The
//! score is **unitless**, 1 for identical images, at most 1.
//!
//! **Conventions.**
//! * The plane is BT.601 luma of 8-bit sRGB codes (`super::psnr::luma`, code
//!   units 0–255, unrounded), so L = 255.
//! * Window: 11x11 Gaussian, σ = 1.5 pixels, normalised to sum 1 (MATLAB's
//!   `fspecial('gaussian', 11, 1.5)`), evaluated only where the whole window
//!   lies inside the image (the "valid" region of the reference
//!   implementation: (W − 10)·(H − 10) positions, no padding).
//! * The mean is taken over window positions whose **centre** pixel is known;
//!   no such position gives NaN. (The caller, `super::evaluate`, first gives
//!   unknown image pixels the truth's values so they add no difference.)
//! * **Small images.** On an axis shorter than 11 pixels the window is clipped
//!   to the image: that axis uses an n-tap Gaussian (n = the image's size on
//!   that axis, σ = 1.5, centred at (n − 1)/2, renormalised), so there is one
//!   window position along it. For even n the centre pixel is the one at
//!   index n/2 − 1 (the upper/left of the two middle pixels).
//! * Computed separably (vertical then horizontal sums of x, y, x², y², xy),
//!   O(N·(11 + 11)) time and O(W) memory, deterministic.

use bitvec::vec::BitVec;

/// Constant K1.
pub const K1: f64 = 0.01;
/// Constant K2.
pub const K2: f64 = 0.03;
/// Dynamic range of the plane (8-bit codes).
pub const L: f64 = 255.0;
/// Window size (pixels per side) for images at least this large.
pub const WINDOW: usize = 11;
/// Standard deviation of the Gaussian window (pixels).
pub const SIGMA: f64 = 1.5;

/// C1 = (K1·L)².
pub const C1: f64 = (K1 * L) * (K1 * L);
/// C2 = (K2·L)².
pub const C2: f64 = (K2 * L) * (K2 * L);

/// The 1D window for an axis of `len` pixels: min(11, len) taps of a Gaussian
/// with σ = 1.5 centred on the middle tap(s), normalised to sum 1.
pub fn gaussian_taps(len: usize) -> Vec<f64> {
    let n = len.clamp(1, WINDOW);
    let centre = (n as f64 - 1.0) / 2.0;
    let raw: Vec<f64> = (0..n).map(|i| (-(i as f64 - centre).powi(2) / (2.0 * SIGMA * SIGMA)).exp()).collect();
    let sum: f64 = raw.iter().sum();
    raw.into_iter().map(|v| v / sum).collect()
}

/// SSIM of one window from its weighted moments.
pub fn ssim_from_moments(mx: f64, my: f64, exx: f64, eyy: f64, exy: f64) -> f64 {
    let vx = exx - mx * mx;
    let vy = eyy - my * my;
    let cxy = exy - mx * my;
    ((2.0 * mx * my + C1) * (2.0 * cxy + C2)) / ((mx * mx + my * my + C1) * (vx + vy + C2))
}

/// Mean SSIM of two `width x height` planes (row-major, code units) over the
/// valid window positions whose centre pixel is set in `known`; NaN if none.
///
/// # Panics
/// If a buffer's length is not `width·height`.
pub fn ssim_mean(width: usize, height: usize, x: &[f64], y: &[f64], known: &BitVec) -> f64 {
    let n = width * height;
    assert!(x.len() == n && y.len() == n && known.len() == n, "ssim_mean: buffer lengths differ from width·height");
    if n == 0 {
        return f64::NAN;
    }
    let kx = gaussian_taps(width);
    let ky = gaussian_taps(height);
    let (out_w, out_h) = (width - kx.len() + 1, height - ky.len() + 1);
    let (cx, cy) = ((kx.len() - 1) / 2, (ky.len() - 1) / 2);

    // Vertical sums for one output row: [μx, μy, E[x²], E[y²], E[xy]] per column.
    let mut col = vec![[0.0f64; 5]; width];
    let mut total = 0.0f64;
    let mut count = 0u64;
    for oy in 0..out_h {
        if !(0..out_w).any(|ox| known[(oy + cy) * width + ox + cx]) {
            continue;
        }
        for (c, acc) in col.iter_mut().enumerate() {
            let mut s = [0.0f64; 5];
            for (k, &w) in ky.iter().enumerate() {
                let i = (oy + k) * width + c;
                let (a, b) = (x[i], y[i]);
                s[0] += w * a;
                s[1] += w * b;
                s[2] += w * a * a;
                s[3] += w * b * b;
                s[4] += w * a * b;
            }
            *acc = s;
        }
        for ox in 0..out_w {
            if !known[(oy + cy) * width + ox + cx] {
                continue;
            }
            let mut m = [0.0f64; 5];
            for (k, &w) in kx.iter().enumerate() {
                let s = &col[ox + k];
                for j in 0..5 {
                    m[j] += w * s[j];
                }
            }
            total += ssim_from_moments(m[0], m[1], m[2], m[3], m[4]);
            count += 1;
        }
    }
    if count == 0 { f64::NAN } else { total / count as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random codes in 0..256 (64-bit LCG, Knuth's constants).
    fn lcg_plane(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 33) % 256) as f64
            })
            .collect()
    }

    /// Independent O(N·121) SSIM: explicit 2D Gaussian weights, direct sums.
    fn brute_force(w: usize, h: usize, x: &[f64], y: &[f64], known: &BitVec) -> f64 {
        let (nw, nh) = (w.min(11), h.min(11));
        let (ccx, ccy) = ((nw as f64 - 1.0) / 2.0, (nh as f64 - 1.0) / 2.0);
        let mut weights = vec![0.0; nw * nh];
        for j in 0..nh {
            for i in 0..nw {
                let r2 = (i as f64 - ccx).powi(2) + (j as f64 - ccy).powi(2);
                weights[j * nw + i] = (-r2 / 4.5).exp();
            }
        }
        let sum: f64 = weights.iter().sum();
        weights.iter_mut().for_each(|v| *v /= sum);
        let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
        let (mut total, mut count) = (0.0, 0);
        for oy in 0..=(h - nh) {
            for ox in 0..=(w - nw) {
                if !known[(oy + (nh - 1) / 2) * w + ox + (nw - 1) / 2] {
                    continue;
                }
                let (mut mx, mut my, mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for j in 0..nh {
                    for i in 0..nw {
                        let p = (oy + j) * w + ox + i;
                        let wt = weights[j * nw + i];
                        mx += wt * x[p];
                        my += wt * y[p];
                    }
                }
                for j in 0..nh {
                    for i in 0..nw {
                        let p = (oy + j) * w + ox + i;
                        let wt = weights[j * nw + i];
                        sxx += wt * (x[p] - mx).powi(2);
                        syy += wt * (y[p] - my).powi(2);
                        sxy += wt * (x[p] - mx) * (y[p] - my);
                    }
                }
                total += ((2.0 * mx * my + c1) * (2.0 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
                count += 1;
            }
        }
        total / count as f64
    }

    #[test]
    fn taps_are_the_matlab_window() {
        let t = gaussian_taps(100);
        assert_eq!(t.len(), 11);
        assert!((t.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        // fspecial('gaussian', 11, 1.5) centre value is 0.0708 (2D) = t[5]².
        assert!((t[5] * t[5] - 0.070_762_4).abs() < 1e-6, "{}", t[5] * t[5]);
        assert!((t[0] - t[10]).abs() < 1e-18 && t[0] < t[1]);
        assert_eq!(gaussian_taps(4).len(), 4);
        assert!((gaussian_taps(4)[0] - gaussian_taps(4)[3]).abs() < 1e-18);
    }

    #[test]
    fn identical_is_one() {
        let (w, h) = (40, 30);
        let x = lcg_plane(w * h, 1);
        let known = BitVec::repeat(true, w * h);
        assert!((ssim_mean(w, h, &x, &x, &known) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn constant_images_give_the_luminance_term_only() {
        let (w, h) = (20, 16);
        let known = BitVec::repeat(true, w * h);
        for (a, b) in [(100.0, 120.0), (0.0, 255.0), (37.5, 36.0)] {
            let got = ssim_mean(w, h, &vec![a; w * h], &vec![b; w * h], &known);
            let want = (2.0 * a * b + C1) / (a * a + b * b + C1);
            assert!((got - want).abs() < 1e-12, "{a} vs {b}: {got} vs {want}");
            // The contrast-structure term (2σxy + C2)/(σx² + σy² + C2) is 1 here.
            let cs = got / ((2.0 * a * b + C1) / (a * a + b * b + C1));
            assert!((cs - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn symmetric() {
        let (w, h) = (33, 21);
        let x = lcg_plane(w * h, 2);
        let y = lcg_plane(w * h, 3);
        let known = BitVec::repeat(true, w * h);
        let (a, b) = (ssim_mean(w, h, &x, &y, &known), ssim_mean(w, h, &y, &x, &known));
        assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        assert!(a < 0.5);
    }

    #[test]
    fn decreases_with_added_noise() {
        let (w, h) = (48, 48);
        // A smooth ramp plus structure, kept inside 0..=255 after noise.
        let x: Vec<f64> = (0..w * h).map(|i| 60.0 + ((i % w) as f64 * 2.0) + ((i / w) % 7) as f64 * 5.0).collect();
        let noise: Vec<f64> = lcg_plane(w * h, 4).iter().map(|v| v / 255.0 - 0.5).collect();
        let known = BitVec::repeat(true, w * h);
        let mut last = 1.0;
        for amp in [2.0, 8.0, 32.0, 100.0] {
            let y: Vec<f64> = x.iter().zip(&noise).map(|(a, n)| a + amp * n).collect();
            let s = ssim_mean(w, h, &x, &y, &known);
            assert!(s < last, "amplitude {amp}: {s} !< {last}");
            last = s;
        }
        assert!(last < 0.6);
    }

    #[test]
    fn matches_brute_force() {
        for (w, h) in [(37, 29), (11, 11), (25, 7), (6, 5)] {
            let x = lcg_plane(w * h, 10 + w as u64);
            let y: Vec<f64> = lcg_plane(w * h, 20 + h as u64).iter().zip(&x).map(|(n, a)| (a + n) / 2.0).collect();
            let mut known = BitVec::repeat(true, w * h);
            for i in (1..w * h).step_by(7) {
                known.set(i, false);
            }
            let fast = ssim_mean(w, h, &x, &y, &known);
            let slow = brute_force(w, h, &x, &y, &known);
            assert!((fast - slow).abs() < 1e-9, "{w}x{h}: {fast} vs {slow}");
            assert!(fast > 0.0 && fast < 0.95);
        }
    }

    #[test]
    fn only_known_centres_count() {
        let (w, h) = (30, 30);
        let x = lcg_plane(w * h, 5);
        let mut y = x.clone();
        // Damage the left half; only right-half centres are known.
        for r in 0..h {
            for c in 0..10 {
                y[r * w + c] = 255.0 - y[r * w + c];
            }
        }
        let mut known = BitVec::repeat(false, w * h);
        for r in 0..h {
            for c in 16..w {
                known.set(r * w + c, true);
            }
        }
        // Windows centred at column ≥ 16 span columns ≥ 11: undamaged.
        assert!((ssim_mean(w, h, &x, &y, &known) - 1.0).abs() < 1e-12);
        known.set(5 * w + 12, true); // a window reaching into the damage
        assert!(ssim_mean(w, h, &x, &y, &known) < 1.0 - 1e-6);
        assert!(ssim_mean(w, h, &x, &y, &BitVec::repeat(false, w * h)).is_nan());
    }
}
