//! Knobs of the cycle-level hardware model.
//!
//! Job: one plain struct, [`EngineConfig`], with every parameter of the
//! hardware model, declared once in a knob table ([`crate::knob_table!`]):
//! each knob's field, unit, one-line description, default (from the paper,
//! UNC TR98-011, or from `docs/warper-reference.md` §5 and §7 where the
//! paper is silent) and valid range, in [`KNOBS`]. The rules between knobs
//! are [`CROSS_RULES`].
//!
//! API: `EngineConfig::default()` (= the `mark1998` preset),
//! [`EngineConfig::preset`] with the names in [`PRESETS`],
//! [`EngineConfig::validate`] (every knob's range from [`KNOBS`], then
//! [`CROSS_RULES`]; the message names the knob), [`EngineConfig::dram`]
//! (the [`DramConfig`] part), [`KNOBS`] (read and set by name:
//! [`crate::knob`]), [`RENAMED_KNOBS`] / [`current_knob_name`].
//!
//! Rules: no parsing here (this crate has no dependencies beyond `glam` and
//! `bitvec`); the `postwarp` crate maps TOML and JSON values onto the knobs
//! of [`KNOBS`] generically (`src/knobs/`) and generates the knob table of
//! `docs/units.md` from it. Only raw knobs are stored; derived quantities
//! (cycles per frame, bytes per cycle needed) are computed by whoever
//! reports them.
//!
//! Throughput/latency: not applicable (plain data).
//!
//! Not modelled: per-unit FIFO depths (they belong to the engine that wires
//! the units), clock domains other than one engine clock.
//!
//! # Presets (assumptions, documented here and nowhere else)
//!
//! `mark1998`, the default: the paper's target, 640x480 at 30 Hz with 2x2
//! super-samples and two references per derived frame (TR98 §10 goals: at
//! least 640x480 anti-aliased, 30–70 Hz, one warper serving both
//! references). A 1998-class ASIC: 100 MHz clock; memory of 1.6 GB/s, i.e.
//! a 128-bit PC100 SDRAM interface (16 bytes per 100 MHz cycle), 32-byte
//! bursts (64-bit DIMM, burst length 4), about 120 ns to first data
//! (row miss at CL2/tRCD 2/tRP 2 plus controller and pad time: 12 cycles).
//! The bandwidth model of `docs/warper-reference.md` §5 needs about
//! 1.1 GB/s at 30 Hz for this frame, so the channel has headroom. The
//! destination cache of 576 KiB covers the §5 working-set example (573 KB
//! for a 1280-sample-wide sweep with 16 rows of tilt plus parallax); the
//! source cache of 256 KiB holds one full column of the reference's
//! A-buffer blocks (a 1496-sample column of the enlarged 2x2 reference is
//! 187 blocks of about 1.3 KB), which the column sweeps of
//! `traversal` rule 6 reuse line after line (64 KiB, two pixel rows,
//! sufficed while sheets were warped one by one in half columns; with
//! whole-column sweeps it reads every block about twice). Transform
//! pipeline depth 12 cycles (a reciprocal and the 13-operation incremental
//! warp).
//!
//! Meeting the targets (`mark1998`), measured on `postwarp make-trace
//! --scene room --width 640 --height 480 --supersample 2 --frames 4` with
//! `postwarp simulate`: at one sample, one rectangle and one hole-fill
//! sample per clock and 576 KiB of destination cache a frame took
//! 4.7–5.2 M cycles (19–21 Hz at 100 MHz) with the prefetch, 5.4–5.7 M
//! without. Two transform and rasterizer lanes, four hole-fill lanes
//! (the fill is a 3–5 tap average: cheap to replicate) and 1 MiB of
//! destination cache (the measured peak with the prefetch is 518–903
//! tiles of 1 KiB on frames 1–3) bring frames 1–3 to 3.20–3.25 M cycles,
//! 30.7–31.2 Hz, with no capacity or demand miss, at 1.21 GB/s (77–78 %
//! of the 1.6 GB/s channel over the frame). One hole-fill lane fewer
//! (2) leaves frame 1 at 30.0 Hz; a second packer lane changes nothing.
//! Frame 0, whose first warp has the reference epipole inside the image,
//! needs 5.7 M cycles (17.6 Hz) and 2.3 GB/s: with sweeps of the two
//! images that do not correspond the fill cannot follow the warp, the
//! working set is most of the frame (12,600 tiles) and 1998 parts do not
//! meet 30 Hz there. 1 MiB of on-chip SRAM was large for a 1998 ASIC but
//! buildable.
//!
//! `fixed-minimal`: `mark1998` with `arith = "fixed"` at the narrowest
//! formats whose luma PSNR against ground truth stays within 0.1 dB of
//! float on room, slants, hairball and motorcycle at once
//! (`specs/precision.toml`, `docs/precision.md`): 22.6 destination bytes
//! per sample instead of 42.4.
//!
//! `hmd2026`: a stereo head-mounted display, 2 views of 2000x2000 at 90 Hz,
//! 2x2 super-samples, two references per view. A 2026 mobile-SoC block at
//! 1 GHz sharing 128-bit LPDDR5X-8533 (136.5 GB/s peak: 8533 MT/s × 16 B;
//! 136 bytes per 1 GHz cycle, rounded down), 64-byte bursts (cache line),
//! 100 ns loaded latency (100 cycles). For reference, Apple's M2 in the
//! Vision Pro has 128-bit LPDDR5-6400 at 100 GB/s. The source load with
//! references 2.6 times the display area (TR98's enlarged field of view) is
//! 2 views × 2 references × 2.6 × 16 M samples × 90 Hz ≈ 15 G samples/s,
//! hence 16 samples and 16 rectangles per cycle; 16 hole-fill samples per
//! cycle (2 views × 2 warps × 16 M samples = 64 M visits per 11.1 M-cycle
//! frame time need at least 6) and 4 packer pixels per cycle (16 M pixel
//! releases need at least 1.5). Measured on a quarter of the area
//! (`postwarp make-trace --scene room --width 1000 --height 1000
//! --supersample 2 --frames 2`, `postwarp simulate` with this preset; a
//! 2000x2000 frame does not yet fit this project's machines, issue 20):
//! with 2 MiB of destination cache frame 1 (epipoles outside) took
//! 2.43 M cycles, the compositor waiting for tiles 57 % of them, its
//! second warp's working set (2490 tiles with 8 MiB) over the 2048 tiles;
//! with 8 MiB, 1.18 M cycles, no capacity or demand miss, 23.1 GB/s at
//! 90 Hz x 2 views. Scaled by the area (x4 cycles and bytes, x2 working
//! set), a 2000x2000 view-pair takes about 9.5 M of the 11.1 M cycles of
//! 90 Hz at about 93 GB/s (68 % of the peak) with a working set near
//! 5 MiB: hence 8 MiB, an extrapolation rather than a measurement. Frame 0
//! (epipole inside) took 7.45 M cycles at 1000x1000: 90 Hz is out of
//! reach there. The §5 working set scales
//! with the sweep width (4000 samples): 4000 × 28 rows × 16 B ≈ 1.8 MB, so
//! at least 2 MiB of destination cache (8 MiB: measured above); 256 KiB of source cache. By the §5 bandwidth
//! model (f = 1.2 fragments, 12 B each) one view-frame moves about
//! 0.49 GB, i.e. about 88 GB/s for two views at 90 Hz: within the peak but
//! a large share of a memory also used by the renderer and the display,
//! which this preset does not subtract.

