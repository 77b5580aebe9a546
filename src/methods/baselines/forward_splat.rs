//! The plain forward splat: the baseline every better warper is measured
//! against (the "plain per-sample forward splat with depth test" of the
//! anchors, and issue 6's baseline for quality and speed).
//!
//! Job: make a derived frame from the same [`FrameCommands`] and reference
//! samples as the golden model, in the simplest way that is still a 3D warp.
//!
//! Rules:
//! 1. Every valid reference sample is warped with its [`ReferenceWarp`]'s
//!    [`WarpSetup::warp`] (sample grids of
//!    both cameras); a sample behind the derived camera (`W <= 0`) is culled.
//! 2. A warped sample writes only the derived sample whose centre is nearest
//!    (its position rounded to integers); one that lands off the image is
//!    dropped.
//! 3. Depth test: the larger derived 1/Z wins; on equal 1/Z the sample
//!    already there stays.
//! 4. References are warped in warp order into one buffer; each reference in
//!    raster order (the order matters only for exact ties).
//! 5. Resolve (`golden::resolve`): each pixel is the mean of its `ss x ss`
//!    samples, empty samples counting as black; a pixel is *covered* when
//!    every one of its samples was written.
//!
//! Not modelled, on purpose: reconstruction (no kernels: a magnified surface
//! leaves pinholes between its samples, a minified one keeps whichever
//! sample came last), hole fill, the A-buffer between warps, the
//! occlusion-compatible traversal, same-surface arbitration between
//! references, slopes and Z tolerances, fixed point and cycles.
//!
//! [`ReferenceWarp`]: postwarp_rtl::ReferenceWarp

use crate::golden::planes::DestPlanes;
use crate::golden::resolve::resolve;
use crate::methods::{Counters, Input, MethodInfo, Reconstruction};
use bitvec::vec::BitVec;
use postwarp_rtl::{FrameCommands, SampleImage, WarpSetup};
use serde::Serialize;

/// Counters of one derived frame (units: reference samples, over all warps;
/// the last five add up to `reference_samples`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ForwardSplatStats {
    /// Reference samples with a surface.
    pub reference_samples: u64,
    /// Samples behind the derived camera (`W <= 0`).
    pub culled_samples: u64,
    /// Samples whose nearest derived sample is off the image.
    pub off_image: u64,
    /// Samples written into an empty derived sample.
    pub filled: u64,
    /// Samples that won the depth test over an earlier one.
    pub nearer: u64,
    /// Samples that lost the depth test.
    pub lost: u64,
}

/// The forward splat's output for one derived frame.
#[derive(Clone, Debug)]
pub struct ForwardSplatFrame {
    /// Final per-sample planes.
    pub samples: DestPlanes,
    /// Resolved display pixels (linear RGB).
    pub pixels: Vec<[f32; 3]>,
    /// Pixels whose samples were all written.
    pub covered: BitVec,
    /// Counters.
    pub stats: ForwardSplatStats,
}

/// Produce derived frame `cmd` from its references (`refs[j]` for
/// `cmd.warps[j]`, each on its camera's sample grid).
///
/// # Panics
/// If `refs` and `cmd.warps` differ in length or a reference's size is not
/// its camera's sample grid.
pub fn forward_splat(cmd: &FrameCommands, refs: &[&SampleImage]) -> ForwardSplatFrame {
    assert_eq!(refs.len(), cmd.warps.len(), "one reference image per warp");
    let ss = cmd.supersample;
    let dst = cmd.derived_camera.sample_grid(ss).intrinsics;
    let mut d = DestPlanes::new(dst.width, dst.height);
    let st = forward_splat_into(cmd, refs, &mut d);
    let (pixels, covered) = resolve(&d, ss);
    ForwardSplatFrame { samples: d, pixels, covered, stats: st }
}

/// Rules 1–4 into `d` (an empty frame of the derived sample grid's size);
/// returns the counters.
pub fn forward_splat_into(cmd: &FrameCommands, refs: &[&SampleImage], d: &mut DestPlanes) -> ForwardSplatStats {
    assert_eq!(refs.len(), cmd.warps.len(), "one reference image per warp");
    let mut st = ForwardSplatStats::default();
    for (j, (warp, img)) in cmd.warps.iter().zip(refs).enumerate() {
        let src = &warp.reference_camera.intrinsics;
        assert_eq!((img.width, img.height), (src.width, src.height), "reference image size");
        splat_reference(&warp.setup, img, j as u8, d, &mut st);
    }
    st
}

/// Rules 1-4 for one reference.
fn splat_reference(setup: &WarpSetup, img: &SampleImage, source: u8, d: &mut DestPlanes, st: &mut ForwardSplatStats) {
    let w = img.width as usize;
    let (dw, dh) = (d.width as f64, d.height as f64);
    for i in img.valid.iter_ones() {
        st.reference_samples += 1;
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        let t = setup.warp(x, y, 1.0 / img.z[i] as f64);
        if t.w <= 0.0 {
            st.culled_samples += 1;
            continue;
        }
        let (rx, ry) = (t.position.x.round(), t.position.y.round());
        // Also rejects NaN positions.
        if !(rx >= 0.0 && ry >= 0.0 && rx < dw && ry < dh) {
            st.off_image += 1;
            continue;
        }
        let k = ry as usize * d.width as usize + rx as usize;
        let inv_z = t.inv_z as f32;
        if !d.real[k] {
            d.real.set(k, true);
            st.filled += 1;
        } else if inv_z > d.inv_z[k] {
            st.nearer += 1;
        } else {
            st.lost += 1;
            continue;
        }
        d.inv_z[k] = inv_z;
        d.colour[k] = img.colour[i];
        d.source[k] = source;
    }
}

