//! Analytic primitives and their ray intersections, in `f64`.
//!
//! A ray is `origin + t·dir` with `dir` NOT normalised (the renderer passes
//! camera rays whose camera-space z is 1, so `t` is the depth `Z`); every
//! routine here returns that same `t`, so no shape may rescale `dir`.
//! A hit carries the unit surface normal in world space: the outward normal
//! for closed solids (box, sphere, capped cylinder), the plane's own
//! orientation `half_u × half_v` for planes (which are two-sided: the
//! renderer flips the normal toward the viewer). Hits count only for
//! `t > T_MIN` so a ray never sees the surface it starts on.
//!
//! Not modelled: tori, cones, CSG, motion, instancing of analytic shapes,
//! thickness of planes.

use super::bvh::Aabb;
use glam::{DMat3, DVec3};

/// Smallest accepted hit distance (scene units).
pub const T_MIN: f64 = 1e-9;

/// A ray `origin + t·dir`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Start point.
    pub origin: DVec3,
    /// Direction (not normalised).
    pub dir: DVec3,
}

impl Ray {
    /// Point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// Unit normal (world): outward for solids, the plane's orientation for
    /// planes, the face normal for triangles.
    pub normal: DVec3,
    /// Texture coordinates, where the shape defines them.
    pub uv: Option<[f64; 2]>,
}

/// A flat parallelogram `centre + a·half_u + b·half_v` (|a|, |b| <= 1), or an
/// unbounded plane.
#[derive(Clone, Debug)]
pub struct Plane {
    centre: DVec3,
    normal: DVec3,
    /// Dual basis: `a = (p − centre)·dual_u`, `b = (p − centre)·dual_v`.
    /// `None` for an unbounded plane.
    extent: Option<(DVec3, DVec3, DVec3, DVec3)>,
}

impl Plane {
    /// A finite parallelogram. `half_u` and `half_v` must not be parallel
    /// (checked by the caller).
    pub fn finite(centre: DVec3, half_u: DVec3, half_v: DVec3) -> Plane {
        let normal = half_u.cross(half_v).normalize();
        let dual_u = half_v.cross(normal) / half_u.dot(half_v.cross(normal));
        let dual_v = normal.cross(half_u) / half_v.dot(normal.cross(half_u));
        Plane { centre, normal, extent: Some((half_u, half_v, dual_u, dual_v)) }
    }

    /// An unbounded plane through `point` with the given (non-zero) normal.
    pub fn infinite(point: DVec3, normal: DVec3) -> Plane {
        Plane { centre: point, normal: normal.normalize(), extent: None }
    }

    /// Bounding box (`None` if unbounded).
    pub fn bounds(&self) -> Option<Aabb> {
        let (u, v, _, _) = self.extent?;
        let c = self.centre;
        Some(Aabb::from_points([c + u + v, c + u - v, c - u + v, c - u - v]))
    }

    /// True if texture coordinates exist (finite planes).
    pub fn has_uv(&self) -> bool {
        self.extent.is_some()
    }

    /// The same rectangle scaled by `factor` (> 0) about `anchor`; an
    /// unbounded plane is returned unchanged.
    pub fn scaled_about(&self, anchor: DVec3, factor: f64) -> Plane {
        match self.extent {
            None => self.clone(),
            Some((u, v, _, _)) => Plane::finite(anchor + (self.centre - anchor) * factor, u * factor, v * factor),
        }
    }

    /// Intersect.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let denom = self.normal.dot(ray.dir);
        if denom == 0.0 {
            return None;
        }
        let t = self.normal.dot(self.centre - ray.origin) / denom;
        if !(t > T_MIN && t < t_max) {
            return None;
        }
        let uv = match self.extent {
            None => None,
            Some((_, _, du, dv)) => {
                let r = ray.at(t) - self.centre;
                let (a, b) = (r.dot(du), r.dot(dv));
                if a.abs() > 1.0 || b.abs() > 1.0 {
                    return None;
                }
                Some([0.5 * (a + 1.0), 0.5 * (b + 1.0)])
            }
        };
        Some(Hit { t, normal: self.normal, uv })
    }
}

/// A box with a rotation about the world y axis.
#[derive(Clone, Debug)]
pub struct Cuboid {
    centre: DVec3,
    half: DVec3,
    /// Local-to-world rotation (about y).
    rot: DMat3,
}

impl Cuboid {
    /// A box of half-size `half` (all > 0) at `centre`, turned `yaw_deg`
    /// about +y (right-handed: +x turns toward −z).
    pub fn new(centre: DVec3, half: DVec3, yaw_deg: f64) -> Cuboid {
        Cuboid { centre, half, rot: DMat3::from_rotation_y(yaw_deg.to_radians()) }
    }

