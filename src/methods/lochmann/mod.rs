//! Lochmann et al.'s reflective and refractive novel-view synthesis (seed
//! 004, VMV 2014) over a v2 trace's ray-tree layers, and the paper's naïve
//! baseline:
//!
//! - `lochmann-raytree`: per reference, decode the ray tree (`decode`:
//!   diffuse positions, normals rebuilt with the 7x7 Gaussian, reflected
//!   and refracted positions); per derived frame, the diffuse flow by
//!   splatting with the 3x3 nearest-to-camera closing and one fixed-point
//!   step (`flow`), the diffuse node gathered along it, then for each
//!   of the reflection and refraction nodes the specular flow by gradient
//!   descent (`specular`), a pull-push fill of that node that "skips
//!   pulling and pushing from and to invalid pixels", and the composite
//!   "weighted by the Fresnel terms computed from the view position, the
//!   normals and the IORs" of the new view, hole-filled by the frame's
//!   hole fill (the paper's pull-push by default);
//! - `lochmann-naive`: the same diffuse flow and fill applied to the
//!   reference image's composited colour ("naïve diffuse warping", Fig. 7
//!   left): every reflection and refraction moves with the surface that
//!   shows it.
//!
//! Rules:
//! 1. Both warp every reference of the frame (the paper's one ray tree per
//!    frame is the first; the splat's depth test merges the others).
//! 2. A node exists at a derived sample iff the diffuse flow reached it
//!    (a real sample, not hole fill) and the node is valid at its source
//!    sample; elsewhere it is *undefined*: neither data nor a target of
//!    its pull-push. Diffuse holes are filled after the composite (rule
//!    4), by the frame's hole fill over the composited colour, as the naïve
//!    warp's are: a mirror disoccluded in every reference takes the
//!    composited colour of the mirror around it, not its (black) diffuse
//!    part.
//! 3. Gathers: the diffuse node's colour and position at the flow's
//!    sub-sample location are the bilinear mix of the four samples around
//!    it that lie on the source sample's surface (a diffuse depth within
//!    [`SAME_SURFACE`] of it; the source sample alone if none other does);
//!    a specular node's colour at the descent's location is the bilinear
//!    mix of its four samples there that have the node (none: undefined).
//! 4. Composite per derived sample with a real diffuse sample: `diffuse +
//!    w_r·reflection + w_t·refraction`, clamped to [0, 1]; `(w_r, w_t)` are
//!    1 and 0 for a `mirror` material, the Fresnel terms of the new view
//!    direction and the rebuilt normal for a dielectric.
//! 5. On a trace without ray-tree layers `lochmann-raytree` is the diffuse
//!    flow of the reference image (= `lochmann-naive`).
//!
//! Primitives: `lochmann-raytree` counts gradient steps (rule 4 of
//! `specular`, over both nodes); `lochmann-naive` counts splats.
//!
//! Counters (`extra`): `splats`, `fpi_rejected` (`flow`),
//! `reflect_samples`, `refract_samples` (derived samples descended),
//! `reflect_accepted`, `refract_accepted` (within ε),
//! `gradient_steps_per_specular_sample`, `node_fill_filled` (node samples
//! pull-push filled).
//!
//! Not modelled: deeper ray-tree nodes (the paper keeps three too), the
//! GPU's texture filtering of the gathers (nearest sample for the diffuse
//! node), compression of the stream, temporal coherence of the descent.

pub mod decode;
pub mod flow;
pub mod specular;

use crate::golden::planes::DestPlanes;
use crate::methods::hole_fills::pull_push::pull_push;
use crate::methods::{Counters, HoleFill, Input, MethodInfo, Prepared, Reconstruction};
use crate::trace::layers::{Layers, Node, RayTreeLayer, SpecularMaterial};
use decode::Decoded;
use flow::{Flow, diffuse_flow};
use glam::DVec2;
use postwarp_rtl::{Camera, SampleImage};
use serde_json::{Map, json};

/// Relative depth difference within which two neighbouring reference
/// samples count as one surface for the diffuse gather (rule 3; our
/// choice).
pub const SAME_SURFACE: f64 = 0.02;

