//! A reference frame as the warper holds it: packed to A-buffer format in
//! memory, and expanded once on the host into the records the units read.
//!
//! Job: pack a rendered reference once ([`HwReference::new`]: the
//! renderer's output, or the warper's conversion on first use; not
//! charged), keep its packed form (block sizes for the source cache), its
//! coarse depth map (the tile manager's schedule) and a host-speed copy of
//! its valid bits (8x8 tiles). The 24-byte records the units read of each
//! sample ([`RefSample`]) are expanded from the packed form a block at a
//! time as a warp reaches them (`crate::ref_blocks`), so a reference costs
//! its packed size, not its expanded size, for as long as it is held.
//!
//! Rules: the expansion is the unpacker's (`units::abuffer`), so every unit
//! sees exactly what a hardware expander would produce; the host copies
//! change no value, only the order in which memory is walked.
//!
//! Not modelled: the conversion's cycles and traffic (a tiled renderer
//! writes the A-buffer format directly, TR98 §10).

use crate::config::EngineConfig;
use crate::qformat::FixedFormats;
use crate::sample_image::SampleImage;
use crate::schedule::CoarseDepth;
use crate::traversal::Major;
use crate::units::abuffer::{self, AbufferCounters, AbufferParams, ExpandedSample, PackedReference};

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
    /// Fixed mode: the formats the expander rounds to ([`record`]).
    fixed: Option<FixedFormats>,
    /// The layout of `valid_tiles` (and of the engine's per-sample bits).
    pub(crate) grid: Grid,
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

    /// The grid words (8x8 tiles) a run of positions `a0..=a1` on line
    /// `line` along `major` crosses, each with the mask of the run's bits
    /// in it, in order along the run.
    pub(crate) fn run_words(&self, major: Major, line: u32, a0: u32, a1: u32) -> impl Iterator<Item = (usize, u64)> {
        let (tiles_x, l) = (self.tiles_x, line as usize);
        (a0 >> 3..=a1 >> 3).map(move |t| {
            let t = t as usize;
            let (lo, hi) = ((a0 as usize).max(t << 3) & 7, (a1 as usize).min((t << 3) + 7) & 7);
            // Bits lo..=hi of an 8-bit row or column.
            let span = (0xffu64 >> (7 - hi)) & !((1u64 << lo) - 1);
            match major {
                // A row of the tile: byte (line & 7), bits lo..=hi.
                Major::Row => ((l >> 3) * tiles_x + t, span << ((l & 7) * 8)),
                // A column of the tile: bit (line & 7) of bytes lo..=hi.
                Major::Column => {
                    let bytes = (0..8).filter(|b| span >> b & 1 != 0).fold(0u64, |m, b| m | 0xff << (b * 8));
                    (t * tiles_x + (l >> 3), bytes & 0x0101_0101_0101_0101u64 << (l & 7))
                }
            }
        })
    }

    /// The sample of bit `bit` of grid word `w` (the inverse of
    /// [`Grid::index`]).
    pub(crate) fn position(&self, w: usize, bit: u32) -> (u32, u32) {
        let (tx, ty) = ((w % self.tiles_x) as u32, (w / self.tiles_x) as u32);
        (tx * 8 + (bit & 7), ty * 8 + (bit >> 3))
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

impl HwReference {
    /// The 1/Z the units read of record `rec`: [`RefSample::inv_z`],
    /// rounded to `q_ref_inv_z` in fixed mode.
    #[inline(always)]
    pub(crate) fn inv_z(&self, rec: &RefSample) -> f64 {
        let v = rec.inv_z();
        match &self.fixed {
            None => v,
            Some(f) => f.ref_inv_z.quantise(v).0,
        }
    }

    #[inline(always)]
    pub(crate) fn valid_at(&self, gi: usize) -> bool {
        self.valid_tiles[gi >> 6] >> (gi & 63) & 1 != 0
    }

    /// The valid bits of grid word `w` (one 8x8 tile, [`Grid`]).
    #[inline(always)]
    pub(crate) fn valid_word(&self, w: usize) -> u64 {
        self.valid_tiles[w]
    }

    /// Fixed mode: the formats the expander rounds to (`None`: float).
    pub(crate) fn fixed_formats(&self) -> Option<&FixedFormats> {
        self.fixed.as_ref()
    }

    /// The samples as the fetch unit expands them (unpacked again: the
    /// reference keeps only its packed form and records).
    pub fn expanded(&self) -> SampleImage {
        self.packed.unpack()
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
        HwReference::from_packed(packed, counters, cfg)
    }

    /// A reference already packed with this configuration's A-buffer
    /// parameters (`abuffer::pack_reference` with [`abuffer_params`];
    /// `counters` are the packer's), expanded into the records the units
    /// read: what [`HwReference::new`] does after packing, so a caller can
    /// pack a loaded reference, let the loaded image go, and expand later.
    pub fn from_packed(packed: PackedReference, counters: AbufferCounters, cfg: &EngineConfig) -> HwReference {
        let fixed = cfg.fixed_formats().ok().flatten();
        let (w, h) = (packed.width(), packed.height());
        let grid = Grid::new(w, h);
        let mut valid_tiles = vec![0u64; grid.len() / 64];
        let mut depth = CoarseDepth::empty(w, h);
        let mut sat = 0u32;
        // Straight from the packed form: neither the expanded image nor
        // the records are held whole (they were the peak of a reference's
        // conversion, and of a `simulate` run).
        packed.for_each_sample(|x, y, s| {
            let Some((rec, iz)) = record(s, x, y, fixed.as_ref(), &mut sat) else { return };
            depth.add(x, y, iz, rec.slopes);
            let gi = grid.index(x, y);
            valid_tiles[gi >> 6] |= 1 << (gi & 63);
        });
        HwReference {
            packed,
            width: w,
            height: h,
            depth,
            counters,
            fixed,
            grid,
            valid_tiles,
            fetch_saturations: sat as u64,
        }
    }
}

/// The record the units read of expanded sample `s` at `(x, y)`, with the
/// 1/Z the tile manager's depth map takes; in fixed mode through
/// [`quantise_expanded`] (`None`: the sample is dropped). Saturations are
/// added to `sat`.
#[inline]
pub(crate) fn record(
    s: ExpandedSample,
    x: u32,
    y: u32,
    fixed: Option<&FixedFormats>,
    sat: &mut u32,
) -> Option<(RefSample, f64)> {
    let mut rec = RefSample { colour: s.colour, slopes: s.slopes, z: s.z };
    let iz = match fixed {
        None => 1.0 / rec.z as f64,
        Some(f) => quantise_expanded(&mut rec, x, y, f, sat)?,
    };
    Some((rec, iz))
}

/// The fixed mode's expander (`docs/fixed-point.md`, fetch) on the record
/// of sample `(x, y)`: colour to `q_colour` and slopes to `q_slope` (held
/// in the FP32 record), its 1/Z checked against `q_ref_inv_z` (rounded
/// where read, [`HwReference::inv_z`]); the rounded 1/Z, or `None` if the
/// sample is dropped (no surface) because `(x + ½, y + ½)` exceeds
/// `q_ref_coord`. Saturations are added to `sat`.
fn quantise_expanded(rec: &mut RefSample, x: u32, y: u32, f: &FixedFormats, sat: &mut u32) -> Option<f64> {
    let (x, y) = (x as f64, y as f64);
    if x + 0.5 > f.ref_coord.max() || y + 0.5 > f.ref_coord.max() {
        *sat += 1;
        return None;
    }
    for c in &mut rec.colour {
        *c = f.colour.q(*c as f64, sat) as f32;
    }
    for g in &mut rec.slopes {
        *g = f.slope.q(*g as f64, sat) as f32;
    }
    f.ref_inv_z.q(1.0 / rec.z as f64, sat);
    Some(f.ref_inv_z.quantise(1.0 / rec.z as f64).0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Every run on every line of a 20x13 grid: the words and masks of
    /// `run_words` name exactly the bits `index` gives its positions, and
    /// `position` inverts them.
    #[test]
    fn a_runs_words_hold_exactly_its_positions_bits() {
        let (w, h) = (20u32, 13u32);
        let g = Grid::new(w, h);
        for major in [Major::Row, Major::Column] {
            let (lines, len) = if major == Major::Row { (h, w) } else { (w, h) };
            for line in 0..lines {
                for a0 in 0..len {
                    for a1 in a0..len {
                        let at = |a: u32| if major == Major::Row { (a, line) } else { (line, a) };
                        let want: BTreeSet<usize> = (a0..=a1).map(at).map(|(x, y)| g.index(x, y)).collect();
                        let mut got = BTreeSet::new();
                        for (word, mask) in g.run_words(major, line, a0, a1) {
                            for bit in (0..64).filter(|b| mask >> b & 1 != 0) {
                                assert!(got.insert(word * 64 + bit as usize), "{major:?} {line} {a0}..={a1}");
                                let (x, y) = g.position(word, bit);
                                assert_eq!(g.index(x, y), word * 64 + bit as usize);
                            }
                        }
                        assert_eq!(got, want, "{major:?} line {line}, {a0}..={a1}");
                    }
                }
            }
        }
    }
}
