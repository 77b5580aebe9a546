//! SRAM and arithmetic budget of a hardware configuration
//! (`docs/budget.md`): the bytes of every on-chip store, the operators per
//! sample of every datapath, and an area estimate for one stated process
//! node from published per-bit and per-operator constants.
//!
//! Job: plain data. [`Budget::of`] sizes a configuration alone (the
//! derived frame from its display knobs, the reference line from
//! [`REFERENCE_LINE_SCALE`]); [`Budget::sized`] takes the frame and
//! reference sizes of a trace (what `postwarp simulate` and `postwarp size`
//! report).
//!
//! Rules:
//! 1. Widths come from one function, [`widths`]: today the float formats
//!    the model actually stores (FP32 planes, FP64 values between units)
//!    and computes in (FP64), the integer types it holds (u8 source and
//!    distance, u32 coordinates, 64-bit rank keys). A fixed-point mode
//!    changes that function only.
//! 2. A store's bytes are `⌈entries · bits_per_entry / 8⌉`; the totals are
//!    the sums over the stores ([`Totals`]). Every store is listed even when
//!    the configuration leaves it empty (0 entries).
//! 3. Operators are counted per item of each datapath (a reference
//!    sample, a kernel, a derived sample, a pixel), on its longest path
//!    (worst case), from the function named in [`Datapath::function`]. A
//!    division counts one reciprocal and one multiply; a division by a
//!    per-warp constant, one multiply (the reciprocal is a register);
//!    multiplies by constants that fold (0.5, ±1, `threshold · |o|`) are
//!    not counted; abs, negation and sign tests are free; min, max and
//!    every comparison count one compare. `items_per_cycle` is the peak
//!    rate the knobs give the datapath; a fully pipelined datapath
//!    instantiates `ops · items_per_cycle` operators.
//! 4. Area: stores at [`AREA_CONSTANTS`]' SRAM bit (SRAM stores) or
//!    flip-flop (register stores) area per bit; operators at their adder or
//!    multiplier area scaled to the format ([`op_area_um2`]). The
//!    constants are those of one process node ([`PROCESS_NODE`]), each with
//!    its source; the ones marked estimate are not published figures.
//!
//! Not counted: the per-warp constant registers (H, ê, intrinsics, a few
//! dozen FP64 values), tag and replacement state of the source cache
//! (variable-size blocks), the memory port's request queues (addresses
//! only), the tile manager's per-line kernel counters, the prefetch lists
//! (driver-built, two 8-byte entries per tile), control logic, multiplexers,
//! wiring and the clock tree.

use crate::config::{CACHE_BYTES_PER_SAMPLE, EngineConfig};
use crate::units::abuffer::{FRAGMENT_BYTES, PIXEL_HEADER_BYTES};
use crate::units::packer::WRITE_QUEUE_LIMIT;

/// Reference line length over the display's, per axis, when no trace gives
/// the reference size (ratio): the default trace's reference has an 88°
/// horizontal field for a 60° display at the same focal length,
/// `tan 44° / tan 30° = 1.6725` (`src/tracegen.rs` rule 4).
pub const REFERENCE_LINE_SCALE: f64 = 1.6725;

/// An arithmetic or storage format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// IEEE binary float: total bits and significand bits (with the hidden
    /// bit).
    Float {
        /// Total bits.
        bits: u32,
        /// Significand bits, hidden bit included.
        mantissa: u32,
    },
    /// Two's-complement or unsigned integer of `bits` bits.
    Int {
        /// Total bits.
        bits: u32,
    },
}

impl Format {
    /// IEEE binary32.
    pub const FP32: Format = Format::Float { bits: 32, mantissa: 24 };
    /// IEEE binary64.
    pub const FP64: Format = Format::Float { bits: 64, mantissa: 53 };

    /// Total bits.
    pub fn bits(self) -> u32 {
        match self {
            Format::Float { bits, .. } | Format::Int { bits } => bits,
        }
    }

    /// Short name (`fp64`, `int64`).
    pub fn name(self) -> String {
        match self {
            Format::Float { bits, .. } => format!("fp{bits}"),
            Format::Int { bits } => format!("int{bits}"),
        }
    }
}