use crate::knob::{CrossRule, Knob, KnobValue, Range};
use crate::mem::DramConfig;

/// Bytes one super-sample occupies in an on-chip cache (colour, 1/Z and
/// slopes, flags), after `docs/warper-reference.md` §5 (16 B per sample).
pub const CACHE_BYTES_PER_SAMPLE: u64 = 16;

crate::knob_names! {
    /// Values of the `dram_backend` knob.
    pub DRAM_BACKENDS, DRAM_BACKENDS_UNIT = "ideal", "dramsim3"
}

/// What `dram_address_mapping` accepts (besides `""`, the ini's own).
const ADDRESS_MAPPING_RULE: &str = "six two-letter fields, each of ch, ra, bg, ba, ro, co once, most significant first (e.g. rochrababgco), or \"\" \
     for the ini's";

/// Check a DRAMsim3 address mapping string the way DRAMsim3 reads it (it
/// exits the process on a bad one): six two-letter fields, each of `ch`,
/// `ra`, `bg`, `ba`, `ro`, `co` once.
pub fn check_address_mapping(m: &str) -> Result<(), String> {
    const FIELDS: [&str; 6] = ["ch", "ra", "bg", "ba", "ro", "co"];
    let bad = || format!("dram_address_mapping = \"{m}\": expected {ADDRESS_MAPPING_RULE}");
    if m.len() != 12 || !m.is_ascii() {
        return Err(bad());
    }
    let mut seen: Vec<&str> = (0..6).map(|i| &m[2 * i..2 * i + 2]).collect();
    seen.sort_unstable();
    let mut want = FIELDS;
    want.sort_unstable();
    if seen != want {
        return Err(bad());
    }
    Ok(())
}

