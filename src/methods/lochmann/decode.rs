//! Decoding a reference's RGBZ ray tree (seed 004, Lochmann et al., VMV
//! 2014, §3.3): diffuse world positions, normals rebuilt from them, and the
//! reflected and refracted world positions, once per reference.
//!
//! Rules:
//! 1. Diffuse position `W_d(l) = unproject(l, Z)`: the reference camera's
//!    ray through sample `l` at the root node's depth (the reference
//!    image's `Z`, the root's `Z` of a ray tree).
//! 2. Normals: `n = (W_d(l + (0, 1)) − W_d(l)) × (W_d(l + (1, 0)) −
//!    W_d(l))` (the paper's formula; a neighbour without a surface or off
//!    the image is replaced by the one on the other side, with the
//!    difference negated), normalised, then blurred with a 7x7 Gaussian
//!    (σ = [`NORMAL_SIGMA`] samples, our choice: the paper gives only the
//!    size) over samples with a surface, renormalised and turned toward the
//!    reference camera.
//! 3. Reflected position `W_r = W_d + δ_r · r̂`, `r = reflect(W_d − c,
//!    n)`; refracted `W_f = W_d + δ_f · f̂`, `f = refract((W_d − c)^, n,
//!    η)` with `η = 1/ior` of the sample's material (the camera is outside
//!    the surface it sees; a refraction the rebuilt normal makes total is
//!    not valid); `δ` is the node's depth. A position exists where the
//!    node is valid.
//!
//! Not modelled: the paper's bilateral alternative (rejected there too),
//! deeper nodes (the paper keeps three nodes), mip-map storage.

use crate::trace::layers::{Node, RayTreeLayer, SpecularMaterial, reflect, refract};
use glam::DVec3;
use postwarp_rtl::{Camera, SampleImage};

/// Standard deviation of the 7x7 normal blur (samples).
pub const NORMAL_SIGMA: f64 = 1.5;

/// One reference, decoded.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// The reference camera (its sample grid).
    pub camera: Camera,
    /// Rule 1 (`None`: no surface).
    pub diffuse: Vec<Option<DVec3>>,
    /// Rule 2 (unit, toward the camera; zero where no surface).
    pub normal: Vec<DVec3>,
    /// Rule 3, reflection (`None` where the node is not valid).
    pub reflected: Vec<Option<DVec3>>,
    /// Rule 3, refraction.
    pub refracted: Vec<Option<DVec3>>,
}

impl Decoded {
    /// Rules 1–3 for `img` (and its ray tree, if any) seen by `camera`
    /// (its sample grid).
    pub fn new(img: &SampleImage, tree: Option<&RayTreeLayer>, camera: &Camera) -> Decoded {
        let (w, h) = (img.width as usize, img.height as usize);
        let diffuse: Vec<Option<DVec3>> = (0..w * h)
            .map(|i| img.valid[i].then(|| camera.unproject((i % w) as f64, (i / w) as f64, img.z[i] as f64)))
            .collect();
        let normal = normals(&diffuse, w, h, camera.pose.position);
        let mut d = Decoded {
            width: img.width,
            height: img.height,
            camera: *camera,
            diffuse,
            normal,
            reflected: vec![None; w * h],
            refracted: vec![None; w * h],
        };
        if let Some(t) = tree {
            for i in 0..w * h {
                let Some(wd) = d.diffuse[i] else { continue };
                let v = (wd - camera.pose.position).normalize();
                let n = d.normal[i];
                if t.has(i, Node::Reflect) {
                    let r = reflect(v, n).normalize();
                    d.reflected[i] = Some(wd + r * t.nodes[Node::Reflect as usize].depth[i] as f64);
                }
                if t.has(i, Node::Refract) {
                    let eta = match t.material_at(i) {
                        Some(SpecularMaterial::Dielectric { ior }) => 1.0 / ior,
                        _ => 1.0,
                    };
                    if let Some(f) = refract(v, n, eta) {
                        d.refracted[i] = Some(wd + f.normalize() * t.nodes[Node::Refract as usize].depth[i] as f64);
                    }
                }
            }
        }
        d
    }

    /// The position image of `node` (reflect or refract).
    pub fn positions(&self, node: Node) -> &[Option<DVec3>] {
        match node {
            Node::Reflect => &self.reflected,
            Node::Refract => &self.refracted,
            Node::Diffuse => &self.diffuse,
        }
    }
}

/// Rule 2.
fn normals(pos: &[Option<DVec3>], w: usize, h: usize, eye: DVec3) -> Vec<DVec3> {
    let at = |x: i64, y: i64| -> Option<DVec3> {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 { None } else { pos[y as usize * w + x as usize] }
    };
    // The central difference along (dx, dy) where both neighbours have a
    // surface, else the one-sided one that exists.
    let diff = |x: i64, y: i64, p: DVec3, dx: i64, dy: i64| -> Option<DVec3> {
        match (at(x + dx, y + dy), at(x - dx, y - dy)) {
            (Some(a), Some(b)) => Some(0.5 * (a - b)),
            (Some(a), None) => Some(a - p),
            (None, Some(b)) => Some(p - b),
            (None, None) => None,
        }
    };
    let raw: Vec<DVec3> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let Some(p) = pos[i] else { return DVec3::ZERO };
            match (diff(x, y, p, 0, 1), diff(x, y, p, 1, 0)) {
                (Some(a), Some(b)) => {
                    let n = a.cross(b);
                    let n = if n.dot(eye - p) < 0.0 { -n } else { n };
                    n.try_normalize().unwrap_or(DVec3::ZERO)
                }
                _ => DVec3::ZERO,
            }
        })
        .collect();
    // Separable 7x7 Gaussian over samples with a surface.
    let g: Vec<f64> = (-3..=3).map(|k: i32| (-(k * k) as f64 / (2.0 * NORMAL_SIGMA * NORMAL_SIGMA)).exp()).collect();
    let blur = |src: &[DVec3], horizontal: bool| -> Vec<DVec3> {
        (0..w * h)
            .map(|i| {
                if pos[i].is_none() {
                    return DVec3::ZERO;
                }
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                let mut s = DVec3::ZERO;
                for (k, wk) in (-3..=3).zip(&g) {
                    let (xx, yy) = if horizontal { (x + k, y) } else { (x, y + k) };
                    if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                        continue;
                    }
                    s += src[yy as usize * w + xx as usize] * *wk;
                }
                s
            })
            .collect()
    };
    let smooth = blur(&blur(&raw, true), false);
    (0..w * h)
        .map(|i| {
            let Some(p) = pos[i] else { return DVec3::ZERO };
            let n = smooth[i].try_normalize().unwrap_or(raw[i]);
            if n.dot(eye - p) < 0.0 { -n } else { n }
        })
        .collect()
}