/// The widths of every stored quantity and the formats of the arithmetic
/// (rule 1), in bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Widths {
    /// One colour channel of a plane (planes 1 and 6, candidates, kernels).
    pub colour: u32,
    /// Derived 1/Z of plane 2 and of a candidate.
    pub inv_z: u32,
    /// One slope of 1/Z (plane 3, candidates, reference records).
    pub slope: u32,
    /// Source (reference) number, plane 4.
    pub source: u32,
    /// A one-bit flag (planes 5 and 7, `real`, valid bits).
    pub flag: u32,
    /// Hole-fill distance, plane 8.
    pub fill_distance: u32,
    /// Hole-fill weight, plane 9.
    pub fill_weight: u32,
    /// A value held between units at compute precision (warped positions,
    /// derived 1/Z, E, kernel boxes, reference 1/Z).
    pub wide: u32,
    /// Sample coordinates, line numbers, tile numbers, counts.
    pub coord: u32,
    /// Raster stamp bounds (signed).
    pub bound: u32,
    /// The hole fill's rank key of a sample.
    pub rank: u32,
    /// A fragment's key (source number or object id).
    pub key: u32,
    /// A fragment's coverage mask.
    pub mask: u32,
    /// Reference depth Z in the kernel-setup records.
    pub depth: u32,
    /// Format of the float datapaths.
    pub compute: Format,
    /// Format of the arithmetic on stored FP32 values (the unpacker).
    pub storage: Format,
    /// Format of the integer datapaths (raster bounds, rank keys).
    pub integer: Format,
    /// Format of the datapaths the fixed mode leaves in floating point
    /// (derived slopes and better mask inside, the A-buffer packer and its
    /// sums): FP64 in both modes.
    pub float_kept: Format,
}

/// The widths of `cfg` (rule 1): with `arith = "float"` the model's float
/// widths (FP32 storage, FP64 arithmetic); with `arith = "fixed"` the Q
/// formats' (`docs/fixed-point.md`): planes and candidates at `q_colour`,
/// `q_inv_z`, `q_slope` and `q_hole_weight`, values between units at the
/// widest of the position, 1/Z, slope and corner formats, the float
/// datapaths as integer datapaths of the widest format (the reciprocal's
/// and numerator's included). The A-buffer's unpacker and the reference
/// depth records stay FP32 (the fixed mode does not change them).
pub fn widths(cfg: &EngineConfig) -> Widths {
    let float = Widths {
        colour: 32,
        inv_z: 32,
        slope: 32,
        source: 8,
        flag: 1,
        fill_distance: 8,
        fill_weight: 32,
        wide: 64,
        coord: 32,
        bound: 64,
        rank: 64,
        key: 32,
        mask: 16,
        depth: 32,
        compute: Format::FP64,
        storage: Format::FP32,
        integer: Format::Int { bits: 64 },
        float_kept: Format::FP64,
    };
    let Ok(Some(f)) = cfg.fixed_formats() else { return float };
    let wide = [f.position, f.inv_z, f.slope, f.corner, f.ref_inv_z].iter().map(|q| q.bits()).max().unwrap_or(64);
    let all = [
        f.ref_coord,
        f.ref_inv_z,
        f.numerator,
        f.denominator,
        f.reciprocal,
        f.position,
        f.inv_z,
        f.slope,
        f.corner,
        f.colour,
        f.hole_weight,
    ];
    Widths {
        colour: f.colour.bits(),
        inv_z: f.inv_z.bits(),
        slope: f.slope.bits(),
        fill_weight: f.hole_weight.bits(),
        wide,
        compute: Format::Int { bits: all.iter().map(|q| q.bits()).max().unwrap_or(64) },
        ..float
    }
}

/// What a store is built from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreKind {
    /// An SRAM array.
    Sram,
    /// Flip-flops (FIFOs, pipeline and working registers).
    Registers,
}

impl StoreKind {
    /// `sram` or `registers`.
    pub fn name(self) -> &'static str {
        match self {
            StoreKind::Sram => "sram",
            StoreKind::Registers => "registers",
        }
    }
}

/// One on-chip store.
#[derive(Clone, Debug, PartialEq)]
pub struct Store {
    /// Name, `unit.store`.
    pub name: &'static str,
    /// The unit that owns it.
    pub unit: &'static str,
    /// SRAM or registers.
    pub kind: StoreKind,
    /// Entries (entries).
    pub entries: u64,
    /// Bits per entry (bits).
    pub bits_per_entry: u64,
    /// `⌈entries · bits_per_entry / 8⌉` (bytes).
    pub bytes: u64,
    /// Estimated area (mm²).
    pub area_mm2: f64,
    /// What an entry holds.
    pub holds: &'static str,
}

