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
//! - semi-transparent surfaces, mirrors and refractors follow `shade.rs`:
//!   the sample's colour is the composite of its fragments over the
//!   radiance of its first surface that is not semi-transparent; depth,
//!   slopes and id are that surface's (semi-transparent surfaces write no
//!   depth, as in a deferred renderer with an A-buffer). An opaque diffuse
//!   surface seen directly is shaded exactly as before these existed, so
//!   diffuse scenes render bit for bit as they did;
//! - layers ([`render`] with the scene's materials): the first
//!   `max_fragments` fragments of each sample, nearest first, with the
//!   opaque surface's radiance behind them (fragment layer); the ray tree
//!   at that surface (`shade::Nodes`, material index from the scene's
//!   table), where a sample behind fragments has them composited over its
//!   root node and their transmittance multiplied into its child nodes
//!   (view-independent, like a tint), so that the root plus the
//!   Fresnel-weighted children is the sample's colour; the non-diffuse mask: the ray met a fragment, or its surface
//!   reflects or refracts.
//!
//! Not modelled: lens effects, anti-aliasing beyond what the caller's
//! super-sampling does.

use super::geometry::Ray;
use super::shade::{Nodes, composite};
use super::{Rendered, Scene};
use crate::trace::layers::{Fragment, FragmentLayer, Node, NodeImage, RayTreeLayer};
use bitvec::vec::BitVec;
use glam::DVec3;
use postwarp_rtl::{Camera, SampleImage};
use rayon::prelude::*;

#[derive(Clone)]
struct Sample {
    colour: [f32; 3],
    z: f32,
    slopes: [f32; 2],
    id: u32,
    valid: bool,
    /// The first `max_fragments` fragments (layer data).
    fragments: Vec<Fragment>,
    /// Radiance of the opaque surface behind the fragments.
    opaque: [f32; 3],
    /// Ray-tree nodes and material index at that surface.
    tree: Option<(Nodes, u8)>,
    nondiffuse: bool,
}

/// Render `camera` at `ss x ss` samples per pixel, with the layers the
/// scene's materials call for (`max_fragments` fragments per sample).
pub fn render(scene: &Scene, camera: &Camera, ss: u32, max_fragments: u32) -> Rendered {
    let cam = camera.sample_grid(ss);
    let k = cam.intrinsics;
    let (w, h) = (k.width, k.height);
    let (want_fragments, want_tree) = (scene.has_transparency(), scene.has_specular());
    if ss == 0 || w == 0 || h == 0 {
        return Rendered {
            samples: SampleImage::empty(w, h),
            fragments: None,
            raytree: None,
            nondiffuse: BitVec::new(),
        };
    }
    let r = cam.pose.rotation();
    let rt = r.transpose();
    let origin = cam.pose.position;
    let keep = max_fragments as usize;
    let shade = |x: u32, y: u32| -> Sample {
        let d_cam = DVec3::new((x as f64 - k.cx) / k.fx, (y as f64 - k.cy) / k.fy, 1.0);
        let ray = Ray { origin, dir: r * d_cam };
        let walk = scene.walk(&ray);
        let fragments: Vec<Fragment> = walk
            .fragments
            .iter()
            .take(keep)
            .map(|f| Fragment { colour: f.colour, alpha: f.alpha, z: f.t as f32 })
            .collect();
        let Some((t, oh, seg)) = walk.hit else {
            return Sample {
                colour: composite(&walk.fragments, scene.background),
                z: 0.0,
                slopes: [0.0; 2],
                id: 0,
                valid: false,
                fragments,
                opaque: scene.background,
                tree: None,
                nondiffuse: !walk.fragments.is_empty(),
            };
        };
        let mut nodes = scene.surface(&seg, &oh, 0);
        nodes.depth[Node::Diffuse as usize] = t as f32;
        let material = scene.specular_index(&oh);
        let colour = composite(&walk.fragments, nodes.radiance);
        let opaque = nodes.radiance;
        if !walk.fragments.is_empty() {
            // The ray tree of a sample behind fragments: the root holds them
            // composited over the diffuse part, the children carry their
            // transmittance like a tint (so root + weighted children is still
            // the sample's colour).
            let t = walk.fragments.iter().fold(1.0f32, |t, f| t * (1.0 - f.alpha));
            nodes.colour[Node::Diffuse as usize] = composite(&walk.fragments, nodes.colour[Node::Diffuse as usize]);
            for node in [Node::Reflect, Node::Refract] {
                nodes.colour[node as usize] = nodes.colour[node as usize].map(|c| c * t);
            }
        }
        let hit = oh.hit;
        let n = hit.normal;
        // Tangent plane in camera space: n_c·X = d with X = t·d_cam.
        let n_c = rt * n;
        let d = t * n_c.dot(d_cam);
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
            z: t as f32,
            slopes: [slope(n_c.x / (k.fx * d)), slope(n_c.y / (k.fy * d))],
            id: oh.object as u32 + 1,
            valid: true,
            fragments,
            opaque,
            tree: Some((nodes, material)),
            nondiffuse: !walk.fragments.is_empty() || material != 0,
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
    let mut fl = want_fragments.then(|| FragmentLayer::empty(w, h, max_fragments));
    let mut tl = want_tree.then(|| RayTreeLayer::empty(w, h, scene.specular_materials().to_vec()));
    let mut nondiffuse = BitVec::with_capacity(n);
    for (i, s) in rows.iter().flatten().enumerate() {
        img.colour.push(s.colour);
        img.z.push(s.z);
        img.inv_z_slopes.push(s.slopes);
        img.object_id.push(s.id);
        img.valid.push(s.valid);
        nondiffuse.push(s.nondiffuse);
        if let Some(fl) = &mut fl {
            fl.count[i] = s.fragments.len() as u8;
            fl.opaque[i] = s.opaque;
            let m = fl.max as usize;
            fl.fragments[i * m..i * m + s.fragments.len()].copy_from_slice(&s.fragments);
        }
        if let (Some(tl), Some((nodes, material))) = (&mut tl, &s.tree) {
            tl.valid[i] = nodes.valid;
            tl.material[i] = *material;
            for node in Node::ALL {
                let img: &mut NodeImage = &mut tl.nodes[node as usize];
                img.colour[i] = nodes.colour[node as usize];
                img.depth[i] = if nodes.valid & node.bit() != 0 { nodes.depth[node as usize] } else { 0.0 };
            }
        }
    }
    Rendered { samples: img, fragments: fl, raytree: tl, nondiffuse }
}
