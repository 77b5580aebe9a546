//! A reference frame as the warper holds it: packed to A-buffer format in
//! memory, and expanded once on the host into the records the units read.
//!
//! Job: pack a rendered reference once ([`HwReference::new`]: the
//! renderer's output, or the warper's conversion on first use; not
//! charged), keep its packed form (block sizes for the source cache), its
//! coarse depth map (the tile manager's schedule) and host-speed copies of
//! what the fetch unit expands (valid bits in 8x8 tiles, one 24-byte
//! record per sample, row-major).
//!
//! Rules: the expansion is the unpacker's (`units::abuffer`), so every unit
//! sees exactly what a hardware expander would produce; the host copies
//! change no value, only the order in which memory is walked.
//!
//! Not modelled: the conversion's cycles and traffic (a tiled renderer
//! writes the A-buffer format directly, TR98 §10).

use crate::config::EngineConfig;
use crate::qformat::{FixedFormats, QFormat};
use crate::sample_image::SampleImage;
use crate::schedule::CoarseDepth;
use crate::traversal::Major;
use crate::units::abuffer::{self, AbufferCounters, AbufferParams, PackedReference};

/// A reference frame as it sits in memory, with the host-side expansion
/// the fetch unit streams (unpacking is deterministic; the model does it
/// once per reference and charges the reads per block).
#[derive(Clone, Debug)]
pub struct HwReference {
    /// The reference in A-buffer format.
    pub packed: PackedReference,
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Coarse depth map for the schedule.
    pub depth: CoarseDepth,
    /// Packer counters of the conversion (reference frames).
    pub counters: AbufferCounters,
    /// What the units read of each sample, one record per sample,
    /// row-major (a host-speed copy: it changes no value). Column sheets
    /// read it with a stride of one row ([`Line`]).
    recs: Vec<RefSample>,
    /// The layout of `valid_tiles` (and of the engine's per-sample bits).
    pub(crate) grid: Grid,
    /// Fixed mode: the format the expander rounds 1/Z to ([`HwReference::inv_z`]).
    ref_inv_z: Option<QFormat>,
    /// Fixed mode: values the expander saturated (colour channels, 1/Z,
    /// slopes, and samples dropped for coordinates beyond `q_ref_coord`),
    /// over every valid sample (counts; 0 in float mode).
    pub fetch_saturations: u64,
    /// `valid`, one word per 8x8 tile of [`Grid`].
    valid_tiles: Vec<u64>,
}

/// Host layout of per-sample bits: 8x8-sample tiles in row-major tile
/// order, each tile row-major (one 64-bit word per tile), so that rows and
/// columns both walk few words.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Grid {
    tiles_x: usize,
    tiles_y: usize,
}

impl Grid {
    pub(crate) fn new(w: u32, h: u32) -> Grid {
        Grid { tiles_x: w.div_ceil(8) as usize, tiles_y: h.div_ceil(8) as usize }
    }

    pub(crate) fn len(&self) -> usize {
        self.tiles_x * self.tiles_y * 64
    }

    #[inline(always)]
    pub(crate) fn index(&self, x: u32, y: u32) -> usize {
        (((y >> 3) as usize * self.tiles_x + (x >> 3) as usize) << 6) | ((y & 7) << 3 | (x & 7)) as usize
    }
}

/// What the units read of one reference sample (valid samples only; all
/// zero elsewhere). 24 bytes: the 1/Z the units use is derived from `z`
/// where it is read ([`RefSample::inv_z`]), the same value the renderer's
/// 1/Z would be.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub(crate) struct RefSample {
    pub(crate) colour: [f32; 3],
    pub(crate) slopes: [f32; 2],
    pub(crate) z: f32,
}

impl RefSample {
    /// `1/Z` in FP64 (the warp's input), 0 where there is no surface.
    #[inline(always)]
    pub(crate) fn inv_z(&self) -> f64 {
        if self.z == 0.0 { 0.0 } else { 1.0 / self.z as f64 }
    }
}

/// One traversal line of a reference's records: row `line`, or column
/// `line` read with a stride of one row.
#[derive(Clone, Copy)]
pub(crate) struct Line<'a> {
    recs: &'a [RefSample],
    base: usize,
    stride: usize,
}

impl<'a> Line<'a> {
    /// The record at position `a` along the line.
    #[inline(always)]
    pub(crate) fn at(&self, a: usize) -> &'a RefSample {
        &self.recs[self.base + a * self.stride]
    }
}

impl HwReference {
    /// The 1/Z the units read of record `rec`: [`RefSample::inv_z`],
    /// rounded to `q_ref_inv_z` in fixed mode.
    #[inline(always)]
    pub(crate) fn inv_z(&self, rec: &RefSample) -> f64 {
        let v = rec.inv_z();
        match self.ref_inv_z {
            None => v,
            Some(f) => f.quantise(v).0,
        }
    }

    #[inline(always)]
    pub(crate) fn valid_at(&self, gi: usize) -> bool {
        self.valid_tiles[gi >> 6] >> (gi & 63) & 1 != 0
    }

