//! The golden model's per-frame counters in `report.json` (`postwarp
//! golden`), mirroring [`crate::golden::frame::GoldenStats`] (a test fails
//! when the two differ). `N` is `u64` in a frame and in `total`, `f64` in
//! `mean`.

use super::keys::{KeyDoc, Reduce, Shape, nested, scalar};
use super::quality::{Pixels, Scores};
use super::{REPORT_VERSION, ReportKind};
use crate::golden::config::GoldenConfig;
use crate::golden::frame::GoldenStats;
use serde::{Deserialize, Serialize};

/// The golden model's counters of one frame, or their `total` / `mean`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoldenCounters<N> {
    /// Reference samples with a surface (samples).
    pub reference_samples: N,
    /// Reference samples behind the derived camera (samples).
    pub culled_samples: N,
    /// Kernels by (width, height) in sample centres (kernels).
    pub kernel_sizes: Vec<Vec<N>>,
    /// Kernels larger than `kernel_limit` (kernels).
    pub kernels_over_limit: N,
    /// Kernel corners computed from the sample alone (corners).
    pub edge_corners: N,
    /// 2x2 groups failing the discontinuity test (groups).
    pub discontinuous_groups: N,
    /// 2x2 groups passing it but folded over (groups).
    pub folded_groups: N,
    /// Samples tagged as forward edges (samples).
    pub forward_edges: N,
    /// Candidates written over empty or hole-fill samples (samples).
    pub composite_filled: N,
    /// Candidates that won the depth test (samples).
    pub composite_nearer: N,
    /// Candidates that won the same-surface arbitration (samples).
    pub composite_better: N,
    /// Candidates that lost (samples).
    pub composite_lost: N,
    /// Mesh triangles rasterized (triangles).
    pub mesh_triangles: N,
    /// Edge splats rasterized (splats).
    pub edge_splats: N,
    /// Edge splats suppressed (splats).
    pub suppressed_splats: N,
    /// Splat candidates refused by the mesh/splat rule (samples).
    pub splats_rejected_by_mesh: N,
    /// Mesh candidates that replaced a splat (samples).
    pub mesh_over_splat: N,
    /// Hole samples filled, summed over passes (samples).
    pub hole_fill_filled: N,
    /// Hole samples no pass reached, summed over passes (samples).
    pub hole_fill_unreached: N,
    /// Empty samples the fallback pass filled (samples). Absent from
    /// reports written before it (0).
    #[serde(default)]
    pub fallback_filled: N,
    /// Empty samples the fallback pass left empty (samples).
    #[serde(default)]
    pub fallback_unreached: N,
    /// Display pixels holding a sample the fallback pass filled (pixels).
    #[serde(default)]
    pub unseen_pixels: N,
    /// Derived samples holding hole fill at the end (samples).
    pub hole_samples: N,
    /// Derived samples with neither surface nor fill (samples).
    pub empty_samples: N,
    /// Pixels by A-buffer fragments needed (pixels; index = fragments).
    pub fragments_per_pixel: Vec<N>,
    /// A-buffer merges forced by the fragment limit (merges).
    pub forced_merges: N,
    /// Fixed mode only (`arith = "fixed"`): values that saturated, per
    /// stage (counts). Absent in float mode.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saturations: Option<super::hardware::SaturationCounts<N>>,
}

