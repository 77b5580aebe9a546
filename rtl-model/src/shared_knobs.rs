//! The functional knobs both engines have, declared once: the rules of
//! TR98 that the golden model and the hardware model implement alike
//! (discontinuity threshold, Z tolerance, A-buffer, hole fill) and the
//! fixed-point datapath's formats (`docs/fixed-point.md`).
//!
//! Job: [`knob_table_with_shared!`] is [`knob_table!`](crate::knob_table)
//! with these knobs appended to the struct's own, so `EngineConfig` and
//! the `postwarp` crate's `GoldenConfig` get the same name, type, unit,
//! description, default and range from this one declaration, plus the one
//! reading of the formats, `fixed_formats()`.
//!
//! Rules:
//! 1. A knob both engines read is declared here and nowhere else; one
//!    engine's own knobs stay in its table (`config.rs`,
//!    `src/golden/config.rs`).
//! 2. The ranges are the hardware's (a golden run accepts exactly what a
//!    `simulate` of the same knobs accepts): the hole-fill distances fit
//!    the 6-bit plane, the tolerances are bounded.
//!
//! Throughput/latency: not applicable (configuration).

/// [`knob_table!`](crate::knob_table) with the shared knobs (module doc)
/// after the struct's own, and `fixed_formats()` reading their formats.
#[macro_export]
macro_rules! knob_table_with_shared {
    (
        $(#[$smeta:meta])*
        $vis:vis struct $name:ident in $table:ident { $($own:tt)* }
    ) => {
        $crate::knob_table! {
            $(#[$smeta])*
            $vis struct $name in $table {
                $($own)*
                kernel_limit: u32 = 4; $crate::knob::Range::Int { min: 1, max: 64 }, "samples",
                    "largest kernel side the rasterizer draws (TR98: 4x4)";
                abuffer_fragments: u32 = 3; $crate::knob::Range::Int { min: 0, max: 16 }, "fragments/pixel",
                    "A-buffer fragments per pixel between warps, in memory (0 = raw samples, no A-buffer; TR98: 3)";
                /// TR98: 1.4 for the plates, 2.3 for the video.
                threshold: f64 = 1.4; $crate::knob::Range::Real { min: 0.01, min_open: false, max: 100.0 },
                    "ratio of E",
                    "discontinuity threshold: same surface iff warped distance ≤ threshold · E · |offset| (TR98: 1.4 \
                     for the plates, 2.3 for the video)";
                /// ∇c, ∇s: the 1/Z slopes of candidate and stored sample.
                slope_tol: f64 = 2.0; $crate::knob::Range::Real { min: 0.0, min_open: false, max: 1000.0 }, "1",
                    "Z tolerance, slope term: tol = slope_tol · max(|∇c|₁, |∇s|₁) + rel_tol · max(1/Zc, 1/Zs)";
                rel_tol: f64 = 0.01; $crate::knob::Range::Real { min: 0.0, min_open: false, max: 1.0 },
                    "fraction of 1/Z", "Z tolerance, relative term";
                better_margin: f64 = 0.05; $crate::knob::Range::Real { min: 0.0, min_open: false, max: 10.0 },
                    "fraction",
                    "another reference is \"better\" only if its |cos| of view angle is larger by this fraction";
                hole_far_distance: u32 = 4; $crate::knob::Range::Int { min: 1, max: 63 }, "samples",
                    "hole-fill distance past which the two far taps join (TR98: 4)";
                hole_far_offset: u32 = 4; $crate::knob::Range::Int { min: 1, max: 64 }, "samples",
                    "offset of the far hole-fill taps along the previous line (TR98: 4)";
                hole_max_distance: u32 = 63; $crate::knob::Range::Int { min: 1, max: 255 }, "samples",
                    "saturation of the hole-fill distance plane (6 bits: 63)";
                /// `units/fallback_fill.rs`, `src/golden/fallback_fill.rs`.
                fallback_fill: bool = true; $crate::knob::Range::Bool, "bool",
                    "after the last warp, the hole fill's fallback pass fills the samples no epipolar pass reached \
                     (in reverse order; the golden model's needs `hole_fill`, `golden --no-fallback-fill` turns it off)";
                /// `docs/fixed-point.md`; the `q_*` formats and the
                /// reciprocal's knobs are read only with `arith = "fixed"`.
                arith: String = "float".into(); $crate::knob::Range::Choice($crate::config::ARITH_MODES),
                    $crate::config::ARITH_MODES_UNIT,
                    "datapath arithmetic: `float` (FP64 arithmetic, FP32 planes) or `fixed` (values rounded to the \
                     `q_*` formats where each unit produces them, saturating and counted; the golden model \
                     quantises at the same points with the same rules, `aa-rect` only; `docs/fixed-point.md`)";
                q_ref_coord: String = "Q16_4".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: reference sample coordinates (x ± 1/2, y ± 1/2) at fetch";
                q_ref_inv_z: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: reference 1/Z at fetch";
                q_numerator: String = "Q18_14".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: the transform's warp numerators N.x, N.y";
                q_denominator: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: the transform's warp denominator W";
                q_reciprocal: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: 1/W, by seed table and Newton–Raphson steps";
                recip_table_bits: u32 = 8; $crate::knob::Range::Int { min: 1, max: 16 }, "bits",
                    "fixed mode: index bits of the reciprocal's seed table (2^bits entries)";
                recip_iterations: u32 = 2; $crate::knob::Range::Int { min: 0, max: 4 }, "iterations",
                    "fixed mode: Newton–Raphson steps after the seed";
                q_position: String = "Q16_16".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: derived positions (x', y') = N·(1/W)";
                q_inv_z: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: derived 1/Z";
                q_slope: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: slopes of 1/Z (reference at fetch, derived at the raster) and the expected spacing E";
                q_corner: String = "Q16_16".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: kernel corners (shared means and exact edge corners)";
                q_colour: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: colour channels (reference at fetch, hole-fill means and accumulations)";
                q_hole_weight: String = "Q8_24".into(); $crate::config::QFORMAT_RANGE, "Q format",
                    "fixed mode: hole-fill weights 1/d and their sums (plane 9)";
            }
        }

        impl $name {
            /// The fixed mode's formats (`None` with `arith = "float"`);
            /// errors name the knob.
            pub fn fixed_formats(&self) -> Result<Option<$crate::qformat::FixedFormats>, String> {
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
                $crate::qformat::FixedFormats::from_knobs(
                    q.map(|s| s.as_str()),
                    self.recip_table_bits,
                    self.recip_iterations,
                )
                .map(Some)
            }
        }
    };
}
