//! The comparison methods' counters in `report.json` (`postwarp golden
//! --method`): `primitives`, and the method-specific counters of the
//! reconstruction and of the hole fill ([`crate::methods::Counters`]),
//! each described once here with its unit and reduction. A method that
//! adds a counter adds its row to [`reconstruction_keys`] or
//! [`hole_fill_keys`]; a test runs every method and fails on a counter
//! without one.

use super::keys::{KeyDoc, Reduce, nested, scalar};
use super::quality::{Pixels, Scores};
use super::{REPORT_VERSION, ReportKind};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// Method-specific counters: name → number, in the order the method
/// reports them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct MethodCounters(pub Map<String, Value>);

impl MethodCounters {
    /// Counter `name` as a number, if present and finite.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.get(name).and_then(Value::as_f64).filter(|x| x.is_finite())
    }
}

const fn sum(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    scalar(key, unit, Reduce::Sum, meaning)
}

const fn peak(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    scalar(key, unit, Reduce::Max, meaning)
}

const fn share(key: &'static str, unit: &'static str, meaning: &'static str) -> KeyDoc {
    scalar(key, unit, Reduce::Mean, meaning)
}

/// Reconstruction counters of every method (`frames[i].reconstruction`).
/// A name used by several methods means the same thing in each.
pub fn reconstruction_keys() -> Vec<KeyDoc> {
    vec![
        sum("reference_samples", "samples", "reference samples with a surface, over all warps"),
        sum("culled_samples", "samples", "reference samples (or vertices) behind the derived camera"),
        sum(
            "off_image",
            "primitives",
            "primitives drawn entirely off the derived image (samples, splats, triangles, quads)",
        ),
        sum("lost", "samples", "candidate samples that lost the depth test"),
        sum("kernels_over_limit", "kernels", "mark-*: kernels larger than `kernel_limit` (clipped or allowed)"),
        sum("discontinuous_groups", "groups", "mark-*: 2x2 reference groups failing the discontinuity test"),
        sum("mesh_triangles", "triangles", "mark-general: mesh triangles rasterized"),
        sum("edge_splats", "splats", "mark-general: edge splats rasterized"),
        sum("forced_merges", "merges", "mark-*: A-buffer merges forced by the fragment limit"),
        sum("composite_filled", "samples", "mark-*: candidates written over empty or hole-fill samples"),
        sum("composite_writes", "samples", "mark-*: candidates composited (filled + nearer + better + lost)"),
        sum("dropped_missing", "triangles", "rubber-sheet: triangles dropped for a vertex without surface"),
        sum("dropped_culled", "triangles", "rubber-sheet: triangles dropped for a culled vertex"),
        sum("back_facing", "triangles", "rubber-sheet: drawn triangles of non-positive or non-finite derived area"),
        sum("samples_written", "samples", "derived samples written (depth-test wins, overwrites included)"),
        sum("references_warped", "references", "didyk*: reference frames warped"),
        sum("leaf_cells", "cells", "didyk*: grid leaves emitted (entirely drawable)"),
        sum("leaf_cells_1x1", "cells", "didyk*: of those, 1x1 cells"),
        sum("empty_cells", "cells", "didyk*: leaves dropped because nothing in them is drawable"),
        sum("splits", "cells", "didyk*: cells split into four"),
        sum("culled_quads", "quads", "didyk*: quads culled because a vertex is behind the derived camera"),
        sum("blended_samples", "samples", "didyk-2ref: derived samples blended from more than one reference"),
        sum("grid_cells", "cells", "schollmeyer-*: cells in the grid"),
        sum("rect_cells", "cells", "schollmeyer-irregular: of which 2:1 rectangles"),
        sum("single_sample_cells", "cells", "schollmeyer-*: of which single samples"),
        sum("surface_nodes", "nodes", "schollmeyer-*: quadtree nodes (levels 1 and up) that are surfaces"),
        sum("vertices", "vertices", "schollmeyer-*: distinct vertices"),
        sum("split_cells", "cells", "schollmeyer-*: cells split because a vertex is behind the camera or not finite"),
        sum("culled_cells", "cells", "schollmeyer-*: cells dropped behind the camera"),
        sum(
            "folded_triangles",
            "triangles",
            "triangles whose warped winding is not positive (folded, seen from behind)",
        ),
        sum("linear_fragments", "samples", "schollmeyer-*: derived samples textured bilinearly"),
        sum("nearest_fragments", "samples", "schollmeyer-*: derived samples textured from the nearest sample"),
        sum("depth_lost", "samples", "schollmeyer-*: candidate samples that lost the depth test"),
        sum("grid_primitives", "cells", "schollmeyer-transparent, -glass-depth: cells the grid warp drew"),
        sum(
            "rays",
            "rays",
            "schollmeyer-transparent: rays cast, one per derived sample and reference whose view the ray crosses",
        ),
        share("cells_per_ray", "cells", "schollmeyer-transparent: quadtree cells visited per ray cast (mean)"),
        sum("fragment_hits", "fragments", "schollmeyer-transparent: fragment hits composited"),
        sum("splats", "splats", "lochmann-*: reference samples splatted by the diffuse flow"),
        sum("fpi_rejected", "samples", "lochmann-*: derived samples the diffuse flow's fixed-point check made holes"),
        sum("reflect_samples", "samples", "lochmann-raytree: derived samples whose reflection node was descended"),
        sum("reflect_accepted", "samples", "lochmann-raytree: of those, descents accepted within ε"),
        sum("refract_samples", "samples", "lochmann-raytree: derived samples whose refraction node was descended"),
        sum("refract_accepted", "samples", "lochmann-raytree: of those, descents accepted within ε"),
        share(
            "gradient_steps_per_specular_sample",
            "steps",
            "lochmann-raytree: gradient steps per descended sample and node (mean)",
        ),
        sum("node_fill_filled", "samples", "lochmann-raytree: specular-node samples filled by the nodes' pull-push"),
        sum("missing_triangles", "triangles", "smit-mesh*: triangles with a vertex missing or culled"),
        sum("broken_triangles", "triangles", "smit-mesh: triangles not drawn at a depth discontinuity"),
        sum("degenerate_triangles", "triangles", "smit-mesh*: drawn triangles of zero or non-finite area"),
        sum("fragments", "samples", "smit-*: fragments rasterized"),
        sum("lost_fragments", "samples", "smit-*: fragments that lost the depth test"),
        sum("clamped_splats", "splats", "smit-point: splats capped at the largest size"),
        share("mean_splat_side", "samples", "smit-point: mean side of the drawn splats"),
        sum("clamped_quads", "quads", "smit-quad: quads scaled down to the cap"),
        sum("degenerate_quads", "quads", "smit-quad: quads of zero or non-finite area (nothing drawn)"),
        sum("triangles", "triangles", "smit-quad: triangles drawn (two per quad that is not degenerate)"),
        sum("level0_hole_pixels", "pixels", "smit-*: display pixels with a level-0 hole (occlusion + sampling errors)"),
        sum("occlusion_error_pixels", "pixels", "smit-*: level-0 holes classified as occlusion errors"),
        sum("sampling_error_pixels", "pixels", "smit-*: level-0 holes classified as sampling errors"),
        share("occlusion_error_share", "fraction", "smit-*: occlusion-error pixels over all display pixels"),
        share("sampling_error_share", "fraction", "smit-*: sampling-error pixels over all display pixels"),
        sum("occlusion_error_samples", "samples", "smit-*: derived samples of occlusion errors"),
        sum("sampling_error_samples", "samples", "smit-*: derived samples of sampling errors"),
    ]
}