crate::knob_names! {
    /// Values of the `arith` knob (both engines' tables).
    pub ARITH_MODES, ARITH_MODES_UNIT = "float", "fixed"
}

/// A Q-format knob's range (`qformat::QFORMAT_RULE`).
pub const QFORMAT_RANGE: Range =
    Range::Text { valid: crate::qformat::QFORMAT_RULE, check: crate::qformat::QFormat::is_valid };

crate::knob_names! {
    /// Names accepted by [`EngineConfig::preset`].
    pub PRESETS, PRESETS_UNIT = "mark1998", "hmd2026", "fixed-minimal"
}

const fn int(min: u64, max: u64) -> Range {
    Range::Int { min, max }
}

crate::knob_table_with_shared! {
    /// Every knob of the hardware model. Field names are the knob names;
    /// `Default` is the `mark1998` preset.
    #[derive(Clone, Debug, PartialEq)]
    pub struct EngineConfig in KNOBS {
        // The A-buffer packs at most 16 samples per pixel (a 16-bit mask).
        supersample: u32 = 2; int(1, 4), "samples",
            "super-samples per pixel along each axis; `postwarp simulate` replaces it by the trace's \
             (`supersample_from_trace`)";
        rects_per_cycle: u32 = 2; int(1, 256), "rectangles/cycle",
            "rectangles the rasterizer (and the compositor) accepts per cycle";
        transform_latency: u32 = 12; int(1, 1024), "cycles", "pipeline depth of the transform unit";
        // Two lanes (module doc, "Meeting the targets").
        transform_throughput: u32 = 2; int(1, 256), "samples/cycle",
            "samples the transform unit accepts per cycle (also fetch and kernel-setup lanes)";
        tile_size: u32 = 8; int(1, 256), "samples",
            "side of a destination tile; the source block side is `tile_size` / `supersample` pixels";
        // The measured working set of 640x480 room with the prefetch, up to
        // 903 tiles, rounded up to 1 MiB (module doc).
        dest_cache_bytes: u64 = 1024 * 1024; int(1, 1 << 34), "bytes", "capacity of the destination tile cache";
        // One full reference column of A-buffer blocks (1496 samples of a
        // 2x2 640x480 reference with its enlarged field of view: 187 blocks
        // of about 1.3 KB): the sweeps of traversal rule 6 run whole
        // columns, and consecutive lines reuse a column's blocks. At 64 KiB
        // the 640x480 room frames read every block about twice (36.9
        // against 17.7 MB of reference fetch per frame).
        source_cache_bytes: u64 = 256 * 1024; int(1, 1 << 34), "bytes", "capacity of the source (reference) cache";
        dram_peak_bytes_per_cycle: u64 = 16; int(1, 1 << 20), "bytes/cycle",
            "peak DRAM bandwidth available to the warper";
        dram_latency_cycles: u64 = 12; int(0, 1_000_000), "cycles",
            "cycles from a DRAM request's acceptance to its first data";
        dram_burst_bytes: u64 = 32; Range::PowerOfTwo { min: 1, max: 4096 }, "bytes",
            "DRAM transfer granule; requests are rounded up to whole bursts";
        dram_max_outstanding: u32 = 16; int(1, 1 << 16), "requests", "DRAM requests outstanding at once";
        /// `ideal` is the fixed-latency, one-bus model of `mem::dram`;
        /// `dramsim3` is provided by the `postwarp` crate's `dramsim3`
        /// feature.
        dram_backend: String = "ideal".into(); Range::Choice(DRAM_BACKENDS), DRAM_BACKENDS_UNIT,
            "what times DRAM requests: `ideal` (`dram_latency_cycles`, one bus at `dram_peak_bytes_per_cycle`) or \
             `dramsim3` (a closed loop through DRAMsim3; needs a build with `--features dramsim3`; `docs/memory.md`)";
        // DRAMsim3 has no SDR SDRAM; its oldest, slowest part is the
        // first-generation LPDDR at 208 MHz (docs/memory.md).
        dram_config: String = "lpddr_2Gb_x16".into();
            Range::Text {
                valid: "a shipped DRAMsim3 ini's name (`configs/dram/`, with or without `.ini`) or a path to an ini file",
                check: |s| !s.is_empty(),
            },
            "name|path",
            "the DRAMsim3 configuration (only with `dram_backend = \"dramsim3\"`)";
        dram_address_mapping: String = String::new();
            Range::Text { valid: ADDRESS_MAPPING_RULE, check: |m| m.is_empty() || check_address_mapping(m).is_ok() },
            "text",
            "DRAMsim3's `address_mapping` overriding the ini's (e.g. `rochrababgco`: fields ch ra bg ba ro co, most \
             significant first); \"\" = the ini's (only with `dram_backend = \"dramsim3\"`)";
        clock_hz: u64 = 100_000_000; int(1, 1 << 40), "Hz",
            "engine clock frequency (used for `frame_rate_at_clock_hz`)";
        target_frame_rate_hz: f64 = 30.0; Range::Real { min: 0.0, min_open: true, max: 10_000.0 }, "Hz",
            "derived frames per second to sustain, per view (used for `dram_gbps_at_target_rate`)";
        display_width: u32 = 640; int(1, 16384), "pixels",
            "display width per view; the preset's target, not read by the simulation (the trace's frame size is \
             simulated)";
        display_height: u32 = 480; int(1, 16384), "pixels", "display height per view; as `display_width`";
        views: u32 = 1; int(1, 8), "views",
            "views rendered per frame time by the one warper (2 = stereo HMD); scales both derived rates";
        references_per_frame: u32 = 2; int(1, 16), "references",
            "reference frames warped per derived frame; the preset's assumption, not read by the simulation (the \
             trace lists each frame's references)";
        hole_fill_per_cycle: u32 = 4; int(1, 256), "samples/cycle",
            "derived samples the hole-fill unit visits per cycle";
        packer_pixels_per_cycle: u32 = 1; int(1, 256), "pixels/cycle",
            "pixels the A-buffer packer packs per cycle: a tile occupies it ⌈(tile_size/supersample)² / lanes⌉ cycles";
        tile_prefetch_distance: u32 = 2; int(0, 1 << 16), "lines",
            "lines ahead of the sweep front at which the schedule loads a destination tile (`units/tile_prefetch.rs`; \
             reference lines for the warp, derived lines for the hole fill); 0 = no prefetch, every tile on demand";
        composite_miss_queue: u32 = 4; int(0, 64), "stamps",
            "stamps that wait in the compositor's miss queue for a tile while later stamps on resident tiles go on \
             (`units/composite.rs` rule 6); 0 = block in order";
    }
}

