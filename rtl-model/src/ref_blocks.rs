//! The host's copy of a reference's records during a warp: expanded from
//! the packed form a block at a time as kernel setup's lines reach it, and
//! let go once the warp has moved on.
//!
//! Job: give the line computation (`units::line_kernels`, `units::line_buffer`)
//! the [`RefSample`] records of a run of positions on a traversal line, or
//! of one sample, without the whole reference expanded in host memory
//! (24 bytes per sample, twice the packed form: it was most of the peak
//! memory of a `simulate` run).
//!
//! Rules:
//! 1. A block is [`BLOCK_PIXELS`] x [`BLOCK_PIXELS`] whole pixels of the
//!    reference (its samples; raw references include the partial pixels
//!    at the right and bottom edges in the last blocks). Its records are
//!    the expander's, [`crate::hw_reference`]'s `record` on
//!    [`crate::units::abuffer::PackedReference::for_each_sample_in`]; a
//!    sample with no surface, or dropped by the fixed mode, is all zero, as
//!    the whole-frame records were.
//! 2. At most [`RefBlocks::capacity`] blocks are held: four block lines of
//!    the reference's longer side. The traversal's lines move through a
//!    sheet one after the other, so a block is reached by consecutive
//!    lines and then left; when a block is needed and the copy is full,
//!    the least recently used block goes (`crate::lru::Lru`) and is
//!    expanded again if a later line needs it.
//! 3. The copy is the host's: which blocks are held, and how often one is
//!    expanded, change no value, cycle or counter (the same records
//!    whatever the capacity; `tests/hw_look_ahead.rs`, the snapshots).
//!
//! Not modelled: nothing of the hardware (the fetch unit's source cache
//! models the reference reads and their timing).

use crate::hw_reference::{HwReference, RefSample, record};
use crate::lru::Lru;
use crate::traversal::Major;

/// Side of a block, in whole pixels (rule 1).
pub const BLOCK_PIXELS: u32 = 8;

/// Block lines of the reference's longer side held at once (rule 2).
const BLOCK_LINES: usize = 4;

/// No slot.
const NONE: u32 = u32::MAX;

/// The records of the blocks of one reference a warp holds (module doc).
#[derive(Debug)]
pub struct RefBlocks {
    /// Block side (samples).
    side: u32,
    /// Blocks per row.
    blocks_x: u32,
    /// Per block: its slot, or [`NONE`].
    slot_of: Vec<u32>,
    /// Per slot: the block it holds.
    block_in: Vec<u32>,
    /// Per slot: the block's records, row-major, `side x side`.
    records: Vec<RefSample>,
    /// Replacement order of the held blocks (rule 2).
    lru: Lru,
    /// Uses so far (the LRU's clock).
    uses: u64,
    /// Blocks held at most (rule 2).
    cap: usize,
    /// Blocks expanded (counts; host work, no model statistic).
    pub expansions: u64,
}

impl RefBlocks {
    /// An empty copy of the records of `r`.
    pub fn new(r: &HwReference) -> RefBlocks {
        let mut b = RefBlocks::with_capacity(r, 0);
        b.cap = BLOCK_LINES * (b.blocks_x as usize).max(b.slot_of.len() / b.blocks_x as usize);
        b
    }

    /// An empty copy of the records of `r` holding at most `cap` blocks
    /// (at least one).
    pub fn with_capacity(r: &HwReference, cap: usize) -> RefBlocks {
        let side = BLOCK_PIXELS * r.packed.ss();
        let (bx, by) = (r.width.div_ceil(side).max(1), r.height.div_ceil(side).max(1));
        RefBlocks {
            side,
            blocks_x: bx,
            slot_of: vec![NONE; (bx * by) as usize],
            block_in: Vec::new(),
            records: Vec::new(),
            lru: Lru::new((bx * by) as usize),
            uses: 0,
            cap: cap.max(1),
            expansions: 0,
        }
    }

    /// Blocks held at most (rule 2).
    pub fn capacity(&self) -> usize {
        self.cap
    }

    /// Records of positions `a0..=a1` of line `line` along `major`, in
    /// order, appended to `out` (the positions must be on the reference).
    pub(crate) fn line(
        &mut self,
        r: &HwReference,
        major: Major,
        line: u32,
        a0: u32,
        a1: u32,
        out: &mut Vec<RefSample>,
    ) {
        debug_assert!(a0 <= a1);
        let side = self.side;
        let mut a = a0;
        while a <= a1 {
            // The run's part in one block.
            let end = ((a / side + 1) * side - 1).min(a1);
            let (x, y) = match major {
                Major::Row => (a, line),
                Major::Column => (line, a),
            };
            let base = self.slot(r, x, y) * (side * side) as usize;
            let (ox, oy) = ((x % side) as usize, (y % side) as usize);
            let block = &self.records[base..base + (side * side) as usize];
            let n = (end - a + 1) as usize;
            match major {
                Major::Row => out.extend_from_slice(&block[oy * side as usize + ox..][..n]),
                Major::Column => out.extend((0..n).map(|k| block[(oy + k) * side as usize + ox])),
            }
            a = end + 1;
        }
    }

