//! Transform unit: warps each reference sample into the derived image
//! (`docs/warper-reference.md` §1, §3; TR98 §5–6).
//!
//! Job: per sample, the derived position `(x', y')`, derived 1/Z and `W`
//! (`W <= 0`: behind the derived camera, culled), the expected spacing `E`
//! of the discontinuity test; on request, the derived-image slopes of 1/Z,
//! the exact edge-splat corners and the better-reference mask.
//!
//! Ports: in, one reference sample `(x, y, 1/Z, slopes)` from the fetch
//! unit; out, a [`Transformed`] sample to kernel setup's line buffer.
//!
//! Throughput and latency: `transform_throughput` samples per cycle,
//! `transform_latency` cycles (knobs; the engine models them with a
//! [`crate::fifo::Fifo`]). One pipeline: the warp numerator
//! `N = H·(x, y, 1) + δ·ê` (the incremental form adds a column of `H` per
//! step; this model evaluates the same affine form directly at every sample,
//! which is the incremental form re-seeded at each sample, so the result
//! does not depend on the traversal direction), a reciprocal of `W`, the
//! spacing, the slopes by Cramer's rule, the mask by dot products.
//!
//! Rules:
//! 1. `E = sqrt(r1 / (r2·W²)) · f2/f1`, `r` the squared length of the
//!    sample's viewing ray `((x−cx)/fx, (y−cy)/fy, 1)` in each camera, `f`
//!    the geometric-mean focal length of each sample grid.
//! 2. Edge corner `(sx, sy)` ∈ {±1}²: warp `(x + sx/2, y + sy/2)` with
//!    `1/Z + (sx·∂x + sy·∂y)/2`.
//! 3. Derived slopes `M⁻ᵀ·G/(W·s2)` (`M` the numerator's 2x2 Jacobian part,
//!    `G` the 1/Z gradient numerator), zero when `|det M|/W² < 1e-12` or
//!    not finite.
//! 4. Better mask bit `j`: `(n·v_j)²·|v_own|² > (n·v_own)²·|v_j|²·(1+m)²`,
//!    `n` the world normal from `(fx·∂x, fy·∂y, c0)`, `v` the vectors from
//!    the surface point to the reference centres.
//!
//! Control ([`TransformStage`]): the pipeline is a [`Fifo`] of
//! `transform_throughput · (transform_latency + 1)` slots and latency
//! `transform_latency`. The fetch unit offers samples ([`TransformStage::accept`]);
//! kernel setup takes them out when visible ([`TransformStage::take`]).
//! The stage is *busy* in a cycle in which it accepted a sample, *stalled*
//! (`fifo_full`) in one in which it refused one and accepted none, *idle*
//! otherwise.
//!
//! Fixed mode (`arith = "fixed"`, `docs/fixed-point.md`): the numerator's
//! sums (per-warp constants times fixed-point inputs, in FP64) round to
//! `q_numerator` and `q_denominator`, `1/W` comes from the seed table and
//! Newton–Raphson steps (`qformat` rule 5) in `q_reciprocal`, `x' = N·(1/W)`
//! is an exact product rounded to `q_position`, `1/Z₂` rounds to `q_inv_z`,
//! `E` to `q_slope`, edge corners to `q_corner`. A numerator, denominator
//! or reciprocal that saturates culls the sample like `W ≤ 0` (an edge
//! corner: the sample's own position, counted); a position, 1/Z, `E` or
//! corner that saturates takes the end of its range and is counted
//! ([`Transformed::sat`]).
//!
//! Not modelled: fixed-point arithmetic in float mode (FP64 arithmetic,
//! FP32 storage, as in the golden model, so that the two agree bit for
//! bit); the fixed mode's derived slopes and better mask are FP64 inside
//! (their inputs and the slopes' outputs are rounded).

use super::{Activity, Run, StallReason, Tick, UnitCycles, UnitState};
use crate::camera::{Camera, WarpSetup};
use crate::clock::Cycle;
use crate::fifo::Fifo;
use crate::qformat::FixedFormats;
use glam::{DMat3, DVec2, DVec3};

/// A warped reference sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transformed {
    /// Derived-image position (samples).
    pub pos: DVec2,
    /// Derived 1/Z.
    pub inv_z: f64,
    /// Expected spacing `E` (derived samples per reference step).
    pub e: f64,
    /// Fixed mode: values of this warp that saturated (position, 1/Z, `E`;
    /// counts, 0 in float mode).
    pub sat: u32,
}