/// Bytes of one destination tile in the cache.
pub fn tile_bytes(c: &EngineConfig) -> u64 {
    u64::from(c.tile_size).pow(2) * CACHE_BYTES_PER_SAMPLE
}

/// Bytes of the largest reference block the source cache may have to hold
/// (`units::fetch` rule 1): `(tile_size / supersample)²` pixels at their
/// largest packed size ([`crate::mem::layout::max_packed_bytes`]: a header
/// and `min(abuffer_fragments, supersample²)` fragments each, or raw
/// samples). Meaningful when `tile_size` is a multiple of `supersample`,
/// which `Engine::new` checks first; it also refuses a source cache smaller
/// than this (at the trace's super-sampling). The memory map's slots of
/// reference blocks and packed tiles are this, rounded to bursts.
pub fn largest_block_bytes(c: &EngineConfig) -> u64 {
    let side = u64::from(c.tile_size / c.supersample.max(1));
    crate::mem::layout::max_packed_bytes(c, side * side)
}

/// The rules between knobs, checked after every knob's own range, in
/// order. (That `tile_size` is a multiple of the trace's `supersample` is
/// checked by `Engine::new`, once the trace's super-sampling applies.)
pub const CROSS_RULES: &[CrossRule<EngineConfig>] = &[
    CrossRule {
        name: "fixed_precision",
        rule: "with `arith = \"fixed\"`: `q_ref_coord` has a fraction bit, `q_numerator`, `q_denominator`, \
               `q_position`, `q_corner` at least 12 and `q_reciprocal` at least 16, and (`recip_table_bits` + 1) · \
               2^`recip_iterations` ≥ 20 (`docs/fixed-point.md`)",
        check: |c| c.fixed_formats().map(|_| ()),
    },
    CrossRule {
        name: "kernel_within_tile",
        rule: "`kernel_limit` ≤ `tile_size`, so a stamp touches at most 4 tiles",
        check: |c| {
            if c.kernel_limit > c.tile_size {
                return Err(format!(
                    "kernel_limit = {}: expected at most tile_size ({}) so that one stamp touches at most 4 tiles",
                    c.kernel_limit, c.tile_size
                ));
            }
            Ok(())
        },
    },
    CrossRule {
        name: "eight_tiles_cached",
        rule: "`dest_cache_bytes` holds at least 8 tiles of `tile_size`² × 16 B (the compositor's oldest stamp keeps up \
               to 4 reserved while the other units share the rest)",
        check: |c| {
            if c.dest_cache_bytes.checked_div(tile_bytes(c)).is_none_or(|tiles| tiles < 8) {
                return Err(format!(
                    "dest_cache_bytes = {}: expected at least 8 tiles ({} bytes): the compositor's oldest stamp keeps up to 4 reserved while the other units share the rest",
                    c.dest_cache_bytes,
                    8 * tile_bytes(c)
                ));
            }
            Ok(())
        },
    },
];

