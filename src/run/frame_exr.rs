//! A derived frame's samples as an EXR in the reference-image format
//! (`docs/trace-format.md`): colour, Z, 1/Z slopes, `valid` = a real
//! surface, `id` = 1 + the writing reference's position in the warp list
//! (0 where nothing real). `postwarp golden` and `postwarp simulate` write
//! it the same way, so identical engines write identical files; run-length
//! encoded (`ExrPacking::Fast`), lossless.

use crate::trace::{ExrPacking, SamplePlanes, write_sample_planes};
use bitvec::vec::BitVec;
use postwarp_rtl::{DestFrame, SampleImage};
use std::path::Path;

/// A derived frame's planes, as either engine stores them.
pub trait DerivedPlanes {
    /// Width and height (samples).
    fn size(&self) -> (u32, u32);
    /// Linear RGB of sample `i`.
    fn colour(&self, i: usize) -> [f32; 3];
    /// 1/Z of sample `i` (where real).
    fn inv_z(&self, i: usize) -> f32;
    /// 1/Z slopes of sample `i`.
    fn slopes(&self, i: usize) -> [f32; 2];
    /// Writing reference of sample `i` (where real).
    fn source(&self, i: usize) -> u8;
    /// Set where a real surface was written.
    fn real(&self) -> &BitVec;
}

/// The planes of a derived frame as separate arrays (the golden model's
/// layout), borrowed.
pub struct Planes<'a> {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Linear RGB per sample.
    pub colour: &'a [[f32; 3]],
    /// 1/Z per sample (where real).
    pub inv_z: &'a [f32],
    /// 1/Z slopes per sample.
    pub slopes: &'a [[f32; 2]],
    /// Writing reference per sample (where real).
    pub source: &'a [u8],
    /// Set where a real surface was written.
    pub real: &'a BitVec,
}

impl DerivedPlanes for Planes<'_> {
    fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    fn colour(&self, i: usize) -> [f32; 3] {
        self.colour[i]
    }
    fn inv_z(&self, i: usize) -> f32 {
        self.inv_z[i]
    }
    fn slopes(&self, i: usize) -> [f32; 2] {
        self.slopes[i]
    }
    fn source(&self, i: usize) -> u8 {
        self.source[i]
    }
    fn real(&self) -> &BitVec {
        self.real
    }
}

/// The hardware model's layout: the word planes of each sample together.
impl DerivedPlanes for DestFrame {
    fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    fn colour(&self, i: usize) -> [f32; 3] {
        self.samples[i].colour
    }
    fn inv_z(&self, i: usize) -> f32 {
        self.samples[i].inv_z
    }
    fn slopes(&self, i: usize) -> [f32; 2] {
        self.samples[i].slopes
    }
    fn source(&self, i: usize) -> u8 {
        self.samples[i].source
    }
    fn real(&self) -> &BitVec {
        &self.real
    }
}

/// The samples of `p` in the reference-image format.
pub fn derived_samples(p: &impl DerivedPlanes) -> SampleImage {
    let (w, h) = p.size();
    let mut s = SampleImage::empty(w, h);
    let real = p.real();
    for i in 0..s.len() {
        s.colour[i] = p.colour(i);
        s.inv_z_slopes[i] = p.slopes(i);
        s.object_id[i] = if real[i] { p.source(i) as u32 + 1 } else { 0 };
        if real[i] {
            s.z[i] = 1.0 / p.inv_z(i);
            s.valid.set(i, true);
        }
    }
    s
}

/// Write `p` to `path` (module rule).
pub fn write_frame_exr(path: &Path, p: &impl DerivedPlanes) -> anyhow::Result<()> {
    // The planes of `derived_samples(p)`, read in place.
    let real = p.real();
    let planes = SamplePlanes {
        size: p.size(),
        colour: |i| p.colour(i),
        valid: real,
        z: |i| 1.0 / p.inv_z(i),
        slopes: Some(|i| p.slopes(i)),
        id: |i| if real[i] { p.source(i) as u32 + 1 } else { 0 },
    };
    write_sample_planes(path, &planes, ExrPacking::Fast)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::{SlopeSource, write_reference_image_packed};

    /// The planes written in place are the bytes of the `SampleImage` path
    /// (`derived_samples` then `write_reference_image_packed`): with real
    /// and empty samples (whose 1/Z is 0, infinite or NaN), with none real
    /// (no `id` channel) and with all real (no `valid` channel).
    #[test]
    fn in_place_planes_are_the_sample_image_bytes() {
        let (w, h) = (7u32, 5u32);
        let n = (w * h) as usize;
        let colour: Vec<[f32; 3]> = (0..n).map(|i| [i as f32 * 0.03, 0.5, 1.0 - i as f32 * 0.02]).collect();
        let inv_z: Vec<f32> = (0..n).map(|i| [0.0, f32::INFINITY, f32::NAN, 0.25 + i as f32][i % 4]).collect();
        let slopes: Vec<[f32; 2]> = (0..n).map(|i| [i as f32 * 1e-3, -(i as f32) * 2e-3]).collect();
        let source: Vec<u8> = (0..n).map(|i| (i % 3) as u8).collect();
        let dir = tempfile::tempdir().unwrap();
        let masks: [BitVec; 3] =
            [(0..n).map(|i| i % 4 == 3).collect(), BitVec::repeat(false, n), BitVec::repeat(true, n)];
        for (k, real) in masks.iter().enumerate() {
            let inv_z: Vec<f32> = if real.all() { (0..n).map(|i| 0.5 + i as f32).collect() } else { inv_z.clone() };
            let p =
                Planes { width: w, height: h, colour: &colour, inv_z: &inv_z, slopes: &slopes, source: &source, real };
            let (a, b) = (dir.path().join(format!("a{k}.exr")), dir.path().join(format!("b{k}.exr")));
            write_frame_exr(&a, &p).unwrap();
            write_reference_image_packed(&b, &derived_samples(&p), SlopeSource::Exact, ExrPacking::Fast).unwrap();
            assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(), "mask {k}: the files differ");
        }
    }
}