    /// The record of sample `(x, y)`.
    #[inline]
    pub(crate) fn rec(&mut self, r: &HwReference, x: u32, y: u32) -> RefSample {
        let side = self.side;
        let base = self.slot(r, x, y) * (side * side) as usize;
        self.records[base + ((y % side) * side + x % side) as usize]
    }

    /// The slot holding the block of sample `(x, y)`, expanded if it is
    /// not held (rule 2).
    #[inline]
    fn slot(&mut self, r: &HwReference, x: u32, y: u32) -> usize {
        debug_assert!(x < r.width && y < r.height, "({x}, {y}) is off the reference");
        let b = (y / self.side) * self.blocks_x + x / self.side;
        self.uses += 1;
        let s = self.slot_of[b as usize];
        if s != NONE {
            self.lru.touch(b, self.uses);
            return s as usize;
        }
        let per = (self.side * self.side) as usize;
        let s = if self.block_in.len() < self.capacity() {
            self.block_in.push(b);
            self.records.resize(self.records.len() + per, RefSample::default());
            self.block_in.len() - 1
        } else {
            let old = self.lru.victim(|_| true).expect("a full copy holds blocks");
            self.lru.remove(old);
            let s = self.slot_of[old as usize];
            self.slot_of[old as usize] = NONE;
            self.block_in[s as usize] = b;
            s as usize
        };
        self.slot_of[b as usize] = s as u32;
        self.lru.insert(b, self.uses);
        self.expand(r, b, s);
        s
    }

    /// Rule 1: block `b`'s records into slot `s`.
    fn expand(&mut self, r: &HwReference, b: u32, s: usize) {
        self.expansions += 1;
        let side = self.side;
        let (bx, by) = (b % self.blocks_x, b / self.blocks_x);
        let (x0, y0) = (bx * side, by * side);
        let per = (side * side) as usize;
        // Clipped to the frame there, the last block of a row or column
        // reaches the partial pixels too (rule 1).
        let (px0, py0) = (bx * BLOCK_PIXELS, by * BLOCK_PIXELS);
        let (px1, py1) = (px0 + BLOCK_PIXELS, py0 + BLOCK_PIXELS);
        r.packed.prefetch_pixels(px0, py0, px1, py1);
        let block = &mut self.records[s * per..(s + 1) * per];
        block.fill(RefSample::default());
        let fixed = r.fixed_formats();
        let mut sat = 0;
        r.packed.for_each_sample_in(px0, py0, px1, py1, |x, y, e| {
            if let Some((rec, _)) = record(e, x, y, fixed, &mut sat) {
                block[((y - y0) * side + (x - x0)) as usize] = rec;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::EngineConfig;
    use crate::sample_image::SampleImage;

    /// A `w x h` reference with a distinct record per valid sample (every
    /// seventh sample empty).
    fn reference(w: u32, h: u32, cfg: &EngineConfig) -> HwReference {
        let mut img = SampleImage::empty(w, h);
        for i in 0..(w * h) as usize {
            if i % 7 == 3 {
                continue;
            }
            img.colour[i] = [i as f32 * 1e-3, 0.5, 0.25];
            img.z[i] = 2.0 + (i % 13) as f32 * 0.1;
            img.inv_z_slopes[i] = [0.0, 0.0];
            img.object_id[i] = (i % 5) as u32;
            img.valid.set(i, true);
        }
        HwReference::new(&img, cfg)
    }

    /// Every row and column read through a copy of one block line's
    /// capacity, in an order that evicts, gives the whole-frame expansion's
    /// records, for raw and packed references.
    #[test]
    fn lines_and_samples_read_the_expanders_records_whatever_is_evicted() {
        for frags in [0, 2] {
            let cfg = EngineConfig { supersample: 2, abuffer_fragments: frags, ..EngineConfig::default() };
            let (w, h) = (70, 38);
            let r = reference(w, h, &cfg);
            let whole = r.expanded();
            let want = |x: u32, y: u32| {
                let i = (y * w + x) as usize;
                if whole.valid[i] {
                    (whole.colour[i], whole.z[i], whole.inv_z_slopes[i])
                } else {
                    ([0.0; 3], 0.0, [0.0; 2])
                }
            };
            let got = |s: RefSample| (s.colour, s.z, s.slopes);
            assert!(RefBlocks::new(&r).capacity() >= 15, "the default holds this reference whole");
            let mut blocks = RefBlocks::with_capacity(&r, 2);
            let mut out = Vec::new();
            for (major, lines, len) in [(Major::Column, w, h), (Major::Row, h, w)] {
                for line in (0..lines).rev() {
                    out.clear();
                    blocks.line(&r, major, line, 1, len - 2, &mut out);
                    for (k, s) in out.iter().enumerate() {
                        let a = k as u32 + 1;
                        let (x, y) = if major == Major::Row { (a, line) } else { (line, a) };
                        assert_eq!(got(*s), want(x, y), "frags {frags}, {major:?} line {line} at {a}");
                    }
                }
            }
            for (x, y) in [(69, 37), (0, 0), (35, 20), (69, 0)] {
                assert_eq!(got(blocks.rec(&r, x, y)), want(x, y));
            }
            assert!(blocks.block_in.len() <= blocks.capacity());
            assert!(blocks.expansions > blocks.slot_of.len() as u64, "the walk evicted and expanded again");
        }
    }
}
