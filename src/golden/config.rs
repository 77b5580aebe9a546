//! Knobs of the golden model's algorithms, declared once in a knob table
//! (`postwarp_rtl::knob_table!`, the hardware model's machinery): each
//! knob's field, unit, one-line description, default (from the paper, or
//! from `docs/warper-reference.md` §7 where the paper is silent) and valid
//! range, in [`KNOBS`]. `docs/golden.md`'s knob table is generated from it
//! (`crate::knobs::docs`, checked by `tests/knob_table.rs`).
//!
//! API: [`GoldenConfig`] (plain struct, `Default`), [`KNOBS`],
//! [`GoldenConfig::validate`] (every knob's range; the message names the
//! knob), [`GoldenConfig::from_toml`] (a `--config` file's text). The
//! serde form (`report.json`'s `config`, a sweep point's key) is the
//! table's `{name: value}` object (`crate::knobs`): same keys, order and
//! values as the field-by-field form. The choice knobs' values are the
//! enums [`OverLimit`], [`WarpOrder`], [`Reconstruction`]
//! (`postwarp_rtl::knob_choice!`); their `clap` names (the command line)
//! must equal their `NAMES`, which `tests/knob_table.rs` checks.

use postwarp_rtl::config::{ARITH_MODES, ARITH_MODES_UNIT, QFORMAT_RANGE};
use postwarp_rtl::knob::{CrossRule, Range};
use postwarp_rtl::qformat::FixedFormats;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

postwarp_rtl::knob_choice! {
    /// What to do with a kernel wider or taller than `kernel_limit` samples.
    #[derive(clap::ValueEnum)]
    pub enum OverLimit {
        /// Clip to a `kernel_limit`-wide window of sample centres around the
        /// warped sample (the hardware's 4x4 rasterizer); the event is counted.
        Clip = "clip",
        /// Rasterize the whole box (counted too); models an unbounded rasterizer.
        Allow = "allow",
    }
}

postwarp_rtl::knob_choice! {
    /// Order in which reference samples are warped.
    #[derive(clap::ValueEnum)]
    pub enum WarpOrder {
        /// Reverse occlusion-compatible eight-sheet order, so the sweep front
        /// crosses the derived image in hole-fill order (default).
        Reverse = "reverse",
        /// Occlusion-compatible eight-sheet order (MB97-style).
        Forward = "forward",
    }
}

postwarp_rtl::knob_choice! {
    /// Reconstruction algorithm.
    #[derive(clap::ValueEnum)]
    pub enum Reconstruction {
        /// Anti-aliased path: flat-shaded axis-aligned rectangles (TR98 §7.2).
        AaRect = "aa-rect",
        /// General path: triangle mesh inside surfaces, edge splats (TR98 §7.1).
        General = "general",
    }
}

/// A finite real of at least 0.
const NON_NEGATIVE: Range = Range::Real { min: 0.0, min_open: false, max: f64::INFINITY };

/// Any `u32`.
const ANY_U32: Range = Range::Int { min: 0, max: u32::MAX as u64 };

