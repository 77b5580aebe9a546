//! Image-quality metrics: a derived frame against its ground truth.
//!
//! [`evaluate`] scores one synthesized image against ground truth the way the
//! post-rendering-warping papers do (Mark et al., UNC TR98-011; Smit et al.)
//! and returns a [`Quality`]: RGB and luminance PSNR, SSIM, mean FLIP, the
//! share of hole pixels and the share of pixels with CIELAB ΔE > 20. Every
//! field, its unit and one line of description are listed by [`describe`];
//! `docs/metrics.md` is the long form.
//!
//! # Conventions
//!
//! * **What is compared.** Images arrive as linear RGB (`[f32; 3]` per pixel,
//!   row-major, display resolution). Every metric sees them as an 8-bit sRGB
//!   display would: both images are first encoded with
//!   [`crate::picture::linear_to_srgb8`] (clamped to [0, 1], NaN → 0, rounded
//!   to the nearest code). PSNR, SSIM and FLIP work on these codes; ΔE decodes
//!   them back with [`crate::picture::srgb_to_linear`] before going to CIELAB.
//! * **Unknown pixels** (`known` bit clear) are excluded from every metric:
//!   pixel-wise metrics skip them, and before the neighbourhood metrics (SSIM,
//!   FLIP) run, the image's unknown pixels are overwritten with the truth's
//!   codes, so the (arbitrary) truth there adds no difference to the windows
//!   of nearby known pixels. SSIM and FLIP are then averaged over known pixels
//!   only. Their number is [`Quality::excluded_pixels`].
//! * **Uncovered pixels** (`covered` bit clear: the warp left a hole that was
//!   filled, not sampled) are scored like any other pixel, except by
//!   [`Quality::psnr_rgb_covered_db`] (known ∧ covered only) and counted by
//!   [`Quality::hole_fraction`] (known ∧ ¬covered over known).
//! * **Nothing to score.** A metric with no pixel to score is NaN (e.g. every
//!   pixel unknown, or nothing covered for `psnr_rgb_covered_db`).
//! * **FLIP only when asked** ([`MetricInput::flip`], the commands'
//!   `--flip`): its two evaluations per frame (one thread of C++ each) were
//!   the critical path of a whole `golden` process (issue 20). Without it
//!   `flip_mean` and `flip_mean_common` are NaN (`null` in report.json).
//! * **Infinities.** Identical images give PSNR = +∞ (MSE = 0). Both stay as
//!   they are in memory; when a [`Quality`] is serialized (report.json), every
//!   non-finite float is written as `null` ([`serialize_finite_or_null`]).
//!   For PSNR, `null` means +∞ (a perfect match) when the corresponding pixel
//!   count (`scored_pixels`, or `covered_pixels` for the covered PSNR) is
//!   above zero, and NaN (nothing scored) when it is zero.
//!
//! # Errors
//!
//! Mismatched buffer sizes and empty images are [`MetricError`]s; no input
//! makes [`evaluate`] panic.

pub mod delta_e;
pub mod flip;
pub mod psnr;
pub mod ssim;

use bitvec::vec::BitVec;
use rayon::prelude::*;
use serde::Serializer;

use crate::picture::linear_to_srgb8;

/// What [`evaluate`] compares.
#[derive(Clone, Copy, Debug)]
pub struct MetricInput<'a> {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// The image under test: linear RGB per pixel, row-major, `width·height` pixels.
    pub image: &'a [[f32; 3]],
    /// Ground truth: linear RGB per pixel, row-major, `width·height` pixels.
    pub truth: &'a [[f32; 3]],
    /// Set where the truth is known; clear pixels are excluded from every metric.
    pub known: &'a BitVec,
    /// Set where the warp covered the pixel with a real sample (not hole fill);
    /// `None` = every pixel covered.
    pub covered: Option<&'a BitVec>,
    /// The common mask the `*_common` keys score (intersected with `known`):
    /// the pixels every compared method covers and a reference sees
    /// (`docs/metrics.md`). `None` = known ∧ covered.
    pub common: Option<&'a BitVec>,
    /// Set where a reference sees the pixel (the truth's `seen` channel);
    /// `None` = every pixel seen. Its complement is the never-seen region.
    pub seen: Option<&'a BitVec>,
    /// Compute FLIP (`flip_mean`, `flip_mean_common`); false leaves both NaN.
    pub flip: bool,
}