impl GoldenCounters<u64> {
    /// The counters of a golden frame.
    pub fn of(s: &GoldenStats) -> GoldenCounters<u64> {
        GoldenCounters {
            reference_samples: s.reference_samples,
            culled_samples: s.culled_samples,
            kernel_sizes: s.kernel_sizes.clone(),
            kernels_over_limit: s.kernels_over_limit,
            edge_corners: s.edge_corners,
            discontinuous_groups: s.discontinuous_groups,
            folded_groups: s.folded_groups,
            forward_edges: s.forward_edges,
            composite_filled: s.composite_filled,
            composite_nearer: s.composite_nearer,
            composite_better: s.composite_better,
            composite_lost: s.composite_lost,
            mesh_triangles: s.mesh_triangles,
            edge_splats: s.edge_splats,
            suppressed_splats: s.suppressed_splats,
            splats_rejected_by_mesh: s.splats_rejected_by_mesh,
            mesh_over_splat: s.mesh_over_splat,
            hole_fill_filled: s.hole_fill_filled,
            hole_fill_unreached: s.hole_fill_unreached,
            fallback_filled: s.fallback_filled,
            fallback_unreached: s.fallback_unreached,
            unseen_pixels: s.unseen_pixels,
            hole_samples: s.hole_samples,
            empty_samples: s.empty_samples,
            fragments_per_pixel: s.fragments_per_pixel.clone(),
            forced_merges: s.forced_merges,
            saturations: s.saturations.map(|t| super::hardware::SaturationCounts {
                fetch: t.fetch,
                transform: t.transform,
                kernel_setup: t.kernel_setup,
                raster: t.raster,
                hole_fill: t.hole_fill,
            }),
        }
    }
}

const fn count(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    scalar(key, unit, Reduce::Sum, meaning)
}

const fn hist(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit, reduce: Reduce::Sum, shape: Shape::List, meaning }
}

/// The rows of [`GoldenCounters`], in field order.
pub fn counter_keys() -> Vec<KeyDoc> {
    vec![
        count("reference_samples", "samples", "reference samples with a surface, over all warps"),
        count("culled_samples", "samples", "reference samples behind the derived camera"),
        hist(
            "kernel_sizes",
            "kernels",
            "9x9 histogram over kernels that reach the derived image: `kernel_sizes[w][h]` = kernels `w` by `h` sample \
             centres before the limit (8 = 8 or more)",
        ),
        count(
            "kernels_over_limit",
            "kernels",
            "kernels reaching the derived image that are larger than `kernel_limit` on some axis (clipped or allowed per \
             `over_limit`)",
        ),
        count(
            "edge_corners",
            "corners",
            "corners of kernels reaching the derived image computed from the sample alone (edge, fold-over, border)",
        ),
        count(
            "discontinuous_groups",
            "groups",
            "2x2 reference groups failing the discontinuity test, counted at the group's top-left sample when that \
             sample's kernel reaches the derived image",
        ),
        count("folded_groups", "groups", "2x2 groups passing it but folded over (counted the same way)"),
        count(
            "forward_edges",
            "samples",
            "samples reaching the derived image tagged as forward edges (hole-fill colour from the deeper neighbour)",
        ),
        count("composite_filled", "samples", "candidates written over empty or hole-fill samples"),
        count("composite_nearer", "samples", "candidates that won the depth test"),
        count("composite_better", "samples", "candidates that won the same-surface arbitration"),
        count("composite_lost", "samples", "candidates that lost"),
        count("mesh_triangles", "triangles", "mesh triangles rasterized (general reconstruction)"),
        count("edge_splats", "splats", "edge splats rasterized (general reconstruction)"),
        count(
            "suppressed_splats",
            "splats",
            "edge splats suppressed on poorly sampled surfaces (general reconstruction)",
        ),
        count("splats_rejected_by_mesh", "samples", "splat candidates refused by the mesh/splat rule"),
        count("mesh_over_splat", "samples", "mesh candidates that replaced a splat at the same depth"),
        count("hole_fill_filled", "samples", "hole samples filled, summed over hole-fill passes"),
        count("hole_fill_unreached", "samples", "hole samples a pass could not reach, summed over passes"),
        count(
            "fallback_filled",
            "samples",
            "empty samples the fallback pass filled after the last warp (`fallback_fill`, `docs/golden.md`)",
        ),
        count("fallback_unreached", "samples", "empty samples the fallback pass could not reach (left empty)"),
        count(
            "unseen_pixels",
            "pixels",
            "display pixels holding a sample the fallback pass filled: seen by no reference along the epipolar passes",
        ),
        count("hole_samples", "samples", "derived samples holding hole fill at the end"),
        count("empty_samples", "samples", "derived samples with neither a surface nor fill at the end (output black)"),
        hist(
            "fragments_per_pixel",
            "pixels",
            "histogram: pixels by A-buffer fragments needed before merging (index = count), over every store of the \
             derived frame",
        ),
        count("forced_merges", "merges", "A-buffer merges forced by the fragment limit"),
        nested(
            "saturations",
            Reduce::Sum,
            super::hardware::saturation_keys,
            "fixed mode only (`arith = \"fixed\"`, absent in float mode): values that saturated their Q format, per \
             stage, over the sets the hardware model counts (`docs/fixed-point.md`)",
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirrors_the_golden_stats_field_for_field() {
        // Fixed mode's counts present (absent in float mode, in both).
        let s = GoldenStats { saturations: Some(Default::default()), ..GoldenStats::default() };
        let engine = serde_json::to_value(&s).unwrap();
        let report = serde_json::to_value(GoldenCounters::of(&s)).unwrap();
        let a: Vec<&String> = engine.as_object().unwrap().keys().collect();
        let b: Vec<&String> = report.as_object().unwrap().keys().collect();
        assert_eq!(a, b, "GoldenStats and GoldenCounters differ: add the new stat to src/report/golden.rs");
        let rows: Vec<&str> = counter_keys().iter().map(|k| k.key).collect();
        assert_eq!(b, rows);
    }
}

/// `references` of a golden report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoldenReferences {
    /// Per reference frame, where its slopes came from (`exact` or
    /// `finite-difference`; `null` if no derived frame used it).
    pub slopes: Vec<Option<String>>,
    /// A-buffer conversion of the references, host time (ms).
    pub prepare_ms: f64,
}

/// One derived frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenFrame {
    /// Derived frame index in the trace.
    pub index: usize,
    /// Quality against ground truth.
    #[serde(flatten)]
    pub scores: Scores,
    /// The pixels behind the scores.
    #[serde(flatten)]
    pub pixels: Pixels<u64>,
    /// Host time of the frame (ms).
    pub host_ms: f64,
    /// Pixels of the derived frame (pixels). Absent from older reports.
    #[serde(default)]
    pub display_pixels: u64,
    /// `unseen_pixels / display_pixels` (fraction).
    #[serde(default)]
    pub unseen_fraction: Option<f64>,
    /// Counters.
    #[serde(flatten)]
    pub counters: GoldenCounters<u64>,
}

