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

use crate::golden::frame::inv_z_plane;
use crate::golden::planes::DestPlanes;
use crate::golden::resolve::resolve;
use crate::golden::transform::warp_of;
use crate::methods::{Counters, Input, MethodInfo, Prepared, Reconstruction};
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
    let inv_z: Vec<Vec<f64>> = refs.iter().map(|r| inv_z_plane(r)).collect();
    let inv_z: Vec<&[f64]> = inv_z.iter().map(|v| v.as_slice()).collect();
    forward_splat_with(cmd, refs, &inv_z)
}

/// [`forward_splat`] with each reference's 1/Z plane made once beforehand
/// ([`inv_z_plane`], as the golden model's prepared references hold it).
pub fn forward_splat_with(cmd: &FrameCommands, refs: &[&SampleImage], inv_z: &[&[f64]]) -> ForwardSplatFrame {
    assert_eq!(refs.len(), cmd.warps.len(), "one reference image per warp");
    let ss = cmd.supersample;
    let dst = cmd.derived_camera.sample_grid(ss).intrinsics;
    let mut d = DestPlanes::new(dst.width, dst.height);
    let st = forward_splat_into(cmd, refs, inv_z, &mut d);
    let (pixels, covered) = resolve(&d, ss);
    ForwardSplatFrame { samples: d, pixels, covered, stats: st }
}

/// Rules 1–4 into `d` (an empty frame of the derived sample grid's size),
/// `inv_z[j]` the 1/Z plane of `refs[j]` ([`inv_z_plane`]); returns the
/// counters.
pub fn forward_splat_into(
    cmd: &FrameCommands,
    refs: &[&SampleImage],
    inv_z: &[&[f64]],
    d: &mut DestPlanes,
) -> ForwardSplatStats {
    assert_eq!(refs.len(), cmd.warps.len(), "one reference image per warp");
    assert_eq!(inv_z.len(), refs.len(), "one 1/Z plane per reference");
    let mut st = ForwardSplatStats::default();
    for (j, ((warp, img), iz)) in cmd.warps.iter().zip(refs).zip(inv_z).enumerate() {
        let src = &warp.reference_camera.intrinsics;
        assert_eq!((img.width, img.height), (src.width, src.height), "reference image size");
        assert_eq!(iz.len(), img.len(), "1/Z plane size");
        splat_reference(&warp.setup, img, iz, j as u8, d, &mut st);
    }
    st
}

/// `p.round()` (half away from zero) for `p` in `(−0.5, 2^52)`: the integer
/// part plus one if the fraction is at least a half (both exact in that
/// range), without a call to `round` per sample.
#[inline(always)]
fn round_nonneg(p: f64) -> usize {
    let t = p as u64; // truncates toward zero; 0 for p in (−0.5, 0)
    (t + ((p - t as f64) >= 0.5) as u64) as usize
}

