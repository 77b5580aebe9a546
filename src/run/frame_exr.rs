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