postwarp_rtl::knob_table! {
    /// The golden model's knobs. Field names are the knob names.
    #[derive(Clone, Debug, PartialEq)]
    pub struct GoldenConfig in KNOBS {
        /// Two adjacent reference samples are one surface iff their warped
        /// distance is at most `threshold · E · |offset|`.
        threshold: f64 = 1.4; Range::Real { min: 0.0, min_open: true, max: f64::INFINITY }, "ratio of E",
            "discontinuity threshold: same surface iff warped distance ≤ threshold · E · |offset| (TR98: 1.4 for the \
             plates, 2.3 for the video)";
        kernel_limit: u32 = 4; Range::Int { min: 1, max: 64 }, "samples",
            "largest kernel side the rasterizer draws (TR98: 4x4)";
        over_limit: OverLimit = OverLimit::Clip; Range::Choice(OverLimit::NAMES), OverLimit::UNIT,
            "kernels larger than the limit: clip to a window around the warped sample, or draw whole; counted either way";
        /// ∇c, ∇s: the 1/Z slopes of candidate and stored sample.
        slope_tol: f64 = 2.0; NON_NEGATIVE, "1",
            "Z tolerance, slope term: tol = slope_tol · max(|∇c|₁, |∇s|₁) + rel_tol · max(1/Zc, 1/Zs)";
        rel_tol: f64 = 0.01; NON_NEGATIVE, "fraction of 1/Z", "Z tolerance, relative term";
        better_margin: f64 = 0.05; NON_NEGATIVE, "fraction",
            "another reference is \"better\" only if its |cos| of view angle is larger by this fraction";
        abuffer_fragments: u32 = 3; Range::Int { min: 0, max: 16 }, "fragments/pixel",
            "A-buffer fragments per pixel between warps (0 = keep samples, no A-buffer; TR98: 3)";
        hole_fill: bool = true; Range::Bool, "bool", "run the epipolar hole fill after each warp";
        /// `fallback_fill.rs`.
        fallback_fill: bool = true; Range::Bool, "bool",
            "after the last warp, fill the samples no epipolar pass reached by the pass in reverse order (needs \
             `hole_fill`; `--no-fallback-fill`)";
        hole_far_distance: u32 = 4; ANY_U32, "samples", "distance past which the two far taps join (TR98: 4)";
        hole_far_offset: u32 = 4; ANY_U32, "samples", "offset of the far taps along the line (TR98: 4)";
        hole_max_distance: u32 = 63; Range::Int { min: 1, max: 255 }, "samples",
            "saturation of the hole-fill distance plane (6 bits: 63)";
        warp_order: WarpOrder = WarpOrder::Reverse; Range::Choice(WarpOrder::NAMES), WarpOrder::UNIT,
            "reference traversal: the occlusion-compatible eight-sheet order reversed within each sweep (sweeps in \
             order), or forward";
        reconstruction: Reconstruction = Reconstruction::AaRect; Range::Choice(Reconstruction::NAMES),
            Reconstruction::UNIT, "§7.2 anti-aliased flat rectangles, or §7.1 mesh + edge splats";
        /// Shared with the hardware table by name (`docs/fixed-point.md`).
        arith: String = "float".into(); Range::Choice(ARITH_MODES), ARITH_MODES_UNIT,
            "arithmetic: `float` (FP64, FP32 planes) or `fixed` (the hardware's fixed-point mode, quantised at the \
             same points with the same rules; `aa-rect` only; `docs/fixed-point.md`)";
        q_ref_coord: String = "Q16_4".into(); QFORMAT_RANGE, "Q format",
            "fixed mode: reference sample coordinates (x ± 1/2, y ± 1/2)";
        q_ref_inv_z: String = "Q8_24".into(); QFORMAT_RANGE, "Q format", "fixed mode: reference 1/Z";
        q_numerator: String = "Q18_14".into(); QFORMAT_RANGE, "Q format", "fixed mode: warp numerators N.x, N.y";
        q_denominator: String = "Q8_24".into(); QFORMAT_RANGE, "Q format", "fixed mode: warp denominator W";
        q_reciprocal: String = "Q8_24".into(); QFORMAT_RANGE, "Q format",
            "fixed mode: 1/W, by seed table and Newton–Raphson steps";
        recip_table_bits: u32 = 8; Range::Int { min: 1, max: 16 }, "bits",
            "fixed mode: index bits of the reciprocal's seed table";
        recip_iterations: u32 = 2; Range::Int { min: 0, max: 4 }, "iterations",
            "fixed mode: Newton–Raphson steps after the seed";
        q_position: String = "Q16_16".into(); QFORMAT_RANGE, "Q format", "fixed mode: derived positions (x', y')";
        q_inv_z: String = "Q8_24".into(); QFORMAT_RANGE, "Q format", "fixed mode: derived 1/Z";
        q_slope: String = "Q8_24".into(); QFORMAT_RANGE, "Q format",
            "fixed mode: slopes of 1/Z (reference and derived) and the expected spacing E";
        q_corner: String = "Q16_16".into(); QFORMAT_RANGE, "Q format", "fixed mode: kernel corners";
        q_colour: String = "Q8_24".into(); QFORMAT_RANGE, "Q format", "fixed mode: colour channels";
        q_hole_weight: String = "Q8_24".into(); QFORMAT_RANGE, "Q format",
            "fixed mode: hole-fill weights 1/d and their sums";
    }
}

/// The rules between golden knobs (`fallback_fill` without `hole_fill`
/// has nothing to extend and does nothing, and is not one).
const CROSS_RULES: &[CrossRule<GoldenConfig>] = &[
    CrossRule {
        name: "fixed_precision",
        rule: "with `arith = \"fixed\"`: the hardware table's `fixed_precision` rule (`docs/fixed-point.md`)",
        check: |c| c.fixed_formats().map(|_| ()),
    },
    CrossRule {
        name: "fixed_aa_rect",
        rule: "`arith = \"fixed\"` needs `reconstruction = \"aa-rect\"` (the hardware's path)",
        check: |c| {
            if c.arith == "fixed" && c.reconstruction != Reconstruction::AaRect {
                return Err(format!(
                    "arith = \"fixed\": expected reconstruction = \"aa-rect\" (the fixed mode is the hardware's \
                     path), got \"{}\"",
                    c.reconstruction.name()
                ));
            }
            Ok(())
        },
    },
];

impl GoldenConfig {
    /// The fixed mode's formats (`None` with `arith = "float"`); errors
    /// name the knob. The golden model's own reading of its knobs.
    pub fn fixed_formats(&self) -> Result<Option<FixedFormats>, String> {
        if self.arith != "fixed" {
            return Ok(None);
        }
        let q = [
            &self.q_ref_coord,
            &self.q_ref_inv_z,
            &self.q_numerator,
            &self.q_denominator,
            &self.q_reciprocal,
            &self.q_position,
            &self.q_inv_z,
            &self.q_slope,
            &self.q_corner,
            &self.q_colour,
            &self.q_hole_weight,
        ];
        FixedFormats::from_knobs(q.map(|s| s.as_str()), self.recip_table_bits, self.recip_iterations).map(Some)
    }

    /// Check the knobs against their ranges in [`KNOBS`]; the message
    /// starts with the knob's name.
    pub fn validate(&self) -> Result<(), String> {
        postwarp_rtl::knob::check_all(KNOBS, CROSS_RULES, self)
    }

    /// The knobs of a TOML file's `text` over the defaults (not yet
    /// validated); errors start with the key.
    pub fn from_toml(text: &str) -> Result<GoldenConfig, String> {
        let t: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        crate::knobs::from_toml_table(KNOBS, GoldenConfig::default(), &t)
    }
}

impl Serialize for GoldenConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        crate::knobs::serialize(KNOBS, self, s)
    }
}

impl<'de> Deserialize<'de> for GoldenConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        crate::knobs::deserialize(KNOBS, d)
    }
}
