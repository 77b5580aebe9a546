//! Knobs of the golden model's algorithms. Each has a unit, a one-line
//! description and a default from the paper (or from `docs/warper-reference.md`
//! §7 where the paper is silent); `docs/golden.md` lists them.

use serde::{Deserialize, Serialize};

/// What to do with a kernel wider or taller than `kernel_limit` samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum OverLimit {
    /// Clip to a `kernel_limit`-wide window of sample centres around the
    /// warped sample (the hardware's 4x4 rasterizer); the event is counted.
    Clip,
    /// Rasterize the whole box (counted too); models an unbounded rasterizer.
    Allow,
}

/// Order in which reference samples are warped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum WarpOrder {
    /// Reverse occlusion-compatible eight-sheet order, so the sweep front
    /// crosses the derived image in hole-fill order (default).
    Reverse,
    /// Occlusion-compatible eight-sheet order (MB97-style).
    Forward,
}

/// Reconstruction algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Reconstruction {
    /// Anti-aliased path: flat-shaded axis-aligned rectangles (TR98 §7.2).
    AaRect,
    /// General path: triangle mesh inside surfaces, edge splats (TR98 §7.1).
    General,
}

/// The golden model's knobs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GoldenConfig {
    /// Discontinuity threshold (ratio of the expected spacing E): two
    /// adjacent reference samples are one surface iff their warped distance
    /// is at most `threshold · E · |offset|`. TR98: 1.4 (plates) to 2.3.
    pub threshold: f64,
    /// Largest kernel side the rasterizer draws (samples). TR98: 4.
    pub kernel_limit: u32,
    /// Handling of kernels larger than `kernel_limit`.
    pub over_limit: OverLimit,
    /// Z tolerance, slope term (dimensionless): tol = slope_tol·(|∂x|+|∂y|)
    /// of the derived 1/Z + rel_tol·(1/Z).
    pub slope_tol: f64,
    /// Z tolerance, relative term (fraction of 1/Z).
    pub rel_tol: f64,
    /// Same-surface arbitration: another reference is "better" only if its
    /// |cos| of view angle exceeds this one's by this fraction.
    pub better_margin: f64,
    /// A-buffer fragments per pixel between warps (0 = store samples, no
    /// A-buffer). TR98: 3.
    pub abuffer_fragments: u32,
    /// Run the epipolar hole fill after each reference warp.
    pub hole_fill: bool,
    /// After the last warp, fill the samples no epipolar pass reached by the
    /// same pass run in the reverse order (`fallback_fill.rs`). Needs
    /// `hole_fill`.
    pub fallback_fill: bool,
    /// Hole-fill distance (samples) past which the two far taps join (TR98: 4).
    pub hole_far_distance: u32,
    /// Offset of the far taps along the line (samples; TR98: 4).
    pub hole_far_offset: u32,
    /// Hole-fill distance saturation (samples; 6-bit plane = 63).
    pub hole_max_distance: u32,
    /// Warp traversal order.
    pub warp_order: WarpOrder,
    /// Reconstruction algorithm.
    pub reconstruction: Reconstruction,
}

impl Default for GoldenConfig {
    fn default() -> Self {
        GoldenConfig {
            threshold: 1.4,
            kernel_limit: 4,
            over_limit: OverLimit::Clip,
            slope_tol: 2.0,
            rel_tol: 0.01,
            better_margin: 0.05,
            abuffer_fragments: 3,
            hole_fill: true,
            fallback_fill: true,
            hole_far_distance: 4,
            hole_far_offset: 4,
            hole_max_distance: 63,
            warp_order: WarpOrder::Reverse,
            reconstruction: Reconstruction::AaRect,
        }
    }
}

/// (name, unit, description) of every knob, for reports and docs.
pub const KNOBS: &[(&str, &str, &str)] = &[
    (
        "threshold",
        "ratio of E",
        "discontinuity threshold: same surface iff warped distance <= threshold x expected spacing",
    ),
    ("kernel_limit", "samples", "largest kernel side the rasterizer draws"),
    ("over_limit", "clip|allow", "kernels larger than kernel_limit: clip to a window around the sample, or draw whole"),
    ("slope_tol", "1", "Z tolerance slope term: tol = slope_tol*(|d/dx|+|d/dy|)(1/Z) + rel_tol*(1/Z)"),
    ("rel_tol", "fraction of 1/Z", "Z tolerance relative term"),
    (
        "better_margin",
        "fraction",
        "another reference is better only if its |cos| view angle is larger by this fraction",
    ),
    ("abuffer_fragments", "fragments/pixel", "A-buffer fragments per pixel between warps (0 = no A-buffer)"),
    ("hole_fill", "bool", "run the epipolar hole fill after each reference warp"),
    (
        "fallback_fill",
        "bool",
        "after the last warp, fill the samples no epipolar pass reached (the pass in reverse order); needs hole_fill",
    ),
    ("hole_far_distance", "samples", "hole-fill distance past which the two far taps join"),
    ("hole_far_offset", "samples", "offset of the far hole-fill taps"),
    ("hole_max_distance", "samples", "saturation of the hole-fill distance plane"),
    (
        "warp_order",
        "reverse|forward",
        "reference traversal: the occlusion-compatible eight-sheet order reversed within each sweep (sweeps in order), or forward",
    ),
    ("reconstruction", "aa-rect|general", "anti-aliased flat rectangles, or mesh + edge splats"),
];

impl GoldenConfig {
    /// Check the knobs; the message names the knob.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(format!("{name} = {v}: expected a positive number")) }
        };
        pos("threshold", self.threshold)?;
        if !(self.slope_tol.is_finite() && self.slope_tol >= 0.0) {
            return Err(format!("slope_tol = {}: expected >= 0", self.slope_tol));
        }
        if !(self.rel_tol.is_finite() && self.rel_tol >= 0.0) {
            return Err(format!("rel_tol = {}: expected >= 0", self.rel_tol));
        }
        if !(self.better_margin.is_finite() && self.better_margin >= 0.0) {
            return Err(format!("better_margin = {}: expected >= 0", self.better_margin));
        }
        if !(1..=64).contains(&self.kernel_limit) {
            return Err(format!("kernel_limit = {}: expected 1 to 64 samples", self.kernel_limit));
        }
        if self.abuffer_fragments > 16 {
            return Err(format!("abuffer_fragments = {}: expected 0 to 16", self.abuffer_fragments));
        }
        if !(1..=255).contains(&self.hole_max_distance) {
            return Err(format!("hole_max_distance = {}: expected 1 to 255", self.hole_max_distance));
        }
        Ok(())
    }
}
