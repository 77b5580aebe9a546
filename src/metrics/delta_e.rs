//! CIELAB colour difference (CIE76 ΔE*ab) and the share of pixels above 20.
//!
//! **Definition.** Each pixel goes linear RGB (sRGB primaries, D65 white) →
//! CIE XYZ → CIELAB (D65 reference white), and ΔE = ‖Lab₁ − Lab₂‖₂ (CIE 1976,
//! unitless; L\* is 0–100, white vs black is 100). The reported number is
//! the **fraction** (0–1) of scored pixels with ΔE > [`DELTA_E_THRESHOLD`]
//! = 20, the threshold Smit et al. use to mark sampling errors ("A
//! shared-scene-graph image-warping architecture for VR: low latency versus
//! image quality", Computers & Graphics 2010, §5).
//!
//! **Conventions.**
//! * Like every metric here, ΔE sees what an 8-bit sRGB display shows: the
//!   linear inputs are encoded with [`crate::picture::linear_to_srgb8`]
//!   (clamped to [0, 1]) and the codes decoded with
//!   [`crate::picture::srgb_to_linear`] before the matrix.
//! * RGB → XYZ: the IEC 61966-2-1 matrix (Lindbloom's 7-digit form, Y = the
//!   BT.709 luminance 0.2126729 R + 0.7151522 G + 0.0721750 B), Y of white = 1.
//! * Reference white Xn, Yn, Zn = the matrix's row sums (0.95047, 1.0000001,
//!   1.08883: D65), so RGB white is exactly L\* = 100, a\* = b\* = 0.
//! * f(t) = t^(1/3) above (6/29)³, else t/(3·(6/29)²) + 4/29 (CIE 15:2004).
//! * Only pixels whose mask bit is set are counted; none set gives NaN.
//!
//! **Speed.** [`delta_e_fraction`] decides most pixels with a cube root of
//! its own ([`cbrt_fast`], within 1e-12 relative of `f64::cbrt` on every
//! value an 8-bit colour reaches: an exhaustive test) and takes the
//! library's cube roots only where ΔE² lies within [`GUARD`] of the
//! threshold², so each count is the one `f64::cbrt` gives; the pixels are
//! counted in chunks on every core (integer sums: the same whatever the
//! thread count).

use bitvec::vec::BitVec;

use crate::picture::srgb_to_linear;

/// ΔE above which a pixel counts as a large colour error (Smit et al.).
pub const DELTA_E_THRESHOLD: f64 = 20.0;

/// Linear sRGB (D65) → CIE XYZ, Y of white = 1.
pub const RGB_TO_XYZ: [[f64; 3]; 3] =
    [[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]];

/// D65 reference white (the row sums of [`RGB_TO_XYZ`]).
pub fn white() -> [f64; 3] {
    RGB_TO_XYZ.map(|row| row[0] + row[1] + row[2])
}

/// Linear RGB (sRGB primaries) → XYZ.
pub fn linear_to_xyz(rgb: [f64; 3]) -> [f64; 3] {
    RGB_TO_XYZ.map(|row| row[0] * rgb[0] + row[1] * rgb[1] + row[2] * rgb[2])
}

/// XYZ → CIELAB [L*, a*, b*] relative to the D65 [`white`].
pub fn xyz_to_lab(xyz: [f64; 3]) -> [f64; 3] {
    xyz_to_lab_with(xyz, f64::cbrt)
}