/// The scores of one image against its ground truth. Field names are the
/// `report.json` keys ([`describe`] gives units and descriptions).
///
/// Non-finite values (PSNR = +∞ for identical images, NaN for a metric with
/// nothing to score) serialize as `null`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Quality {
    /// RGB PSNR over known pixels (dB, 8-bit sRGB codes, peak 255).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub psnr_rgb_db: f64,
    /// RGB PSNR over known ∧ covered pixels (dB).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub psnr_rgb_covered_db: f64,
    /// Luma (BT.601 Y' on sRGB codes) PSNR over known pixels (dB).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub psnr_luma_db: f64,
    /// Mean SSIM of the luma over valid window centres that are known (1 = identical).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub ssim_luma: f64,
    /// Mean LDR-FLIP over known pixels (0 = identical, 1 = maximal error).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub flip_mean: f64,
    /// Share of known pixels the warp did not cover (0–1).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub hole_fraction: f64,
    /// Share of known pixels with CIE76 ΔE*ab > 20 (0–1).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub delta_e20_fraction: f64,
    /// RGB PSNR over the common mask (dB).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub psnr_rgb_common_db: f64,
    /// Mean luma SSIM over window centres in the common mask (1 = identical).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub ssim_luma_common: f64,
    /// Mean LDR-FLIP over the common mask (0 = identical).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub flip_mean_common: f64,
    /// RGB PSNR over known pixels no reference sees (dB).
    #[serde(serialize_with = "serialize_finite_or_null")]
    pub psnr_rgb_never_seen_db: f64,
    /// Pixels excluded because the truth is unknown.
    pub excluded_pixels: u64,
    /// Known pixels the warp covered with a real sample.
    pub covered_pixels: u64,
    /// Known pixels (the pixels every metric scores).
    pub scored_pixels: u64,
    /// Pixels in the common mask (what the `*_common` keys score).
    pub common_pixels: u64,
    /// Known pixels no reference sees (what `psnr_rgb_never_seen_db` scores).
    pub never_seen_pixels: u64,
}

/// Why [`evaluate`] cannot score an input.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetricError {
    /// A buffer's length is not `width·height`.
    #[error("{what} has {got} entries; expected {expected} ({width}x{height} pixels)")]
    SizeMismatch { what: &'static str, got: usize, expected: usize, width: u32, height: u32 },
    /// A mask to intersect has another length than the known mask.
    #[error("{what} has {got} entries; expected {expected}, as the known mask")]
    MaskMismatch { what: &'static str, got: usize, expected: usize },
    /// Width or height is zero.
    #[error("image is {width}x{height}; expected at least 1x1 pixels")]
    Empty { width: u32, height: u32 },
    /// The image is too large for the FLIP library (3·width·height must fit in 32 bits).
    #[error("image is {width}x{height}; at most 2^32 - 1 colour values are supported")]
    TooLarge { width: u32, height: u32 },
}

/// One row of the [`describe`] table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MetricDoc {
    /// The [`Quality`] field name, which is also the `report.json` key.
    pub key: &'static str,
    /// Unit ("dB", "fraction", "pixels", "—" for unitless scores).
    pub unit: &'static str,
    /// One line: what the number is.
    pub description: &'static str,
}

const DOCS: &[MetricDoc] = &[
    MetricDoc {
        key: "psnr_rgb_db",
        unit: "dB",
        description: "PSNR of R, G, B on 8-bit sRGB codes (peak 255), known pixels; JSON null = +inf or none scored",
    },
    MetricDoc {
        key: "psnr_rgb_covered_db",
        unit: "dB",
        description: "psnr_rgb_db restricted to known pixels the warp covered with a real sample (holes left out)",
    },
    MetricDoc {
        key: "psnr_luma_db",
        unit: "dB",
        description: "PSNR of BT.601 luma 0.299R' + 0.587G' + 0.114B' of 8-bit sRGB codes (peak 255), known pixels",
    },
    MetricDoc {
        key: "ssim_luma",
        unit: "—",
        description: "mean SSIM (Wang et al. 2004) of the luma, 11x11 Gaussian sigma 1.5, valid region, known centres",
    },
    MetricDoc {
        key: "flip_mean",
        unit: "—",
        description: "mean LDR-FLIP error (Andersson et al. 2020, 67 pixels per degree) over known pixels, 0 to 1; null unless asked (--flip)",
    },
    MetricDoc {
        key: "hole_fraction",
        unit: "fraction",
        description: "share of known pixels the warp did not cover with a real sample (hole-filled), 0 to 1",
    },
    MetricDoc {
        key: "delta_e20_fraction",
        unit: "fraction",
        description: "share of known pixels whose CIELAB (D65) CIE76 colour difference exceeds 20, 0 to 1",
    },
    MetricDoc {
        key: "psnr_rgb_common_db",
        unit: "dB",
        description: "psnr_rgb_db on the common mask: known pixels every compared method covers and a reference sees",
    },
    MetricDoc {
        key: "ssim_luma_common",
        unit: "—",
        description: "ssim_luma averaged over window centres in the common mask, the image taking the truth outside it",
    },
    MetricDoc {
        key: "flip_mean_common",
        unit: "—",
        description: "flip_mean averaged over the common mask, the image taking the truth outside it, 0 to 1; null unless asked (--flip)",
    },
    MetricDoc {
        key: "psnr_rgb_never_seen_db",
        unit: "dB",
        description: "psnr_rgb_db over known pixels no reference sees (truth's seen clear): the fill's share alone",
    },
    MetricDoc {
        key: "excluded_pixels",
        unit: "pixels",
        description: "pixels excluded because the ground truth is unknown",
    },
    MetricDoc {
        key: "covered_pixels",
        unit: "pixels",
        description: "known pixels the warp covered with a real sample",
    },
    MetricDoc { key: "scored_pixels", unit: "pixels", description: "known pixels: the pixels every metric scores" },
    MetricDoc {
        key: "common_pixels",
        unit: "pixels",
        description: "pixels in the common mask: known, covered by every compared method, seen by a reference",
    },
    MetricDoc {
        key: "never_seen_pixels",
        unit: "pixels",
        description: "known pixels no reference sees (the truth's seen channel clear; 0 without the channel)",
    },
];