/// Operator counts (operators).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ops {
    /// Multiplies.
    pub mul: u64,
    /// Adds and subtracts (and float-to-integer conversions).
    pub add: u64,
    /// Reciprocals (one per division).
    pub recip: u64,
    /// Square roots.
    pub sqrt: u64,
    /// Compares, min and max.
    pub cmp: u64,
}

impl Ops {
    const fn new(mul: u64, add: u64, recip: u64, sqrt: u64, cmp: u64) -> Ops {
        Ops { mul, add, recip, sqrt, cmp }
    }

    /// Every count times `k`.
    pub fn times(self, k: u64) -> Ops {
        Ops::new(self.mul * k, self.add * k, self.recip * k, self.sqrt * k, self.cmp * k)
    }

    /// The sum with `o`.
    pub fn plus(self, o: Ops) -> Ops {
        Ops::new(self.mul + o.mul, self.add + o.add, self.recip + o.recip, self.sqrt + o.sqrt, self.cmp + o.cmp)
    }
}

/// One datapath of a unit (rule 3).
#[derive(Clone, Debug, PartialEq)]
pub struct Datapath {
    /// The unit.
    pub unit: &'static str,
    /// The function the counts were read from.
    pub function: &'static str,
    /// What one item is.
    pub item: &'static str,
    /// Peak items per cycle (items/cycle).
    pub items_per_cycle: u64,
    /// Operators per item.
    pub per_item: Ops,
    /// Operators instantiated: `per_item · items_per_cycle`.
    pub instances: Ops,
    /// Format of the operators.
    pub format: Format,
    /// Estimated area of the instances (mm²).
    pub area_mm2: f64,
}

/// Sums over the stores and datapaths (rule 2).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    /// Bytes of every store (bytes).
    pub store_bytes: u64,
    /// Bytes of the SRAM stores (bytes).
    pub sram_bytes: u64,
    /// Bytes of the register stores (bytes).
    pub register_bytes: u64,
    /// Operators instantiated over every datapath.
    pub instances: Ops,
    /// Area of the SRAM stores (mm²).
    pub sram_area_mm2: f64,
    /// Area of the register stores (mm²).
    pub register_area_mm2: f64,
    /// Area of the operators (mm²).
    pub logic_area_mm2: f64,
    /// The three areas summed (mm²).
    pub area_mm2: f64,
}

/// The sizes a budget depends on beyond the knobs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    /// Derived frame (samples per row and column).
    pub derived: (u32, u32),
    /// Longest reference line: the larger side of the largest reference
    /// sample grid (samples).
    pub reference_line: u32,
}

impl Sizes {
    /// The sizes `cfg` implies alone: the display times `supersample`, the
    /// reference line `⌈REFERENCE_LINE_SCALE · max(display) · supersample⌉`.
    pub fn of(cfg: &EngineConfig) -> Sizes {
        let ss = cfg.supersample;
        let side = cfg.display_width.max(cfg.display_height) as f64 * ss as f64;
        Sizes {
            derived: (cfg.display_width * ss, cfg.display_height * ss),
            reference_line: (side * REFERENCE_LINE_SCALE).ceil() as u32,
        }
    }
}

/// The budget of one configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Budget {
    /// The process node of the area estimate.
    pub process_node: &'static str,
    /// The sizes used.
    pub sizes: Sizes,
    /// Every on-chip store.
    pub stores: Vec<Store>,
    /// Every datapath.
    pub datapaths: Vec<Datapath>,
    /// Sums.
    pub totals: Totals,
}

/// The process node of [`AREA_CONSTANTS`].
pub const PROCESS_NODE: &str = "45 nm";