/// Hole-fill counters of every hole fill (`frames[i].hole_fill`).
pub fn hole_fill_keys() -> Vec<KeyDoc> {
    vec![
        sum("filled", "samples", "hole samples filled"),
        sum("unreached", "samples", "hole samples no pass could reach (left empty)"),
        sum(
            "fallback_filled",
            "samples",
            "epipolar: empty samples the fallback pass filled after the last warp (`fallback_fill`)",
        ),
        sum("fallback_unreached", "samples", "epipolar: empty samples the fallback pass could not reach (left empty)"),
        sum("left_empty", "samples", "didyk-inpaint: empty samples with no real 8-neighbour (left empty)"),
        peak("levels", "levels", "pull-push: pyramid levels, level 0 included (0 with nothing to fill)"),
        sum("replaced", "samples", "stretch: fills replaced by a later pass with a nearer source"),
        sum("march_steps", "samples", "stretch: samples looked at over all passes"),
        sum("border_found", "samples", "low-pass: holes whose epipolar border search found a border"),
        sum("fallback", "samples", "low-pass: holes filled from level 1 up without a border"),
        sum("unfilled", "samples", "low-pass: holes left empty (a frame without a real sample)"),
        peak("pyramid_levels", "levels", "low-pass: pyramid levels built (0 when the frame has no hole)"),
    ]
}

