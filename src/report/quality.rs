//! A frame's quality against ground truth in `report.json`: the metric keys
//! of `docs/metrics.md` ([`crate::metrics::Quality`]), described by
//! [`crate::metrics::describe`]. Scores are means over frames in `mean`;
//! the pixel counts are summed in `total`.
//!
//! A frame without ground truth has every key `null`; a score is `null`
//! when it is not finite (a PSNR of +∞ for identical images when pixels
//! were scored, NaN when none were).

use super::keys::{KeyDoc, Reduce, scalar};
use crate::metrics::Quality;
use serde::{Deserialize, Serialize};

/// The scores (means over frames in `mean`, nothing in `total`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    /// RGB PSNR over known pixels (dB).
    pub psnr_rgb_db: Option<f64>,
    /// RGB PSNR over known pixels covered by real samples (dB).
    pub psnr_rgb_covered_db: Option<f64>,
    /// Luma PSNR over known pixels (dB).
    pub psnr_luma_db: Option<f64>,
    /// Mean luma SSIM (1).
    pub ssim_luma: Option<f64>,
    /// Mean LDR-FLIP (1).
    pub flip_mean: Option<f64>,
    /// Share of known pixels not covered by a real sample (fraction).
    pub hole_fraction: Option<f64>,
    /// Share of known pixels with ΔE*ab > 20 (fraction).
    pub delta_e20_fraction: Option<f64>,
    /// RGB PSNR on the common mask (dB). Absent from older reports.
    pub psnr_rgb_common_db: Option<f64>,
    /// Mean luma SSIM on the common mask (1).
    pub ssim_luma_common: Option<f64>,
    /// Mean LDR-FLIP on the common mask (1).
    pub flip_mean_common: Option<f64>,
    /// RGB PSNR over known pixels no reference sees (dB).
    pub psnr_rgb_never_seen_db: Option<f64>,
}

/// The pixel counts behind the scores (`N` = `u64` in a frame and in
/// `total`, `f64` in `mean`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pixels<N> {
    /// Pixels the ground truth marks unknown (pixels).
    pub excluded_pixels: Option<N>,
    /// Known pixels covered by real samples (pixels).
    pub covered_pixels: Option<N>,
    /// Known pixels (pixels).
    pub scored_pixels: Option<N>,
    /// Pixels of the common mask (pixels). Absent from older reports.
    pub common_pixels: Option<N>,
    /// Known pixels no reference sees (pixels).
    pub never_seen_pixels: Option<N>,
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

impl Scores {
    /// The scores of `q` (`None`: no ground truth, every key null).
    pub fn of(q: Option<&Quality>) -> Scores {
        let Some(q) = q else { return Scores::default() };
        Scores {
            psnr_rgb_db: finite(q.psnr_rgb_db),
            psnr_rgb_covered_db: finite(q.psnr_rgb_covered_db),
            psnr_luma_db: finite(q.psnr_luma_db),
            ssim_luma: finite(q.ssim_luma),
            flip_mean: finite(q.flip_mean),
            hole_fraction: finite(q.hole_fraction),
            delta_e20_fraction: finite(q.delta_e20_fraction),
            psnr_rgb_common_db: finite(q.psnr_rgb_common_db),
            ssim_luma_common: finite(q.ssim_luma_common),
            flip_mean_common: finite(q.flip_mean_common),
            psnr_rgb_never_seen_db: finite(q.psnr_rgb_never_seen_db),
        }
    }
}

impl Pixels<u64> {
    /// The pixel counts of `q`.
    pub fn of(q: Option<&Quality>) -> Pixels<u64> {
        let Some(q) = q else { return Pixels::default() };
        Pixels {
            excluded_pixels: Some(q.excluded_pixels),
            covered_pixels: Some(q.covered_pixels),
            scored_pixels: Some(q.scored_pixels),
            common_pixels: Some(q.common_pixels),
            never_seen_pixels: Some(q.never_seen_pixels),
        }
    }
}

/// Scores and pixel counts together, as simulate's `vs_truth` holds them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Truth<N> {
    /// The scores.
    #[serde(flatten)]
    pub scores: Scores,
    /// The pixel counts.
    #[serde(flatten)]
    pub pixels: Pixels<N>,
}

impl Truth<u64> {
    /// `q` as written in a report.
    pub fn of(q: &Quality) -> Truth<u64> {
        Truth { scores: Scores::of(Some(q)), pixels: Pixels::of(Some(q)) }
    }
}

/// The metric keys, in report order: scores reduce by [`Reduce::Mean`],
/// pixel counts by [`Reduce::Sum`].
pub fn keys() -> Vec<KeyDoc> {
    crate::metrics::describe()
        .iter()
        .map(|d| {
            let reduce = if d.unit == "pixels" { Reduce::Sum } else { Reduce::Mean };
            scalar(d.key, d.unit, reduce, d.description)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_structs_hold_every_metric_key_in_order() {
        let t = Truth::<u64>::default();
        let v = serde_json::to_value(&t).unwrap();
        let fields: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let described: Vec<&str> = keys().iter().map(|k| k.key).collect();
        assert_eq!(fields, described);
    }
}