/// One area constant: (name, value, unit, source).
pub type AreaConstant = (&'static str, f64, &'static str, &'static str);

/// Every area constant (rule 4), one process node ([`PROCESS_NODE`]).
pub const AREA_CONSTANTS: &[AreaConstant] = &[
    (
        "sram_cell_um2",
        0.346,
        "µm²/bit",
        "6T SRAM cell of Intel's 45 nm process: Mistry et al., IEDM 2007, 'A 45nm logic technology with high-k + metal \
         gate transistors, strained silicon, 9 Cu interconnect layers, 193nm dry patterning, and 100% Pb-free packaging'",
    ),
    (
        "sram_array_efficiency",
        0.6,
        "fraction",
        "estimate: bit cells over macro area (decoders, sense amplifiers, I/O); CACTI-style arrays of 32 KiB and more \
         are typically 50-70 %",
    ),
    ("flop_um2", 4.522, "µm²/bit", "DFF_X1 of the Nangate 45 nm Open Cell Library (FreePDK45)"),
    (
        "int_add_32_um2",
        137.0,
        "µm²",
        "32-bit integer adder at 45 nm: Horowitz, ISSCC 2014, 'Computing's energy problem (and what we can do about \
         it)', area table",
    ),
    ("int_mul_32_um2", 3495.0, "µm²", "32-bit integer multiplier at 45 nm: Horowitz, ISSCC 2014, area table"),
    ("fp32_add_um2", 4184.0, "µm²", "32-bit float adder at 45 nm: Horowitz, ISSCC 2014, area table"),
    ("fp32_mul_um2", 7700.0, "µm²", "32-bit float multiplier at 45 nm: Horowitz, ISSCC 2014, area table"),
    (
        "recip_in_muls",
        3.0,
        "multipliers",
        "estimate: a reciprocal (seed table and Newton-Raphson steps) costs about three multipliers of its format",
    ),
    ("sqrt_in_muls", 3.0, "multipliers", "estimate: a square root costs about three multipliers of its format"),
];

fn constant(name: &str) -> f64 {
    AREA_CONSTANTS.iter().find(|c| c.0 == name).map_or(f64::NAN, |c| c.1)
}

/// Per-operator areas (µm²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OpArea {
    /// Multiplier.
    pub mul: f64,
    /// Adder.
    pub add: f64,
    /// Reciprocal.
    pub recip: f64,
    /// Square root.
    pub sqrt: f64,
    /// Comparator.
    pub cmp: f64,
}

impl OpArea {
    /// Area of `n` operators (µm²).
    pub fn of(&self, n: Ops) -> f64 {
        self.mul * n.mul as f64
            + self.add * n.add as f64
            + self.recip * n.recip as f64
            + self.sqrt * n.sqrt as f64
            + self.cmp * n.cmp as f64
    }
}

/// Area of one operator of `f` (µm²): an integer adder or comparator
/// scales linearly with its bits and a multiplier with their square, from
/// the 32-bit figures; a float adder scales linearly with its significand
/// and a multiplier with its square, from the FP32 figures (estimates
/// beyond the published widths); a float comparator is an integer adder of
/// the format's bits; a reciprocal or square root is `recip_in_muls` /
/// `sqrt_in_muls` multipliers.
pub fn op_area_um2(f: Format) -> OpArea {
    let int_add = |b: u32| constant("int_add_32_um2") * b as f64 / 32.0;
    let int_mul = |b: u32| constant("int_mul_32_um2") * (b as f64 / 32.0).powi(2);
    let (add, mul, cmp) = match f {
        Format::Int { bits } => (int_add(bits), int_mul(bits), int_add(bits)),
        Format::Float { bits, mantissa } => {
            let r = mantissa as f64 / 24.0;
            (constant("fp32_add_um2") * r, constant("fp32_mul_um2") * r * r, int_add(bits))
        }
    };
    OpArea { mul, add, recip: mul * constant("recip_in_muls"), sqrt: mul * constant("sqrt_in_muls"), cmp }
}

/// Area of one bit of a store of `kind` (µm²).
pub fn bit_area_um2(kind: StoreKind) -> f64 {
    match kind {
        StoreKind::Sram => constant("sram_cell_um2") / constant("sram_array_efficiency"),
        StoreKind::Registers => constant("flop_um2"),
    }
}

/// Hole-fill taps read per sample: three near, two far (`units::hole_fill`).
pub const HOLE_FILL_TAPS: u64 = 5;