/// Rules 1-4 for one reference. The work per sample is the splat's own:
/// the warp (three divisions), a cull test, rounding, a bounds test and
/// the depth test; 1/Z comes from the prepared plane, positions from the
/// row loop (no division by the width), and only valid samples are
/// visited (a word of the valid plane at a time).
fn splat_reference(
    setup: &WarpSetup,
    img: &SampleImage,
    inv_z: &[f64],
    source: u8,
    d: &mut DestPlanes,
    st: &mut ForwardSplatStats,
) {
    let w = img.width as usize;
    let dw = d.width as usize;
    // round(p) is in [0, n) iff p is in (−0.5, n − 0.5) (NaN is in neither).
    let (xmax, ymax) = (d.width as f64 - 0.5, d.height as f64 - 0.5);
    for y in 0..img.height as usize {
        let row = y * w;
        for x in img.valid[row..row + w].iter_ones() {
            let i = row + x;
            st.reference_samples += 1;
            let [px, py, iz, ww] = warp_of(setup, x as f64, y as f64, inv_z[i]);
            if ww <= 0.0 {
                st.culled_samples += 1;
                continue;
            }
            if !(px > -0.5 && py > -0.5 && px < xmax && py < ymax) {
                st.off_image += 1;
                continue;
            }
            let k = round_nonneg(py) * dw + round_nonneg(px);
            let inv_z = iz as f32;
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

    /// The 1/Z plane, once per reference (the golden model instead divides
    /// 1/Z from Z where it reads a sample, to hold 8 bytes less per sample).
    fn prepare(&self, img: &SampleImage, _ss: u32) -> Prepared {
        Box::new(inv_z_plane(img))
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        // Each reference's plane from `prepare`, or made here if the caller
        // prepared nothing.
        let prepared = |j: usize| input.prepared.get(j).and_then(|p| p.downcast_ref::<Vec<f64>>());
        let own: Vec<Option<Vec<f64>>> =
            input.refs.iter().enumerate().map(|(j, r)| prepared(j).is_none().then(|| inv_z_plane(r))).collect();
        let planes: Vec<&[f64]> = own
            .iter()
            .enumerate()
            .map(|(j, o)| o.as_deref().or(prepared(j).map(|v| v.as_slice())).unwrap_or(&[]))
            .collect();
        let st = forward_splat_into(input.cmd, input.refs, &planes, out);
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

    /// The splat as first written (per-sample 1/Z division, position from
    /// the index, `f64::round`): the row loop above must give its bits.
    fn oracle(cmd: &FrameCommands, refs: &[&SampleImage]) -> (DestPlanes, ForwardSplatStats) {
        let dst = cmd.derived_camera.sample_grid(cmd.supersample).intrinsics;
        let mut d = DestPlanes::new(dst.width, dst.height);
        let mut st = ForwardSplatStats::default();
        for (j, (warp, img)) in cmd.warps.iter().zip(refs).enumerate() {
            let w = img.width as usize;
            let (dw, dh) = (d.width as f64, d.height as f64);
            for i in img.valid.iter_ones() {
                st.reference_samples += 1;
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let t = warp.setup.warp(x, y, 1.0 / img.z[i] as f64);
                if t.w <= 0.0 {
                    st.culled_samples += 1;
                    continue;
                }
                let (rx, ry) = (t.position.x.round(), t.position.y.round());
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
                d.source[k] = j as u8;
            }
        }
        (d, st)
    }

    #[test]
    fn row_loop_gives_the_oracles_bits() {
        use glam::{DQuat, DVec3};
        // A rotated, moved derived camera (samples land between centres,
        // off the image and behind the camera) and two references with
        // depth steps and holes.
        let mut derived = cam(30, 20, 0.3);
        derived.pose.position = DVec3::new(0.3, -0.1, 0.4);
        derived.pose.orientation = DQuat::from_euler(glam::EulerRot::YXZ, 0.35, -0.1, 0.05);
        let (a, b) = (cam(40, 30, 0.0), cam(40, 30, 0.6));
        let depth = |x: u32, y: u32| match (x * 13 + y * 7) % 17 {
            0 => None,
            1 => Some(0.2), // behind the moved derived camera
            k => Some(1.0 + (k as f32) * 0.37 + (x as f32) * 0.01),
        };
        let ia = crate::methods::test_frames::image(80, 60, |x, _| x as f32 * 0.01, depth);
        let ib = crate::methods::test_frames::image(80, 60, |_, y| y as f32 * 0.02, |x, y| depth(y % 80, x % 60));
        for ss in [1, 2] {
            let (ia, ib) = if ss == 2 { (ia.clone(), ib.clone()) } else { (shrink(&ia), shrink(&ib)) };
            let cmd = FrameCommands::new(0, derived, ss, &[(0, a), (1, b)]);
            let got = forward_splat(&cmd, &[&ia, &ib]);
            let (want, st) = oracle(&cmd, &[&ia, &ib]);
            assert_eq!(got.samples, want, "ss {ss}");
            assert_eq!(got.stats, st, "ss {ss}");
            assert!(st.culled_samples > 0 && st.off_image > 0 && st.lost > 0 && st.nearer > 0, "{st:?}");
        }
    }

    #[test]
    fn rounding_matches_f64_round_in_its_range() {
        let below = |v: f64| f64::from_bits(v.to_bits() - 1);
        for p in [-0.49, -1e-300, -0.0, 0.0, below(0.5), 0.5, 1.5, 2.5, below(2.5), 1e6 + 0.5, 4503599627370495.5] {
            assert_eq!(round_nonneg(p), p.round() as usize, "{p}");
        }
        for k in 0..10_000 {
            let p = k as f64 * 0.0137 - 0.4;
            assert_eq!(round_nonneg(p), p.round() as usize, "{p}");
        }
    }

    /// The top-left `w/2 x h/2` samples (a 1x1 grid for a camera of that size).
    fn shrink(img: &SampleImage) -> SampleImage {
        let (w, h) = (img.width / 2, img.height / 2);
        let mut out = SampleImage::empty(w, h);
        for y in 0..h {
            for x in 0..w {
                let (i, j) = (out.index(x, y), img.index(x, y));
                out.colour[i] = img.colour[j];
                out.z[i] = img.z[j];
                out.valid.set(i, img.valid[j]);
            }
        }
        out
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
