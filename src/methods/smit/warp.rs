//! Smit et al.'s per-pixel warp (seed 001, Smit et al., C&G 2010, §3.4),
//! shared by their three reconstructions (`smit-point`, `smit-quad`,
//! `smit-mesh`) and by the hole classification (`errors`).
//!
//! Job: turn one reference into warped samples: derived position, derived
//! 1/Z and the warp's Jacobian on the sample's surface plane, then write
//! fragments into the derived frame with a plain depth test (the GPU's
//! z-buffer).
//!
//! Rules:
//! 1. Every reference sample with a surface (`valid`, finite `Z > 0`) is
//!    warped with [`WarpSetup::warp`] on the sample grids of both cameras
//!    (Smit's `P' = M·P`; the same warp as every other method here). A
//!    sample behind the derived camera (`W <= 0`) or whose warped position
//!    or 1/Z is not finite is *culled*.
//! 2. Jacobian: `J = ∂(x', y')/∂(x, y)` of the warp with 1/Z following the
//!    sample's own slopes, i.e. on its surface plane ([`WarpContext::jacobian`];
//!    Smit computes the same matrix from the pixel's normal, "a more robust
//!    depth derivative" than depth-buffer differences). Column `k` of `J`
//!    is the derived-image step of one reference sample step along axis
//!    `k`; units: derived samples per reference sample.
//! 3. Depth test (GL `LESS` on a z-buffer cleared to far): a fragment
//!    writes a derived sample iff the sample is empty or the fragment's
//!    derived 1/Z (as `f32`) is larger than the stored one; on equal 1/Z the
//!    sample already there stays. A write sets `real`, `colour`, `inv_z`
//!    and `source`.
//! 4. References are drawn in warp order, each in raster order of its
//!    samples (the order matters only for exact depth ties).
//!
//! Not modelled: Smit's per-object warp matrices (dynamic objects, the
//! shared scene graph: every trace here is a static scene, one matrix per
//! reference), deferred shading from warped normals (colours are warped as
//! they are), GPU fixed point and the z-buffer's precision.

use crate::golden::general::{Window, triangle};
use crate::golden::planes::DestPlanes;
use crate::golden::transform::{WarpContext, warp_of};
use glam::{DMat2, DVec2};
use postwarp_rtl::{ReferenceWarp, SampleImage};
use serde_json::{Map, Value, json};

/// One warped reference sample (rule 1–2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpedSample {
    /// Derived-image position (derived samples).
    pub pos: DVec2,
    /// Derived 1/Z (1/scene unit), positive.
    pub inv_z: f64,
    /// Jacobian on the sample's surface plane (derived samples per
    /// reference sample); may be non-finite near `W = 0`.
    pub jac: DMat2,
}

/// A reference warped into the derived image (rules 1–2).
#[derive(Clone, Debug)]
pub struct WarpedReference {
    /// Reference width (samples).
    pub width: u32,
    /// Reference height (samples).
    pub height: u32,
    /// Index of the reference in the frame's warp order.
    pub source: u8,
    /// Per reference sample, row-major: `None` = no surface or culled.
    pub samples: Vec<Option<WarpedSample>>,
    /// Reference samples with a surface.
    pub reference_samples: u64,
    /// Of those, culled (behind the derived camera or not finite).
    pub culled_samples: u64,
}

impl WarpedReference {
    /// The warped sample at reference `(x, y)`.
    #[inline(always)]
    pub fn at(&self, x: u32, y: u32) -> Option<&WarpedSample> {
        self.samples[y as usize * self.width as usize + x as usize].as_ref()
    }
}

/// Warp every sample of `img` (reference `source` of the frame, `warp` its
/// command) into the derived sample grid of camera `dst` (rules 1–2).
///
/// # Panics
/// If `img` is not the reference camera's sample-grid size.
pub fn warp_reference(
    warp: &ReferenceWarp,
    dst: &postwarp_rtl::Camera,
    img: &SampleImage,
    source: u8,
) -> WarpedReference {
    let src = warp.reference_camera;
    assert_eq!((img.width, img.height), (src.intrinsics.width, src.intrinsics.height), "reference image size");
    let ctx = WarpContext::new(warp.setup, src, *dst, vec![src.pose.position], 0, 0.0);
    let w = img.width as usize;
    let mut samples = vec![None; img.len()];
    let (mut reference_samples, mut culled_samples) = (0u64, 0u64);
    for i in img.valid.iter_ones() {
        reference_samples += 1;
        let z = img.z[i] as f64;
        let inv_z = 1.0 / z;
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        // `WarpSetup::warp`, operation for operation, inlined.
        let [px, py, iz, pw] = warp_of(&warp.setup, x, y, inv_z);
        let ok =
            z > 0.0 && inv_z.is_finite() && pw > 0.0 && px.is_finite() && py.is_finite() && iz.is_finite() && iz > 0.0;
        if !ok {
            culled_samples += 1;
            continue;
        }
        let jac = ctx.jacobian(x, y, inv_z, img.inv_z_slopes[i]);
        samples[i] = Some(WarpedSample { pos: DVec2::new(px, py), inv_z: iz, jac });
    }
    WarpedReference { width: img.width, height: img.height, source, samples, reference_samples, culled_samples }
}

/// Warp all references of a frame, in warp order.
pub fn warp_frame(input: &crate::methods::Input) -> Vec<WarpedReference> {
    let ss = input.cmd.supersample;
    let dst = input.cmd.derived_camera.sample_grid(ss);
    assert_eq!(input.refs.len(), input.cmd.warps.len(), "one reference image per warp");
    input
        .cmd
        .warps
        .iter()
        .zip(input.refs)
        .enumerate()
        .map(|(j, (warp, img))| warp_reference(warp, &dst, img, j as u8))
        .collect()
}