/// Per-sample planes of the destination tile cache (`dest_frame`): (store
/// name, what it holds, bits per sample).
pub fn dest_planes(w: &Widths) -> [(&'static str, &'static str, u32); 10] {
    [
        ("dest_cache.plane1_colour", "plane 1: colour RGB", 3 * w.colour),
        ("dest_cache.plane2_inv_z", "plane 2: derived 1/Z", w.inv_z),
        ("dest_cache.plane3_slopes", "plane 3: slopes of 1/Z (x, y)", 2 * w.slope),
        ("dest_cache.plane4_source", "plane 4: source reference number", w.source),
        ("dest_cache.plane5_hole", "plane 5: colour is hole fill", w.flag),
        ("dest_cache.plane6_fill_colour", "plane 6: hole-fill colour RGB", 3 * w.colour),
        ("dest_cache.plane7_fill_valid", "plane 7: hole-fill colour valid", w.flag),
        ("dest_cache.plane8_fill_distance", "plane 8: hole-fill distance", w.fill_distance),
        ("dest_cache.plane9_fill_weight", "plane 9: hole-fill weight", w.fill_weight),
        ("dest_cache.real", "a warped surface wrote the sample (not a plane of TR98)", w.flag),
    ]
}

/// Bits of a kernel in the kernel FIFO (`kernel_setup::Kernel`).
pub fn kernel_bits(w: &Widths) -> u32 {
    // line, sample (x, y), pos (x, y), inv_z, box (4), colour, fill colour,
    // reference 1/Z, reference slopes.
    w.coord + 2 * w.coord + 2 * w.wide + w.wide + 4 * w.wide + 3 * w.colour + 3 * w.colour + w.wide + 2 * w.slope
}

/// Bits of a stamp in the stamp FIFO (`raster::Stamped`).
pub fn stamp_bits(w: &Widths) -> u32 {
    let rect = 4 * w.bound + 2 * w.coord + w.flag;
    let candidate = 3 * w.colour + w.inv_z + 2 * w.slope + w.source + 3 * w.colour;
    // line, rect, candidate, sample, reference 1/Z and slopes, better mask
    // and its valid bit, counted flag.
    w.coord + rect + candidate + 2 * w.coord + w.wide + 2 * w.slope + w.coord + w.flag + w.flag
}

/// Bits of one packer working register (`abuffer::Building`): a fragment
/// and its running sums.
pub fn packer_register_bits(w: &Widths) -> u32 {
    let fragment = 3 * w.colour + w.inv_z + 2 * w.slope + w.mask + w.flag + w.key + w.fill_weight;
    fragment + 4 * w.float_kept.bits() + w.coord
}

fn div_ceil(a: u64, b: u64) -> u64 {
    a.div_ceil(b.max(1))
}

impl Budget {
    /// The budget of `cfg` alone ([`Sizes::of`]).
    pub fn of(cfg: &EngineConfig) -> Budget {
        Budget::sized(cfg, Sizes::of(cfg))
    }

    /// The budget of `cfg` for a derived frame and reference line of
    /// `sizes`.
    pub fn sized(cfg: &EngineConfig, sizes: Sizes) -> Budget {
        let w = widths(cfg);
        let stores = stores(cfg, &w, &sizes);
        let datapaths = datapaths(cfg, &w);
        let mut t = Totals::default();
        for s in &stores {
            t.store_bytes += s.bytes;
            match s.kind {
                StoreKind::Sram => {
                    t.sram_bytes += s.bytes;
                    t.sram_area_mm2 += s.area_mm2;
                }
                StoreKind::Registers => {
                    t.register_bytes += s.bytes;
                    t.register_area_mm2 += s.area_mm2;
                }
            }
        }
        for d in &datapaths {
            t.instances = t.instances.plus(d.instances);
            t.logic_area_mm2 += d.area_mm2;
        }
        t.area_mm2 = t.sram_area_mm2 + t.register_area_mm2 + t.logic_area_mm2;
        Budget { process_node: PROCESS_NODE, sizes, stores, datapaths, totals: t }
    }
}

fn store(
    name: &'static str,
    unit: &'static str,
    kind: StoreKind,
    entries: u64,
    bits: u64,
    holds: &'static str,
) -> Store {
    let area_mm2 = (entries * bits) as f64 * bit_area_um2(kind) / 1e6;
    Store { name, unit, kind, entries, bits_per_entry: bits, bytes: div_ceil(entries * bits, 8), area_mm2, holds }
}

