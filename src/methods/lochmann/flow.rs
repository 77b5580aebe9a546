//! The diffuse flow of seed 004 (Lochmann et al., §3.4 "Diffuse flow"): a
//! backward flow from every derived sample to a reference sample, made by
//! splatting, closed by the 3x3 nearest-to-camera rule and checked by one
//! step of fixed-point iteration (Bowles et al. 2012).
//!
//! Rules:
//! 1. Splat: every reference sample with a surface is projected into the
//!    derived sample grid at its diffuse position and written to the
//!    nearest derived sample with a depth test (nearer wins; on a tie the
//!    earlier reference, then the earlier sample, stays): "all old image
//!    location values are splat to the new flow ... with depth testing".
//! 2. Closing: each derived sample takes the source of the sample nearest
//!    to the camera among the 3x3 around it, itself included ("the flow at
//!    each pixel is replaced by the flow of the pixel that is closest to
//!    the camera in a 3x3 neighborhood").
//! 3. One fixed-point step: from the source `s` of rule 2, `s' = s + ρ·(k −
//!    w(s))` rounded to the nearest sample, where `w` is the warp of a
//!    reference sample into the derived grid and `ρ` the ratio of the
//!    reference's focal length to the derived one; `s'` is kept if it has
//!    a surface and `|w(s') − k| <= `[`FPI_TOLERANCE`] derived samples,
//!    else the derived sample is a hole ("discarding pixels where the
//!    convergence criterion is not satisfied"). The flow's location is
//!    then `s' + ρ·(k − w(s'))` unrounded: the sub-sample point of the
//!    reference the derived sample sees (where a GPU's gather would
//!    sample with filtering).
//!
//! Counters: `splats` (reference samples splatted onto the image),
//! `fpi_rejected` (derived samples rule 3 made holes).

use super::decode::Decoded;
use glam::{DVec2, DVec3};
use postwarp_rtl::Camera;

/// Rule 3's convergence criterion (derived samples, our choice: the paper
/// gives none; one sample keeps every direct splat, whose warped position
/// is within 0.71 of its derived sample).
pub const FPI_TOLERANCE: f64 = 1.0;

/// Where a derived sample's backward flow points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Reference (position in the frame's warp list).
    pub reference: usize,
    /// Reference sample index (the nearest sample to `pos`).
    pub sample: usize,
    /// Sub-sample location in the reference's sample grid.
    pub pos: DVec2,
    /// Depth of its diffuse position in the derived camera.
    pub depth: f64,
}

/// The flow of one frame and its counters.
pub struct Flow {
    /// Per derived sample (row-major), its source or `None` (a hole).
    pub source: Vec<Option<Source>>,
    /// Rule 1's splats.
    pub splats: u64,
    /// Rule 3's rejections.
    pub fpi_rejected: u64,
}

/// The derived sample-grid position and depth of world point `p`.
fn warp(derived: &Camera, p: DVec3) -> Option<(DVec2, f64)> {
    derived.project(p)
}

/// Rules 1–3 for the references `refs` (decoded, warp order) into the
/// `width x height` derived sample grid of `derived`.
pub fn diffuse_flow(refs: &[&Decoded], derived: &Camera, width: u32, height: u32) -> Flow {
    let (w, h) = (width as usize, height as usize);
    let mut splat: Vec<Option<Source>> = vec![None; w * h];
    let mut splats = 0u64;
    for (j, r) in refs.iter().enumerate() {
        for (i, p) in r.diffuse.iter().enumerate() {
            let Some(p) = p else { continue };
            let Some((q, z)) = warp(derived, *p) else { continue };
            let (x, y) = (q.x.round(), q.y.round());
            if !(x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64) {
                continue;
            }
            splats += 1;
            let k = y as usize * w + x as usize;
            if splat[k].is_none_or(|s| z < s.depth) {
                let pos = DVec2::new((i % r.width as usize) as f64, (i / r.width as usize) as f64);
                splat[k] = Some(Source { reference: j, sample: i, pos, depth: z });
            }
        }
    }
    let mut source = vec![None; w * h];
    let mut fpi_rejected = 0u64;
    for y in 0..h {
        for x in 0..w {
            let mut best: Option<Source> = None;
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    if let Some(s) = splat[yy * w + xx] {
                        if best.is_none_or(|b| s.depth < b.depth) {
                            best = Some(s);
                        }
                    }
                }
            }
            let Some(b) = best else { continue };
            let k = DVec2::new(x as f64, y as f64);
            match fixed_point(refs[b.reference], b.sample, derived, k) {
                Some((sample, pos, depth)) => {
                    source[y * w + x] = Some(Source { reference: b.reference, sample, pos, depth });
                }
                None => fpi_rejected += 1,
            }
        }
    }
    Flow { source, splats, fpi_rejected }
}

/// Rule 3 from reference sample `s` toward derived sample position `k`:
/// the kept sample, the sub-sample location and the derived depth.
fn fixed_point(r: &Decoded, s: usize, derived: &Camera, k: DVec2) -> Option<(usize, DVec2, f64)> {
    let w = r.width as usize;
    let (q, _) = warp(derived, r.diffuse[s]?)?;
    let rho = r.camera.intrinsics.fx / derived.intrinsics.fx;
    let next = DVec2::new((s % w) as f64, (s / w) as f64) + (k - q) * rho;
    let (x, y) = (next.x.round(), next.y.round());
    if !(x >= 0.0 && y >= 0.0 && x < r.width as f64 && y < r.height as f64) {
        return None;
    }
    let s2 = y as usize * w + x as usize;
    let (q2, z2) = warp(derived, r.diffuse[s2]?)?;
    let pos = DVec2::new(x, y) + (k - q2) * rho;
    ((q2 - k).length() <= FPI_TOLERANCE).then_some((s2, pos, z2))
}