/// `references` of a method report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MethodReferences {
    /// Per-reference preparation ([`crate::methods::Reconstruction::prepare`]), host time (ms).
    pub prepare_ms: f64,
}

/// One derived frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodFrame {
    /// Derived frame index in the trace.
    pub index: usize,
    /// Quality against ground truth.
    #[serde(flatten)]
    pub scores: Scores,
    /// The pixels behind the scores.
    #[serde(flatten)]
    pub pixels: Pixels<u64>,
    /// Median host time of the runs (ms).
    pub host_ms: f64,
    /// Primitives drawn (the method's primitive).
    pub primitives: u64,
    /// Derived samples holding hole fill at the end (samples).
    pub hole_samples: u64,
    /// Derived samples with neither surface nor fill (samples).
    pub empty_samples: u64,
    /// Reconstruction counters.
    pub reconstruction: MethodCounters,
    /// Hole-fill counters.
    pub hole_fill: MethodCounters,
}

/// `total` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodTotal {
    /// Derived frames (frames).
    pub frames: u64,
    /// Pixel counts.
    #[serde(flatten)]
    pub pixels: Pixels<u64>,
    /// Host time (ms).
    pub host_ms: f64,
    /// Primitives drawn.
    pub primitives: u64,
    /// Hole samples (samples).
    pub hole_samples: u64,
    /// Empty samples (samples).
    pub empty_samples: u64,
    /// Reconstruction counters (summed or maxed; shares left out).
    #[serde(default)]
    pub reconstruction: MethodCounters,
    /// Hole-fill counters.
    #[serde(default)]
    pub hole_fill: MethodCounters,
}

/// `mean` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodMean {
    /// Scores.
    #[serde(flatten)]
    pub scores: Scores,
    /// Pixel counts.
    #[serde(flatten)]
    pub pixels: Pixels<f64>,
    /// Host time per frame (ms).
    pub host_ms: f64,
    /// Primitives per frame.
    pub primitives: f64,
    /// Hole samples per frame (samples).
    pub hole_samples: f64,
    /// Empty samples per frame (samples).
    pub empty_samples: f64,
    /// Reconstruction counters per frame.
    #[serde(default)]
    pub reconstruction: MethodCounters,
    /// Hole-fill counters per frame.
    #[serde(default)]
    pub hole_fill: MethodCounters,
}

/// `report.json` of `postwarp golden --method`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodReport {
    /// [`super::REPORT_VERSION`].
    pub report_version: u32,
    /// [`ReportKind::Method`].
    pub kind: ReportKind,
    /// Path of the trace manifest.
    pub trace: String,
    /// FLIP scored (`--flip`); false: the FLIP keys are null.
    pub flip: bool,
    /// Reconstruction name (`postwarp methods`).
    pub method: String,
    /// Hole-fill name.
    pub hole_fill: String,
    /// The paper it comes from.
    pub paper: String,
    /// What `primitives` counts.
    pub primitive: String,
    /// Timed runs per frame.
    pub runs: u32,
    /// Reference preparation.
    pub references: MethodReferences,
    /// Per derived frame.
    pub frames: Vec<MethodFrame>,
    /// Sums over frames.
    pub total: MethodTotal,
    /// Means over frames.
    pub mean: MethodMean,
}

/// What a method report says about the method (its header).
#[derive(Clone, Debug, PartialEq)]
pub struct MethodHeader {
    /// Path of the trace manifest.
    pub trace: String,
    /// FLIP scored.
    pub flip: bool,
    /// Reconstruction name.
    pub method: String,
    /// Hole-fill name.
    pub hole_fill: String,
    /// The paper.
    pub paper: String,
    /// What `primitives` counts.
    pub primitive: String,
    /// Timed runs per frame.
    pub runs: u32,
}