/// Rule 3: depth-tested write of one fragment into derived sample `k`;
/// returns whether it was written.
#[inline(always)]
pub fn depth_write(d: &mut DestPlanes, k: usize, inv_z: f32, colour: [f32; 3], source: u8) -> bool {
    if d.real[k] && inv_z <= d.inv_z[k] {
        return false;
    }
    d.real.set(k, true);
    d.inv_z[k] = inv_z;
    d.colour[k] = colour;
    d.source[k] = source;
    true
}

/// Half-open window `[lo, lo + n)` of sample centres covering the interval
/// `[a, b)`, clipped to `0..size`: `(first, last)` inclusive, or `None` when
/// empty or not finite.
#[inline(always)]
pub fn centres(a: f64, b: f64, size: u32) -> Option<(u32, u32)> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let lo = ceil(a).max(0.0);
    let hi = (ceil(b) - 1.0).min(size as f64 - 1.0);
    (lo <= hi).then_some((lo as u32, hi as u32))
}

/// Coordinates beyond this are clamped by [`ceil`] and [`floor`] (samples;
/// far outside any image).
const FAR: f64 = 1e9;

/// `f64::ceil` of a finite `v` clamped to ±[`FAR`], without the libm call
/// that `ceil` is on baseline x86-64.
#[inline(always)]
pub fn ceil(v: f64) -> f64 {
    let v = v.clamp(-FAR, FAR);
    let t = v as i64 as f64;
    if t < v { t + 1.0 } else { t }
}

/// `f64::floor` of a finite `v` clamped to ±[`FAR`] (as [`ceil`]).
#[inline(always)]
pub fn floor(v: f64) -> f64 {
    let v = v.clamp(-FAR, FAR);
    let t = v as i64 as f64;
    if t > v { t - 1.0 } else { t }
}

/// The inclusive window of sample centres inside the bounding box of
/// `points`, clipped to a `width x height` image; `None` when empty or not
/// finite.
pub fn window_of(points: &[DVec2], width: u32, height: u32) -> Option<Window> {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let x0 = ceil(lo.x).max(0.0);
    let x1 = floor(hi.x).min(width as f64 - 1.0);
    let y0 = ceil(lo.y).max(0.0);
    let y1 = floor(hi.y).min(height as f64 - 1.0);
    (x0 <= x1 && y0 <= y1).then_some(((x0 as i64, x1 as i64), (y0 as i64, y1 as i64)))
}

/// [`triangle`] whatever the winding (the GPU with face culling off): a
/// triangle of negative winding is drawn with two vertices swapped; the
/// weights passed to `f` are those of the vertices in the order given.
/// Returns whether the winding was negative. Zero or non-finite area
/// covers nothing.
pub fn triangle_any_winding(v: [DVec2; 3], win: Window, mut f: impl FnMut(u32, u32, [f64; 3])) -> bool {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    if e1.x * e2.y - e1.y * e2.x < 0.0 {
        triangle([v[0], v[2], v[1]], win, |x, y, w| f(x, y, [w[0], w[2], w[1]]));
        true
    } else {
        triangle(v, win, f);
        false
    }
}

/// The counters every Smit reconstruction starts its `extra` with:
/// `reference_samples` and `culled_samples` summed over the references.
pub fn warp_counters(warped: &[WarpedReference]) -> Map<String, Value> {
    let (refs, culled) = warped.iter().fold((0, 0), |(a, b), r| (a + r.reference_samples, b + r.culled_samples));
    let mut extra = Map::new();
    extra.insert("reference_samples".into(), json!(refs));
    extra.insert("culled_samples".into(), json!(culled));
    extra
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_and_floor_match_std_in_range() {
        for v in [-3.5, -3.0, -2.9, -0.2, -0.0, 0.0, 0.3, 1.0, 1.000001, 7.99, 1e8 + 0.5, -1e8 - 0.5] {
            assert_eq!(ceil(v), v.ceil(), "{v}");
            assert_eq!(floor(v), v.floor(), "{v}");
        }
        assert_eq!(ceil(1e300), 1e9);
        assert_eq!(floor(-1e300), -1e9);
    }

    #[test]
    fn centres_are_half_open_and_clipped() {
        assert_eq!(centres(0.5, 3.5, 10), Some((1, 3)));
        assert_eq!(centres(1.0, 3.0, 10), Some((1, 2)));
        assert_eq!(centres(-4.0, 2.0, 10), Some((0, 1)));
        assert_eq!(centres(8.2, 20.0, 10), Some((9, 9)));
        assert_eq!(centres(10.0, 12.0, 10), None);
        assert_eq!(centres(-3.0, -1.0, 10), None);
        assert_eq!(centres(f64::NAN, 1.0, 10), None);
        assert_eq!(centres(0.2, 0.9, 10), None);
    }

    #[test]
    fn depth_write_keeps_the_nearer_and_the_first_on_ties() {
        let mut d = DestPlanes::new(2, 1);
        assert!(depth_write(&mut d, 0, 0.5, [1.0; 3], 0));
        assert!(!depth_write(&mut d, 0, 0.5, [0.0; 3], 1), "tie: first stays");
        assert!(!depth_write(&mut d, 0, 0.25, [0.0; 3], 1), "farther loses");
        assert!(depth_write(&mut d, 0, 0.75, [0.5; 3], 1), "nearer wins");
        assert_eq!((d.colour[0], d.source[0], d.inv_z[0]), ([0.5; 3], 1, 0.75));
        assert!(d.real[0] && !d.real[1]);
    }
}