/// Rule 3's diffuse gather at `pos` around `sample` of reference `r`:
/// (colour, diffuse position).
fn gather(r: &Decoded, colour: &[[f32; 3]], sample: usize, pos: DVec2) -> ([f32; 3], glam::DVec3) {
    let w = r.width as i64;
    let h = r.height as i64;
    let Some(centre) = r.diffuse[sample] else { return (colour[sample], glam::DVec3::ZERO) };
    let eye = r.camera.pose.position;
    let dist = (centre - eye).length();
    let (x0, y0) = (pos.x.floor() as i64, pos.y.floor() as i64);
    let (fx, fy) = (pos.x - pos.x.floor(), pos.y - pos.y.floor());
    let (mut c, mut p, mut wsum) = ([0.0f64; 3], glam::DVec3::ZERO, 0.0);
    for (dx, dy, wt) in
        [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)]
    {
        let (x, y) = (x0 + dx, y0 + dy);
        if x < 0 || y < 0 || x >= w || y >= h || wt <= 0.0 {
            continue;
        }
        let i = (y * w + x) as usize;
        let Some(q) = r.diffuse[i] else { continue };
        if ((q - eye).length() - dist).abs() > SAME_SURFACE * dist {
            continue;
        }
        wsum += wt;
        p += q * wt;
        for (ck, v) in c.iter_mut().zip(colour[i]) {
            *ck += wt * v as f64;
        }
    }
    if wsum <= 0.0 {
        return (colour[sample], centre);
    }
    (c.map(|v| (v / wsum) as f32), p / wsum)
}

/// `lochmann-raytree` (`naive = false`) or `lochmann-naive`.
pub struct Lochmann {
    naive: bool,
}

impl Lochmann {
    /// The ray-tree method.
    pub fn ray_tree() -> Self {
        Lochmann { naive: false }
    }

    /// The naïve baseline.
    pub fn naive() -> Self {
        Lochmann { naive: true }
    }
}

/// Per reference: decoded positions, the colour the diffuse flow gathers,
/// the ray tree.
pub struct Prep {
    /// `decode` rules 1–3 (`None` when prepared without the camera: then
    /// decoded per frame, inside the timed section).
    pub decoded: Option<Decoded>,
    /// The reference image (to decode per frame).
    pub image: SampleImage,
    /// Root colour (ray tree) or composited colour (naïve, v1).
    pub colour: Vec<[f32; 3]>,
    /// The ray tree (`None` for the naïve method and v1 traces).
    pub tree: Option<RayTreeLayer>,
}

/// Rule 3 at location `q` of reference `tree`'s `node`.
fn node_colour(tree: &RayTreeLayer, node: Node, q: DVec2) -> Option<[f32; 3]> {
    let (w, h) = (tree.width as i64, tree.height as i64);
    let (x0, y0) = (q.x.floor() as i64, q.y.floor() as i64);
    let (fx, fy) = (q.x - q.x.floor(), q.y - q.y.floor());
    let (mut c, mut wsum) = ([0.0f64; 3], 0.0);
    for (dx, dy, wt) in
        [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)]
    {
        let (x, y) = (x0 + dx, y0 + dy);
        if x < 0 || y < 0 || x >= w || y >= h || wt <= 0.0 {
            continue;
        }
        let i = (y * w + x) as usize;
        if !tree.has(i, node) {
            continue;
        }
        wsum += wt;
        for (ck, v) in c.iter_mut().zip(tree.nodes[node as usize].colour[i]) {
            *ck += wt * v as f64;
        }
    }
    (wsum > 0.0).then(|| c.map(|v| (v / wsum) as f32))
}

