//! A derived frame's samples as an EXR in the reference-image format
//! (`docs/trace-format.md`): colour, Z, 1/Z slopes, `valid` = a real
//! surface, `id` = 1 + the writing reference's position in the warp list
//! (0 where nothing real). `postwarp golden` and `postwarp simulate` write
//! it the same way, so identical engines write identical files; run-length
//! encoded (`ExrPacking::Fast`), lossless.

use crate::trace::{ExrPacking, SamplePlanes, write_sample_planes};
use bitvec::vec::BitVec;
use postwarp_rtl::SampleImage;
use std::path::Path;

/// The planes of a derived frame, borrowed from either engine.
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

/// The samples of `p` in the reference-image format.
pub fn derived_samples(p: &Planes) -> SampleImage {
    let mut s = SampleImage::empty(p.width, p.height);
    for i in 0..s.len() {
        s.colour[i] = p.colour[i];
        s.inv_z_slopes[i] = p.slopes[i];
        s.object_id[i] = if p.real[i] { p.source[i] as u32 + 1 } else { 0 };
        if p.real[i] {
            s.z[i] = 1.0 / p.inv_z[i];
            s.valid.set(i, true);
        }
    }
    s
}

/// Write `p` to `path` (module rule).
pub fn write_frame_exr(path: &Path, p: &Planes) -> anyhow::Result<()> {
    // The planes of `derived_samples(p)`, read in place.
    let planes = SamplePlanes {
        size: (p.width, p.height),
        colour: p.colour,
        valid: p.real,
        z: |i| 1.0 / p.inv_z[i],
        slopes: Some(p.slopes),
        id: |i| if p.real[i] { p.source[i] as u32 + 1 } else { 0 },
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