impl GoldenFrame {
    /// A frame's entry: `unseen_fraction` derived from the counters.
    pub fn new(
        index: usize,
        scores: Scores,
        pixels: Pixels<u64>,
        host_ms: f64,
        display_pixels: u64,
        counters: GoldenCounters<u64>,
    ) -> GoldenFrame {
        let unseen_fraction = unseen_fraction(counters.unseen_pixels as f64, display_pixels as f64);
        GoldenFrame { index, scores, pixels, host_ms, display_pixels, unseen_fraction, counters }
    }
}

/// The never-seen share: `unseen / display` (`None` without pixels).
fn unseen_fraction(unseen: f64, display: f64) -> Option<f64> {
    (display > 0.0).then(|| unseen / display)
}

/// `total` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenTotal {
    /// Derived frames (frames).
    pub frames: u64,
    /// Pixel counts.
    #[serde(flatten)]
    pub pixels: Pixels<u64>,
    /// Host time (ms).
    pub host_ms: f64,
    /// Pixels of the derived frames (pixels).
    #[serde(default)]
    pub display_pixels: u64,
    /// Counters.
    #[serde(flatten)]
    pub counters: GoldenCounters<u64>,
}

/// `mean` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenMean {
    /// Scores.
    #[serde(flatten)]
    pub scores: Scores,
    /// Pixel counts.
    #[serde(flatten)]
    pub pixels: Pixels<f64>,
    /// Host time per frame (ms).
    pub host_ms: f64,
    /// Pixels per derived frame (pixels).
    #[serde(default)]
    pub display_pixels: f64,
    /// The never-seen share from the summed counters (fraction).
    #[serde(default)]
    pub unseen_fraction: Option<f64>,
    /// Counters per frame.
    #[serde(flatten)]
    pub counters: GoldenCounters<f64>,
}

