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

use postwarp_rtl::knob::{CrossRule, Range};
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

postwarp_rtl::knob_table_with_shared! {
    /// The golden model's knobs. Field names are the knob names.
    #[derive(Clone, Debug, PartialEq)]
    pub struct GoldenConfig in KNOBS {
        over_limit: OverLimit = OverLimit::Clip; Range::Choice(OverLimit::NAMES), OverLimit::UNIT,
            "kernels larger than the limit: clip to a window around the warped sample, or draw whole; counted either way";
        hole_fill: bool = true; Range::Bool, "bool", "run the epipolar hole fill after each warp";
        warp_order: WarpOrder = WarpOrder::Reverse; Range::Choice(WarpOrder::NAMES), WarpOrder::UNIT,
            "reference traversal: the occlusion-compatible eight-sheet order reversed within each sweep (sweeps in \
             order), or forward";
        reconstruction: Reconstruction = Reconstruction::AaRect; Range::Choice(Reconstruction::NAMES),
            Reconstruction::UNIT, "§7.2 anti-aliased flat rectangles, or §7.1 mesh + edge splats";
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