    /// The same box scaled by `factor` (> 0) about `anchor`.
    pub fn scaled_about(&self, anchor: DVec3, factor: f64) -> Cuboid {
        Cuboid { centre: anchor + (self.centre - anchor) * factor, half: self.half * factor, rot: self.rot }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        let local = Aabb { min: -self.half, max: self.half };
        Aabb::from_points(local.corners().map(|p| self.centre + self.rot * p))
    }

    /// Intersect.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let inv = self.rot.transpose();
        let o = inv * (ray.origin - self.centre);
        let d = inv * ray.dir;
        let mut t_near = f64::NEG_INFINITY;
        let mut t_far = f64::INFINITY;
        let (mut near_axis, mut far_axis) = (0usize, 0usize);
        for axis in 0..3 {
            if d[axis] == 0.0 {
                if o[axis].abs() > self.half[axis] {
                    return None;
                }
                continue;
            }
            let a = (-self.half[axis] - o[axis]) / d[axis];
            let b = (self.half[axis] - o[axis]) / d[axis];
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            if lo > t_near {
                t_near = lo;
                near_axis = axis;
            }
            if hi < t_far {
                t_far = hi;
                far_axis = axis;
            }
        }
        if t_near > t_far {
            return None;
        }
        let (t, axis, sign) = if t_near > T_MIN {
            (t_near, near_axis, -d[near_axis].signum())
        } else if t_far > T_MIN {
            (t_far, far_axis, d[far_axis].signum())
        } else {
            return None;
        };
        if t >= t_max {
            return None;
        }
        let mut n = DVec3::ZERO;
        n[axis] = sign;
        Some(Hit { t, normal: self.rot * n, uv: None })
    }
}

/// A sphere.
#[derive(Clone, Debug)]
pub struct Sphere {
    centre: DVec3,
    radius: f64,
}

impl Sphere {
    /// Sphere of `radius > 0`.
    pub fn new(centre: DVec3, radius: f64) -> Sphere {
        Sphere { centre, radius }
    }

    /// The same sphere scaled by `factor` (> 0) about `anchor`.
    pub fn scaled_about(&self, anchor: DVec3, factor: f64) -> Sphere {
        Sphere { centre: anchor + (self.centre - anchor) * factor, radius: self.radius * factor }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb { min: self.centre - self.radius, max: self.centre + self.radius }
    }

    /// Intersect.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let (t0, t1) = solve_sphere(ray.origin - self.centre, ray.dir, self.radius)?;
        let t = pick(t0, t1, t_max)?;
        let normal = (ray.at(t) - self.centre) / self.radius;
        Some(Hit { t, normal: normal.normalize(), uv: None })
    }
}

/// Both roots of `|w + t·d|² = r²`, nearest first. Solved so that it stays
/// accurate when the ray starts far away: the parameter of closest approach
/// first, then the half chord from the squared distance there (computed from
/// the vector at that point, not from `|w|² − (w·d)²/|d|²`, which cancels).
fn solve_sphere(w: DVec3, d: DVec3, r: f64) -> Option<(f64, f64)> {
    let a = d.length_squared();
    if a == 0.0 {
        return None;
    }
    let t_mid = -w.dot(d) / a;
    let h2 = r * r - (w + d * t_mid).length_squared();
    if h2 < 0.0 {
        return None;
    }
    let half = (h2 / a).sqrt();
    Some((t_mid - half, t_mid + half))
}

fn pick(t0: f64, t1: f64, t_max: f64) -> Option<f64> {
    let t = if t0 > T_MIN { t0 } else { t1 };
    (t > T_MIN && t < t_max).then_some(t)
}

/// A capped cylinder: base point, unit axis, radius and height.
#[derive(Clone, Debug)]
pub struct Cylinder {
    base: DVec3,
    axis: DVec3,
    radius: f64,
    height: f64,
}

impl Cylinder {
    /// Cylinder from `base` along the (non-zero) `axis` direction.
    pub fn new(base: DVec3, axis: DVec3, radius: f64, height: f64) -> Cylinder {
        Cylinder { base, axis: axis.normalize(), radius, height }
    }

    /// The same cylinder with its radius multiplied by `factor` (> 0).
    pub fn with_radius_scaled(&self, factor: f64) -> Cylinder {
        Cylinder { radius: self.radius * factor, ..self.clone() }
    }

    /// The same cylinder scaled by `factor` (> 0) about the point `centre`:
    /// base, height and radius alike.
    pub fn scaled_about(&self, centre: DVec3, factor: f64) -> Cylinder {
        Cylinder {
            base: centre + (self.base - centre) * factor,
            axis: self.axis,
            radius: self.radius * factor,
            height: self.height * factor,
        }
    }