/// Every [`Quality`] field (= `report.json` key) with its unit and a one-line
/// description, in field order. Used by reports and docs.
pub fn describe() -> &'static [MetricDoc] {
    DOCS
}

/// Serialize a float, writing `null` when it is not finite (JSON has no
/// infinities or NaN). For PSNR fields `null` means +∞ (identical images) when
/// pixels were scored and NaN (nothing scored) when none were; see the
/// module documentation.
pub fn serialize_finite_or_null<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() { s.serialize_f64(*v) } else { s.serialize_none() }
}

/// Both images as 8-bit sRGB codes, the image's unknown pixels replaced by
/// the truth's (see the module documentation).
pub(crate) fn encode_pair(input: &MetricInput) -> (Vec<[u8; 3]>, Vec<[u8; 3]>) {
    let truth: Vec<[u8; 3]> = input.truth.par_iter().map(|c| c.map(linear_to_srgb8)).collect();
    let image = outside_as_truth(input.image, &truth, input.known);
    (image, truth)
}

/// `image` as 8-bit sRGB codes, taking `truth`'s codes where `mask` is clear.
fn outside_as_truth(image: &[[f32; 3]], truth: &[[u8; 3]], mask: &BitVec) -> Vec<[u8; 3]> {
    image
        .par_iter()
        .zip(truth)
        .enumerate()
        .map(|(i, (c, t))| if mask[i] { c.map(linear_to_srgb8) } else { *t })
        .collect()
}

fn check(input: &MetricInput) -> Result<usize, MetricError> {
    let (width, height) = (input.width, input.height);
    if width == 0 || height == 0 {
        return Err(MetricError::Empty { width, height });
    }
    let n = width as u64 * height as u64;
    if n * 3 > u32::MAX as u64 {
        return Err(MetricError::TooLarge { width, height });
    }
    let n = n as usize;
    let lens = [
        ("image", input.image.len()),
        ("truth", input.truth.len()),
        ("known mask", input.known.len()),
        ("covered mask", input.covered.map_or(n, BitVec::len)),
        ("common mask", input.common.map_or(n, BitVec::len)),
        ("seen mask", input.seen.map_or(n, BitVec::len)),
    ];
    for (what, got) in lens {
        if got != n {
            return Err(MetricError::SizeMismatch { what, got, expected: n, width, height });
        }
    }
    Ok(n)
}

/// The common mask of a comparison (`docs/metrics.md`): the pixels the truth
/// knows, that a reference sees (`seen`; `None` = every pixel) and that every
/// compared image covers with a real sample (`covered`, one mask per
/// image). Errors when a mask's length is not `known`'s.
pub fn common_mask(known: &BitVec, seen: Option<&BitVec>, covered: &[&BitVec]) -> Result<BitVec, MetricError> {
    let n = known.len();
    let mut m = known.clone();
    for (what, mask) in seen.map(|s| ("seen mask", s)).into_iter().chain(covered.iter().map(|c| ("covered mask", *c))) {
        if mask.len() != n {
            return Err(MetricError::MaskMismatch { what, got: mask.len(), expected: n });
        }
        m &= mask;
    }
    Ok(m)
}

