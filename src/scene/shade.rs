//! Surface radiance: diffuse shading, the walk through semi-transparent
//! fragments, and mirror reflection and refraction to a bounded ray depth.
//!
//! Rules (`docs/scene-format.md`, "Transparency, mirrors, refraction"):
//! 1. Diffuse: `albedo · (ambient + (1 − ambient)·max(0, n·l))`, the normal
//!    turned toward the ray on two-sided surfaces, clamped to [0, 1] (the
//!    shading of every surface, and all of an opaque diffuse one).
//! 2. A ray walks through semi-transparent surfaces (opacity < 1): each is a
//!    fragment, shaded by rule 1, with its opacity; the walk goes on from
//!    just past it ([`STEP`]) and stops at the first surface that is not
//!    semi-transparent, or when nothing is hit. At most [`MAX_WALK`]
//!    fragments are walked through; a further semi-transparent surface is
//!    then treated as opaque.
//! 3. Fragments composite front to back over what lies behind them:
//!    `C = Σ T_k α_k c_k + T·L`, `T_0 = 1`, `T_{k+1} = T_k (1 − α_k)`.
//! 4. At a surface that reflects or refracts, hit at depth `d` (the camera
//!    ray is depth 0), with unit direction `v` and outward normal `n`:
//!    radiance = diffuse + `w_r`·reflect tint·`L(reflected ray)` +
//!    `w_t`·refract tint·`L(refracted ray)`, clamped to [0, 1]; the weights
//!    are 1 and 0 for a mirror, the Fresnel terms `F`, `1 − F` for a
//!    dielectric (`ior`; total internal reflection: no refracted ray, `F =
//!    1`). Child rays start [`OFFSET`] off the surface on their side. At
//!    depth `ray_depth` no child is traced (its radiance counts 0).
//! 5. A planar or mesh refractor is an interface to a medium behind its
//!    normal side that fills everything up to the next surface the
//!    refracted ray hits (a pool's water); a closed solid's medium is its
//!    inside.
//!
//! Not modelled: absorption along the path inside a medium (tints are
//! per interface), shadows, dispersion.

use super::Scene;
use super::geometry::Ray;
use super::world::ObjectHit;
use crate::trace::layers::{Node, reflect, refract};
use glam::DVec3;

/// How far past a fragment the walk goes on (ray parameter units).
pub const STEP: f64 = 1e-6;
/// How far off a surface a reflected or refracted ray starts (metres).
pub const OFFSET: f64 = 1e-6;
/// Most fragments one walk goes through (rule 2).
pub const MAX_WALK: usize = 64;

/// A fragment met on a walk: ray parameter, colour, opacity.
#[derive(Clone, Copy, Debug)]
pub struct WalkFragment {
    /// Ray parameter of the hit (for a camera ray: depth along the axis).
    pub t: f64,
    /// Colour (rule 1).
    pub colour: [f32; 3],
    /// Opacity.
    pub alpha: f32,
}

/// What a walk found: the fragments in ray order and the first surface
/// that is not semi-transparent (with the ray parameter from the walk's
/// start).
pub struct Walk {
    /// Fragments, nearest first.
    pub fragments: Vec<WalkFragment>,
    /// The opaque hit: parameter from the ray's origin, and the hit (whose
    /// own `t` is from the point the last step started at).
    pub hit: Option<(f64, ObjectHit, Ray)>,
}

/// The nodes at one surface (rule 4), for the ray tree.
#[derive(Clone, Copy, Debug, Default)]
pub struct Nodes {
    /// Radiance of each node, tint included, Fresnel not.
    pub colour: [[f32; 3]; 3],
    /// Distance from the hit to the child's hit (reflect, refract; 0 for
    /// the root, which the caller fills).
    pub depth: [f32; 3],
    /// Validity bits ([`Node::bit`]).
    pub valid: u8,
    /// The composite (rule 4).
    pub radiance: [f32; 3],
}

impl Scene {
    /// Rule 1 at `oh` on `ray`.
    pub(super) fn diffuse(&self, ray: &Ray, oh: &ObjectHit) -> [f32; 3] {
        let hit = oh.hit;
        let object = &self.world.objects[oh.object];
        let material = &self.world.materials[object.material];
        let n = hit.normal;
        let n_shade = if object.shape.two_sided() && n.dot(ray.dir) > 0.0 { -n } else { n };
        let albedo = material.albedo(ray.at(hit.t), n, hit.uv);
        let light = self.ambient + (1.0 - self.ambient) * n_shade.dot(self.to_light).max(0.0) as f32;
        albedo.map(|a| (a * light).clamp(0.0, 1.0))
    }