/// The forward splat as a [`Reconstruction`] (`forward-splat`).
pub struct ForwardSplat;

impl Reconstruction for ForwardSplat {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "forward-splat",
            description: "plain forward splat: each reference sample writes its nearest derived sample, depth test",
            paper: "baseline (anchors; 001 Smit et al. §3 without splat sizes)",
            primitive: "splats",
            default_hole_fill: "none",
        }
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let st = forward_splat_into(input.cmd, input.refs, out);
        let drawn = st.filled + st.nearer + st.lost;
        let mut extra = serde_json::Map::new();
        for (k, v) in [("culled_samples", st.culled_samples), ("off_image", st.off_image), ("lost", st.lost)] {
            extra.insert(k.into(), v.into());
        }
        Counters { primitives: drawn, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::test_frames::cam;

    fn image(w: u32, h: u32, depth: impl Fn(u32, u32) -> Option<f32>) -> SampleImage {
        crate::methods::test_frames::image(w, h, |_, _| 0.5, depth)
    }

    #[test]
    fn identity_warp_reproduces_the_reference() {
        let (c, ss) = (cam(12, 8, 0.0), 2);
        let img = image(24, 16, |x, y| ((x * 7 + y * 3) % 11 != 0).then_some(1.0 + ((x * 5 + y) % 9) as f32));
        let cmd = FrameCommands::new(0, c, ss, &[(0, c)]);
        let f = forward_splat(&cmd, &[&img]);
        assert_eq!(f.samples.real, img.valid);
        for i in img.valid.iter_ones() {
            assert_eq!(f.samples.colour[i], img.colour[i], "sample {i}");
            assert!((f.samples.inv_z[i] - 1.0 / img.z[i]).abs() < 1e-6, "sample {i}");
        }
        let n = img.valid.count_ones() as u64;
        assert_eq!(f.stats, ForwardSplatStats { reference_samples: n, filled: n, ..Default::default() });
        // Pixel (0, 0) averages samples 0, 1, 24, 25 (sample 0 is empty: black).
        assert!(!img.valid[0] && !f.covered[0]);
        for (c, got) in f.pixels[0].iter().enumerate() {
            let want = [1, 24, 25].iter().map(|&k| img.colour[k][c]).sum::<f32>() / 4.0;
            assert!((got - want).abs() < 1e-6, "channel {c}: {got} vs {want}");
        }
        assert!(f.covered[1]);
    }

    #[test]
    fn translated_plane_lands_shifted() {
        // Plane Z = 5; derived camera 0.2 to the right. On the 2x2 sample grid
        // fx = 100, so the image moves by −100·0.2/5 = −4 samples.
        let ss = 2;
        let img = image(40, 20, |_, _| Some(5.0));
        let cmd = FrameCommands::new(0, cam(20, 10, 0.2), ss, &[(0, cam(20, 10, 0.0))]);
        let f = forward_splat(&cmd, &[&img]);
        for y in 0..20u32 {
            for x in 0..40u32 {
                let k = img.index(x, y);
                if x + 4 < 40 {
                    assert!(f.samples.real[k], "({x}, {y})");
                    assert_eq!(f.samples.colour[k], img.colour[img.index(x + 4, y)], "({x}, {y})");
                    assert!((f.samples.inv_z[k] - 0.2).abs() < 1e-6);
                } else {
                    assert!(!f.samples.real[k], "({x}, {y})");
                }
            }
        }
        assert_eq!(f.stats.off_image, 4 * 20);
        // The two rightmost pixel columns are empty, the rest covered.
        for p in 0..200 {
            assert_eq!(f.covered[p], p % 20 < 18, "pixel {p}");
        }
    }

    #[test]
    fn nearer_sample_wins() {
        // Within one reference: background at Z = 5 moves +1 sample, a strip
        // at Z = 1 (x 5..7) moves +5 onto x 10..12; the background of x 9..11
        // lands there too, after the strip in raster order, and loses.
        let img = image(20, 4, |x, _| Some(if (5..7).contains(&x) { 1.0 } else { 5.0 }));
        let cmd = FrameCommands::new(0, cam(20, 4, -0.1), 1, &[(0, cam(20, 4, 0.0))]);
        let f = forward_splat(&cmd, &[&img]);
        for y in 0..4 {
            for x in 10..12 {
                let k = img.index(x, y);
                assert_eq!(f.samples.colour[k], img.colour[img.index(x - 5, y)], "({x}, {y})");
                assert!((f.samples.inv_z[k] - 1.0).abs() < 1e-6);
            }
        }
        assert_eq!(f.stats.lost, 2 * 4);

        // Across references, in either warp order: the near one wins.
        let c = cam(8, 6, 0.0);
        let far = image(8, 6, |_, _| Some(10.0));
        let mut near = image(8, 6, |x, _| (x < 4).then_some(2.0));
        near.colour.iter_mut().for_each(|c| *c = [1.0, 0.0, 0.0]);
        let cmd = FrameCommands::new(0, c, 1, &[(0, c), (1, c)]);
        for (refs, nearer, lost) in [([&far, &near], 24, 0), ([&near, &far], 0, 24)] {
            let f = forward_splat(&cmd, &refs);
            for k in 0..48 {
                let want = if k % 8 < 4 { [1.0, 0.0, 0.0] } else { far.colour[k] };
                assert_eq!(f.samples.colour[k], want, "sample {k}");
            }
            assert_eq!((f.stats.nearer, f.stats.lost), (nearer, lost));
        }
    }
}
