//! The compiled scene contents: objects (shape + material), and the nearest
//! hit along a ray over all of them.
//!
//! Rules: objects keep the order of the scene file; the object id of a hit
//! is that position + 1 (0 means "no surface"). Bounded objects are found
//! through a BVH over their boxes; unbounded planes are tested one by one.
//! Among equally near hits the earlier object wins, whatever order the BVH
//! visits them in, so ids never depend on the tree shape.
//!
//! Not modelled: shadows. Secondary rays (reflection, refraction, the
//! walk through semi-transparent fragments) are the renderer's, built on
//! [`World::closest`].

use super::bvh::{Aabb, Bvh, RayBoxTest};
use super::geometry::{Cuboid, Cylinder, Hit, Plane, Ray, Sphere};
use super::mesh::MeshInstance;
use super::texture::Material;

/// The geometry of one object.
#[derive(Clone, Debug)]
pub enum Shape {
    /// Finite rectangle or unbounded plane (two-sided).
    Plane(Plane),
    /// Box turned about y.
    Box(Cuboid),
    /// Sphere.
    Sphere(Sphere),
    /// Capped cylinder (also used for rods).
    Cylinder(Cylinder),
    /// Placed triangle mesh (two-sided).
    Mesh(MeshInstance),
}

impl Shape {
    /// Bounding box, `None` for an unbounded plane.
    pub fn bounds(&self) -> Option<Aabb> {
        match self {
            Shape::Plane(p) => p.bounds(),
            Shape::Box(b) => Some(b.bounds()),
            Shape::Sphere(s) => Some(s.bounds()),
            Shape::Cylinder(c) => Some(c.bounds()),
            Shape::Mesh(m) => Some(m.bounds()),
        }
    }

    /// Nearest hit closer than `t_max`.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        match self {
            Shape::Plane(p) => p.intersect(ray, t_max),
            Shape::Box(b) => b.intersect(ray, t_max),
            Shape::Sphere(s) => s.intersect(ray, t_max),
            Shape::Cylinder(c) => c.intersect(ray, t_max),
            Shape::Mesh(m) => m.intersect(ray, t_max),
        }
    }

    /// The same shape scaled by `factor` (> 0) about the middle of the
    /// bottom face of its bounding box (so an object standing on a floor
    /// stays on it, and a rectangle stays in its plane); meshes and
    /// unbounded planes are returned unchanged.
    pub fn scaled_about_base(&self, factor: f64) -> Shape {
        let Some(b) = self.bounds() else { return self.clone() };
        let anchor = glam::DVec3::new(0.5 * (b.min.x + b.max.x), b.min.y, 0.5 * (b.min.z + b.max.z));
        match self {
            Shape::Plane(p) => Shape::Plane(p.scaled_about(anchor, factor)),
            Shape::Box(c) => Shape::Box(c.scaled_about(anchor, factor)),
            Shape::Sphere(s) => Shape::Sphere(s.scaled_about(anchor, factor)),
            Shape::Cylinder(c) => Shape::Cylinder(c.scaled_about(anchor, factor)),
            Shape::Mesh(_) => self.clone(),
        }
    }

    /// True for surfaces shaded from whichever side the ray comes from.
    pub fn two_sided(&self) -> bool {
        matches!(self, Shape::Plane(_) | Shape::Mesh(_))
    }

    /// True if hits carry texture coordinates.
    pub fn has_uv(&self) -> bool {
        match self {
            Shape::Plane(p) => p.has_uv(),
            Shape::Mesh(m) => m.has_uv(),
            _ => false,
        }
    }
}

/// The next larger `f64` (for positive `t`; infinity stays).
fn next_up(t: f64) -> f64 {
    if t.is_finite() && t >= 0.0 { f64::from_bits(t.to_bits() + 1) } else { t }
}

/// One object of the scene.
#[derive(Clone, Debug)]
pub struct Object {
    /// Geometry.
    pub shape: Shape,
    /// Index into [`World::materials`].
    pub material: usize,
}

/// A hit on a known object.
#[derive(Clone, Copy, Debug)]
pub struct ObjectHit {
    /// The surface hit.
    pub hit: Hit,
    /// Index of the object (id − 1).
    pub object: usize,
}

/// Objects, materials and the acceleration structure.
#[derive(Clone, Debug, Default)]
pub struct World {
    /// Materials referenced by objects.
    pub materials: Vec<Material>,
    /// Objects in scene-file order.
    pub objects: Vec<Object>,
    bounded: Vec<u32>,
    unbounded: Vec<u32>,
    bvh: Bvh,
}

impl World {
    /// Assemble and build the top-level BVH.
    pub fn new(materials: Vec<Material>, objects: Vec<Object>) -> World {
        let mut bounded = Vec::new();
        let mut boxes = Vec::new();
        let mut unbounded = Vec::new();
        for (i, o) in objects.iter().enumerate() {
            match o.shape.bounds() {
                Some(b) => {
                    bounded.push(i as u32);
                    boxes.push(b);
                }
                None => unbounded.push(i as u32),
            }
        }
        let bvh = Bvh::build(&boxes);
        World { materials, objects, bounded, unbounded, bvh }
    }

    /// Nearest hit along `ray`, ties to the earlier object.
    pub fn closest(&self, ray: &Ray) -> Option<ObjectHit> {
        let mut best: Option<ObjectHit> = None;
        let consider = |i: usize, t_max: f64, best: &mut Option<ObjectHit>| -> Option<f64> {
            // Allow an equal distance through so the earlier object can win a tie.
            let limit = next_up(t_max);
            let hit = self.objects[i].shape.intersect(ray, limit)?;
            let better = match best {
                None => true,
                Some(b) => hit.t < b.hit.t || (hit.t == b.hit.t && i < b.object),
            };
            if better {
                *best = Some(ObjectHit { hit, object: i });
            }
            Some(hit.t)
        };
        for &i in &self.unbounded {
            let t_max = best.map_or(f64::INFINITY, |b| b.hit.t);
            consider(i as usize, t_max, &mut best);
        }
        let test = RayBoxTest::new(ray.origin, ray.dir);
        let t0 = best.map_or(f64::INFINITY, |b| b.hit.t);
        self.bvh.closest(&test, t0, |k, t_max| consider(self.bounded[k as usize] as usize, t_max, &mut best));
        best
    }
}
