//! Ray casting a [`Scene`] into a [`SampleImage`]: one ray per super-sample,
//! view-independent diffuse shading, exact depth and 1/Z slopes.
//!
//! Rules:
//! - the ray of sample `(x, y)` goes through the sample centre of
//!   `camera.sample_grid(ss)`: direction `R·((x − cx)/fx, (y − cy)/fy, 1)`
//!   from the centre of projection. Its camera-space z is 1, so the hit
//!   parameter `t` is the depth `Z` along the optical axis;
//! - slopes come from the tangent plane at the hit, not from neighbours:
//!   with camera-space unit normal `n` and hit point `X`, the plane
//!   `n·P = d` (`d = n·X`) gives `1/Z = (n.x·xn + n.y·yn + n.z)/d` along the
//!   ray through normalised coordinates `(xn, yn)`, hence
//!   `∂(1/Z)/∂x = n.x/(fx·d)` and `∂(1/Z)/∂y = n.y/(fy·d)` per sample step.
//!   Triangles use their face normal (exact on flat faces), spheres and
//!   cylinders their analytic normal;
//! - colour = albedo·(ambient + (1 − ambient)·max(0, n·l)) with the outward
//!   normal, flipped toward the viewer for two-sided surfaces (planes,
//!   meshes); linear RGB clamped to [0, 1];
//! - a ray that hits nothing: `valid = false`, colour = background, Z = 0,
//!   slopes 0, id 0;
//! - rows are rendered in parallel; every sample depends only on the scene
//!   and its own coordinates, so the output is bit-identical for any number
//!   of threads.
//!
//! Not modelled: shadows, specular or any view-dependent light, emission,
//! lens effects, anti-aliasing beyond what the caller's super-sampling does.

use super::Scene;
use super::geometry::Ray;
use bitvec::vec::BitVec;
use glam::DVec3;
use postwarp_rtl::{Camera, SampleImage};
use rayon::prelude::*;

#[derive(Clone, Copy)]
struct Sample {
    colour: [f32; 3],
    z: f32,
    slopes: [f32; 2],
    id: u32,
    valid: bool,
}

/// Render `camera` at `ss x ss` samples per pixel.
pub fn render(scene: &Scene, camera: &Camera, ss: u32) -> SampleImage {
    let cam = camera.sample_grid(ss);
    let k = cam.intrinsics;
    let (w, h) = (k.width, k.height);
    if ss == 0 || w == 0 || h == 0 {
        return SampleImage::empty(w, h);
    }
    let r = cam.pose.rotation();
    let rt = r.transpose();
    let origin = cam.pose.position;
    let miss = Sample { colour: scene.background, z: 0.0, slopes: [0.0; 2], id: 0, valid: false };
    let shade = |x: u32, y: u32| -> Sample {
        let d_cam = DVec3::new((x as f64 - k.cx) / k.fx, (y as f64 - k.cy) / k.fy, 1.0);
        let ray = Ray { origin, dir: r * d_cam };
        let Some(oh) = scene.world.closest(&ray) else { return miss };
        let hit = oh.hit;
        let object = &scene.world.objects[oh.object];
        let material = &scene.world.materials[object.material];
        let n = hit.normal;
        let n_shade = if object.shape.two_sided() && n.dot(ray.dir) > 0.0 { -n } else { n };
        let albedo = material.albedo(ray.at(hit.t), n, hit.uv);
        let light = scene.ambient + (1.0 - scene.ambient) * n_shade.dot(scene.to_light).max(0.0) as f32;
        let colour = albedo.map(|a| (a * light).clamp(0.0, 1.0));
        // Tangent plane in camera space: n_c·X = d with X = t·d_cam.
        let n_c = rt * n;
        let d = hit.t * n_c.dot(d_cam);
        let slope = |v: f64| {
            let s = v as f32;
            if s.is_finite() {
                s
            } else if s.is_nan() {
                0.0
            } else {
                f32::MAX.copysign(s)
            }
        };
        Sample {
            colour,
            z: hit.t as f32,
            slopes: [slope(n_c.x / (k.fx * d)), slope(n_c.y / (k.fy * d))],
            id: oh.object as u32 + 1,
            valid: true,
        }
    };
    let rows: Vec<Vec<Sample>> = (0..h).into_par_iter().map(|y| (0..w).map(|x| shade(x, y)).collect()).collect();
    let n = w as usize * h as usize;
    let mut img = SampleImage {
        width: w,
        height: h,
        colour: Vec::with_capacity(n),
        z: Vec::with_capacity(n),
        inv_z_slopes: Vec::with_capacity(n),
        object_id: Vec::with_capacity(n),
        valid: BitVec::with_capacity(n),
    };
    for s in rows.iter().flatten() {
        img.colour.push(s.colour);
        img.z.push(s.z);
        img.inv_z_slopes.push(s.slopes);
        img.object_id.push(s.id);
        img.valid.push(s.valid);
    }
    img
}
