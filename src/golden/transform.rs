//! Transform: warp each reference sample into the derived image
//! (`docs/warper-reference.md` §1, §3), in double precision.
//!
//! Per sample: the warped position (x', y'), derived 1/Z and `W`
//! (`W <= 0`: behind the derived camera, culled); the expected spacing `E`
//! of the discontinuity test; the derived-image slopes of 1/Z (plane 3);
//! the exact edge-splat corners; the "better reference" bit-mask; the
//! forward-edge neighbour; the warp's Jacobian and footprint (general path).
//!
//! Rules:
//! 1. `E = (|P1·x̄1| · f2) / (W · |P2·x̄2| · f1)` with `f` the geometric
//!    mean focal length of each sample grid: the derived-image distance of
//!    one reference sample step on a surface facing the reference centre
//!    (`docs/warper-reference.md` §3 for equal intrinsics).
//! 2. Edge corner `(sx, sy)` ∈ {±1}²: warp `(x + sx/2, y + sy/2)` with
//!    `1/Z + (sx·∂x + sy·∂y)/2`: exact for planar surfaces.
//! 3. Derived slopes `∇2(1/Z2) = J⁻ᵀ·g` (J the warp's Jacobian, g the
//!    reference-space gradient of 1/Z2); zero when J is singular.
//! 4. Better mask: bit `j` is set iff reference `j` sees the surface less
//!    obliquely: `|n·r̂_j| > |n·r̂_self|·(1 + margin)`, with `n` the normal
//!    `(a, b, c0)` from the slopes and `r̂` the unit vector to a centre.
//! 5. Forward-edge neighbour: the 8-neighbour nearest the direction `−D(p)`
//!    (the inverse occlusion-compatible direction in the reference).
//! 6. Jacobian `J = ∂(x', y')/∂(x, y)` of the warp restricted to the
//!    sample's surface plane (1/Z1 moving with the reference slopes), and
//!    the *footprint* `|det J|`: the derived-image area (derived samples)
//!    covered by one reference sample, i.e. the inverse of the density of
//!    warped samples (TR98 §7.1 "poorly sampled": density below 1/2, that
//!    is footprint above 2). Infinite when J is not finite.
//!
//! Fixed mode (`arith = "fixed"`, `docs/fixed-point.md`; the golden
//! model's own code for the hardware's rules): the numerator's sums
//! (per-warp constants times fixed-point inputs, in FP64) round to
//! `q_numerator`/`q_denominator`, `1/W` is the seed table and
//! Newton–Raphson reciprocal in `q_reciprocal` (`qformat` rule 5),
//! `x' = N·(1/W)` an exact product rounded to `q_position`, `1/Z₂` to
//! `q_inv_z`, `E` to `q_slope`, edge corners to `q_corner`. A numerator,
//! denominator or reciprocal that saturates culls the sample (an edge
//! corner: the sample's own position, counted); a position, 1/Z, `E` or
//! corner that saturates takes the end of its range, counted
//! ([`Transformed::sat`]).
//!
//! Not modelled: fixed-point datapaths in float mode (FP64 here, stored as
//! FP32); in fixed mode the derived slopes, Jacobian and better mask are
//! FP64 inside.

use glam::{DMat2, DMat3, DVec2, DVec3};
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::qformat::FixedFormats;
use postwarp_rtl::{Camera, WarpSetup};

/// A warped sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transformed {
    /// Derived-image position (samples).
    pub pos: DVec2,
    /// Derived 1/Z.
    pub inv_z: f64,
    /// Expected spacing `E` (derived samples per reference sample step).
    pub e: f64,
    /// Fixed mode: values of this warp that saturated (position, 1/Z,
    /// `E`; counts, 0 in float mode).
    pub sat: u32,
}

/// Everything the transform needs for one reference warp.
#[derive(Clone, Debug)]
pub struct WarpContext {
    /// Warp parameters (sample grids).
    pub setup: WarpSetup,
    /// Reference camera (sample grid).
    pub src: Camera,
    /// Derived camera (sample grid).
    pub dst: Camera,
    /// Centres of every reference of the frame, in warp order.
    pub centres: Vec<DVec3>,
    /// Index of this reference in the warp order.
    pub this: usize,
    /// Margin of the better-reference test (fraction).
    pub better_margin: f64,
    /// Focal-length ratio (geometric means) derived / reference sample grid.
    focal_ratio: f64,
    /// Reciprocal focal lengths of the reference and derived sample grids.
    inv_f_src: (f64, f64),
    inv_f_dst: (f64, f64),
    /// Reference camera-to-world rotation as a matrix.
    rot_src: DMat3,
    /// The fixed mode's formats (`None`: float).
    fixed: Option<FixedFormats>,
}

fn focal(c: &Camera) -> f64 {
    (c.intrinsics.fx * c.intrinsics.fy).sqrt()
}

/// Samples per call of the batch functions (`*_batch`) at most.
pub const BATCH: usize = 256;

/// Squared length of the ray `((x−cx)/fx, (y−cy)/fy, 1)` from offsets to
/// the principal point and reciprocal focal lengths.
#[inline(always)]
fn ray_len_sq(dx: f64, dy: f64, inv_f: (f64, f64)) -> f64 {
    let (a, b) = (dx * inv_f.0, dy * inv_f.1);
    a * a + b * b + 1.0
}