/// `report.json` of `postwarp golden`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenReport {
    /// [`super::REPORT_VERSION`].
    pub report_version: u32,
    /// [`ReportKind::Golden`].
    pub kind: ReportKind,
    /// Path of the trace manifest.
    pub trace: String,
    /// FLIP scored (`--flip`); false: the FLIP keys are null.
    pub flip: bool,
    /// `mark-aa` or `mark-general`.
    pub method: String,
    /// Every golden knob.
    pub config: GoldenConfig,
    /// Reference frames.
    pub references: GoldenReferences,
    /// Per derived frame.
    pub frames: Vec<GoldenFrame>,
    /// Sums over frames.
    pub total: GoldenTotal,
    /// Means over frames.
    pub mean: GoldenMean,
}

impl GoldenReport {
    /// The report of `frames`, with `total` and `mean` reduced by the key
    /// rules.
    pub fn new(
        trace: String,
        flip: bool,
        method: String,
        config: GoldenConfig,
        references: GoldenReferences,
        frames: Vec<GoldenFrame>,
    ) -> GoldenReport {
        let (total, mut mean): (GoldenTotal, GoldenMean) = super::reduce(&frames, &frame_keys(), |t| {
            t.insert("frames".into(), frames.len().into());
        });
        mean.unseen_fraction = unseen_fraction(mean.counters.unseen_pixels, mean.display_pixels);
        GoldenReport {
            report_version: REPORT_VERSION,
            kind: ReportKind::Golden,
            trace,
            flip,
            method,
            config,
            references,
            frames,
            total,
            mean,
        }
    }
}

/// Keys of a frame.
pub fn frame_keys() -> Vec<KeyDoc> {
    let mut k = vec![scalar("index", "—", Reduce::Once, "derived frame index in the trace")];
    k.extend(super::quality::keys());
    k.push(scalar(
        "host_ms",
        "ms",
        Reduce::Sum,
        "host time of the golden model for this frame, one core (not deterministic)",
    ));
    k.push(scalar("display_pixels", "pixels", Reduce::Sum, "pixels of the derived frame"));
    k.push(scalar(
        "unseen_fraction",
        "fraction",
        Reduce::Derived,
        "`unseen_pixels / display_pixels`: the share of the frame no reference saw along the epipolar passes (a \
         border strip the fallback fill supplied), apart from the holes inside the image (`hole_fraction` counts both)",
    ));
    k.extend(counter_keys());
    k
}

fn reference_keys() -> Vec<KeyDoc> {
    vec![
        KeyDoc {
            key: "slopes",
            unit: "—",
            reduce: Reduce::Once,
            shape: Shape::List,
            meaning: "per reference frame: `exact` or `finite-difference` (how its 1/Z slopes were obtained; `null` if \
                      unused)",
        },
        scalar(
            "prepare_ms",
            "ms",
            Reduce::Once,
            "A-buffer conversion time of the references (host, not deterministic)",
        ),
    ]
}

fn config_keys() -> Vec<KeyDoc> {
    crate::golden::config::KNOBS.iter().map(|k| scalar(k.name, k.unit, Reduce::Once, k.description)).collect()
}

fn total_keys() -> Vec<KeyDoc> {
    super::total_keys(frame_keys())
}

fn mean_keys() -> Vec<KeyDoc> {
    super::mean_keys(frame_keys())
}

/// Top-level keys.
pub fn report_keys() -> Vec<KeyDoc> {
    let mut k = super::header_keys();
    k.extend([
        scalar("method", "—", Reduce::Once, "`mark-aa` or `mark-general` (the golden model's reconstruction)"),
        nested("config", Reduce::Once, config_keys, "every golden-model knob (`docs/golden.md`)"),
        nested("references", Reduce::Once, reference_keys, "the reference frames"),
        nested("frames", Reduce::Once, frame_keys, "one object per derived frame"),
        nested("total", Reduce::Once, total_keys, "sums over frames (key rules)"),
        nested("mean", Reduce::Once, mean_keys, "means over frames (key rules)"),
    ]);
    k
}