/// The transform unit's registers for one reference warp.
#[derive(Clone, Debug)]
pub struct TransformUnit {
    /// Warp parameters (sample grids).
    pub setup: WarpSetup,
    src: Camera,
    dst: Camera,
    centres: Vec<DVec3>,
    this: usize,
    better_margin: f64,
    focal_ratio: f64,
    inv_f_src: (f64, f64),
    inv_f_dst: (f64, f64),
    rot_src: DMat3,
    /// Fixed mode's formats (`None`: float).
    fixed: Option<FixedFormats>,
}

fn geometric_focal(c: &Camera) -> f64 {
    (c.intrinsics.fx * c.intrinsics.fy).sqrt()
}

#[inline(always)]
fn ray_len_sq(dx: f64, dy: f64, inv_f: (f64, f64)) -> f64 {
    let (a, b) = (dx * inv_f.0, dy * inv_f.1);
    a * a + b * b + 1.0
}

impl TransformUnit {
    /// The reference camera (pixels).
    pub fn reference_camera(&self) -> Camera {
        self.src
    }

    /// Load the unit for the warp `setup` from `src` to `dst` (sample
    /// grids); `centres` are all references' centres in warp order, `this`
    /// is ours; `better_margin` as in rule 4.
    pub fn new(
        setup: WarpSetup,
        src: Camera,
        dst: Camera,
        centres: Vec<DVec3>,
        this: usize,
        better_margin: f64,
    ) -> Self {
        TransformUnit {
            setup,
            src,
            dst,
            centres,
            this,
            better_margin,
            focal_ratio: geometric_focal(&dst) / geometric_focal(&src),
            inv_f_src: (1.0 / src.intrinsics.fx, 1.0 / src.intrinsics.fy),
            inv_f_dst: (1.0 / dst.intrinsics.fx, 1.0 / dst.intrinsics.fy),
            rot_src: src.pose.rotation(),
            fixed: None,
        }
    }

    /// The unit in the fixed mode of `fixed` (module doc; `None`: float).
    pub fn with_fixed(mut self, fixed: Option<FixedFormats>) -> Self {
        self.fixed = fixed;
        self
    }

    /// The fixed mode's formats, if any.
    pub fn fixed(&self) -> Option<&FixedFormats> {
        self.fixed.as_ref()
    }

    /// The fixed mode's warp of `(x, y)` with 1/Z `inv_z` (module doc):
    /// the rounded numerator, denominator and reciprocal (`None` if
    /// culled: `W ≤ 0` or one of them saturated), then the position.
    #[inline(never)]
    fn fixed_numerator(&self, f: &FixedFormats, x: f64, y: f64, inv_z: f64) -> Option<(f64, f64, f64, f64, f64)> {
        let s = &self.setup;
        let (h, e) = (&s.h, s.e_hat);
        let delta = s.s1 * inv_z;
        let row = |i: usize| h.x_axis[i] * x + h.y_axis[i] * y + h.z_axis[i] * 1.0 + e[i] * delta;
        let (nx, a) = f.numerator.quantise(row(0));
        let (ny, b) = f.numerator.quantise(row(1));
        let (w, c) = f.denominator.quantise(row(2));
        if a | b | c || w <= 0.0 {
            return None;
        }
        let (rw, d) = f.reciprocal_of(w);
        (!d).then_some((nx, ny, w, rw, delta))
    }

    /// The fixed mode's [`TransformUnit::warp`] (module doc).
    #[inline(never)]
    fn warp_fixed(&self, f: &FixedFormats, x: f64, y: f64, inv_z: f64) -> Option<Transformed> {
        let (nx, ny, w, rw, delta) = self.fixed_numerator(f, x, y, inv_z)?;
        let mut sat = 0;
        let (px, a) = f.position.mul(nx, f.numerator, rw, f.reciprocal);
        let (py, b) = f.position.mul(ny, f.numerator, rw, f.reciprocal);
        sat += a as u32 + b as u32;
        let iz = f.inv_z.q(delta / self.setup.s2 * rw, &mut sat);
        let (ks, kd) = (&self.src.intrinsics, &self.dst.intrinsics);
        let r1 = ray_len_sq(x - ks.cx, y - ks.cy, self.inv_f_src);
        let r2 = ray_len_sq(px - kd.cx, py - kd.cy, self.inv_f_dst);
        let e = f.slope.q((r1 / (r2 * w * w)).sqrt() * self.focal_ratio, &mut sat);
        Some(Transformed { pos: DVec2::new(px, py), inv_z: iz, e, sat })
    }