/// The warp's numerator `N = H·(x, y, 1) + δ·ê`, in glam's order of
/// operations: `(H.x_axis·x + H.y_axis·y) + H.z_axis·1`, then `+ ê·δ`.
#[inline(always)]
fn numerator_of(s: &WarpSetup, x: f64, y: f64, delta: f64) -> [f64; 3] {
    let (h, e) = (&s.h, s.e_hat);
    let row = |k: usize| h.x_axis[k] * x + h.y_axis[k] * y + h.z_axis[k] * 1.0 + e[k] * delta;
    [row(0), row(1), row(2)]
}

/// [`WarpSetup::warp`] operation for operation (the same bits; tested), here
/// so that the batch loops can inline it: `(x', y', 1/Z2, W)`.
#[inline(always)]
pub fn warp_of(s: &WarpSetup, x: f64, y: f64, inv_z: f64) -> [f64; 4] {
    let delta = s.s1 * inv_z;
    let [nx, ny, w] = numerator_of(s, x, y, delta);
    [nx / w, ny / w, delta / (s.s2 * w), w]
}

impl WarpContext {
    /// The context of the warp `setup` from `src` to `dst` (sample grids);
    /// `centres` are all references' centres in warp order, `this` is ours.
    pub fn new(
        setup: WarpSetup,
        src: Camera,
        dst: Camera,
        centres: Vec<DVec3>,
        this: usize,
        better_margin: f64,
    ) -> Self {
        WarpContext {
            setup,
            src,
            dst,
            centres,
            this,
            better_margin,
            focal_ratio: focal(&dst) / focal(&src),
            inv_f_src: (1.0 / src.intrinsics.fx, 1.0 / src.intrinsics.fy),
            inv_f_dst: (1.0 / dst.intrinsics.fx, 1.0 / dst.intrinsics.fy),
            rot_src: src.pose.rotation(),
            fixed: None,
        }
    }

    /// The context in the fixed mode of `fixed` (module doc; `None`: float).
    pub fn with_fixed(mut self, fixed: Option<FixedFormats>) -> Self {
        self.fixed = fixed;
        self
    }

    /// The fixed mode's formats, if any.
    pub fn fixed(&self) -> Option<&FixedFormats> {
        self.fixed.as_ref()
    }

    /// Warp sample `(x, y)` with 1/Z `inv_z`; `None` if behind the derived
    /// camera or not finite.
    pub fn transform(&self, x: f64, y: f64, inv_z: f64) -> Option<Transformed> {
        if let Some(f) = &self.fixed {
            return fixed_transform(self, f, x, y, inv_z);
        }
        let ([px, py, iz, e], ok) = self.transform_of(x, y, inv_z);
        ok.then(|| Transformed { pos: DVec2::new(px, py), inv_z: iz, e, sat: 0 })
    }

    /// [`WarpContext::transform_batch`] in the fixed mode: `sat[k]` gets
    /// the saturations of sample `k` (module doc).
    #[inline(always)]
    pub fn transform_batch_fixed(
        &self,
        x0: f64,
        y: f64,
        inv_z: &[f64],
        out: &mut [[f64; 4]],
        ok: &mut [bool],
        sat: &mut [u32],
    ) {
        let Some(f) = &self.fixed else { return self.transform_batch(x0, y, inv_z, out, ok) };
        let n = out.len().min(BATCH);
        for k in 0..n {
            match fixed_transform(self, f, x0 + k as f64, y, inv_z[k]) {
                Some(t) => (out[k], ok[k], sat[k]) = ([t.pos.x, t.pos.y, t.inv_z, t.e], true, t.sat),
                None => (ok[k], sat[k]) = (false, 0),
            }
        }
    }

    /// Exact edge corner in either mode, with the fixed mode's saturations
    /// (module doc); `None` if behind the camera (or its fixed warp saturated).
    pub fn edge_corner_counted(
        &self,
        x: f64,
        y: f64,
        inv_z: f64,
        slopes: [f32; 2],
        sx: f64,
        sy: f64,
    ) -> (Option<DVec2>, u32) {
        let Some(f) = &self.fixed else { return (self.edge_corner(x, y, inv_z, slopes, sx, sy), 0) };
        let iz = inv_z + 0.5 * (sx * slopes[0] as f64 + sy * slopes[1] as f64);
        let Some((nx, ny, _, rw, _)) = fixed_numerator(self, f, x + 0.5 * sx, y + 0.5 * sy, iz) else {
            return (None, 0);
        };
        let (Some(nx), Some(ny), Some(rw)) = (nx, ny, rw) else { return (None, 1) };
        let (px, a) = f.corner.mul(nx, f.numerator, rw, f.reciprocal);
        let (py, b) = f.corner.mul(ny, f.numerator, rw, f.reciprocal);
        (Some(DVec2::new(px, py)), a as u32 + b as u32)
    }

