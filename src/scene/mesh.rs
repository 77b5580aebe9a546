//! Triangle meshes: Wavefront OBJ loading (via `tobj`), a BVH in the mesh's
//! own coordinates, and placed instances of a mesh in the scene.
//!
//! Rules:
//! - a mesh is loaded and its BVH built once ([`MeshData`], shared by `Arc`);
//!   an instance ([`MeshInstance`]) places it by a similarity transform
//!   (rotation, uniform scale, translation) and intersects by carrying the
//!   ray into mesh coordinates. Because the ray direction is transformed
//!   along with the origin (not renormalised), the hit parameter `t` is the
//!   same in both spaces.
//! - placement: `rotate_deg = [x, y, z]` Euler angles applied x first, then
//!   y, then z (world axes); then uniform scale so the largest extent of the
//!   rotated mesh's bounding box is `size`; then translation so the centre
//!   of that box's bottom face (lowest y) lands on `position`.
//! - the normal of a hit is the triangle's geometric (face) normal, so depth
//!   slopes are exact on flat triangles; meshes are two-sided.
//! - all groups of the OBJ file are merged into one mesh; polygons are
//!   triangulated as fans; points, lines and zero-area triangles are dropped; `.mtl` material
//!   libraries are ignored (the scene file gives the material). Texture
//!   coordinates are kept only if every vertex has them.
//!
//! Not modelled: vertex normals / smooth shading, per-face materials,
//! non-uniform scale, watertight edge handling (a ray through a shared edge
//! may, very rarely, slip between two triangles).

use super::bvh::{Aabb, Bvh, RayBoxTest};
use super::geometry::{Hit, Ray, T_MIN};
use glam::{DMat3, DVec3};
use std::sync::Arc;

/// A loaded mesh in its own coordinates, with its BVH.
#[derive(Debug)]
pub struct MeshData {
    tris: Vec<[DVec3; 3]>,
    uvs: Option<Vec<[[f64; 2]; 3]>>,
    /// Vertex positions (for placement bounds).
    positions: Vec<DVec3>,
    bvh: Bvh,
}

impl MeshData {
    /// Parse OBJ text. `Err` holds a message without the file name.
    pub fn from_obj_bytes(bytes: &[u8]) -> Result<MeshData, String> {
        let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
        let load = || {
            let mut reader = std::io::BufReader::new(bytes);
            tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
        };
        // A panic in the third-party parser on a malformed file is that
        // file's error, not a crash of the tool.
        let (models, _materials) = std::panic::catch_unwind(load)
            .map_err(|_| "not a readable Wavefront OBJ file (the OBJ parser failed on it)".to_string())?
            .map_err(|e| format!("not a readable Wavefront OBJ file ({e})"))?;
        let mut positions = Vec::new();
        let mut uv_per_vertex: Vec<[f64; 2]> = Vec::new();
        let mut all_uv = true;
        let mut indices: Vec<[u32; 3]> = Vec::new();
        for m in &models {
            let mesh = &m.mesh;
            let base = positions.len() as u32;
            let nv = mesh.positions.len() / 3;
            positions.extend(mesh.positions.chunks_exact(3).map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)));
            if mesh.texcoords.len() == 2 * nv && nv > 0 {
                uv_per_vertex.extend(mesh.texcoords.chunks_exact(2).map(|t| [t[0] as f64, t[1] as f64]));
            } else {
                all_uv = false;
            }
            for f in mesh.indices.chunks_exact(3) {
                if f.iter().any(|&i| i as usize >= nv) {
                    return Err(format!("face refers to vertex {} of {nv}", f.iter().max().unwrap_or(&0) + 1));
                }
                indices.push([base + f[0], base + f[1], base + f[2]]);
            }
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err("the OBJ file has a non-finite vertex coordinate".into());
        }
        // Zero-area triangles have no normal and can never be seen: drop them.
        indices.retain(|f| {
            let [a, b, c] = f.map(|i| positions[i as usize]);
            (b - a).cross(c - a).length_squared() > 0.0
        });
        if indices.is_empty() {
            return Err("the OBJ file has no faces (of non-zero area)".into());
        }
        let tris: Vec<[DVec3; 3]> = indices.iter().map(|f| f.map(|i| positions[i as usize])).collect();
        let uvs = all_uv.then(|| indices.iter().map(|f| f.map(|i| uv_per_vertex[i as usize])).collect());
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
        let bvh = Bvh::build(&boxes);
        Ok(MeshData { tris, uvs, positions, bvh })
    }

    /// Number of triangles.
    #[cfg(test)]
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// True if every triangle has texture coordinates.
    pub fn has_uv(&self) -> bool {
        self.uvs.is_some()
    }

    /// Nearest hit in mesh coordinates: `(t, triangle, barycentric u, v)`.
    fn closest(&self, ray: &Ray, t_max: f64) -> Option<(f64, u32, f64, f64)> {
        let test = RayBoxTest::new(ray.origin, ray.dir);
        let mut best = None;
        self.bvh.closest(&test, t_max, |i, t_max| {
            let (t, u, v) = intersect_triangle(&self.tris[i as usize], ray, t_max)?;
            best = Some((t, i, u, v));
            Some(t)
        });
        best
    }
}

