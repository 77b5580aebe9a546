//! The specular flow of seed 004 (Lochmann et al., §3.4 "Specular flow"):
//! for a derived sample on a reflecting or refracting surface, the
//! reference sample whose reflected (refracted) position lies in the
//! direction the new view's specular ray takes, found by gradient descent
//! on the angle between the two.
//!
//! Rules:
//! 1. Specular direction `ω` at the derived sample: from the new camera
//!    centre `c` to the warped diffuse position `w_d` (its source's
//!    diffuse position), reflected about the source's rebuilt normal `n`,
//!    or refracted with `η = 1/ior` (none under total internal
//!    reflection).
//! 2. Energy `Δ(q) = ∠(ω, W_s(q) − w_d)` in degrees, for a reference
//!    image location `q`, `W_s` the node's position image interpolated
//!    bilinearly; undefined where one of the four samples has no position.
//! 3. Initial guess (the paper's): the diffuse flow's source `q_d` and the
//!    specular guess `q_s`, blended `p_0 = λ q_d + (1 − λ) q_s` with `λ =
//!    1 − Δ_d / (Δ_d + Δ_s)`, `Δ_d = Δ(q_d)`, `Δ_s = Δ(q_s)` (the paper
//!    prints `W_d` in `Δ_d`, whose angle to `ω` from `w_d` itself is
//!    undefined; we read it as `W_s`, like `Δ_s`). An undefined guess
//!    gives the other all the weight; a blend whose energy is above the
//!    better guess's (it fell between two branches of the surface) is
//!    replaced by that guess (our choice). `q_s`: for a reflection, "a simple
//!    reflection around the current normal": the point `w_d + δ ω` (`δ`
//!    the node depth at `q_d`) mirrored about the tangent plane at `w_d`
//!    and projected into the reference (exact for a planar mirror); for a
//!    refraction, "treat the interface as transparent with an IOR ratio η
//!    of 1": `w_d + δ ω` projected into the reference as is.
//! 4. Descent: [`STEPS`] steps in image coordinates normalised by the
//!    reference's width (`u = q / width`), gradient by central finite
//!    differences of [`FD_STEP`] samples, `u ← u − α ∇Δ` with `α` starting at
//!    [`STEP_SIZE`]; a step to an undefined or not lower energy is
//!    rejected and `α` halved ("we simply reject the last step and choose
//!    a lower step size"); an accepted step doubles `α` (our choice: the
//!    paper only lowers it, and a fixed 10^-5 moves the estimate by a
//!    fraction of a sample at our image sizes); an undefined gradient ends
//!    the descent.
//! 5. Accept if the final `Δ <= `[`EPSILON_DEG`], else the sample is
//!    undefined in this node (filled by the node's pull-push).
//!
//! Units: `Δ` in degrees, `u` in reference widths, so `α` is in widths²
//! per degree (our reading: the paper gives 10^-5 without units; this one
//! moves the estimate by about a sample per step where the energy changes
//! by half a degree per sample).

use super::decode::Decoded;
use crate::trace::layers::{Node, reflect, refract};
use glam::{DVec2, DVec3};

/// Gradient steps per sample (the paper's 10).
pub const STEPS: u32 = 10;
/// Initial step size `α` (the paper's 10^-5; widths² per degree).
pub const STEP_SIZE: f64 = 1e-5;
/// Finite-difference step of the gradient (samples; our choice).
pub const FD_STEP: f64 = 0.25;
/// Acceptance threshold ε (the paper's 1°).
pub const EPSILON_DEG: f64 = 1.0;

/// Where the descent ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    /// Reference image location (samples).
    pub q: DVec2,
    /// The node's position there (rule 2's `W_s(q)`).
    pub position: DVec3,
    /// Final energy (degrees).
    pub energy_deg: f64,
    /// Gradient steps taken.
    pub steps: u32,
    /// Rule 5.
    pub accepted: bool,
}

/// Rule 1: the new view's specular direction at `w_d` with normal `n`
/// (unit, facing the reference camera) for `node`, `eta` its index ratio.
pub fn direction(node: Node, eye: DVec3, w_d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let v = (w_d - eye).normalize();
    let n = if v.dot(n) > 0.0 { -n } else { n };
    match node {
        Node::Reflect => Some(reflect(v, n).normalize()),
        Node::Refract => refract(v, n, eta).map(|d| d.normalize()),
        Node::Diffuse => None,
    }
}