    /// [`WarpContext::transform`] of the samples `(x0 + k, y)` with 1/Z
    /// `inv_z[k]`, `k < out.len() <= BATCH`: `out[k]` is `(x', y', 1/Z2, E)`,
    /// valid where `ok[k]`. Branch-free, so that the loop vectorises.
    #[inline(always)]
    pub fn transform_batch(&self, x0: f64, y: f64, inv_z: &[f64], out: &mut [[f64; 4]], ok: &mut [bool]) {
        let n = out.len().min(BATCH);
        let (inv_z, ok) = (&inv_z[..n], &mut ok[..n]);
        for k in 0..n {
            (out[k], ok[k]) = self.transform_of(x0 + k as f64, y, inv_z[k]);
        }
    }

    #[inline(always)]
    fn transform_of(&self, x: f64, y: f64, inv_z: f64) -> ([f64; 4], bool) {
        let [px, py, iz, w] = warp_of(&self.setup, x, y, inv_z);
        let ok = (w > 0.0) & px.is_finite() & py.is_finite() & iz.is_finite();
        let (ks, kd) = (&self.src.intrinsics, &self.dst.intrinsics);
        let r1 = ray_len_sq(x - ks.cx, y - ks.cy, self.inv_f_src);
        let r2 = ray_len_sq(px - kd.cx, py - kd.cy, self.inv_f_dst);
        let e = (r1 / (r2 * w * w)).sqrt() * self.focal_ratio;
        ([px, py, iz, e], ok)
    }