fn stores(c: &EngineConfig, w: &Widths, z: &Sizes) -> Vec<Store> {
    use StoreKind::{Registers, Sram};
    let tile_samples = u64::from(c.tile_size).pow(2);
    let slots = c.dest_cache_bytes / (tile_samples * CACHE_BYTES_PER_SAMPLE);
    let frame_tiles = u64::from(z.derived.0.div_ceil(c.tile_size)) * u64::from(z.derived.1.div_ceil(c.tile_size));
    let line = u64::from(z.reference_line);
    let ss2 = u64::from(c.supersample).pow(2);
    let frags = u64::from(c.abuffer_fragments);
    let pixels_per_tile = u64::from(c.tile_size / c.supersample).pow(2);
    let packed_tile = pixels_per_tile * (PIXEL_HEADER_BYTES + frags * FRAGMENT_BYTES);
    let raw_tile = tile_samples * CACHE_BYTES_PER_SAMPLE;
    let thr = u64::from(c.transform_throughput);
    let rate = u64::from(c.rects_per_cycle);
    let b = |x: u32| u64::from(x);
    let mut v = vec![store(
        "source_cache.data",
        "fetch",
        Sram,
        div_ceil(c.source_cache_bytes, FRAGMENT_BYTES),
        8 * FRAGMENT_BYTES,
        "reference blocks in A-buffer format, one 128-bit fragment word",
    )];
    for (name, holds, bits) in dest_planes(w) {
        v.push(store(name, "dest_cache", Sram, slots * tile_samples, b(bits), holds));
    }
    v.extend([
        store(
            "dest_cache.tags",
            "dest_cache",
            Registers,
            slots,
            b(w.coord) + 3,
            "per slot: tile number and its state (untouched, loading, resident, spilled, released)",
        ),
        store(
            "line_buffer.warps",
            "kernel_setup",
            Sram,
            4 * line,
            b(4 * w.wide + w.flag),
            "4 lines of warped samples: position (x, y), derived 1/Z, E, valid",
        ),
        store(
            "line_buffer.groups",
            "kernel_setup",
            Sram,
            4 * line,
            2 + b(2 * w.wide),
            "4 lines of 2x2 group verdicts: shared, missing, discontinuous or folded, and the shared corner",
        ),
        store(
            "line_buffer.records",
            "kernel_setup",
            Sram,
            4 * line,
            b(w.wide + 2 * w.slope + 3 * w.colour + w.depth),
            "4 lines of the reference records kernel setup reads: 1/Z, slopes, colour, Z",
        ),
        store(
            "transform.pipeline",
            "transform",
            Registers,
            thr * (u64::from(c.transform_latency) + 1),
            b(2 * w.coord + 2 * w.coord + w.wide + 2 * w.slope),
            "samples in flight: grid index, interval, x, y, 1/Z, slopes",
        ),
        store("kernel_fifo", "kernel_setup", Registers, 2 * rate, b(kernel_bits(w)), "kernels to the rasterizer"),
        store("stamp_fifo", "raster", Registers, 2 * rate, b(stamp_bits(w)), "stamps to the compositor"),
        store(
            "composite.miss_queue",
            "composite",
            Registers,
            u64::from(c.composite_miss_queue),
            b(stamp_bits(w) + 4 * w.coord) + 3,
            "stamps waiting for a tile, with their up to 4 tiles and the count",
        ),
        store(
            "hole_fill.taps",
            "hole_fill",
            Registers,
            u64::from(c.hole_fill_per_cycle) * HOLE_FILL_TAPS,
            b(3 * w.colour + w.flag + w.fill_distance + w.rank),
            "per lane, the five taps read: fill colour, valid, distance, rank key",
        ),
        store(
            "hole_fill.dirty",
            "hole_fill",
            Registers,
            if c.fallback_fill { frame_tiles } else { 0 },
            1,
            "per tile of the frame: holds an empty sample (the fallback pass's flags)",
        ),
        store(
            "tile_manager.retired",
            "tile_manager",
            Registers,
            frame_tiles,
            1,
            "per tile of the frame: retired by the warp",
        ),
        store(
            "packer.registers",
            "abuffer",
            Registers,
            if frags == 0 { 0 } else { u64::from(c.packer_pixels_per_cycle) * ss2 },
            b(packer_register_bits(w)),
            "per lane, one fragment being built per sample of the pixel, with its colour and weight sums",
        ),
        store(
            "packer.write_buffer",
            "packer",
            Sram,
            WRITE_QUEUE_LIMIT as u64,
            8 * packed_tile.max(raw_tile),
            "tiles written back or spilled, waiting for the DRAM: the larger of a packed and a raw tile",
        ),
    ]);
    v
}

