//! The derived frame's per-sample planes as the hardware holds them (TR98
//! Appendix B.2): the functional contents of the destination tile cache and
//! of the destination frame in DRAM, which are one store here.
//!
//! Job: plain storage. The destination tile cache (`units::tile_cache`)
//! decides *when* a tile is on chip and counts the traffic; the values live
//! here, so a tile spilled raw and reloaded is bit-identical by
//! construction. The A-buffer packer (`units::abuffer`) rewrites a tile's
//! memory planes in place when the tile is written back in A-buffer format.
//!
//! | # | plane | field | kept |
//! |---|---|---|---|
//! | 1 | colour RGB | `colour` | memory |
//! | 2 | derived 1/Z | `inv_z` | memory |
//! | 3 | ∂(1/Z)/∂x, ∂(1/Z)/∂y | `slopes` | memory |
//! | 4 | source (reference) number | `source` | memory |
//! | 5 | colour is hole fill | `hole` | memory |
//! | 6 | hole-fill colour | `fill_colour` | cache only (reset per warp) |
//! | 7 | hole-fill colour valid | `fill_valid` | cache only |
//! | 8 | hole-fill distance (0 = true surface) | `fill_distance` | cache only |
//! | 9 | hole-fill weight | `fill_weight` | memory |
//!
//! `real` is not a plane of the paper: "a warped surface wrote this sample".
//!
//! Not modelled: the mesh/splat bit of TR98 §7.1 (the hardware draws only
//! the anti-aliased flat rectangles of §7.2).

use crate::bits;
use bitvec::vec::BitVec;

/// Per-sample planes of a derived frame, row-major (`y·width + x`).
#[derive(Clone, Debug, PartialEq)]
pub struct DestFrame {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Plane 1: linear RGB.
    pub colour: Vec<[f32; 3]>,
    /// Plane 2: derived-camera 1/Z (1/scene unit).
    pub inv_z: Vec<f32>,
    /// Plane 3: slopes of 1/Z per derived sample step.
    pub slopes: Vec<[f32; 2]>,
    /// Plane 4: index (in the frame's warp list) of the reference that wrote it.
    pub source: Vec<u8>,
    /// Plane 5: colour comes from hole fill.
    pub hole: BitVec,
    /// A real surface sample.
    pub real: BitVec,
    /// Plane 6: hole-fill colour.
    pub fill_colour: Vec<[f32; 3]>,
    /// Plane 7: hole-fill colour valid.
    pub fill_valid: BitVec,
    /// Plane 8: hole-fill distance (samples, saturating).
    pub fill_distance: Vec<u8>,
    /// Plane 9: accumulated hole-fill weight (Σ 1/distance).
    pub fill_weight: Vec<f32>,
}

impl DestFrame {
    /// An empty derived frame of `width x height` samples.
    pub fn new(width: u32, height: u32) -> DestFrame {
        let n = width as usize * height as usize;
        DestFrame {
            width,
            height,
            colour: vec![[0.0; 3]; n],
            inv_z: vec![0.0; n],
            slopes: vec![[0.0; 2]; n],
            source: vec![0; n],
            hole: BitVec::repeat(false, n),
            real: BitVec::repeat(false, n),
            fill_colour: vec![[0.0; 3]; n],
            fill_valid: BitVec::repeat(false, n),
            fill_distance: vec![0; n],
            fill_weight: vec![0.0; n],
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.colour.len()
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.colour.is_empty()
    }

    /// Linear index of sample `(x, y)`.
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Reset the cache-only planes 6–8 of sample `i` as a tile enters the
    /// cache for a new warp: a real sample is a true surface (distance 0,
    /// fill colour = its colour); any other has no fill colour yet.
    pub fn begin_warp_sample(&mut self, i: usize) {
        let real = self.real[i];
        self.fill_valid.set(i, real);
        self.fill_colour[i] = if real { self.colour[i] } else { [0.0; 3] };
        self.fill_distance[i] = 0;
    }

    /// Ask the host CPU to bring sample `i`'s planes into its cache (a hint:
    /// no value changes, nothing is read). The compositor calls it for the
    /// stamps it will draw next cycle, whose planes are otherwise missed
    /// in the host's caches at nearly every stamp.
    #[inline(always)]
    pub fn prefetch(&self, i: usize) {
        if i < self.len() {
            use crate::host_hint::prefetch;
            prefetch(self.colour[i..].as_ptr());
            prefetch(self.inv_z[i..].as_ptr());
            prefetch(self.slopes[i..].as_ptr());
            prefetch(self.source[i..].as_ptr());
            prefetch(self.fill_colour[i..].as_ptr());
            prefetch(self.fill_distance[i..].as_ptr());
            prefetch(self.fill_weight[i..].as_ptr());
            let word = i / usize::BITS as usize;
            for bits in [&self.real, &self.hole, &self.fill_valid] {
                prefetch(bits.as_raw_slice()[word..].as_ptr());
            }
        }
    }

    /// [`DestFrame::begin_warp_sample`] of every sample in `range` (one run
    /// of a row): the same values.
    pub fn begin_warp_run(&mut self, range: std::ops::Range<usize>) {
        for i in range.clone() {
            let real = bits::get(&self.real, i);
            bits::put(&mut self.fill_valid, i, real);
            self.fill_colour[i] = if real { self.colour[i] } else { [0.0; 3] };
        }
        self.fill_distance[range].fill(0);
    }
}