    /// The fixed mode's edge corner (module doc): the corner, `None` if
    /// behind the camera or its warp saturated, and the saturations.
    #[inline(never)]
    fn edge_corner_fixed(
        &self,
        f: &FixedFormats,
        (x, y, inv_z): (f64, f64, f64),
        slopes: [f32; 2],
        sx: f64,
        sy: f64,
    ) -> (Option<DVec2>, u32) {
        let iz = inv_z + 0.5 * (sx * slopes[0] as f64 + sy * slopes[1] as f64);
        let (cx, cy) = (x + 0.5 * sx, y + 0.5 * sy);
        let s = &self.setup;
        let (h, e) = (&s.h, s.e_hat);
        let delta = s.s1 * iz;
        let row = |i: usize| h.x_axis[i] * cx + h.y_axis[i] * cy + h.z_axis[i] * 1.0 + e[i] * delta;
        let (nx, a) = f.numerator.quantise(row(0));
        let (ny, b) = f.numerator.quantise(row(1));
        let (w, c) = f.denominator.quantise(row(2));
        if w <= 0.0 {
            return (None, 0);
        }
        if a | b | c {
            return (None, 1);
        }
        let (rw, d) = f.reciprocal_of(w);
        if d {
            return (None, 1);
        }
        let (px, a) = f.corner.mul(nx, f.numerator, rw, f.reciprocal);
        let (py, b) = f.corner.mul(ny, f.numerator, rw, f.reciprocal);
        (Some(DVec2::new(px, py)), a as u32 + b as u32)
    }

    /// Exact edge corner `(sx, sy)` (rule 2) in either mode, and the fixed
    /// mode's saturations; `None` if behind the camera (or, fixed, its
    /// warp saturated).
    #[inline(always)]
    pub fn edge_corner_counted(
        &self,
        x: f64,
        y: f64,
        inv_z: f64,
        slopes: [f32; 2],
        sx: f64,
        sy: f64,
    ) -> (Option<DVec2>, u32) {
        match &self.fixed {
            None => (self.edge_corner(x, y, inv_z, slopes, sx, sy), 0),
            Some(f) => self.edge_corner_fixed(f, (x, y, inv_z), slopes, sx, sy),
        }
    }

    /// Warp sample `(x, y)` with 1/Z `inv_z`; `None` if culled (behind the
    /// derived camera or not finite).
    #[inline(always)]
    pub fn warp(&self, x: f64, y: f64, inv_z: f64) -> Option<Transformed> {
        if let Some(f) = &self.fixed {
            return self.warp_fixed(f, x, y, inv_z);
        }
        let w = self.setup.warp(x, y, inv_z);
        if !(w.w > 0.0 && w.position.is_finite() && w.inv_z.is_finite()) {
            return None;
        }
        let (ks, kd) = (&self.src.intrinsics, &self.dst.intrinsics);
        let r1 = ray_len_sq(x - ks.cx, y - ks.cy, self.inv_f_src);
        let r2 = ray_len_sq(w.position.x - kd.cx, w.position.y - kd.cy, self.inv_f_dst);
        let e = (r1 / (r2 * w.w * w.w)).sqrt() * self.focal_ratio;
        Some(Transformed { pos: w.position, inv_z: w.inv_z, e, sat: 0 })
    }

    /// [`TransformUnit::warp`] of the run of samples `(x0 + k·dx, y0 +
    /// k·dy)` with 1/Z `inv_z(k)`, `k < out.len()`: `out[k]` is the warp or
    /// `None` where culled. The same operations as [`WarpSetup::warp`] in
    /// the same order (the same bits; tested), without branches in the
    /// arithmetic, so that the loop pipelines: the transform unit is one
    /// pipeline streaming a line.
    #[inline]
    pub fn warp_run(
        &self,
        (x0, y0): (f64, f64),
        (dx, dy): (f64, f64),
        inv_z: impl Fn(usize) -> f64,
        out: &mut [Option<Transformed>],
    ) {
        if let Some(f) = &self.fixed {
            for (k, o) in out.iter_mut().enumerate() {
                *o = self.warp_fixed(f, x0 + k as f64 * dx, y0 + k as f64 * dy, inv_z(k));
            }
            return;
        }
        let s = &self.setup;
        let (h, e) = (&s.h, s.e_hat);
        let (ks, kd) = (&self.src.intrinsics, &self.dst.intrinsics);
        for (k, o) in out.iter_mut().enumerate() {
            let (x, y) = (x0 + k as f64 * dx, y0 + k as f64 * dy);
            let delta = s.s1 * inv_z(k);
            // glam's DMat3 · DVec3: x_axis·x + y_axis·y + z_axis·1, then + ê·δ.
            let row = |i: usize| h.x_axis[i] * x + h.y_axis[i] * y + h.z_axis[i] * 1.0 + e[i] * delta;
            let (nx, ny, w) = (row(0), row(1), row(2));
            let (px, py, iz) = (nx / w, ny / w, delta / (s.s2 * w));
            let ok = (w > 0.0) & px.is_finite() & py.is_finite() & iz.is_finite();
            let r1 = ray_len_sq(x - ks.cx, y - ks.cy, self.inv_f_src);
            let r2 = ray_len_sq(px - kd.cx, py - kd.cy, self.inv_f_dst);
            let e = (r1 / (r2 * w * w)).sqrt() * self.focal_ratio;
            *o = ok.then_some(Transformed { pos: DVec2::new(px, py), inv_z: iz, e, sat: 0 });
        }
    }