/// Möller–Trumbore, both faces: `(t, u, v)` for a hit in `(T_MIN, t_max)`.
fn intersect_triangle(tri: &[DVec3; 3], ray: &Ray, t_max: f64) -> Option<(f64, f64, f64)> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - tri[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > T_MIN && t < t_max).then_some((t, u, v))
}

/// A mesh placed in the scene.
#[derive(Clone, Debug)]
pub struct MeshInstance {
    data: Arc<MeshData>,
    /// Mesh-to-world rotation.
    rot: DMat3,
    scale: f64,
    translate: DVec3,
    bounds: Aabb,
}

impl MeshInstance {
    /// Place `data`: rotate by `rotate_deg` (x, then y, then z), scale so the
    /// largest bounding-box extent is `size` (> 0), put the centre of the
    /// bottom face of the box at `position`. `Err` if the mesh is flat to a
    /// point.
    pub fn new(data: Arc<MeshData>, rotate_deg: DVec3, size: f64, position: DVec3) -> Result<MeshInstance, String> {
        let r = rotate_deg * (std::f64::consts::PI / 180.0);
        let rot = DMat3::from_rotation_z(r.z) * DMat3::from_rotation_y(r.y) * DMat3::from_rotation_x(r.x);
        let b = Aabb::from_points(data.positions.iter().map(|&p| rot * p));
        let extent = (b.max - b.min).max_element();
        if extent.is_nan() || extent <= 0.0 {
            return Err("the mesh has zero extent".into());
        }
        let scale = size / extent;
        let bottom = DVec3::new(0.5 * (b.min.x + b.max.x), b.min.y, 0.5 * (b.min.z + b.max.z));
        let translate = position - bottom * scale;
        let bounds = Aabb { min: b.min * scale + translate, max: b.max * scale + translate };
        Ok(MeshInstance { data, rot, scale, translate, bounds })
    }

    /// World bounding box.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// True if the mesh has texture coordinates.
    pub fn has_uv(&self) -> bool {
        self.data.has_uv()
    }

    /// Intersect; the normal is the world-space face normal.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let inv = self.rot.transpose();
        let local = Ray { origin: inv * (ray.origin - self.translate) / self.scale, dir: inv * ray.dir / self.scale };
        let (t, i, u, v) = self.data.closest(&local, t_max)?;
        let tri = &self.data.tris[i as usize];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let normal = (self.rot * n).normalize();
        let uv = self.data.uvs.as_ref().map(|uvs| {
            let w = &uvs[i as usize];
            let b0 = 1.0 - u - v;
            [b0 * w[0][0] + u * w[1][0] + v * w[2][0], b0 * w[0][1] + u * w[1][1] + v * w[2][1]]
        });
        Some(Hit { t, normal, uv })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD: &str = "v 0 0 0\nv 2 0 0\nv 2 0 1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";

    #[test]
    fn quad_is_triangulated_placed_and_hit() {
        let data = Arc::new(MeshData::from_obj_bytes(QUAD.as_bytes()).unwrap());
        assert_eq!(data.triangle_count(), 2);
        assert!(data.has_uv());
        // Size 4: x extent 2 → scale 2; bottom-face centre (1, 0, 0.5)·2 goes to (10, 1, 0).
        let m = MeshInstance::new(data, DVec3::ZERO, 4.0, DVec3::new(10.0, 1.0, 0.0)).unwrap();
        assert_eq!(m.bounds().min, DVec3::new(8.0, 1.0, -1.0));
        let h = m.intersect(&Ray { origin: DVec3::new(9.0, 5.0, 0.0), dir: DVec3::new(0.0, -2.0, 0.0) }, 1e9).unwrap();
        assert!((h.t - 2.0).abs() < 1e-12);
        assert!((h.normal.y.abs() - 1.0).abs() < 1e-12);
        let uv = h.uv.unwrap();
        assert!((uv[0] - 0.25).abs() < 1e-12 && (uv[1] - 0.5).abs() < 1e-12, "{uv:?}");
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        assert!(MeshData::from_obj_bytes(b"v 0 0 0\n").is_err());
        assert!(MeshData::from_obj_bytes(b"v 0 0 0\nf 1 2 3\n").is_err());
        assert!(MeshData::from_obj_bytes(b"v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n").is_err());
    }
}