    /// Rule 2 along `ray`.
    pub(super) fn walk(&self, ray: &Ray) -> Walk {
        let mut fragments = Vec::new();
        let mut t0 = 0.0;
        loop {
            let step = Ray { origin: ray.at(t0), dir: ray.dir };
            let seg = if t0 == 0.0 { *ray } else { step };
            let Some(oh) = self.world.closest(&seg) else { return Walk { fragments, hit: None } };
            let t = t0 + oh.hit.t;
            let optics = &self.world.materials[self.world.objects[oh.object].material].optics;
            if optics.is_transparent() && fragments.len() < MAX_WALK {
                fragments.push(WalkFragment { t, colour: self.diffuse(&seg, &oh), alpha: optics.opacity });
                t0 = t + STEP;
                continue;
            }
            return Walk { fragments, hit: Some((t, oh, seg)) };
        }
    }

    /// Radiance along a unit-direction ray at depth `depth`, and the
    /// distance to its first surface that is not semi-transparent.
    fn radiance(&self, ray: &Ray, depth: u32) -> ([f32; 3], Option<f64>) {
        let walk = self.walk(ray);
        let (behind, dist) = match &walk.hit {
            None => (self.background, None),
            Some((t, oh, seg)) => (self.surface(seg, oh, depth).radiance, Some(*t)),
        };
        (composite(&walk.fragments, behind), dist)
    }

    /// Rule 4 at `oh` on `seg` (any direction length), at depth `depth`.
    pub(super) fn surface(&self, seg: &Ray, oh: &ObjectHit, depth: u32) -> Nodes {
        let diffuse = self.diffuse(seg, oh);
        let object = &self.world.objects[oh.object];
        let optics = &self.world.materials[object.material].optics;
        let mut nodes = Nodes { radiance: diffuse, valid: Node::Diffuse.bit(), ..Nodes::default() };
        nodes.colour[Node::Diffuse as usize] = diffuse;
        let Some(material) = optics.specular_material() else { return nodes };
        let v = seg.dir.normalize();
        let n = oh.hit.normal;
        let p = seg.at(oh.hit.t);
        let facing = if v.dot(n) > 0.0 { -n } else { n };
        let (w_r, w_t) = material.weights(v, n);
        let mut sum = diffuse.map(f64::from);
        let mut child = |node: Node, dir: DVec3, start: DVec3, tint: [f32; 3], w: f64, nodes: &mut Nodes| {
            if depth >= self.ray_depth {
                return;
            }
            let (l, dist) = self.radiance(&Ray { origin: start, dir }, depth + 1);
            let c: [f32; 3] = std::array::from_fn(|k| tint[k] * l[k]);
            nodes.colour[node as usize] = c;
            if let Some(d) = dist {
                nodes.valid |= node.bit();
                nodes.depth[node as usize] = (start + dir * d - p).length() as f32;
            }
            for k in 0..3 {
                sum[k] += w * c[k] as f64;
            }
        };
        if let Some(tint) = optics.reflection_tint() {
            child(Node::Reflect, reflect(v, facing).normalize(), p + facing * OFFSET, tint, w_r, &mut nodes);
        }
        if let Some(tint) = optics.refract {
            if let Some(t) = refract(v, facing, material.eta(v, n)) {
                child(Node::Refract, t.normalize(), p - facing * OFFSET, tint, w_t, &mut nodes);
            }
        }
        nodes.radiance = sum.map(|c| (c as f32).clamp(0.0, 1.0));
        nodes
    }

    /// The ray-tree material index (0: none) of the object hit.
    pub(super) fn specular_index(&self, oh: &ObjectHit) -> u8 {
        self.specular_table.1[self.world.objects[oh.object].material]
    }
}

/// Rule 3: `fragments` (nearest first) over `behind`, clamped to [0, 1].
pub fn composite(fragments: &[WalkFragment], behind: [f32; 3]) -> [f32; 3] {
    if fragments.is_empty() {
        return behind;
    }
    let mut c = [0.0f64; 3];
    let mut t = 1.0f64;
    for f in fragments {
        let a = f.alpha as f64;
        for (ck, fk) in c.iter_mut().zip(f.colour) {
            *ck += t * a * fk as f64;
        }
        t *= 1.0 - a;
    }
    std::array::from_fn(|k| ((c[k] + t * behind[k] as f64) as f32).clamp(0.0, 1.0))
}