    /// Exact edge corner `(sx, sy)` (rule 2); `None` if behind the camera.
    #[inline]
    pub fn edge_corner(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2], sx: f64, sy: f64) -> Option<DVec2> {
        let iz = inv_z + 0.5 * (sx * slopes[0] as f64 + sy * slopes[1] as f64);
        let w = self.setup.warp(x + 0.5 * sx, y + 0.5 * sy, iz);
        (w.w > 0.0 && w.position.is_finite()).then_some(w.position)
    }

    /// Derived-image slopes of 1/Z (rule 3).
    #[inline]
    pub fn dest_slopes(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> [f64; 2] {
        let s = &self.setup;
        let d = s.s1 * inv_z;
        let (dx, dy) = (s.s1 * slopes[0] as f64, s.s1 * slopes[1] as f64);
        let n = s.h * DVec3::new(x, y, 1.0) + s.e_hat * d;
        let nx = s.h.x_axis + s.e_hat * dx;
        let ny = s.h.y_axis + s.e_hat * dy;
        let w = n.z;
        let inv_w = 1.0 / w;
        let (xp, yp) = (n.x * inv_w, n.y * inv_w);
        let (m00, m01) = (nx.x - xp * nx.z, ny.x - xp * ny.z);
        let (m10, m11) = (nx.y - yp * nx.z, ny.y - yp * ny.z);
        let (gx, gy) = (dx * w - d * nx.z, dy * w - d * ny.z);
        let det = m00 * m11 - m01 * m10;
        if !det.is_finite() || det.abs() < 1e-12 * w * w {
            return [0.0, 0.0];
        }
        let k = 1.0 / (det * w * s.s2);
        let v = [(gx * m11 - m10 * gy) * k, (m00 * gy - m01 * gx) * k];
        if v[0].is_finite() && v[1].is_finite() { v } else { [0.0, 0.0] }
    }

    /// Better-reference mask (rule 4).
    #[inline]
    pub fn better_mask(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> u32 {
        let k = &self.src.intrinsics;
        let (xn, yn) = ((x - k.cx) / k.fx, (y - k.cy) / k.fy);
        let a = k.fx * slopes[0] as f64;
        let b = k.fy * slopes[1] as f64;
        let c0 = inv_z - a * xn - b * yn;
        let n = self.rot_src * DVec3::new(a, b, c0);
        if n == DVec3::ZERO || !n.is_finite() {
            return 0;
        }
        let p = self.src.pose.position + self.rot_src * DVec3::new(xn, yn, 1.0) / inv_z;
        let v_own = self.centres[self.this] - p;
        let (dot_own, len_own) = (n.dot(v_own), v_own.length_squared());
        let m = (1.0 + self.better_margin) * (1.0 + self.better_margin);
        let mut mask = 0;
        for (j, &c) in self.centres.iter().enumerate() {
            let v = c - p;
            let dot = n.dot(v);
            if j != self.this && dot * dot * len_own > dot_own * dot_own * v.length_squared() * m {
                mask |= 1 << j;
            }
        }
        mask
    }
}

/// A sample in the transform pipeline: its grid index (the reference's
/// host layout) and the fetch interval it belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InFlightSample {
    /// Grid index of the sample (`HwReference`'s layout).
    pub grid_index: u32,
    /// Index of its fetch interval in the schedule.
    pub interval: u32,
}

/// The transform unit's pipeline control for one warp (module doc).
pub struct TransformStage {
    pipe: Fifo<InFlightSample>,
    /// Per sample (grid index): accepted in this warp.
    transformed: Vec<u64>,
    accepted: u32,
    refused: bool,
    samples: u64,
    activity: Activity,
}

