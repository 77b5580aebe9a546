//! The derived frame's per-sample planes while a warp is in progress (TR98
//! Appendix B.2), held as typed planes; flags are `bitvec` bit-planes.
//!
//! | # | plane | field here | kept |
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
//! | – | mesh/splat bit (TR98 §7.1, general path) | `splat` | memory, not in the A-buffer |
//!
//! A sample is *real* when `real` is set (a warped surface wrote it), a
//! *hole-fill* sample when `hole` is set, and *empty* otherwise.
//!
//! The general reconstruction path (TR98 §7.1, `general.rs`) adds one
//! memory bit-plane, `splat`: the stored real sample came from an edge
//! splat (set) or from the triangle mesh (clear; the anti-aliased path's
//! kernels count as mesh). It is not kept in the A-buffer: when the frame
//! goes through the A-buffer between warps at ss > 1 the bit is forgotten
//! ([`DestPlanes::forget_splats`]) and every stored sample counts as mesh.

use bitvec::vec::BitVec;

/// Per-sample planes of the derived frame.
#[derive(Clone, Debug, PartialEq)]
pub struct DestPlanes {
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
    /// A real surface sample (not a plane of the paper: "written, not hole").
    pub real: BitVec,
    /// Plane 6: hole-fill colour.
    pub fill_colour: Vec<[f32; 3]>,
    /// Plane 7: hole-fill colour valid.
    pub fill_valid: BitVec,
    /// Plane 8: hole-fill distance (samples, saturating).
    pub fill_distance: Vec<u8>,
    /// Plane 9: accumulated hole-fill weight (Σ 1/distance).
    pub fill_weight: Vec<f32>,
    /// Mesh/splat bit (TR98 §7.1): the stored real sample came from an
    /// edge splat. Clear for mesh samples, hole fill and empty samples.
    pub splat: BitVec,
}

impl DestPlanes {
    /// An empty derived frame of `width x height` samples.
    pub fn new(width: u32, height: u32) -> DestPlanes {
        let n = width as usize * height as usize;
        DestPlanes {
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
            splat: BitVec::repeat(false, n),
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

    /// Empty samples (neither real nor hole fill), counted a word of each
    /// flag plane at a time (the planes start at bit 0 of their first word,
    /// as `BitVec::repeat` makes them; `begin_warp` assumes the same).
    pub fn empty_count(&self) -> usize {
        let (n, bits) = (self.len(), usize::BITS as usize);
        let words = self.real.as_raw_slice().iter().zip(self.hole.as_raw_slice());
        words
            .enumerate()
            .map(|(w, (&real, &hole))| {
                let live = n.saturating_sub(w * bits).min(bits);
                let mask = if live == bits { !0 } else { (1usize << live) - 1 };
                (!(real | hole) & mask).count_ones() as usize
            })
            .sum()
    }

    /// Clear the mesh/splat plane: every stored sample counts as mesh (after
    /// a trip through the A-buffer, which does not keep the bit).
    pub fn forget_splats(&mut self) {
        self.splat.fill(false);
    }

    /// After the last warp (and the fallback pass): free the cache-only
    /// planes 6–8 (`fill_colour`, `fill_valid`, `fill_distance`), which the
    /// frame in memory does not keep (module table); they are left empty,
    /// 13 bytes per sample less for whatever the frame is read by next.
    /// A frame so trimmed takes no further warp.
    pub fn drop_cache_planes(&mut self) {
        self.fill_colour = Vec::new();
        self.fill_valid = BitVec::new();
        self.fill_distance = Vec::new();
    }

    /// Reset the cache-only planes 6–8 for a new reference warp: real
    /// samples are true surfaces (distance 0, fill colour = colour); others
    /// have no fill colour yet.
    #[inline(always)] // into each vector level's warp (`vector_level`)
    pub fn begin_warp(&mut self) {
        self.fill_valid.copy_from_bitslice(&self.real);
        self.fill_distance.fill(0);
        // A word of the real plane at a time (bit b of word w: sample 64w + b).
        let bits = usize::BITS as usize;
        let n = self.len();
        for (w, &word) in self.real.as_raw_slice().iter().enumerate() {
            let lo = w * bits;
            let hi = (lo + bits).min(n);
            for (b, (fill, &colour)) in self.fill_colour[lo..hi].iter_mut().zip(&self.colour[lo..hi]).enumerate() {
                *fill = if (word >> b) & 1 != 0 { colour } else { [0.0; 3] };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_count_counts_samples_neither_real_nor_hole() {
        // Whole words, and a partial last word whose spare bits (clear in
        // both planes) are no samples.
        for (w, h) in [(8, 8), (13, 11), (64, 2), (1, 1)] {
            let mut d = DestPlanes::new(w, h);
            for i in 0..d.len() {
                d.real.set(i, i % 3 == 0);
                d.hole.set(i, i % 5 == 1);
            }
            let want = (0..d.len()).filter(|&i| !d.real[i] && !d.hole[i]).count();
            assert!(want > 0 || d.len() == 1, "{w}x{h}");
            assert_eq!(d.empty_count(), want, "{w}x{h}");
        }
    }

    #[test]
    fn begin_warp_seeds_the_fill_planes_from_real_samples() {
        // Past one word of flags, with a partial last word.
        let mut d = DestPlanes::new(13, 11);
        for i in 0..d.len() {
            d.colour[i] = [i as f32, 1.0, 2.0];
            d.real.set(i, i % 3 == 0 || i % 7 == 1);
            d.fill_colour[i] = [9.0; 3];
            d.fill_distance[i] = 5;
        }
        d.begin_warp();
        for i in 0..d.len() {
            let real = i % 3 == 0 || i % 7 == 1;
            assert_eq!(d.fill_valid[i], real, "{i}");
            assert_eq!(d.fill_colour[i], if real { d.colour[i] } else { [0.0; 3] }, "{i}");
            assert_eq!(d.fill_distance[i], 0);
        }
    }
}
