//! A reference frame as the warper holds it: packed to A-buffer format in
//! memory, and expanded once on the host into the records the units read.
//!
//! Job: pack a rendered reference once ([`HwReference::new`]: the
//! renderer's output, or the warper's conversion on first use; not
//! charged), keep its packed form (block sizes for the source cache), its
//! coarse depth map (the tile manager's schedule) and host-speed copies of
//! what the fetch unit expands (valid bits, per-sample records).
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

/// A reference frame as it sits in memory, with the host-side expansion
/// the fetch unit streams (unpacking is deterministic; the model does it
/// once per reference and charges the reads per block).
#[derive(Clone, Debug)]
pub struct HwReference {
    /// The reference in A-buffer format.
    pub packed: PackedReference,
    /// Its samples as the fetch unit expands them.
    pub samples: SampleImage,
    /// 1/Z of every sample (0 without a surface).
    pub inv_z: Vec<f64>,
    /// Coarse depth map for the schedule.
    pub depth: CoarseDepth,
    /// Packer counters of the conversion (reference frames).
    pub counters: AbufferCounters,
    /// What the units read of each sample, packed in one record, twice
    /// (host-speed copies; they change no value): row-major for the
    /// row-major sheets and column-major for the others, so that a sheet
    /// streams its records in address order.
    rows: Vec<RefSample>,
    cols: Vec<RefSample>,
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

    /// The records of line `line` along `major` (row `line`, or column
    /// `line`), indexed by the position along it.
    #[inline(always)]
    pub(crate) fn line_recs(&self, major: Major, line: u32) -> &[RefSample] {
        let (w, h) = (self.samples.width as usize, self.samples.height as usize);
        match major {
            Major::Row => &self.rows[line as usize * w..(line as usize + 1) * w],
            Major::Column => &self.cols[line as usize * h..(line as usize + 1) * h],
        }
    }

    /// The record of sample `(x, y)`, from the copy laid out along `major`.
    #[inline(always)]
    pub(crate) fn rec(&self, major: Major, x: u32, y: u32) -> &RefSample {
        match major {
            Major::Row => &self.rows[y as usize * self.samples.width as usize + x as usize],
            Major::Column => &self.cols[x as usize * self.samples.height as usize + y as usize],
        }
    }
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
        let inv_z: Vec<f64> =
            (0..samples.len()).map(|i| if samples.valid[i] { 1.0 / samples.z[i] as f64 } else { 0.0 }).collect();
        let depth = CoarseDepth::new(&samples);
        let (w, h) = (samples.width as usize, samples.height as usize);
        let grid = Grid::new(samples.width, samples.height);
        let mut rows = vec![RefSample::default(); w * h];
        let mut cols = vec![RefSample::default(); w * h];
        let mut valid_tiles = vec![0u64; grid.len() / 64];
        for i in samples.valid.iter_ones() {
            let (x, y) = (i % w, i / w);
            let gi = grid.index(x as u32, y as u32);
            valid_tiles[gi >> 6] |= 1 << (gi & 63);
            let rec = RefSample {
                inv_z: inv_z[i],
                slopes: samples.inv_z_slopes[i],
                colour: samples.colour[i],
                z: samples.z[i],
            };
            rows[i] = rec;
            cols[x * h + y] = rec;
        }
        HwReference { packed, samples, inv_z, depth, counters, rows, cols, grid, valid_tiles }
    }
}