impl TransformStage {
    /// A pipeline of `throughput` lanes and `latency` cycles over a
    /// reference whose grid has `grid_len` samples, accounted by `activity`.
    pub fn new(throughput: u32, latency: u32, grid_len: usize, activity: Activity) -> TransformStage {
        let slots = throughput as usize * (latency as usize + 1);
        TransformStage {
            pipe: Fifo::new(slots, latency as u64),
            transformed: vec![0; grid_len.div_ceil(64)],
            accepted: 0,
            refused: false,
            samples: 0,
            activity,
        }
    }

    /// Offer a sample at `now`: accepted unless the pipeline is full (the
    /// sample is then handed back and the fetch unit stalls).
    #[inline]
    pub fn accept(&mut self, now: Cycle, s: InFlightSample) -> Result<(), InFlightSample> {
        match self.pipe.push(now, s) {
            Ok(()) => {
                let i = s.grid_index as usize;
                self.transformed[i >> 6] |= 1 << (i & 63);
                self.accepted += 1;
                self.samples += 1;
                Ok(())
            }
            Err(s) => {
                self.refused = true;
                Err(s)
            }
        }
    }

    /// Take the oldest sample whose transform is done at `now`.
    #[inline]
    pub fn take(&mut self, now: Cycle) -> Option<InFlightSample> {
        self.pipe.pop(now)
    }

    /// The interval of the oldest sample still in the pipeline.
    #[inline]
    pub fn oldest_interval(&self) -> Option<usize> {
        self.pipe.oldest().map(|s| s.interval as usize)
    }

    /// True if sample `grid_index` was accepted in this warp.
    #[inline(always)]
    pub fn has_transformed(&self, grid_index: usize) -> bool {
        self.transformed[grid_index >> 6] >> (grid_index & 63) & 1 != 0
    }

    /// The accepted bits of grid word `w` (one 8x8 tile of the
    /// reference's host layout).
    #[inline(always)]
    pub(crate) fn transformed_word(&self, w: usize) -> u64 {
        self.transformed[w]
    }

    /// The stage's state in cycle `now`, after the fetch unit's offers of
    /// that cycle.
    #[inline]
    pub fn tick(&mut self, now: Cycle) -> Tick {
        let t = if self.accepted > 0 {
            Tick::BUSY
        } else if self.refused {
            Tick::stall(StallReason::FifoFull)
        } else {
            Tick::IDLE
        };
        self.accepted = 0;
        self.refused = false;
        self.activity.record(now, t)
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }

    /// State of the last tick.
    pub fn state(&self) -> UnitState {
        self.activity.state()
    }

    /// Samples accepted in this warp (samples).
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// No sample in the pipeline.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pipe.is_empty()
    }

    /// Samples in the pipeline.
    pub fn len(&self) -> usize {
        self.pipe.len()
    }

    /// When the oldest sample becomes visible.
    #[inline]
    pub fn next_visible(&self) -> Option<Cycle> {
        self.pipe.next_visible()
    }

    /// The first cycle after `now` at which a sample in flight completes.
    #[inline]
    pub fn next_visible_after(&self, now: Cycle) -> Option<Cycle> {
        self.pipe.next_visible_after(now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Pose};
    use glam::DQuat;

    #[test]
    fn a_run_warps_to_the_same_bits_as_one_sample_at_a_time() {
        let k = Intrinsics { width: 64, height: 48, fx: 50.0, fy: 51.0, cx: 31.5, cy: 23.5 };
        let src = Camera { intrinsics: k, pose: Pose { position: DVec3::ZERO, orientation: DQuat::IDENTITY } };
        let dst = Camera {
            intrinsics: k,
            pose: Pose { position: DVec3::new(0.3, -0.1, 0.2), orientation: DQuat::from_rotation_y(0.2) },
        };
        let tu = TransformUnit::new(WarpSetup::new(&src, &dst), src, dst, vec![DVec3::ZERO], 0, 0.05);
        let inv_z = |k: usize| if k % 7 == 3 { -2.0 } else { 0.1 + 0.37 * k as f64 };
        for (start, step) in [((0.0, 5.0), (1.0, 0.0)), ((9.0, 40.0), (0.0, -1.0))] {
            let mut out = [None; 40];
            tu.warp_run(start, step, inv_z, &mut out);
            for (j, o) in out.iter().enumerate() {
                let (x, y) = (start.0 + j as f64 * step.0, start.1 + j as f64 * step.1);
                assert_eq!(*o, tu.warp(x, y, inv_z(j)), "sample {j}");
            }
            assert!(out.iter().any(Option::is_none) && out.iter().any(Option::is_some));
        }
    }
}
