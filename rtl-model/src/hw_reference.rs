//! A reference frame as the warper holds it: packed to A-buffer format in
//! memory, and expanded once on the host into the records the units read.
//!
//! Job: pack a rendered reference once ([`HwReference::new`]: the
//! renderer's output, or the warper's conversion on first use; not
//! charged), keep its packed form (block sizes for the source cache), its
//! coarse depth map (the tile manager's schedule) and host-speed copies of
//! what the fetch unit expands (valid bits, per-sample records, along the
//! axes warps walk).
//!
//! Rules: the expansion is the unpacker's (`units::abuffer`), so every unit
//! sees exactly what a hardware expander would produce; the host copies
//! change no value, only the order in which memory is walked.
//!
//! Not modelled: the conversion's cycles and traffic (a tiled renderer
//! writes the A-buffer format directly, TR98 §10).

use crate::config::EngineConfig;
use crate::sample_image::SampleImage;
use crate::schedule::CoarseDepth;
use crate::traversal::Major;
use crate::units::abuffer::{self, AbufferCounters, AbufferParams, PackedReference};
use std::sync::OnceLock;

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
    /// What the units read of each sample, packed in one record
    /// (host-speed copies; they change no value): row-major for the
    /// row-major sheets and column-major for the others, so that a sheet
    /// streams its records in address order. Each is made from the other
    /// (or the packed form) the first time a warp walks that way, so a
    /// reference only ever warped along one axis holds one copy.
    rows: OnceLock<Vec<RefSample>>,
    cols: OnceLock<Vec<RefSample>>,
    /// The layout of `valid_tiles` (and of the engine's per-sample bits).
    pub(crate) grid: Grid,
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

/// What the units read of one reference sample (valid samples only).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RefSample {
    pub(crate) inv_z: f64,
    pub(crate) slopes: [f32; 2],
    pub(crate) colour: [f32; 3],
    pub(crate) z: f32,
}

impl HwReference {
    #[inline(always)]
    pub(crate) fn valid_at(&self, gi: usize) -> bool {
        self.valid_tiles[gi >> 6] >> (gi & 63) & 1 != 0
    }

    /// The records along `major` (made on first use, module docs).
    #[inline(always)]
    fn recs(&self, major: Major) -> &[RefSample] {
        let (w, h) = (self.width as usize, self.height as usize);
        match major {
            Major::Row => self.rows.get_or_init(|| match self.cols.get() {
                Some(c) => transpose(c, w, h),
                None => records(&self.packed.unpack()),
            }),
            Major::Column => self.cols.get_or_init(|| match self.rows.get() {
                Some(r) => transpose(r, h, w),
                None => transpose(&records(&self.packed.unpack()), h, w),
            }),
        }
    }

    /// The records of line `line` along `major` (row `line`, or column
    /// `line`), indexed by the position along it.
    #[inline(always)]
    pub(crate) fn line_recs(&self, major: Major, line: u32) -> &[RefSample] {
        let (w, h) = (self.width as usize, self.height as usize);
        let recs = self.recs(major);
        match major {
            Major::Row => &recs[line as usize * w..(line as usize + 1) * w],
            Major::Column => &recs[line as usize * h..(line as usize + 1) * h],
        }
    }

    /// The record of sample `(x, y)`, from the copy laid out along `major`.
    #[inline(always)]
    pub(crate) fn rec(&self, major: Major, x: u32, y: u32) -> &RefSample {
        let recs = self.recs(major);
        match major {
            Major::Row => &recs[y as usize * self.width as usize + x as usize],
            Major::Column => &recs[x as usize * self.height as usize + y as usize],
        }
    }

    /// The samples as the fetch unit expands them (unpacked again: the
    /// reference keeps only its packed form and records).
    pub fn expanded(&self) -> SampleImage {
        self.packed.unpack()
    }
}

/// The records of `samples`, row-major (zero where not valid).
fn records(samples: &SampleImage) -> Vec<RefSample> {
    let mut rows = vec![RefSample::default(); samples.len()];
    for i in samples.valid.iter_ones() {
        rows[i] = RefSample {
            inv_z: 1.0 / samples.z[i] as f64,
            slopes: samples.inv_z_slopes[i],
            colour: samples.colour[i],
            z: samples.z[i],
        };
    }
    rows
}

/// `m` (`rows` lines of `len` records) transposed: `len` lines of `rows`.
fn transpose(m: &[RefSample], rows: usize, len: usize) -> Vec<RefSample> {
    let mut t = vec![RefSample::default(); m.len()];
    for (r, line) in m.chunks_exact(len).enumerate() {
        for (a, rec) in line.iter().enumerate() {
            t[a * rows + r] = *rec;
        }
    }
    t
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
        let samples = packed.unpack();
        let depth = CoarseDepth::new(&samples);
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
            rows: OnceLock::new(),
            cols: OnceLock::new(),
            grid,
            valid_tiles,
        }
    }
}