/// Rule 2's `W_s(q)` by bilinear interpolation.
fn position(r: &Decoded, pos: &[Option<DVec3>], q: DVec2) -> Option<DVec3> {
    let (w, h) = (r.width as i64, r.height as i64);
    let (x0, y0) = (q.x.floor(), q.y.floor());
    let (fx, fy) = (q.x - x0, q.y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let at = |x: i64, y: i64| -> Option<DVec3> {
        let (x, y) = (x.clamp(0, w - 1), y.clamp(0, h - 1));
        pos[(y * w + x) as usize]
    };
    if !q.is_finite() || x0 < -1 || y0 < -1 || x0 >= w || y0 >= h {
        return None;
    }
    let (a, b, c, d) = (at(x0, y0)?, at(x0 + 1, y0)?, at(x0, y0 + 1)?, at(x0 + 1, y0 + 1)?);
    Some((a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy)
}

/// Rule 2.
fn energy(r: &Decoded, pos: &[Option<DVec3>], omega: DVec3, w_d: DVec3, q: DVec2) -> Option<(f64, DVec3)> {
    let p = position(r, pos, q)?;
    let d = (p - w_d).try_normalize()?;
    Some((d.dot(omega).clamp(-1.0, 1.0).acos().to_degrees(), p))
}

/// Rules 3–5 for `node` of reference `r` at a derived sample whose
/// diffuse flow points at reference location `q_d` (samples), where the
/// warped diffuse position is `w_d` with normal `n`, the specular
/// direction `omega` (rule 1) and the node depth `depth`.
pub fn descend(r: &Decoded, node: Node, w_d: DVec3, n: DVec3, q_d: DVec2, omega: DVec3, depth: f64) -> Option<Found> {
    let pos = r.positions(node);
    let guess = w_d + omega * depth;
    let target = match node {
        Node::Reflect => guess - 2.0 * (guess - w_d).dot(n) * n,
        _ => guess,
    };
    let q_s = r.camera.project(target).map(|(q, _)| q);
    let e_d = energy(r, pos, omega, w_d, q_d).map(|e| e.0);
    let e_s = q_s.and_then(|q| energy(r, pos, omega, w_d, q)).map(|e| e.0);
    let mut q = match (e_d, e_s, q_s) {
        (Some(a), Some(b), Some(qs)) => {
            let lambda = if a + b > 0.0 { 1.0 - a / (a + b) } else { 0.5 };
            q_d * lambda + qs * (1.0 - lambda)
        }
        (Some(_), _, _) => q_d,
        (None, Some(_), Some(qs)) => qs,
        _ => return None,
    };
    let best_guess = match (e_d, e_s, q_s) {
        (Some(a), Some(b), Some(qs)) if b < a => (qs, b),
        (Some(a), _, _) => (q_d, a),
        (None, Some(b), Some(qs)) => (qs, b),
        _ => return None,
    };
    let (mut e, mut p) = match energy(r, pos, omega, w_d, q) {
        Some((e, p)) if e <= best_guess.1 => (e, p),
        _ => {
            q = best_guess.0;
            energy(r, pos, omega, w_d, q)?
        }
    };
    let width = r.width as f64;
    let mut alpha = STEP_SIZE;
    let mut steps = 0;
    for _ in 0..STEPS {
        steps += 1;
        let f = |dq: DVec2| energy(r, pos, omega, w_d, q + dq).map(|v| v.0);
        let (hx, hy) = (DVec2::X * FD_STEP, DVec2::Y * FD_STEP);
        let (Some(xp), Some(xm), Some(yp), Some(ym)) = (f(hx), f(-hx), f(hy), f(-hy)) else {
            break;
        };
        // ∂Δ/∂u with u = q / width: a sample is 1/width.
        let grad = DVec2::new(xp - xm, yp - ym) * (0.5 * width / FD_STEP);
        let next = q - grad * (alpha * width);
        match energy(r, pos, omega, w_d, next) {
            Some((en, pn)) if en < e => {
                q = next;
                e = en;
                p = pn;
                alpha *= 2.0;
            }
            _ => alpha *= 0.5,
        }
    }
    Some(Found { q, position: p, energy_deg: e, steps, accepted: e <= EPSILON_DEG })
}
