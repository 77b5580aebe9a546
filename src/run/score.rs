//! Scoring one derived frame against its ground truth, the same way for
//! every engine (`golden`, `golden --method`, `simulate`): the metrics of
//! `docs/metrics.md` over the trace's known pixels (the common mask of a
//! run alone: known ∧ seen ∧ covered by this image), and, when an output
//! directory is given, the difference heat-map `diff-<k>.png` (saturating
//! at a difference of [`HEATMAP_FULL_SCALE`] 8-bit sRGB codes).
//!
//! Frames without ground truth score `None` and write no heat-map.

use crate::metrics::{MetricInput, Quality, common_mask, evaluate};
use crate::report::images::write_diff_heatmap;
use crate::trace::TruthImage;
use bitvec::vec::BitVec;
use std::path::Path;

/// Difference (8-bit sRGB codes) at which the heat-map saturates.
pub const HEATMAP_FULL_SCALE: f64 = 64.0;

/// Score derived frame `k`, a `w x h` image `pixels` whose `covered` bits
/// mark pixels covered by real samples, against its `truth`
/// ([`crate::trace::Trace::load_truth`]; FLIP only with `flip`,
/// [`crate::metrics::MetricInput::flip`]); with `out`, also write
/// `out/diff-<k>.png`, beside the metrics.
pub fn score_frame(
    truth: Option<&TruthImage>,
    k: usize,
    (w, h): (u32, u32),
    pixels: &[[f32; 3]],
    covered: &BitVec,
    flip: bool,
    out: Option<&Path>,
) -> anyhow::Result<Option<Quality>> {
    let Some(truth) = truth else { return Ok(None) };
    let common = common_mask(&truth.known, truth.seen.as_ref(), &[covered])?;
    let (q, heatmap) = rayon::join(
        || {
            evaluate(&MetricInput {
                width: w,
                height: h,
                image: pixels,
                truth: &truth.colour,
                known: &truth.known,
                covered: Some(covered),
                common: Some(&common),
                seen: truth.seen.as_ref(),
                flip,
            })
        },
        || {
            out.map(|out| {
                write_diff_heatmap(
                    &out.join(format!("diff-{k:04}.png")),
                    w,
                    h,
                    pixels,
                    &truth.colour,
                    &truth.known,
                    HEATMAP_FULL_SCALE,
                )
            })
            .transpose()
        },
    );
    heatmap?;
    Ok(Some(q?))
}