    /// The records of line `line` along `major` (row `line`, or column
    /// `line`), indexed by the position along it.
    #[inline(always)]
    pub(crate) fn line_recs(&self, major: Major, line: u32) -> Line<'_> {
        let w = self.width as usize;
        match major {
            Major::Row => Line { recs: &self.recs, base: line as usize * w, stride: 1 },
            Major::Column => Line { recs: &self.recs, base: line as usize, stride: w },
        }
    }

    /// The record of sample `(x, y)`.
    #[inline(always)]
    pub(crate) fn rec(&self, x: u32, y: u32) -> &RefSample {
        &self.recs[y as usize * self.width as usize + x as usize]
    }

    /// The samples as the fetch unit expands them (unpacked again: the
    /// reference keeps only its packed form and records).
    pub fn expanded(&self) -> SampleImage {
        self.packed.unpack()
    }
}

/// The records of `samples`, row-major (zero where not valid), in a zeroed
/// block: the host's allocator may then map it in huge pages, which the
/// column sheets' strided reads need.
fn records(samples: &SampleImage) -> Vec<RefSample> {
    let mut rows = zeroed_records(samples.len());
    for i in samples.valid.iter_ones() {
        rows[i] = RefSample { colour: samples.colour[i], slopes: samples.inv_z_slopes[i], z: samples.z[i] };
    }
    rows
}

/// `n` all-zero records, allocated zeroed.
fn zeroed_records(n: usize) -> Vec<RefSample> {
    const _: () = assert!(std::mem::size_of::<RefSample>() == 24);
    let mut words: Vec<[f32; 6]> = vec![[0.0; 6]; n];
    let (ptr, len, cap) = (words.as_mut_ptr(), words.len(), words.capacity());
    std::mem::forget(words);
    // SAFETY: `RefSample` is `repr(C)` of six `f32`s, so it has the size
    // and alignment of `[f32; 6]` and every bit pattern of one is a value
    // of the other; the block keeps its allocation's layout (same size and
    // alignment per element, same capacity).
    unsafe { Vec::from_raw_parts(ptr.cast::<RefSample>(), len, cap) }
}

/// The A-buffer format's parameters of a configuration.
pub fn abuffer_params(cfg: &EngineConfig) -> AbufferParams {
    AbufferParams {
        ss: cfg.supersample,
        abuffer_fragments: cfg.abuffer_fragments,
        slope_tol: cfg.slope_tol,
        rel_tol: cfg.rel_tol,
    }
}

impl HwReference {
    /// Pack a rendered reference into A-buffer format (the renderer's
    /// output, or the warper's conversion on first use; not charged here).
    pub fn new(img: &SampleImage, cfg: &EngineConfig) -> HwReference {
        let mut counters = AbufferCounters::default();
        let packed = abuffer::pack_reference(img, &abuffer_params(cfg), &mut counters);
        let mut samples = packed.unpack();
        let fixed = cfg.fixed_formats().ok().flatten();
        let fetch_saturations = fixed.as_ref().map_or(0, |f| quantise_expanded(&mut samples, f));
        let ref_inv_z = fixed.as_ref().map(|f| f.ref_inv_z);
        let depth = match ref_inv_z {
            None => CoarseDepth::new(&samples),
            Some(f) => CoarseDepth::with_inv_z(&samples, |i| f.quantise(1.0 / samples.z[i] as f64).0),
        };
        let w = samples.width as usize;
        let grid = Grid::new(samples.width, samples.height);
        let mut valid_tiles = vec![0u64; grid.len() / 64];
        for i in samples.valid.iter_ones() {
            let gi = grid.index((i % w) as u32, (i / w) as u32);
            valid_tiles[gi >> 6] |= 1 << (gi & 63);
        }
        HwReference {
            packed,
            width: samples.width,
            height: samples.height,
            depth,
            counters,
            recs: records(&samples),
            grid,
            valid_tiles,
            ref_inv_z,
            fetch_saturations,
        }
    }
}

/// The fixed mode's expander (`docs/fixed-point.md`, fetch): every valid
/// sample's colour to `q_colour` and slopes to `q_slope` (held in the FP32
/// records), its 1/Z checked against `q_ref_inv_z` (rounded where read,
/// [`HwReference::inv_z`]); a sample whose `(x + ½, y + ½)` exceeds
/// `q_ref_coord` is dropped (no surface). Returns the saturations.
fn quantise_expanded(s: &mut SampleImage, f: &FixedFormats) -> u64 {
    let w = s.width as usize;
    let mut sat = 0u32;
    let ones: Vec<usize> = s.valid.iter_ones().collect();
    for i in ones {
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        if x + 0.5 > f.ref_coord.max() || y + 0.5 > f.ref_coord.max() {
            sat += 1;
            s.valid.set(i, false);
            continue;
        }
        for c in &mut s.colour[i] {
            *c = f.colour.q(*c as f64, &mut sat) as f32;
        }
        for g in &mut s.inv_z_slopes[i] {
            *g = f.slope.q(*g as f64, &mut sat) as f32;
        }
        f.ref_inv_z.q(1.0 / s.z[i] as f64, &mut sat);
    }
    sat as u64
}