/// Operators per pixel of the A-buffer packer (`abuffer::Packer::pack_in_place`),
/// worst case for `s` samples per pixel and `f` fragments (0: no packer).
pub fn packer_ops(s: u64, f: u64) -> Ops {
    if f == 0 {
        return Ops::default();
    }
    // Every sample tested against every earlier fragment and opening its own.
    let tests = s * (s - 1) / 2;
    let mut ops = Ops::new(4, 5, 0, 0, 3).times(tests);
    ops = ops.plus(Ops::new(2, 2, 0, 0, 0).times(s)); // open: centre 1/Z
    ops = ops.plus(Ops::new(0, 4, 0, 0, 0).times(s)); // colour and weight sums
    // Forced merges: closest pair over m fragments, m = s down to f + 1.
    let mut m = s;
    while m > f && m > 1 {
        ops = ops.plus(Ops::new(0, 1, 0, 0, 4).times(m * (m - 1) / 2));
        ops = ops.plus(Ops::new(0, 5, 0, 0, 2));
        m -= 1;
    }
    // Means: one reciprocal of the count, four multiplies per fragment.
    ops.plus(Ops::new(4, 0, 1, 0, 0).times(f.min(s)))
}

/// Operators per rule-3 stamp of the better-reference mask
/// (`TransformUnit::better_mask`) with `refs` references per frame.
pub fn better_mask_ops(refs: u64) -> Ops {
    Ops::new(30, 26, 1, 0, 3).plus(Ops::new(11, 7, 0, 0, 1).times(refs.saturating_sub(1)))
}

fn datapath(
    unit: &'static str,
    function: &'static str,
    item: &'static str,
    items_per_cycle: u64,
    per_item: Ops,
    format: Format,
) -> Datapath {
    let instances = per_item.times(items_per_cycle);
    let area_mm2 = op_area_um2(format).of(instances) / 1e6;
    Datapath { unit, function, item, items_per_cycle, per_item, instances, format, area_mm2 }
}

fn datapaths(c: &EngineConfig, w: &Widths) -> Vec<Datapath> {
    let thr = u64::from(c.transform_throughput);
    let rate = u64::from(c.rects_per_cycle);
    let fill = u64::from(c.hole_fill_per_cycle);
    let ss2 = u64::from(c.supersample).pow(2);
    vec![
        datapath(
            "fetch",
            "abuffer::Fragment::inv_z_at, abuffer::reference_depth",
            "reference sample",
            thr,
            Ops::new(2, 2, 1, 0, 1),
            w.storage,
        ),
        datapath(
            "transform",
            "transform::TransformUnit::warp_run",
            "reference sample",
            thr,
            Ops::new(20, 14, 2, 1, 1),
            w.compute,
        ),
        datapath(
            "transform",
            "transform::TransformUnit::edge_corner",
            "edge corner (4 per kernel)",
            4 * thr,
            Ops::new(12, 13, 1, 0, 1),
            w.compute,
        ),
        datapath(
            "transform",
            "transform::TransformUnit::dest_slopes",
            "non-empty stamp",
            rate,
            Ops::new(40, 24, 2, 0, 1),
            w.float_kept,
        ),
        datapath(
            "transform",
            "transform::TransformUnit::better_mask",
            "stamp needing rule 3",
            rate,
            better_mask_ops(u64::from(c.references_per_frame)),
            w.float_kept,
        ),
        datapath(
            "kernel_setup",
            "kernel_setup::group",
            "2x2 group (one per sample)",
            thr,
            Ops::new(32, 42, 0, 0, 10),
            w.compute,
        ),
        datapath(
            "kernel_setup",
            "kernel_setup::bounding_box, backward_step, same_surface (rule 5)",
            "kernel",
            thr,
            Ops::new(10, 7, 0, 0, 17),
            w.compute,
        ),
        datapath("raster", "raster::rect", "kernel", rate, Ops::new(0, 26, 0, 0, 18), w.integer),
        datapath(
            "composite",
            "composite::composite",
            "covered derived sample",
            rate * u64::from(c.kernel_limit).pow(2),
            Ops::new(2, 4, 0, 0, 5),
            w.compute,
        ),
        datapath(
            "hole_fill",
            "hole_fill::HoleFillUnit::counted, traversal::OrderKey::key",
            "derived sample visited",
            fill,
            Ops::new(30, 83, 0, 0, 47),
            w.integer,
        ),
        datapath(
            "hole_fill",
            "hole_fill::HoleFillUnit::fill_sample (colour mean, rule 6)",
            "derived sample visited",
            fill,
            Ops::new(12, 16, 3, 0, 0),
            w.compute,
        ),
        datapath(
            "abuffer",
            "abuffer::Packer::pack_in_place",
            "pixel packed",
            u64::from(c.packer_pixels_per_cycle),
            packer_ops(ss2, u64::from(c.abuffer_fragments)),
            w.float_kept,
        ),
    ]
}