impl Lochmann {
    fn preps<'a>(input: &'a Input) -> Vec<&'a Prep> {
        input.prepared.iter().map(|p| p.downcast_ref::<Prep>().expect("prepared by a lochmann method")).collect()
    }

    /// Each reference decoded (at its warp's camera if `prepare` lacked it).
    fn decoded<'a>(input: &Input, preps: &[&'a Prep]) -> Vec<std::borrow::Cow<'a, Decoded>> {
        preps
            .iter()
            .zip(&input.cmd.warps)
            .map(|(p, w)| match &p.decoded {
                Some(d) => std::borrow::Cow::Borrowed(d),
                None => std::borrow::Cow::Owned(Decoded::new(&p.image, p.tree.as_ref(), &w.reference_camera)),
            })
            .collect()
    }

    /// The diffuse flow and the diffuse node gathered along it into `out`.
    fn diffuse(&self, input: &Input, preps: &[&Prep], dec: &[&Decoded], out: &mut DestPlanes) -> Flow {
        let derived = input.cmd.derived_camera.sample_grid(input.cmd.supersample);
        let decoded = dec;
        let flow = diffuse_flow(decoded, &derived, out.width, out.height);
        for (k, s) in flow.source.iter().enumerate() {
            let Some(s) = s else { continue };
            out.real.set(k, true);
            out.colour[k] = gather(decoded[s.reference], &preps[s.reference].colour, s.sample, s.pos).0;
            out.inv_z[k] = (1.0 / s.depth) as f32;
            out.source[k] = s.reference as u8;
        }
        flow
    }

    /// Diffuse flow, the specular nodes and composite, the fill (if any).
    fn run(&self, input: &Input, fill: Option<&dyn HoleFill>, out: &mut DestPlanes) -> (Counters, Counters) {
        let preps = Self::preps(input);
        let owned = Self::decoded(input, &preps);
        let dec: Vec<&Decoded> = owned.iter().map(|d| d.as_ref()).collect();
        let flow = self.diffuse(input, &preps, &dec, out);
        let r = if self.naive {
            Counters { primitives: flow.splats, extra: self.flow_counters(&flow) }
        } else {
            self.specular(input, &preps, &dec, &flow, out)
        };
        // Rule 2: the frame's fill runs over the composite, so a hole where a
        // mirror was hidden in every reference takes the mirror's composited
        // colour around it (not its black diffuse part).
        let f = fill.map(|f| f.fill(input, out)).unwrap_or_default();
        (r, f)
    }

    fn flow_counters(&self, flow: &Flow) -> Map<String, serde_json::Value> {
        let mut extra = Map::new();
        extra.insert("splats".into(), json!(flow.splats));
        extra.insert("fpi_rejected".into(), json!(flow.fpi_rejected));
        extra
    }

    /// The specular nodes (rules 2–4) over the diffuse `out` (before its fill).
    fn specular(
        &self,
        input: &Input,
        preps: &[&Prep],
        dec: &[&Decoded],
        flow: &Flow,
        out: &mut DestPlanes,
    ) -> Counters {
        let derived = input.cmd.derived_camera.sample_grid(input.cmd.supersample);
        let eye = derived.pose.position;
        let (w, h) = (out.width, out.height);
        let n = out.len();
        let mut extra = self.flow_counters(flow);
        let mut steps_total = 0u64;
        let mut samples_total = 0u64;
        let mut filled_total = 0u64;
        let mut nodes: Vec<(Node, DestPlanes)> = Vec::new();
        for node in [Node::Reflect, Node::Refract] {
            let mut planes = DestPlanes::new(w, h);
            let (mut samples, mut accepted) = (0u64, 0u64);
            for k in 0..n {
                let exists = flow.source[k].and_then(|s| {
                    let tree = preps[s.reference].tree.as_ref()?;
                    tree.has(s.sample, node).then_some((s, tree))
                });
                let Some((s, tree)) = exists else {
                    planes.hole.set(k, true); // undefined (rule 2)
                    continue;
                };
                let r = dec[s.reference];
                if r.diffuse[s.sample].is_none() {
                    planes.hole.set(k, true);
                    continue;
                }
                let w_d = gather(r, &preps[s.reference].colour, s.sample, s.pos).1;
                let normal = r.normal[s.sample];
                let eta = match tree.material_at(s.sample) {
                    Some(SpecularMaterial::Dielectric { ior }) => 1.0 / ior,
                    _ => 1.0,
                };
                let Some(omega) = specular::direction(node, eye, w_d, normal, eta) else {
                    planes.hole.set(k, true); // total internal reflection in the new view: weight 0
                    continue;
                };
                samples += 1;
                let depth = tree.nodes[node as usize].depth[s.sample] as f64;
                let Some(found) = specular::descend(r, node, w_d, normal, s.pos, omega, depth) else { continue };
                steps_total += found.steps as u64;
                if !found.accepted {
                    continue;
                }
                if let Some(c) = node_colour(tree, node, found.q) {
                    planes.real.set(k, true);
                    planes.colour[k] = c;
                    accepted += 1;
                }
            }
            let (filled, _, _) = pull_push(&mut planes);
            filled_total += filled;
            samples_total += samples;
            extra.insert(format!("{}_samples", node.name()), json!(samples));
            extra.insert(format!("{}_accepted", node.name()), json!(accepted));
            nodes.push((node, planes));
        }
        // Rule 4.
        for k in 0..n {
            let Some(s) = flow.source[k] else { continue };
            let Some(tree) = preps[s.reference].tree.as_ref() else { continue };
            let Some(material) = tree.material_at(s.sample) else { continue };
            let r = dec[s.reference];
            if r.diffuse[s.sample].is_none() {
                continue;
            }
            let w_d = gather(r, &preps[s.reference].colour, s.sample, s.pos).1;
            let (w_r, w_t) = material.weights((w_d - eye).normalize(), r.normal[s.sample]);
            let mut c = out.colour[k].map(f64::from);
            for (node, planes) in &nodes {
                let wt = if *node == Node::Reflect { w_r } else { w_t };
                if planes.real[k] || (planes.hole[k] && tree.has(s.sample, *node)) {
                    for (ck, v) in c.iter_mut().zip(planes.colour[k]) {
                        *ck += wt * v as f64;
                    }
                }
            }
            out.colour[k] = c.map(|v| (v as f32).clamp(0.0, 1.0));
        }
        extra.insert(
            "gradient_steps_per_specular_sample".into(),
            json!(if samples_total > 0 { steps_total as f64 / samples_total as f64 } else { 0.0 }),
        );
        extra.insert("node_fill_filled".into(), json!(filled_total));
        Counters { primitives: steps_total, extra }
    }
}