/// Knobs renamed since they were introduced: (old name, new name). Files
/// that use the old name still load (the new name wins if both are
/// given, which is an error); reports and `results.csv` carry the new name
/// only (`report_version` 3).
pub const RENAMED_KNOBS: &[(&str, &str)] = &[("max_fragments", "abuffer_fragments")];

/// The current name of knob `name` (itself unless it was renamed).
pub fn current_knob_name(name: &str) -> &str {
    RENAMED_KNOBS.iter().find(|(old, _)| *old == name).map_or(name, |(_, new)| new)
}

/// Check `v` against the range of hardware knob `name` ([`Knob::check`]).
pub fn check_knob(name: &str, v: KnobValue) -> Result<(), String> {
    let k: &Knob<EngineConfig> =
        crate::knob::find(KNOBS, name).ok_or_else(|| format!("{name}: not a hardware knob"))?;
    k.check(&v)
}

impl EngineConfig {
    /// A named preset (see the module documentation for the numbers and
    /// their sources); the error lists the known names.
    pub fn preset(name: &str) -> Result<EngineConfig, String> {
        match name {
            "mark1998" => Ok(EngineConfig::default()),
            "hmd2026" => Ok(EngineConfig {
                rects_per_cycle: 16,
                transform_throughput: 16,
                hole_fill_per_cycle: 16,
                packer_pixels_per_cycle: 4,
                // Measured working set, scaled to 4000-sample sweeps (module doc).
                dest_cache_bytes: 8 * 1024 * 1024,
                source_cache_bytes: 256 * 1024,
                dram_peak_bytes_per_cycle: 136,
                dram_latency_cycles: 100,
                dram_burst_bytes: 64,
                dram_max_outstanding: 64,
                // DRAMsim3's newest mobile part (no LPDDR5 config ships).
                dram_config: "LPDDR4_8Gb_x16_2400".into(),
                clock_hz: 1_000_000_000,
                target_frame_rate_hz: 90.0,
                display_width: 2000,
                display_height: 2000,
                views: 2,
                ..EngineConfig::default()
            }),
            // mark1998 with the fixed-point datapath at the narrowest
            // formats within 0.1 dB of float on room, slants, hairball and
            // motorcycle together (`docs/precision.md`, specs/precision.toml).
            "fixed-minimal" => Ok(EngineConfig {
                arith: "fixed".into(),
                q_ref_coord: "Q16_1".into(),
                q_ref_inv_z: "Q8_12".into(),
                q_numerator: "Q18_12".into(),
                q_denominator: "Q8_12".into(),
                q_reciprocal: "Q8_16".into(),
                recip_table_bits: 4,
                q_position: "Q16_12".into(),
                q_inv_z: "Q8_8".into(),
                q_slope: "Q8_12".into(),
                q_corner: "Q16_12".into(),
                q_colour: "Q8_8".into(),
                q_hole_weight: "Q8_2".into(),
                ..EngineConfig::default()
            }),
            _ => Err(format!("unknown preset `{name}`: expected one of {}", PRESETS.join(", "))),
        }
    }