    /// Exact edge-splat corner `(sx, sy)` of a sample (rule 2).
    pub fn edge_corner(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2], sx: f64, sy: f64) -> Option<DVec2> {
        let iz = inv_z + 0.5 * (sx * slopes[0] as f64 + sy * slopes[1] as f64);
        let w = self.setup.warp(x + 0.5 * sx, y + 0.5 * sy, iz);
        (w.w > 0.0 && w.position.is_finite()).then_some(w.position)
    }

    /// The warp's Jacobian on the sample's surface plane (rule 6) and the
    /// reference-space gradient `g` of the derived 1/Z (rule 3).
    /// The warp's numerator `N`, its derivatives along reference x and y,
    /// and the disparity `δ` with its slopes, at a sample.
    fn numerator(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> (DVec3, DVec3, DVec3, [f64; 3]) {
        let s = &self.setup;
        let d = s.s1 * inv_z;
        let (dx, dy) = (s.s1 * slopes[0] as f64, s.s1 * slopes[1] as f64);
        let n = s.h * DVec3::new(x, y, 1.0) + s.e_hat * d;
        let nx = s.h.x_axis + s.e_hat * dx;
        let ny = s.h.y_axis + s.e_hat * dy;
        (n, nx, ny, [d, dx, dy])
    }

    fn local(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> (DMat2, DVec2) {
        let (n, nx, ny, [d, dx, dy]) = self.numerator(x, y, inv_z, slopes);
        let w = n.z;
        let (xp, yp) = (n.x / w, n.y / w);
        let j = DMat2::from_cols(
            DVec2::new((nx.x - xp * nx.z) / w, (nx.y - yp * nx.z) / w),
            DVec2::new((ny.x - xp * ny.z) / w, (ny.y - yp * ny.z) / w),
        );
        let g = DVec2::new((dx * w - d * nx.z) / (w * w), (dy * w - d * ny.z) / (w * w)) / self.setup.s2;
        (j, g)
    }

    /// Jacobian `∂(x', y')/∂(x, y)` of the warp on the sample's surface
    /// plane (rule 6): column `k` is the derived-image step of one reference
    /// sample step along axis `k`.
    pub fn jacobian(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> DMat2 {
        self.local(x, y, inv_z, slopes).0
    }

    /// Footprint `|det J|` (rule 6): derived samples covered by one
    /// reference sample; `f64::INFINITY` when J is not finite.
    pub fn footprint(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> f64 {
        let det = self.jacobian(x, y, inv_z, slopes).determinant().abs();
        if det.is_finite() { det } else { f64::INFINITY }
    }

    /// Derived-image slopes of 1/Z (rule 3). With `J = M/W` and the
    /// reference-space gradient `g = G/(W²·s2)`, `J⁻ᵀ·g = M⁻ᵀ·G/(W·s2)`,
    /// solved by Cramer's rule with a single division.
    pub fn dest_slopes(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> [f64; 2] {
        self.dest_slopes_of(x, y, inv_z, slopes[0] as f64, slopes[1] as f64)
    }

    /// [`WarpContext::dest_slopes`] of the samples `s[k]`, `k < out.len() <=
    /// BATCH`, into `out[k]`. Branch-free, so that the loop vectorises.
    #[inline(always)]
    pub fn dest_slopes_batch(&self, s: &SampleBatch, out: &mut [[f64; 2]]) {
        let n = out.len().min(BATCH);
        let (x, y, inv_z, sx, sy) = (&s.x[..n], &s.y[..n], &s.inv_z[..n], &s.sx[..n], &s.sy[..n]);
        for k in 0..n {
            out[k] = self.dest_slopes_of(x[k], y[k], inv_z[k], sx[k], sy[k]);
        }
    }

    #[inline(always)]
    fn dest_slopes_of(&self, x: f64, y: f64, inv_z: f64, sx: f64, sy: f64) -> [f64; 2] {
        // The same numerator as `numerator` below.
        let s = &self.setup;
        let d = s.s1 * inv_z;
        let (dx, dy) = (s.s1 * sx, s.s1 * sy);
        let n = numerator_of(s, x, y, d);
        let nx: [f64; 3] = std::array::from_fn(|k| s.h.x_axis[k] + s.e_hat[k] * dx);
        let ny: [f64; 3] = std::array::from_fn(|k| s.h.y_axis[k] + s.e_hat[k] * dy);
        let w = n[2];
        let inv_w = 1.0 / w;
        let (xp, yp) = (n[0] * inv_w, n[1] * inv_w);
        let (m00, m01) = (nx[0] - xp * nx[2], ny[0] - xp * ny[2]);
        let (m10, m11) = (nx[1] - yp * nx[2], ny[1] - yp * ny[2]);
        let (gx, gy) = (dx * w - d * nx[2], dy * w - d * ny[2]);
        let det = m00 * m11 - m01 * m10;
        // |det J| = |det M|/W² below 1e-12: singular (edge-on), no slopes.
        let singular = !det.is_finite() | (det.abs() < 1e-12 * w * w);
        let k = 1.0 / (det * w * s.s2);
        let v = [(gx * m11 - m10 * gy) * k, (m00 * gy - m01 * gx) * k];
        let ok = !singular & v[0].is_finite() & v[1].is_finite();
        if ok { v } else { [0.0, 0.0] }
    }

    /// Better-reference bit-mask (rule 4).
    pub fn better_mask(&self, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> u32 {
        let v = self.view_of(x, y, inv_z, slopes[0] as f64, slopes[1] as f64);
        if v.none {
            return 0;
        }
        let m = self.margin_sq();
        let mut mask = 0;
        for (j, &c) in self.centres.iter().enumerate() {
            if j != self.this && better_of(&v, c, m) {
                mask |= 1 << j;
            }
        }
        mask
    }

    /// [`WarpContext::better_mask`] of the samples `s[k]`, `k < out.len() <=
    /// BATCH`, into `out[k]`: the per-sample part, then one centre at a time
    /// over the batch. Branch-free, so that the loops vectorise.
    #[inline(always)]
    pub fn better_mask_batch(&self, s: &mut SampleBatch, out: &mut [u32]) {
        let n = out.len().min(BATCH);
        let out = &mut out[..n];
        // The views, one array per term (so that the loops vectorise).
        let w = &mut s.work;
        for k in 0..n {
            let v = self.view_of(s.x[k], s.y[k], s.inv_z[k], s.sx[k], s.sy[k]);
            for c in 0..3 {
                w.n[c][k] = v.n[c];
                w.p[c][k] = v.p[c];
            }
            (w.dot_own[k], w.len_own[k], w.none[k]) = (v.dot_own, v.len_own, v.none);
        }
        out.fill(0);
        let m = self.margin_sq();
        for (j, &c) in self.centres.iter().enumerate() {
            if j != self.this {
                for (k, o) in out.iter_mut().enumerate() {
                    let v = View {
                        n: [w.n[0][k], w.n[1][k], w.n[2][k]],
                        p: [w.p[0][k], w.p[1][k], w.p[2][k]],
                        dot_own: w.dot_own[k],
                        len_own: w.len_own[k],
                        none: false,
                    };
                    *o |= (better_of(&v, c, m) as u32) << j;
                }
            }
        }
        for (o, &none) in out.iter_mut().zip(&w.none) {
            *o = if none { 0 } else { *o };
        }
    }

    /// `(1 + margin)²`.
    fn margin_sq(&self) -> f64 {
        (1.0 + self.better_margin) * (1.0 + self.better_margin)
    }

    /// The per-sample part of rule 4: the surface normal `n = R·(a, b, c0)`
    /// from the slopes, the surface point `p`, and the terms of its own
    /// reference's view ray (glam's order of operations throughout).
    #[inline(always)]
    fn view_of(&self, x: f64, y: f64, inv_z: f64, sx: f64, sy: f64) -> View {
        let k = &self.src.intrinsics;
        let (xn, yn) = ((x - k.cx) / k.fx, (y - k.cy) / k.fy);
        let a = k.fx * sx;
        let b = k.fy * sy;
        let c0 = inv_z - a * xn - b * yn;
        // glam's R·v: (R.x_axis·v.x + R.y_axis·v.y) + R.z_axis·v.z.
        let r = &self.rot_src;
        let rot = |v: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|i| r.x_axis[i] * v[0] + r.y_axis[i] * v[1] + r.z_axis[i] * v[2])
        };
        let n = rot([a, b, c0]);
        let none =
            (n[0] == 0.0) & (n[1] == 0.0) & (n[2] == 0.0) | !(n[0].is_finite() & n[1].is_finite() & n[2].is_finite());
        let q = rot([xn, yn, 1.0]);
        let o = self.src.pose.position;
        let p = [o.x + q[0] / inv_z, o.y + q[1] / inv_z, o.z + q[2] / inv_z];
        let v_own = to_centre(p, self.centres[self.this]);
        View { n, p, dot_own: dot(n, v_own), len_own: dot(v_own, v_own), none }
    }
}

/// The fixed mode's numerator of the warp of `(x, y)` with 1/Z `inv_z`:
/// `None` if `W ≤ 0` (behind the camera); else `N.x`, `N.y` (`None` where
/// saturated), `W`, `1/W` (`None` if `W` or its reciprocal saturated) and `δ`.
#[allow(clippy::type_complexity)]
#[inline]
fn fixed_numerator(
    c: &WarpContext,
    f: &FixedFormats,
    x: f64,
    y: f64,
    inv_z: f64,
) -> Option<(Option<f64>, Option<f64>, f64, Option<f64>, f64)> {
    let s = &c.setup;
    let delta = s.s1 * inv_z;
    let [n0, n1, n2] = numerator_of(s, x, y, delta);
    let (w, ws) = f.denominator.quantise(n2);
    if w <= 0.0 {
        return None;
    }
    let (nx, a) = f.numerator.quantise(n0);
    let (ny, b) = f.numerator.quantise(n1);
    let (rw, d) = f.reciprocal_of(w);
    Some(((!a).then_some(nx), (!b).then_some(ny), w, (!(ws | d)).then_some(rw), delta))
}

/// The fixed mode's warp of one sample (module doc).
#[inline]
fn fixed_transform(c: &WarpContext, f: &FixedFormats, x: f64, y: f64, inv_z: f64) -> Option<Transformed> {
    let (Some(nx), Some(ny), w, Some(rw), delta) = fixed_numerator(c, f, x, y, inv_z)? else { return None };
    let mut sat = 0;
    let (px, a) = f.position.mul(nx, f.numerator, rw, f.reciprocal);
    let (py, b) = f.position.mul(ny, f.numerator, rw, f.reciprocal);
    sat += a as u32 + b as u32;
    let iz = f.inv_z.q(delta / c.setup.s2 * rw, &mut sat);
    let (ks, kd) = (&c.src.intrinsics, &c.dst.intrinsics);
    let r1 = ray_len_sq(x - ks.cx, y - ks.cy, c.inv_f_src);
    let r2 = ray_len_sq(px - kd.cx, py - kd.cy, c.inv_f_dst);
    let e = f.slope.q((r1 / (r2 * w * w)).sqrt() * c.focal_ratio, &mut sat);
    Some(Transformed { pos: DVec2::new(px, py), inv_z: iz, e, sat })
}

/// A sample's view terms for rule 4 ([`WarpContext::view_of`]).
#[derive(Clone, Copy, Debug)]
struct View {
    n: [f64; 3],
    p: [f64; 3],
    dot_own: f64,
    len_own: f64,
    /// The normal is zero or not finite: the mask is 0.
    none: bool,
}

/// Reference sample batch for the `*_batch` functions: position, 1/Z and
/// slopes of 1/Z (widened to `f64`) of up to [`BATCH`] samples.
#[derive(Clone, Debug)]
pub struct SampleBatch {
    /// Reference x (samples).
    pub x: [f64; BATCH],
    /// Reference y (samples).
    pub y: [f64; BATCH],
    /// Reference 1/Z.
    pub inv_z: [f64; BATCH],
    /// ∂(1/Z)/∂x in the reference.
    pub sx: [f64; BATCH],
    /// ∂(1/Z)/∂y in the reference.
    pub sy: [f64; BATCH],
    /// Working arrays of [`WarpContext::better_mask_batch`].
    work: ViewArrays,
}

/// [`View`]s of a batch, one array per term.
#[derive(Clone, Debug)]
struct ViewArrays {
    n: [[f64; BATCH]; 3],
    p: [[f64; BATCH]; 3],
    dot_own: [f64; BATCH],
    len_own: [f64; BATCH],
    none: [bool; BATCH],
}

impl Default for SampleBatch {
    fn default() -> Self {
        let z = [0.0; BATCH];
        SampleBatch {
            x: z,
            y: z,
            inv_z: z,
            sx: z,
            sy: z,
            work: ViewArrays { n: [z; 3], p: [z; 3], dot_own: z, len_own: z, none: [false; BATCH] },
        }
    }
}

/// glam's `DVec3::dot`: `(x·x' + y·y') + z·z'`.
#[inline(always)]
fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// `c − p`.
#[inline(always)]
fn to_centre(p: [f64; 3], c: DVec3) -> [f64; 3] {
    [c.x - p[0], c.y - p[1], c.z - p[2]]
}

/// Whether centre `c` sees the surface of view `v` better: `|cos_c| >
/// |cos_own|·(1 + margin)`, squared and cross-multiplied so that neither
/// the normal nor the view rays need normalising: `(n·v_c)²·|v_own|² >
/// (n·v_own)²·|v_c|²·(1 + margin)²` (`m` = `(1 + margin)²`).
#[inline(always)]
fn better_of(v: &View, c: DVec3, m: f64) -> bool {
    let vc = to_centre(v.p, c);
    let d = dot(v.n, vc);
    d * d * v.len_own > v.dot_own * v.dot_own * dot(vc, vc) * m
}

/// The 8-neighbour offset nearest the direction `−D(p)` (rule 5); `None`
/// where `D` vanishes (at the epipole or with coincident centres).
pub fn backward_neighbour(epipole: &Epipole, x: f64, y: f64) -> Option<(i32, i32)> {
    let d = -epipole.direction_at(DVec2::new(x, y));
    if d.length_squared() == 0.0 || !d.is_finite() {
        return None;
    }
    // Nearest of the 8 directions: sectors of 45° centred on them, split at
    // tan(22.5°) = √2 − 1 (no atan2 in the per-sample path).
    const T: f64 = std::f64::consts::SQRT_2 - 1.0;
    let (ax, ay) = (d.x.abs(), d.y.abs());
    let sx = if d.x < 0.0 { -1 } else { 1 };
    let sy = if d.y < 0.0 { -1 } else { 1 };
    Some(if ay <= T * ax {
        (sx, 0)
    } else if ax <= T * ay {
        (0, sy)
    } else {
        (sx, sy)
    })
}

/// A context warping from reference camera `s` (at the origin of the
/// centres) to a rotated, shifted derived camera, with three centres: for
/// tests that compare two forms of the per-sample arithmetic.
#[cfg(test)]
pub(crate) fn scrambled_context(s: Camera) -> WarpContext {
    use glam::DQuat;
    use postwarp_rtl::{Intrinsics, Pose};
    let d = Camera {
        intrinsics: Intrinsics { width: 80, height: 60, fx: 52.0, fy: 51.0, cx: 39.5, cy: 29.5 },
        pose: Pose {
            position: DVec3::new(0.3, -0.2, 0.9),
            orientation: DQuat::from_euler(glam::EulerRot::YXZ, 0.4, -0.2, 0.1),
        },
    };
    let centres = vec![s.pose.position, d.pose.position, DVec3::new(-1.0, 0.5, 2.0)];
    WarpContext::new(WarpSetup::new(&s, &d), s, d, centres, 0, 0.05)
}

/// Pseudo-random numbers in [0, 1) from `seed` (xorshift64), for tests.
#[cfg(test)]
pub(crate) fn unit_random(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use postwarp_rtl::{Intrinsics, Pose};

    fn cam(x: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { width: 64, height: 48, fx: 40.0, fy: 40.0, cx: 31.5, cy: 23.5 },
            pose: Pose { position: DVec3::new(x, 0.0, 0.0), orientation: DQuat::IDENTITY },
        }
    }

    fn ctx(dst_x: f64) -> WarpContext {
        let (s, d) = (cam(0.0), cam(dst_x));
        WarpContext::new(WarpSetup::new(&s, &d), s, d, vec![s.pose.position, d.pose.position], 0, 0.05)
    }

    #[test]
    fn a_plane_translated_sideways_lands_where_the_equation_says() {
        // Fronto-parallel plane at Z = 4, derived camera 0.1 to the right:
        // every sample shifts left by f·B/Z = 40·0.1/4 = 1 sample.
        let c = ctx(0.1);
        let t = c.transform(10.0, 7.0, 0.25).unwrap();
        assert!((t.pos - DVec2::new(9.0, 7.0)).length() < 1e-12);
        assert!((t.inv_z - 0.25).abs() < 1e-15);
        // E is defined for a surface facing the reference centre: ~1 off axis.
        assert!((t.e - 1.0).abs() < 0.02, "pure translation keeps spacing: {}", t.e);
        assert!((c.transform(31.5, 23.5, 0.25).unwrap().e - 1.0).abs() < 0.01);
        let corner = c.edge_corner(10.0, 7.0, 0.25, [0.0, 0.0], 1.0, -1.0).unwrap();
        assert!((corner - DVec2::new(9.5, 6.5)).length() < 1e-12);
        assert_eq!(c.dest_slopes(10.0, 7.0, 0.25, [0.0, 0.0]), [0.0, 0.0]);
    }

    #[test]
    fn derived_slopes_match_finite_differences_on_a_tilted_plane() {
        let c = ctx(0.2);
        // 1/Z = 0.25 + 0.002·(x − 31.5) − 0.001·(y − 23.5) on the reference grid.
        let iz = |x: f64, y: f64| 0.25 + 0.002 * (x - 31.5) - 0.001 * (y - 23.5);
        let (x, y) = (20.0, 10.0);
        let s = c.dest_slopes(x, y, iz(x, y), [0.002, -0.001]);
        // Numerically: warp two nearby points and difference 1/Z2 over the derived step.
        let t0 = c.transform(x, y, iz(x, y)).unwrap();
        let tx = c.transform(x + 1e-4, y, iz(x + 1e-4, y)).unwrap();
        let ty = c.transform(x, y + 1e-4, iz(x, y + 1e-4)).unwrap();
        let j = DMat2::from_cols((tx.pos - t0.pos) / 1e-4, (ty.pos - t0.pos) / 1e-4);
        let g = DVec2::new((tx.inv_z - t0.inv_z) / 1e-4, (ty.inv_z - t0.inv_z) / 1e-4);
        let want = j.transpose().inverse() * g;
        assert!((want.x - s[0]).abs() < 1e-6 && (want.y - s[1]).abs() < 1e-6, "{s:?} vs {want:?}");
    }

    #[test]
    fn footprint_is_the_area_ratio_of_warped_samples() {
        // Pure sideways translation of a fronto-parallel plane: area kept.
        let c = ctx(0.1);
        assert!((c.footprint(10.0, 7.0, 0.25, [0.0, 0.0]) - 1.0).abs() < 1e-12);
        // Moving toward a fronto-parallel plane at Z = 4 by 2: magnification
        // 4/2 = 2 per axis, area 4.
        let mut z = ctx(0.0);
        z.dst.pose.position = DVec3::new(0.0, 0.0, 2.0);
        z.setup = WarpSetup::new(&z.src, &z.dst);
        assert!((z.footprint(31.5, 23.5, 0.25, [0.0, 0.0]) - 4.0).abs() < 1e-9);
        // A tilted plane: |det J| equals the area of the warped unit square
        // measured by finite differences.
        let c = ctx(0.3);
        let iz = |x: f64, y: f64| 0.25 + 0.004 * (x - 31.5) - 0.002 * (y - 23.5);
        let (x, y) = (20.0, 10.0);
        let t0 = c.transform(x, y, iz(x, y)).unwrap().pos;
        let tx = c.transform(x + 1e-4, y, iz(x + 1e-4, y)).unwrap().pos;
        let ty = c.transform(x, y + 1e-4, iz(x, y + 1e-4)).unwrap().pos;
        let j = DMat2::from_cols((tx - t0) / 1e-4, (ty - t0) / 1e-4);
        let f = c.footprint(x, y, iz(x, y), [0.004, -0.002]);
        assert!((f - j.determinant().abs()).abs() < 1e-5, "{f} vs {}", j.determinant());
        let jj = c.jacobian(x, y, iz(x, y), [0.004, -0.002]);
        assert!((jj.x_axis - j.x_axis).length() < 1e-5 && (jj.y_axis - j.y_axis).length() < 1e-5);
    }

    #[test]
    fn behind_the_derived_camera_is_culled() {
        let mut c = ctx(0.0);
        c.dst.pose.position = DVec3::new(0.0, 0.0, 10.0);
        c.setup = WarpSetup::new(&c.src, &c.dst);
        assert!(c.transform(31.5, 23.5, 0.25).is_none(), "a point at Z = 4 is behind a camera at z = 10");
    }

    #[test]
    fn better_mask_prefers_the_reference_facing_the_surface() {
        // A plane facing +x (normal along x): 1/Z varies with x. Reference 1
        // sits far to the side, seeing it less obliquely.
        let mut c = ctx(0.0);
        c.centres = vec![DVec3::ZERO, DVec3::new(5.0, 0.0, 4.0)];
        // Plane X = 1 in camera 0: 1/Z = xn → a = 1·..., slope = 1/fx per sample.
        let (x, y) = (51.5, 23.5); // xn = 0.5 → Z = 2
        let m = c.better_mask(x, y, 0.5, [1.0 / 40.0, 0.0]);
        assert_eq!(m, 0b10);
        // A centre far along the plane sees it edge-on: not better.
        c.centres = vec![DVec3::ZERO, DVec3::new(0.5, 0.0, 20.0)];
        assert_eq!(c.better_mask(x, y, 0.5, [1.0 / 40.0, 0.0]), 0);
    }

    /// The formulas as first written with glam's vector types: the
    /// branch-free, batch-friendly forms above must give the same bits.
    mod glam_form {
        use super::*;

        pub fn transform(c: &WarpContext, x: f64, y: f64, inv_z: f64) -> Option<Transformed> {
            let w = c.setup.warp(x, y, inv_z);
            if !(w.w > 0.0 && w.position.is_finite() && w.inv_z.is_finite()) {
                return None;
            }
            let (ks, kd) = (&c.src.intrinsics, &c.dst.intrinsics);
            let r1 = ray_len_sq(x - ks.cx, y - ks.cy, c.inv_f_src);
            let r2 = ray_len_sq(w.position.x - kd.cx, w.position.y - kd.cy, c.inv_f_dst);
            let e = (r1 / (r2 * w.w * w.w)).sqrt() * c.focal_ratio;
            Some(Transformed { pos: w.position, inv_z: w.inv_z, e, sat: 0 })
        }

        pub fn dest_slopes(c: &WarpContext, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> [f64; 2] {
            let (n, nx, ny, [d, dx, dy]) = c.numerator(x, y, inv_z, slopes);
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
            let k = 1.0 / (det * w * c.setup.s2);
            let v = [(gx * m11 - m10 * gy) * k, (m00 * gy - m01 * gx) * k];
            if v[0].is_finite() && v[1].is_finite() { v } else { [0.0, 0.0] }
        }

        pub fn better_mask(c: &WarpContext, x: f64, y: f64, inv_z: f64, slopes: [f32; 2]) -> u32 {
            let k = &c.src.intrinsics;
            let (xn, yn) = ((x - k.cx) / k.fx, (y - k.cy) / k.fy);
            let a = k.fx * slopes[0] as f64;
            let b = k.fy * slopes[1] as f64;
            let c0 = inv_z - a * xn - b * yn;
            let r = c.rot_src;
            let n = r * DVec3::new(a, b, c0);
            if n == DVec3::ZERO || !n.is_finite() {
                return 0;
            }
            let p = c.src.pose.position + r * DVec3::new(xn, yn, 1.0) / inv_z;
            let v_own = c.centres[c.this] - p;
            let (dot_own, len_own) = (n.dot(v_own), v_own.length_squared());
            let m = (1.0 + c.better_margin) * (1.0 + c.better_margin);
            let mut mask = 0;
            for (j, &cj) in c.centres.iter().enumerate() {
                let v = cj - p;
                let dot = n.dot(v);
                if j != c.this && dot * dot * len_own > dot_own * dot_own * v.length_squared() * m {
                    mask |= 1 << j;
                }
            }
            mask
        }
    }

    /// Reference x, y, 1/Z and slopes.
    type Sample = (f64, f64, f64, [f32; 2]);

    /// A context with a rotated, shifted derived camera and three centres,
    /// and pseudo-random samples (some behind the camera, some edge-on).
    fn scrambled() -> (WarpContext, Vec<Sample>) {
        let c = scrambled_context(cam(0.0));
        let mut next = unit_random(0x2545f4914f6cdd1d);
        let samples = (0..3000)
            .map(|_| {
                let (x, y) = ((next() * 64.0).floor(), (next() * 48.0).floor());
                let inv_z = if next() < 0.05 { 0.0 } else { 0.02 + next() * 2.0 };
                let sl = [((next() - 0.5) * 0.2) as f32, ((next() - 0.5) * 0.2) as f32];
                (x, y, inv_z, if next() < 0.05 { [0.0, 0.0] } else { sl })
            })
            .collect();
        (c, samples)
    }

    #[test]
    fn branch_free_and_batch_forms_give_the_glam_forms_bits() {
        let (c, samples) = scrambled();
        let bits2 = |v: [f64; 2]| v.map(f64::to_bits);
        let (mut culled, mut masks_set) = (0, 0);
        for &(x, y, iz, sl) in &samples {
            let w = c.setup.warp(x, y, iz);
            let [px, py, iz2, ww] = warp_of(&c.setup, x, y, iz);
            assert_eq!(
                [px, py, iz2, ww].map(f64::to_bits),
                [w.position.x, w.position.y, w.inv_z, w.w].map(f64::to_bits)
            );
            let t = c.transform(x, y, iz);
            culled += t.is_none() as u32;
            assert_eq!(
                t.map(|t| [t.pos.x, t.pos.y, t.inv_z, t.e].map(f64::to_bits)),
                glam_form::transform(&c, x, y, iz).map(|t| [t.pos.x, t.pos.y, t.inv_z, t.e].map(f64::to_bits))
            );
            assert_eq!(bits2(c.dest_slopes(x, y, iz, sl)), bits2(glam_form::dest_slopes(&c, x, y, iz, sl)));
            let m = c.better_mask(x, y, iz, sl);
            assert_eq!(m, glam_form::better_mask(&c, x, y, iz, sl));
            masks_set += (m != 0) as u32;
        }
        assert!(culled > 0, "some samples behind the derived camera");
        assert!(masks_set > 0 && masks_set < samples.len() as u32, "{masks_set} masks set");
        // Batches (a short last one too).
        let mut b = SampleBatch::default();
        for chunk in samples.chunks(BATCH - 7) {
            let n = chunk.len();
            for (k, &(x, y, iz, sl)) in chunk.iter().enumerate() {
                (b.x[k], b.y[k], b.inv_z[k], b.sx[k], b.sy[k]) = (x, y, iz, sl[0] as f64, sl[1] as f64);
            }
            let mut slopes = [[0.0; 2]; BATCH];
            c.dest_slopes_batch(&b, &mut slopes[..n]);
            let mut masks = [0u32; BATCH];
            c.better_mask_batch(&mut b, &mut masks[..n]);
            for (k, &(x, y, iz, sl)) in chunk.iter().enumerate() {
                assert_eq!(bits2(slopes[k]), bits2(c.dest_slopes(x, y, iz, sl)));
                assert_eq!(masks[k], c.better_mask(x, y, iz, sl));
            }
        }
        let iz: Vec<f64> = samples.iter().map(|s| s.2).take(BATCH).collect();
        let (mut out, mut ok) = ([[0.0; 4]; BATCH], [false; BATCH]);
        c.transform_batch(3.0, 7.0, &iz, &mut out, &mut ok);
        for (k, &iz) in iz.iter().enumerate() {
            let t = ok[k].then(|| out[k].map(f64::to_bits));
            assert_eq!(
                t,
                c.transform(3.0 + k as f64, 7.0, iz).map(|t| [t.pos.x, t.pos.y, t.inv_z, t.e].map(f64::to_bits))
            );
        }
    }

    #[test]
    fn backward_neighbour_points_away_from_a_front_epipole() {
        let e = Epipole { h: DVec3::new(10.0, 10.0, 1.0) };
        // At (20, 10), D points toward e (−x): −D is +x.
        assert_eq!(backward_neighbour(&e, 20.0, 10.0), Some((1, 0)));
        assert_eq!(backward_neighbour(&e, 0.0, 0.0), Some((-1, -1)));
        assert_eq!(backward_neighbour(&e, 10.0, 10.0), None);
    }
}