impl MethodReport {
    /// The report of `frames`, with `total` and `mean` reduced by the key
    /// rules.
    pub fn new(h: MethodHeader, references: MethodReferences, frames: Vec<MethodFrame>) -> MethodReport {
        let (total, mean) = super::reduce(&frames, &frame_keys(), |t| {
            t.insert("frames".into(), frames.len().into());
        });
        MethodReport {
            report_version: REPORT_VERSION,
            kind: ReportKind::Method,
            trace: h.trace,
            flip: h.flip,
            method: h.method,
            hole_fill: h.hole_fill,
            paper: h.paper,
            primitive: h.primitive,
            runs: h.runs,
            references,
            frames,
            total,
            mean,
        }
    }

    /// The same report with `total` and `mean` reduced again from `frames`
    /// (after a comparison re-scored them on its common mask).
    pub fn reduced_again(mut self) -> MethodReport {
        let (total, mean) = super::reduce(&self.frames, &frame_keys(), |t| {
            t.insert("frames".into(), self.frames.len().into());
        });
        self.total = total;
        self.mean = mean;
        self
    }

    /// Mean over frames of reconstruction counter `name`, if every frame
    /// has it.
    pub fn mean_reconstruction_counter(&self, name: &str) -> Option<f64> {
        let v: Option<Vec<f64>> = self.frames.iter().map(|f| f.reconstruction.get(name)).collect();
        v.filter(|v| !v.is_empty()).map(|v| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// Sum over frames of reconstruction counter `num` over the sum of
    /// `den`, if every frame has both and `den` is not 0.
    pub fn reconstruction_ratio(&self, num: &str, den: &str) -> Option<f64> {
        let sum = |name: &str| self.frames.iter().map(|f| f.reconstruction.get(name)).sum::<Option<f64>>();
        let (n, d) = (sum(num)?, sum(den)?);
        (d > 0.0).then(|| n / d)
    }
}

/// Keys of a frame.
pub fn frame_keys() -> Vec<KeyDoc> {
    let mut k = vec![scalar("index", "—", Reduce::Once, "derived frame index in the trace")];
    k.extend(super::quality::keys());
    k.extend([
        scalar(
            "host_ms",
            "ms",
            Reduce::Sum,
            "median over `runs` runs of the method's host time for this frame, one core (not deterministic)",
        ),
        scalar(
            "primitives",
            "primitives",
            Reduce::Sum,
            "primitives drawn (the report's `primitive` says what they are)",
        ),
        scalar("hole_samples", "samples", Reduce::Sum, "derived samples holding hole fill at the end"),
        scalar(
            "empty_samples",
            "samples",
            Reduce::Sum,
            "derived samples with neither a surface nor fill (output black)",
        ),
        nested("reconstruction", Reduce::Sum, reconstruction_keys, "the reconstruction's own counters (below)"),
        nested("hole_fill", Reduce::Sum, hole_fill_keys, "the hole fill's own counters (below)"),
    ]);
    k
}

fn reference_keys() -> Vec<KeyDoc> {
    vec![scalar(
        "prepare_ms",
        "ms",
        Reduce::Once,
        "per-reference preparation time, all references (host, not deterministic)",
    )]
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
        scalar("method", "—", Reduce::Once, "the reconstruction (`postwarp methods`)"),
        scalar("hole_fill", "—", Reduce::Once, "the hole fill"),
        scalar("paper", "—", Reduce::Once, "the paper the reconstruction comes from"),
        scalar("primitive", "—", Reduce::Once, "what `primitives` counts (splats, triangles, quads, …)"),
        scalar("runs", "runs", Reduce::Once, "timed runs per frame; `host_ms` is their median"),
        nested("references", Reduce::Once, reference_keys, "reference preparation"),
        nested("frames", Reduce::Once, frame_keys, "one object per derived frame"),
        nested("total", Reduce::Once, total_keys, "sums over frames (key rules)"),
        nested("mean", Reduce::Once, mean_keys, "means over frames (key rules)"),
    ]);
    k
}