/// Score `input.image` against `input.truth`. Errors (never panics) when a
/// buffer's size is not `width·height` or the image is empty.
pub fn evaluate(input: &MetricInput) -> Result<Quality, MetricError> {
    let n = check(input)?;
    let known = input.known;
    let scored_pixels = known.count_ones() as u64;
    let covered_known: BitVec = match input.covered {
        Some(c) => known.clone() & c,
        None => known.clone(),
    };
    let covered_pixels = covered_known.count_ones() as u64;
    let hole_fraction =
        if scored_pixels == 0 { f64::NAN } else { (scored_pixels - covered_pixels) as f64 / scored_pixels as f64 };

    let common: BitVec = match input.common {
        Some(c) => known.clone() & c,
        None => covered_known.clone(),
    };

    let never_seen: BitVec = match input.seen {
        Some(s) => known.clone() & !s.clone(),
        None => BitVec::repeat(false, n),
    };

    let (image8, truth8) = encode_pair(input);
    let luma_of = |codes: &[[u8; 3]]| -> Vec<f64> { codes.par_iter().map(|&c| psnr::luma(c)).collect() };
    let (image_luma, truth_luma) = rayon::join(|| luma_of(&image8), || luma_of(&truth8));
    let (w, h) = (input.width as usize, input.height as usize);
    // The neighbourhood metrics on the common mask see the truth outside it,
    // as they see it on unknown pixels; a mask of every known pixel is the
    // whole-image case.
    let separate_common = common != *known;
    // common ⊆ known, so image8 holds the image's codes on it.
    let common8: Vec<[u8; 3]> = if separate_common {
        image8.par_iter().zip(&truth8).enumerate().map(|(i, (c, t))| if common[i] { *c } else { *t }).collect()
    } else {
        Vec::new()
    };
    let common_luma = luma_of(&common8);
    // The two FLIPs (the most expensive, one thread each) beside each other
    // and beside the rest; each score is computed once, whatever the
    // thread count, so the scores do not depend on it.
    let flips = || {
        rayon::join(
            || match input.flip {
                true => flip::flip_mean(input.width, input.height, &image8, &truth8, known),
                false => f64::NAN,
            },
            || {
                (separate_common && input.flip)
                    .then(|| flip::flip_mean(input.width, input.height, &common8, &truth8, &common))
            },
        )
    };
    let psnrs = || {
        [
            psnr::psnr_plane(&image_luma, &truth_luma, known),
            psnr::psnr_rgb(&image8, &truth8, known),
            psnr::psnr_rgb(&image8, &truth8, &covered_known),
            psnr::psnr_rgb(&image8, &truth8, &never_seen),
            if separate_common { psnr::psnr_rgb(&common8, &truth8, &common) } else { f64::NAN },
        ]
    };
    let ssims = || {
        rayon::join(
            || ssim::ssim_mean(w, h, &image_luma, &truth_luma, known),
            || separate_common.then(|| ssim::ssim_mean(w, h, &common_luma, &truth_luma, &common)),
        )
    };
    let delta_e = || delta_e::delta_e_fraction(&image8, &truth8, known, delta_e::DELTA_E_THRESHOLD);
    let (((flip_mean, flip_c), psnrs), ((ssim_luma, ssim_c), delta_e20_fraction)) =
        rayon::join(|| rayon::join(flips, psnrs), || rayon::join(ssims, delta_e));
    let [psnr_luma_db, psnr_rgb_db, psnr_rgb_covered_db, psnr_rgb_never_seen_db, psnr_common] = psnrs;
    let (psnr_rgb_common_db, ssim_luma_common, flip_mean_common) = match ssim_c {
        Some(ssim_c) => (psnr_common, ssim_c, flip_c.unwrap_or(f64::NAN)),
        None => (psnr_rgb_db, ssim_luma, flip_mean),
    };

    Ok(Quality {
        psnr_rgb_db,
        psnr_rgb_covered_db,
        psnr_luma_db,
        ssim_luma,
        flip_mean,
        hole_fraction,
        delta_e20_fraction,
        psnr_rgb_common_db,
        ssim_luma_common,
        flip_mean_common,
        psnr_rgb_never_seen_db,
        excluded_pixels: (n as u64) - scored_pixels,
        covered_pixels,
        scored_pixels,
        common_pixels: common.count_ones() as u64,
        never_seen_pixels: never_seen.count_ones() as u64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::picture::srgb_to_linear;

    fn grey(code: u8) -> [f32; 3] {
        [srgb_to_linear(code); 3]
    }

    #[test]
    fn describe_lists_every_serialized_key() {
        let q = Quality {
            psnr_rgb_db: 1.0,
            psnr_rgb_covered_db: 2.0,
            psnr_luma_db: 3.0,
            ssim_luma: 0.5,
            flip_mean: 0.1,
            hole_fraction: 0.2,
            delta_e20_fraction: 0.3,
            psnr_rgb_common_db: 7.0,
            ssim_luma_common: 0.6,
            flip_mean_common: 0.2,
            psnr_rgb_never_seen_db: 8.0,
            excluded_pixels: 4,
            covered_pixels: 5,
            scored_pixels: 6,
            common_pixels: 3,
            never_seen_pixels: 2,
        };
        let v = serde_json::to_value(&q).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let mut documented: Vec<&str> = describe().iter().map(|d| d.key).collect();
        assert_eq!(documented.len(), 16);
        // serde_json's map is sorted by key unless preserve_order is on.
        let mut sorted_keys = keys.clone();
        sorted_keys.sort_unstable();
        documented.sort_unstable();
        assert_eq!(sorted_keys, documented);
        for d in describe() {
            assert!(!d.unit.is_empty() && !d.description.is_empty(), "{}", d.key);
        }
    }

    #[test]
    fn non_finite_serializes_as_null() {
        let q = Quality {
            psnr_rgb_db: f64::INFINITY,
            psnr_rgb_covered_db: f64::NAN,
            psnr_luma_db: 30.5,
            ssim_luma: 1.0,
            flip_mean: 0.0,
            hole_fraction: 0.0,
            delta_e20_fraction: 0.0,
            psnr_rgb_common_db: f64::NAN,
            ssim_luma_common: f64::NAN,
            flip_mean_common: f64::NAN,
            psnr_rgb_never_seen_db: f64::NAN,
            excluded_pixels: 0,
            covered_pixels: 0,
            scored_pixels: 1,
            common_pixels: 0,
            never_seen_pixels: 0,
        };
        let s = serde_json::to_string(&q).unwrap();
        assert!(s.contains("\"psnr_rgb_db\":null"), "{s}");
        assert!(s.contains("\"psnr_rgb_covered_db\":null"), "{s}");
        assert!(s.contains("\"psnr_luma_db\":30.5"), "{s}");
    }

    #[test]
    fn unknown_pixels_take_the_truths_codes() {
        let image = [grey(10), grey(20)];
        let truth = [grey(200), grey(210)];
        let known: BitVec = [true, false].into_iter().collect();
        let input = MetricInput {
            width: 2,
            height: 1,
            image: &image,
            truth: &truth,
            known: &known,
            covered: None,
            common: None,
            seen: None,
            flip: true,
        };
        let (i8, t8) = encode_pair(&input);
        assert_eq!(i8, vec![[10; 3], [210; 3]]);
        assert_eq!(t8, vec![[200; 3], [210; 3]]);
    }

    #[test]
    fn check_rejects_bad_sizes() {
        let px = vec![[0.0f32; 3]; 6];
        let known = BitVec::repeat(true, 6);
        let short = BitVec::repeat(true, 5);
        let ok = MetricInput {
            width: 3,
            height: 2,
            image: &px,
            truth: &px,
            known: &known,
            covered: None,
            common: None,
            seen: None,
            flip: true,
        };
        assert_eq!(check(&ok), Ok(6));
        let e = check(&MetricInput { common: Some(&short), ..ok }).unwrap_err();
        assert!(matches!(e, MetricError::SizeMismatch { what: "common mask", got: 5, .. }), "{e}");
        let e = check(&MetricInput { seen: Some(&short), ..ok }).unwrap_err();
        assert!(matches!(e, MetricError::SizeMismatch { what: "seen mask", got: 5, .. }), "{e}");
        let e = check(&MetricInput { covered: Some(&short), ..ok }).unwrap_err();
        assert!(matches!(e, MetricError::SizeMismatch { what: "covered mask", got: 5, expected: 6, .. }), "{e}");
        let e = check(&MetricInput { known: &short, ..ok }).unwrap_err();
        assert!(e.to_string().contains("known mask has 5 entries; expected 6"), "{e}");
        let e = check(&MetricInput { image: &px[..4], ..ok }).unwrap_err();
        assert!(matches!(e, MetricError::SizeMismatch { what: "image", .. }));
        let e = check(&MetricInput { width: 0, height: 0, image: &[], truth: &[], ..ok }).unwrap_err();
        assert_eq!(e, MetricError::Empty { width: 0, height: 0 });
        let e = check(&MetricInput { width: 65536, height: 65536, ..ok }).unwrap_err();
        assert_eq!(e, MetricError::TooLarge { width: 65536, height: 65536 });
    }
}