    /// Radius (scene units).
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Centre of the axis (scene units).
    pub fn mid_point(&self) -> DVec3 {
        self.base + self.axis * (0.5 * self.height)
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        let top = self.base + self.axis * self.height;
        // Disc of radius r with normal a spans r·sqrt(1 − a_i²) along axis i.
        let e = (DVec3::ONE - self.axis * self.axis).max(DVec3::ZERO).map(f64::sqrt) * self.radius;
        Aabb { min: self.base.min(top) - e, max: self.base.max(top) + e }
    }

    /// Intersect (side and both caps).
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let a = self.axis;
        let w = ray.origin - self.base;
        let wa = w.dot(a);
        let da = ray.dir.dot(a);
        let w_perp = w - a * wa;
        let d_perp = ray.dir - a * da;
        let mut best: Option<Hit> = None;
        let mut limit = t_max;
        // Side.
        if let Some((t0, t1)) = solve_sphere(w_perp, d_perp, self.radius) {
            for t in [t0, t1] {
                if t > T_MIN && t < limit {
                    let h = wa + da * t;
                    if (0.0..=self.height).contains(&h) {
                        let radial = w_perp + d_perp * t;
                        best = Some(Hit { t, normal: radial.normalize(), uv: None });
                        limit = t;
                        break;
                    }
                }
            }
        }
        // Caps.
        if da != 0.0 {
            for (h, n) in [(0.0, -a), (self.height, a)] {
                let t = (h - wa) / da;
                if t > T_MIN && t < limit {
                    let radial = w_perp + d_perp * t;
                    if radial.length_squared() <= self.radius * self.radius {
                        best = Some(Hit { t, normal: n, uv: None });
                        limit = t;
                    }
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f64; 3], d: [f64; 3]) -> Ray {
        Ray { origin: DVec3::from(o), dir: DVec3::from(d) }
    }

    #[test]
    fn plane_hits_inside_and_misses_outside_the_rectangle() {
        let p = Plane::finite(DVec3::new(0.0, 0.0, 5.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0));
        let h = p.intersect(&ray([0.5, 1.5, 0.0], [0.0, 0.0, 1.0]), f64::INFINITY).unwrap();
        assert_eq!(h.t, 5.0);
        assert_eq!(h.uv, Some([0.75, 0.875]));
        assert!(p.intersect(&ray([1.5, 0.0, 0.0], [0.0, 0.0, 1.0]), f64::INFINITY).is_none());
        assert!(p.intersect(&ray([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), 4.0).is_none());
    }

    #[test]
    fn box_normals_point_out_and_inside_rays_hit_the_far_face() {
        let b = Cuboid::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0), 0.0);
        let h = b.intersect(&ray([-5.0, 0.0, 0.0], [2.0, 0.0, 0.0]), f64::INFINITY).unwrap();
        assert_eq!((h.t, h.normal), (2.0, DVec3::new(-1.0, 0.0, 0.0)));
        let h = b.intersect(&ray([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]), f64::INFINITY).unwrap();
        assert_eq!((h.t, h.normal), (2.0, DVec3::Y));
        let turned = Cuboid::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 1.0), 45.0);
        let h = turned.intersect(&ray([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0]), f64::INFINITY).unwrap();
        assert!((h.t - (5.0 - 2f64.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn sphere_and_cylinder_distances() {
        let s = Sphere::new(DVec3::new(0.0, 0.0, 10.0), 2.0);
        let h = s.intersect(&ray([0.0, 0.0, 0.0], [0.0, 0.0, 0.5]), f64::INFINITY).unwrap();
        assert_eq!(h.t, 16.0);
        assert_eq!(h.normal, DVec3::new(0.0, 0.0, -1.0));
        let c = Cylinder::new(DVec3::new(0.0, -1.0, 5.0), DVec3::Y, 1.0, 2.0);
        let h = c.intersect(&ray([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), f64::INFINITY).unwrap();
        assert_eq!((h.t, h.normal), (4.0, DVec3::new(0.0, 0.0, -1.0)));
        // Down onto the top cap.
        let h = c.intersect(&ray([0.2, 5.0, 5.0], [0.0, -1.0, 0.0]), f64::INFINITY).unwrap();
        assert_eq!((h.t, h.normal), (4.0, DVec3::Y));
        // Past the side below the base.
        assert!(c.intersect(&ray([0.0, -1.5, 0.0], [0.0, 0.0, 1.0]), f64::INFINITY).is_none());
        let b = c.bounds();
        assert_eq!((b.min, b.max), (DVec3::new(-1.0, -1.0, 4.0), DVec3::new(1.0, 1.0, 6.0)));
    }
}