/// (name, unit, description) of a store's fields, for reports and docs.
pub const STORE_FIELDS: &[(&str, &str, &str)] = &[
    ("name", "—", "the store, `unit.store`"),
    ("unit", "—", "the unit that owns it"),
    ("kind", "sram|registers", "an SRAM array or flip-flops"),
    ("entries", "entries", "entries of the store"),
    ("bits_per_entry", "bits", "bits per entry at the configuration's widths"),
    ("bytes", "bytes", "⌈entries × bits_per_entry / 8⌉"),
    ("area_mm2", "mm²", "estimated area: bits × the SRAM bit or flip-flop area of the process node"),
    ("holds", "—", "what an entry holds"),
];

/// (name, unit, description) of an operator count.
pub const OP_FIELDS: &[(&str, &str, &str)] = &[
    ("mul", "multiplies", "multiplies (a division counts one, with one reciprocal)"),
    ("add", "adds", "adds and subtracts, float-to-integer conversions"),
    ("recip", "reciprocals", "reciprocals (one per division by a variable)"),
    ("sqrt", "square roots", "square roots"),
    ("cmp", "compares", "compares, min and max"),
];

/// (name, unit, description) of a datapath's fields.
pub const DATAPATH_FIELDS: &[(&str, &str, &str)] = &[
    ("unit", "—", "the unit"),
    ("function", "—", "the model's function the counts were read from"),
    ("item", "—", "what one item is"),
    ("items_per_cycle", "items/cycle", "peak items per cycle the knobs give the datapath"),
    ("format", "—", "format of its operators (fp64, fp32, int64)"),
    ("per_item", "operators/item", "operators per item, longest path"),
    ("instances", "operators", "operators instantiated: per_item × items_per_cycle"),
    ("area_mm2", "mm²", "estimated area of the instances"),
];

/// (name, unit, description) of the totals.
pub const TOTAL_FIELDS: &[(&str, &str, &str)] = &[
    ("store_bytes", "bytes", "bytes of every on-chip store"),
    ("sram_bytes", "bytes", "bytes of the SRAM stores"),
    ("register_bytes", "bytes", "bytes of the register stores"),
    ("instances", "operators", "operators instantiated over every datapath"),
    ("sram_area_mm2", "mm²", "estimated area of the SRAM stores"),
    ("register_area_mm2", "mm²", "estimated area of the register stores"),
    ("logic_area_mm2", "mm²", "estimated area of the operators (no control, wiring or muxes)"),
    ("area_mm2", "mm²", "sram_area_mm2 + register_area_mm2 + logic_area_mm2"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn totals_are_the_sums_and_every_constant_has_a_source() {
        for name in crate::config::PRESETS {
            let b = Budget::of(&EngineConfig::preset(name).unwrap());
            let t = &b.totals;
            assert_eq!(t.store_bytes, b.stores.iter().map(|s| s.bytes).sum::<u64>());
            assert_eq!(t.store_bytes, t.sram_bytes + t.register_bytes);
            assert!(t.area_mm2.is_finite() && t.area_mm2 > 0.0, "{name}");
        }
        assert!(AREA_CONSTANTS.iter().all(|c| c.1.is_finite() && c.1 > 0.0 && !c.3.is_empty()));
    }

    #[test]
    fn the_packer_counts_follow_its_worst_case() {
        assert_eq!(packer_ops(4, 0), Ops::default());
        // 1 sample, 1 fragment: open, sums, one mean.
        assert_eq!(packer_ops(1, 1), Ops::new(6, 6, 1, 0, 0));
        assert_eq!(packer_ops(4, 3), Ops::new(44, 65, 3, 0, 44));
    }
}