/// [`xyz_to_lab`] with the cube root `cbrt` (of values above (6/29)³).
#[inline(always)]
fn xyz_to_lab_with(xyz: [f64; 3], cbrt: impl Fn(f64) -> f64) -> [f64; 3] {
    const D: f64 = 6.0 / 29.0;
    let f = |t: f64| if t > D * D * D { cbrt(t) } else { t / (3.0 * D * D) + 4.0 / 29.0 };
    let w = white();
    let (fx, fy, fz) = (f(xyz[0] / w[0]), f(xyz[1] / w[1]), f(xyz[2] / w[2]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIELAB of an 8-bit sRGB pixel.
pub fn srgb8_to_lab(c: [u8; 3]) -> [f64; 3] {
    xyz_to_lab(linear_to_xyz(c.map(|v| srgb_to_linear(v) as f64)))
}

/// [`srgb8_to_lab`] with [`cbrt_fast`].
#[inline(always)]
fn srgb8_to_lab_fast(c: [u8; 3], cbrt: impl Fn(f64) -> f64) -> [f64; 3] {
    xyz_to_lab_with(linear_to_xyz(c.map(|v| srgb_to_linear(v) as f64)), cbrt)
}

/// t^(1/3) for t > 0: Kahan's start (the exponent divided by three, within
/// a few per cent) and three Halley steps (cubic convergence). Within 1e-12
/// relative of `f64::cbrt` wherever [`delta_e_fraction`] uses it (tested
/// on every 8-bit colour), not necessarily the same last bits.
#[inline(always)]
pub fn cbrt_fast(t: f64) -> f64 {
    let mut y = f64::from_bits(t.to_bits() / 3 + 0x2A9F_7893_782D_A1CE);
    for _ in 0..3 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * t) / (2.0 * y3 + t);
    }
    y
}

/// Relative band around threshold² inside which [`delta_e_fraction`]
/// decides with `f64::cbrt` instead of [`cbrt_fast`]. With cube roots at
/// most 1e-12 (relative) off, and cube roots at most ≈1.03 here, L\*, a\*
/// and b\* (116, 500 and 200 times a cube root or a difference of two)
/// move by at most 1.2e-9 each, so ΔE² by at most about 2·ΔE·2e-9
/// (absolute): inside the band for every threshold, 1e-6·max(1, thr²).
pub const GUARD: f64 = 1e-6;

/// Whether ΔE76 of `a` and `b` exceeds `threshold` (`thr2` = threshold²),
/// as [`delta_e76`] of [`srgb8_to_lab`] decides it, first with the cube
/// root `cbrt` (within 1e-12 of `f64::cbrt`: [`cbrt_fast`]).
#[inline(always)]
fn above(a: [u8; 3], b: [u8; 3], threshold: f64, thr2: f64, cbrt: impl Fn(f64) -> f64 + Copy) -> bool {
    let (la, lb) = (srgb8_to_lab_fast(a, cbrt), srgb8_to_lab_fast(b, cbrt));
    let d2 = (la[0] - lb[0]).powi(2) + (la[1] - lb[1]).powi(2) + (la[2] - lb[2]).powi(2);
    if (d2 - thr2).abs() > GUARD * thr2.max(1.0) {
        d2 > thr2
    } else {
        delta_e76(srgb8_to_lab(a), srgb8_to_lab(b)) > threshold
    }
}

/// CIE76 colour difference: Euclidean distance in CIELAB.
pub fn delta_e76(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Fraction of pixels whose `mask` bit is set with ΔE76 > `threshold`
/// between `image` and `truth` (8-bit sRGB); NaN if no bit is set.
///
/// # Panics
/// If the slices and the mask differ in length.
pub fn delta_e_fraction(image: &[[u8; 3]], truth: &[[u8; 3]], mask: &BitVec, threshold: f64) -> f64 {
    use rayon::prelude::*;
    assert!(image.len() == truth.len() && image.len() == mask.len(), "delta_e_fraction: buffer lengths differ");
    const CHUNK: usize = 1 << 14;
    let thr2 = threshold * threshold;
    let (over, n) = (0..image.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let r = c * CHUNK..((c + 1) * CHUNK).min(image.len());
            let (mut over, mut n) = (0u64, 0u64);
            for i in mask[r.clone()].iter_ones().map(|j| r.start + j) {
                over += (image[i] != truth[i] && above(image[i], truth[i], threshold, thr2, cbrt_fast)) as u64;
                n += 1;
            }
            (over, n)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if n == 0 { f64::NAN } else { over as f64 / n as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_and_black() {
        let w = srgb8_to_lab([255; 3]);
        let k = srgb8_to_lab([0; 3]);
        assert!((w[0] - 100.0).abs() < 1e-9 && w[1].abs() < 1e-9 && w[2].abs() < 1e-9, "{w:?}");
        assert!(k.iter().all(|v| v.abs() < 1e-12), "{k:?}");
        assert!((delta_e76(w, k) - 100.0).abs() < 1e-3);
    }

    #[test]
    fn primaries_match_published_lab() {
        // Standard sRGB (D65) values, e.g. Lindbloom's calculator.
        let cases = [
            ([255u8, 0, 0], [53.2408, 80.0925, 67.2032]),
            ([0, 255, 0], [87.7347, -86.1827, 83.1793]),
            ([0, 0, 255], [32.2970, 79.1875, -107.8602]),
        ];
        for (rgb, want) in cases {
            let got = srgb8_to_lab(rgb);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 0.05, "{rgb:?}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn mid_grey_lightness() {
        // sRGB 119 is the classic L* ≈ 50 grey.
        let l = srgb8_to_lab([119; 3])[0];
        assert!((l - 50.0).abs() < 0.5, "{l}");
    }

    #[test]
    fn fraction_counts_only_masked_pixels() {
        let truth = vec![[128u8; 3]; 8];
        let mut image = truth.clone();
        image[0] = [255, 0, 0]; // far (ΔE > 20)
        image[1] = [130, 128, 128]; // near (ΔE < 20)
        image[5] = [0, 0, 0]; // far, but unknown
        image[6] = [0, 0, 255]; // far, but unknown
        let mut mask = BitVec::repeat(true, 8);
        mask.set(5, false);
        mask.set(6, false);
        assert_eq!(delta_e_fraction(&image, &truth, &mask, DELTA_E_THRESHOLD), 1.0 / 6.0);
        assert_eq!(delta_e_fraction(&image, &truth, &BitVec::repeat(true, 8), DELTA_E_THRESHOLD), 3.0 / 8.0);
        assert!(delta_e_fraction(&image, &truth, &BitVec::repeat(false, 8), 20.0).is_nan());
    }

    /// Every value t = X/Xn, Y/Yn, Z/Zn an 8-bit colour reaches above
    /// (6/29)³, where `delta_e_fraction` takes `cbrt_fast`: within 1e-12 of
    /// `f64::cbrt`. Ignored: 50 M cube roots; run with
    /// `cargo test --release --lib delta_e -- --include-ignored`.
    #[test]
    #[ignore]
    fn fast_cube_root_is_close_on_every_8_bit_colour() {
        check_cube_roots(1);
    }

    /// The same on every 37th colour (about 450 k).
    #[test]
    fn fast_cube_root_is_close_on_a_sample_of_colours() {
        check_cube_roots(37);
    }

    fn check_cube_roots(stride: usize) {
        const D3: f64 = (6.0 / 29.0) * (6.0 / 29.0) * (6.0 / 29.0);
        let w = white();
        let mut worst = 0.0f64;
        for code in (0..1usize << 24).step_by(stride) {
            let c = [(code >> 16) as u8, (code >> 8) as u8, code as u8];
            let xyz = linear_to_xyz(c.map(|v| srgb_to_linear(v) as f64));
            for (v, wv) in xyz.iter().zip(w) {
                let t = v / wv;
                if t > D3 {
                    let exact = t.cbrt();
                    worst = worst.max(((cbrt_fast(t) - exact) / exact).abs());
                }
            }
        }
        assert!(worst <= 1e-12, "worst relative error {worst:e}");
    }

    /// Pixels whose ΔE lies at the threshold are decided by `f64::cbrt`:
    /// the fraction with the fast path equals a direct count with the
    /// library's cube roots, at thresholds set to pixels' own ΔE.
    /// `n` pseudo-random pairs of 8-bit colours (xorshift64 from `seed`).
    fn colour_pairs(seed: u64, n: usize) -> Vec<([u8; 3], [u8; 3])> {
        let mut rng = seed;
        (0..n)
            .map(|_| {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                let a = rng.to_le_bytes();
                ([a[0], a[1], a[2]], [a[3], a[4], a[5]])
            })
            .collect()
    }

    #[test]
    fn the_fast_count_is_the_exact_count() {
        let (image, truth): (Vec<[u8; 3]>, Vec<[u8; 3]>) =
            colour_pairs(0x2545_f491_4f6c_dd1d, 40_000).into_iter().unzip();
        let mask = BitVec::repeat(true, image.len());
        let direct = |thr: f64| {
            let n = image.iter().zip(&truth).filter(|(a, b)| delta_e76(srgb8_to_lab(**a), srgb8_to_lab(**b)) > thr);
            n.count() as f64 / image.len() as f64
        };
        for i in [0, 1, 17, 4321] {
            let d = delta_e76(srgb8_to_lab(image[i]), srgb8_to_lab(truth[i]));
            for thr in [d, d - 1e-12, d + 1e-12, 20.0] {
                assert_eq!(delta_e_fraction(&image, &truth, &mask, thr), direct(thr), "threshold {thr}");
            }
        }
    }

    /// The guard itself: with cube roots pushed 1e-12 off either way (the
    /// bound the fast one meets), every pixel at a threshold equal to its
    /// own ΔE, or a hair either side, is decided as `f64::cbrt` decides it.
    /// Without the guard about half of these would flip.
    #[test]
    fn the_guard_absorbs_cube_roots_off_by_the_bound() {
        let mut flips_without_guard = 0;
        for (a, b) in colour_pairs(0x9e37_79b9_7f4a_7c15, 2000) {
            let d = delta_e76(srgb8_to_lab(a), srgb8_to_lab(b));
            for thr in [d, d.next_up(), d.next_down()] {
                let exact = d > thr;
                for off in [1.0 + 1e-12, 1.0 - 1e-12] {
                    let cbrt = move |t: f64| t.cbrt() * off;
                    assert_eq!(above(a, b, thr, thr * thr, cbrt), exact, "{a:?} {b:?} at {thr}");
                    let (la, lb) = (srgb8_to_lab_fast(a, cbrt), srgb8_to_lab_fast(b, cbrt));
                    let d2 = (la[0] - lb[0]).powi(2) + (la[1] - lb[1]).powi(2) + (la[2] - lb[2]).powi(2);
                    flips_without_guard += ((d2 > thr * thr) != exact) as u32;
                }
            }
        }
        assert!(flips_without_guard > 100, "the test must reach the band: {flips_without_guard}");
    }

    #[test]
    fn threshold_is_strict() {
        // Two greys whose ΔE is exactly their L* difference.
        let (a, b) = ([100u8; 3], [160u8; 3]);
        let d = delta_e76(srgb8_to_lab(a), srgb8_to_lab(b));
        assert!(d > 20.0 && d < 30.0, "{d}");
        let m = BitVec::repeat(true, 1);
        assert_eq!(delta_e_fraction(&[a], &[b], &m, d), 0.0);
        assert_eq!(delta_e_fraction(&[a], &[b], &m, d - 1e-9), 1.0);
    }
}