    /// The DRAM model's knobs.
    pub fn dram(&self) -> DramConfig {
        DramConfig {
            peak_bytes_per_cycle: self.dram_peak_bytes_per_cycle,
            latency_cycles: self.dram_latency_cycles,
            burst_bytes: self.dram_burst_bytes,
            max_outstanding: self.dram_max_outstanding as usize,
        }
    }

    /// Check the knobs: each against its range in [`KNOBS`], then
    /// [`CROSS_RULES`]; the message starts with the knob's name.
    pub fn validate(&self) -> Result<(), String> {
        crate::knob::check_all(KNOBS, CROSS_RULES, self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_match_the_paper() {
        let c = EngineConfig::default();
        assert_eq!(c.validate(), Ok(()));
        assert_eq!((c.supersample, c.abuffer_fragments, c.kernel_limit, c.tile_size), (2, 3, 4, 8));
        assert_eq!((c.display_width, c.display_height, c.references_per_frame), (640, 480, 2));
        assert_eq!(c.dest_cache_bytes, 1 << 20);
    }

    #[test]
    fn presets_validate() {
        for name in PRESETS {
            let c = EngineConfig::preset(name).unwrap();
            assert_eq!(c.validate(), Ok(()), "{name}");
        }
        assert_eq!(EngineConfig::preset("mark1998"), Ok(EngineConfig::default()));
        let hmd = EngineConfig::preset("hmd2026").unwrap();
        assert_eq!((hmd.views, hmd.display_width, hmd.display_height, hmd.target_frame_rate_hz), (2, 2000, 2000, 90.0));
    }

    #[test]
    fn an_unknown_preset_lists_the_known_ones() {
        let e = EngineConfig::preset("nope").unwrap_err();
        assert!(e.contains("nope") && e.contains("mark1998") && e.contains("hmd2026"), "{e}");
    }

    /// Sets one knob to an invalid value.
    type Breaker = fn(&mut EngineConfig);

    /// One invalid setting per knob.
    fn invalid_cases() -> Vec<(&'static str, Breaker)> {
        vec![
            ("supersample", |c| c.supersample = 5),
            ("abuffer_fragments", |c| c.abuffer_fragments = 17),
            ("kernel_limit", |c| c.kernel_limit = 0),
            ("rects_per_cycle", |c| c.rects_per_cycle = 0),
            ("transform_latency", |c| c.transform_latency = 0),
            ("transform_throughput", |c| c.transform_throughput = 0),
            ("tile_size", |c| c.tile_size = 0),
            ("dest_cache_bytes", |c| c.dest_cache_bytes = 8 * 8 * 16 * 8 - 1),
            ("source_cache_bytes", |c| c.source_cache_bytes = 0),
            ("dram_peak_bytes_per_cycle", |c| c.dram_peak_bytes_per_cycle = 0),
            ("dram_latency_cycles", |c| c.dram_latency_cycles = u64::MAX),
            ("dram_burst_bytes", |c| c.dram_burst_bytes = 24),
            ("dram_max_outstanding", |c| c.dram_max_outstanding = 0),
            ("dram_backend", |c| c.dram_backend = "ramulator".into()),
            ("dram_config", |c| c.dram_config = String::new()),
            ("dram_address_mapping", |c| c.dram_address_mapping = "rochrababgcoX".into()),
            ("clock_hz", |c| c.clock_hz = 0),
            ("target_frame_rate_hz", |c| c.target_frame_rate_hz = f64::NAN),
            ("display_width", |c| c.display_width = 0),
            ("display_height", |c| c.display_height = 20_000),
            ("views", |c| c.views = 0),
            ("references_per_frame", |c| c.references_per_frame = 0),
            ("threshold", |c| c.threshold = -1.0),
            ("slope_tol", |c| c.slope_tol = f64::INFINITY),
            ("rel_tol", |c| c.rel_tol = 2.0),
            ("better_margin", |c| c.better_margin = f64::NAN),
            ("hole_far_distance", |c| c.hole_far_distance = 0),
            ("hole_far_offset", |c| c.hole_far_offset = 0),
            ("hole_max_distance", |c| c.hole_max_distance = 256),
            ("hole_fill_per_cycle", |c| c.hole_fill_per_cycle = 0),
            ("packer_pixels_per_cycle", |c| c.packer_pixels_per_cycle = 0),
            ("tile_prefetch_distance", |c| c.tile_prefetch_distance = 70_000),
            ("composite_miss_queue", |c| c.composite_miss_queue = 65),
            ("arith", |c| c.arith = "double".into()),
            ("q_ref_coord", |c| c.q_ref_coord = "Q0_0".into()),
            ("q_ref_inv_z", |c| c.q_ref_inv_z = "Q40_40".into()),
            ("q_numerator", |c| c.q_numerator = "X16_16".into()),
            ("q_denominator", |c| c.q_denominator = "Q16".into()),
            ("q_reciprocal", |c| c.q_reciprocal = String::new()),
            ("recip_table_bits", |c| c.recip_table_bits = 0),
            ("recip_iterations", |c| c.recip_iterations = 5),
            ("q_position", |c| c.q_position = "q16_16".into()),
            ("q_inv_z", |c| c.q_inv_z = "Q8_-1".into()),
            ("q_slope", |c| c.q_slope = "Q8_24_1".into()),
            ("q_corner", |c| c.q_corner = "Q_16".into()),
            ("q_colour", |c| c.q_colour = "Q64_1".into()),
            ("q_hole_weight", |c| c.q_hole_weight = "Q0_8".into()),
        ]
    }

    #[test]
    fn each_invalid_knob_is_rejected_with_its_name() {
        for (knob, break_it) in invalid_cases() {
            let mut c = EngineConfig::default();
            break_it(&mut c);
            let e = c.validate().expect_err(knob);
            assert!(e.starts_with(&format!("{knob} = ")), "{knob}: {e}");
        }
    }

    #[test]
    fn every_knob_is_listed_and_has_an_invalid_case() {
        // A bool knob has no invalid value.
        let mut listed: Vec<&str> = KNOBS.iter().filter(|k| k.unit != "bool").map(|k| k.name).collect();
        let mut tested: Vec<&str> = invalid_cases().iter().map(|k| k.0).collect();
        listed.sort();
        tested.sort();
        assert_eq!(listed, tested);
        assert!(KNOBS.iter().all(|k| !k.unit.is_empty() && !k.description.is_empty()));
        // Field count check: Debug prints one `name: value` per field.
        let fields = format!("{:?}", EngineConfig::default()).matches(": ").count();
        assert_eq!(fields, KNOBS.len());
    }

    #[test]
    fn the_largest_block_is_its_pixels_at_their_largest_packed_size() {
        use crate::units::abuffer::{FRAGMENT_BYTES, PIXEL_HEADER_BYTES, RAW_SAMPLE_BYTES};
        // 8-sample tiles at 2x2: 4x4-pixel blocks of min(3, 4) fragments.
        let default = EngineConfig::default();
        assert_eq!((default.tile_size, default.supersample, default.abuffer_fragments), (8, 2, 3));
        assert_eq!(largest_block_bytes(&default), 16 * (PIXEL_HEADER_BYTES + 3 * FRAGMENT_BYTES));
        let raw = EngineConfig { abuffer_fragments: 0, tile_size: 16, supersample: 1, ..default.clone() };
        assert_eq!(largest_block_bytes(&raw), 256 * RAW_SAMPLE_BYTES);
        // More fragments allowed than samples in a pixel: one per sample at most.
        let wide = EngineConfig { abuffer_fragments: 16, supersample: 1, ..default };
        assert_eq!(largest_block_bytes(&wide), 64 * (PIXEL_HEADER_BYTES + FRAGMENT_BYTES));
    }

    #[test]
    fn address_mappings_are_checked_as_dramsim3_reads_them() {
        for ok in ["rochrababgco", "robabgrachco", "chrabgbaroco", "rorabgbachco"] {
            assert_eq!(check_address_mapping(ok), Ok(()), "{ok}");
        }
        for bad in ["", "rochrababg", "rorochbabgco", "rochrababgcx", "rochrababgcoco", "ROCHRABABGCO"] {
            assert!(check_address_mapping(bad).unwrap_err().starts_with("dram_address_mapping = "), "{bad}");
        }
    }

    #[test]
    fn the_dram_part_maps_field_by_field() {
        let c = EngineConfig::preset("hmd2026").unwrap();
        let d = c.dram();
        assert_eq!((d.peak_bytes_per_cycle, d.latency_cycles, d.burst_bytes, d.max_outstanding), (136, 100, 64, 64));
    }
}
