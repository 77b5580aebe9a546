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

use bitvec::vec::BitVec;

/// The word planes of one derived-frame sample (planes 1–4, 6, 8 and 9),
/// kept together: the compositor writes all of them when it wins a sample,
/// and stored side by side they share one or two host cache lines where
/// seven separate arrays needed seven (a host layout only: no value or
/// cycle depends on it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DestSample {
    /// Plane 1: linear RGB.
    pub colour: [f32; 3],
    /// Plane 2: derived-camera 1/Z (1/scene unit).
    pub inv_z: f32,
    /// Plane 3: slopes of 1/Z per derived sample step.
    pub slopes: [f32; 2],
    /// Plane 6: hole-fill colour.
    pub fill_colour: [f32; 3],
    /// Plane 9: accumulated hole-fill weight (Σ 1/distance).
    pub fill_weight: f32,
    /// Plane 4: index (in the frame's warp list) of the reference that wrote it.
    pub source: u8,
    /// Plane 8: hole-fill distance (samples, saturating).
    pub fill_distance: u8,
}

// SAFETY: `f32`s and `u8`s; all zero is `DestSample::default()`.
unsafe impl crate::host_hint::Zeroable for DestSample {}

/// Per-sample planes of a derived frame, row-major (`y·width + x`): the
/// word planes per sample, the flag planes as bit planes.
#[derive(Clone, Debug, PartialEq)]
pub struct DestFrame {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Planes 1–4, 6, 8 and 9 of each sample.
    pub samples: Vec<DestSample>,
    /// Plane 5: colour comes from hole fill.
    pub hole: BitVec,
    /// A real surface sample.
    pub real: BitVec,
    /// Plane 7: hole-fill colour valid.
    pub fill_valid: BitVec,
}

impl DestFrame {
    /// An empty derived frame of `width x height` samples.
    pub fn new(width: u32, height: u32) -> DestFrame {
        let n = width as usize * height as usize;
        DestFrame {
            width,
            height,
            samples: crate::host_hint::zeroed_vec(n),
            hole: BitVec::repeat(false, n),
            real: BitVec::repeat(false, n),
            fill_valid: BitVec::repeat(false, n),
        }
    }

    /// One plane of every sample, in sample order (for reports and tests).
    pub fn plane<T>(&self, field: impl Fn(&DestSample) -> T) -> Vec<T> {
        self.samples.iter().map(field).collect()
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
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
        let s = &mut self.samples[i];
        s.fill_colour = if real { s.colour } else { [0.0; 3] };
        s.fill_distance = 0;
    }

    /// Ask the host CPU to bring sample `i`'s planes into its cache (a hint:
    /// no value changes, nothing is read). The compositor calls it for the
    /// stamps it will draw next cycle, whose planes are otherwise missed
    /// in the host's caches at nearly every stamp.
    #[inline(always)]
    pub fn prefetch(&self, i: usize) {
        if i < self.len() {
            use crate::host_hint::prefetch;
            prefetch(self.samples[i..].as_ptr());
            let word = i / usize::BITS as usize;
            for bits in [&self.real, &self.hole, &self.fill_valid] {
                prefetch(bits.as_raw_slice()[word..].as_ptr());
            }
        }
    }

    /// [`DestFrame::begin_warp_sample`] of every sample in `range` (one run
    /// of a row): the same values. Host speed only: the same run of the
    /// next row is prefetched, as tiles are reset row after row.
    pub fn begin_warp_run(&mut self, range: std::ops::Range<usize>) {
        let w = self.width as usize;
        self.prefetch_run(range.start + w..range.end + w);
        let real = &self.real[range.clone()];
        self.fill_valid[range.clone()].copy_from_bitslice(real);
        for (s, real) in self.samples[range].iter_mut().zip(real.iter().by_vals()) {
            s.fill_colour = if real { s.colour } else { [0.0; 3] };
            s.fill_distance = 0;
        }
    }

    /// Ask the host CPU to fetch the samples of `range` (a hint, as
    /// [`DestFrame::prefetch`]; nothing if the range leaves the frame): for
    /// the passes that walk a tile row after row, one row ahead.
    #[inline]
    pub fn prefetch_run(&self, range: std::ops::Range<usize>) {
        if let Some(run) = self.samples.get(range) {
            let bytes = run.as_ptr_range();
            let (start, end) = (bytes.start.cast::<u8>(), bytes.end.cast::<u8>());
            let mut p = start;
            while p < end {
                crate::host_hint::prefetch(p);
                p = p.wrapping_add(64);
            }
            crate::host_hint::prefetch(end.wrapping_sub(1));
        }
    }
}