impl Reconstruction for Lochmann {
    fn info(&self) -> MethodInfo {
        if self.naive {
            MethodInfo {
                name: "lochmann-naive",
                description: "Lochmann's naive baseline: the diffuse flow (splat, 3x3 nearest closing, fixed-point check) of the composited colour, reflections moving with their surfaces",
                paper: "004 Lochmann et al. VMV 2014 §3.4, Fig. 7 (naive)",
                primitive: "splats",
                default_hole_fill: "pull-push",
            }
        } else {
            MethodInfo {
                name: "lochmann-raytree",
                description: "Lochmann RGBZ ray tree: diffuse flow, specular flow of the reflection and refraction nodes by gradient descent, pull-push per node, Fresnel composite in the new view",
                paper: "004 Lochmann et al. VMV 2014 §3.2-3.5",
                primitive: "gradient steps",
                default_hole_fill: "pull-push",
            }
        }
    }

    fn prepare(&self, img: &SampleImage, _ss: u32) -> Prepared {
        Box::new(Prep { decoded: None, image: img.clone(), colour: img.colour.clone(), tree: None })
    }

    fn prepare_layers(&self, img: &SampleImage, layers: &Layers, camera: &Camera, ss: u32) -> Prepared {
        let cam = camera.sample_grid(ss);
        let tree = if self.naive { None } else { layers.raytree.clone() };
        let decoded = Decoded::new(img, tree.as_ref(), &cam);
        let colour = match &tree {
            Some(t) => t.nodes[Node::Diffuse as usize].colour.clone(),
            None => img.colour.clone(),
        };
        Box::new(Prep { decoded: Some(decoded), image: img.clone(), colour, tree })
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        self.run(input, None, out).0
    }

    fn reconstruct_and_fill(&self, input: &Input, fill: &dyn HoleFill, out: &mut DestPlanes) -> (Counters, Counters) {
        self.run(input, Some(fill), out)
    }
}
