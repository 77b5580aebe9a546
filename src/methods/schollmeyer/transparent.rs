//! Schollmeyer et al.'s warp of semi-transparent surfaces (seed 000, TVCG
//! 2017, §3, §4.2, §5.3 and Fig. 7) and the paper's two baselines, as
//! reconstructions over a v2 trace's fragment layers:
//!
//! - `schollmeyer-transparent` (Fig. 7e): the adaptive grid warp
//!   (`schollmeyer-irregular`) of the *opaque* pixels (the fragment
//!   layer's opaque colour, the reference depth), the low-pass hole fill,
//!   then per derived sample a ray cast through each reference's min-max
//!   quadtree of fragments (`minmax`), the hits composited front to back
//!   over the filled opaque colour ("in the first stage, the adaptive warp
//!   grid is used to reproject all opaque geometry. In the second stage,
//!   the intermediate result is passed to a low-pass filter ... Finally, a
//!   ray is generated for each pixel and intersected with the fragments
//!   stored in the A-Buffer to gather and blend all semi-transparent
//!   objects");
//! - `schollmeyer-glass-depth` (Fig. 7d, "if semi-transparent geometry
//!   contributed to the depth buffer as well"): the grid warp of the
//!   composited colour with the depth of each sample's nearest fragment
//!   where it has one;
//! - the other baseline (Fig. 7c, "conventional image warping based on
//!   depth values written only by opaque geometry") is
//!   `schollmeyer-irregular` itself on the same trace: the composited
//!   colour at the opaque depth is what a v2 reference image holds.
//!
//! Rules (besides `grid` and `minmax`):
//! 1. Rays: one per derived sample and reference, from the derived centre
//!    of projection through the sample centre to the depth of the grid
//!    warp's surface there (`t_far` = 1/`inv_z` of a real sample;
//!    unbounded for hole-filled and empty samples).
//! 2. Hits of all references are merged in derived depth; a hit within
//!    the box thickness (rule 4 of `minmax`, in derived depth) of the last
//!    kept one is the same surface seen from another reference and is
//!    dropped (the earlier in derived depth is kept).
//! 3. Compositing front to back: `C = Σ T_k α_k c_k + T·C_opaque`,
//!    stopping (and dropping the rest, `T·C_opaque` included) once the
//!    accumulated opacity `1 − T` reaches [`OPACITY_THRESHOLD`]. The
//!    sample keeps the opaque surface's depth and its `real`/`hole` flags
//!    (semi-transparent surfaces write no depth).
//! 4. On a trace without fragment layers both methods are
//!    `schollmeyer-irregular`.
//!
//! Parameters (the paper leaves them open; our choices): extrusion
//! half-thickness [`EXTRUSION`] κ = 1 % of the fragment's depth (covers a
//! surface seen up to about 77° from its normal at 2x2 super-sampling: its
//! depth changes by less than κ·Z over half a sample); opacity threshold
//! [`OPACITY_THRESHOLD`] = 0.99; quadtree top level 32x32 samples (the
//! paper's maximum node size).
//!
//! Primitives: quadtree cells visited, over all rays (the work of Fig.
//! 7b); the grid warp's cells drawn are `grid_primitives`.
//!
//! Counters (`extra`): `rays` (rays cast with a segment in a reference's
//! view), `cells_per_ray` (mean), `fragment_hits` (hits composited),
//! `grid_primitives`, and the grid's counters.
//!
//! Not modelled: per-fragment programmable transparency (fragments carry a
//! fixed colour and opacity), the paper's cyclops set-up (every reference
//! is cast, rule 2), the GPU's linked-list memory layout.

use super::grid::Schollmeyer;
use super::minmax::{self, MinMaxQuadtree, Segment};
use super::quadtree::Reduction;
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, HoleFill, Input, MethodInfo, Prepared, Reconstruction};
use crate::trace::layers::{FragmentLayer, Layers};
use postwarp_rtl::{Camera, SampleImage};
use serde_json::{Value, json};

/// Fragment extrusion κ: half-thickness of a fragment's box, relative to
/// its depth (rule 4 of `minmax`).
pub const EXTRUSION: f64 = 0.01;
/// Accumulated opacity at which a ray stops (rule 3).
pub const OPACITY_THRESHOLD: f64 = 0.99;

/// Which of the paper's three warps of Fig. 7.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Fig. 7e: A-buffer ray casting.
    RayCast,
    /// Fig. 7d: semi-transparent surfaces write depth.
    GlassDepth,
}

/// `schollmeyer-transparent` or `schollmeyer-glass-depth`.
pub struct SchollmeyerTransparent {
    mode: Mode,
    grid: Schollmeyer,
}

impl SchollmeyerTransparent {
    /// The method of `mode`.
    pub fn new(mode: Mode) -> Self {
        SchollmeyerTransparent { mode, grid: Schollmeyer::new(Reduction::Irregular) }
    }
}

/// Per reference: the image the grid warps, its grid, the fragments.
struct Prep {
    image: SampleImage,
    grid: Prepared,
    fragments: Option<(FragmentLayer, MinMaxQuadtree)>,
}

impl SchollmeyerTransparent {
    fn prep<'a>(input: &'a Input) -> Vec<&'a Prep> {
        input.prepared.iter().map(|p| p.downcast_ref::<Prep>().expect("prepared by schollmeyer-transparent")).collect()
    }

    /// Rules 1–3 over `out` (after the grid warp and the fill).
    fn cast_all(&self, input: &Input, preps: &[&Prep], out: &mut DestPlanes) -> Counters {
        let ss = input.cmd.supersample;
        let cam = input.cmd.derived_camera.sample_grid(ss);
        let origin = cam.pose.position;
        let (mut rays, mut cells, mut hits_used) = (0u64, 0u64, 0u64);
        let mut hits = Vec::new();
        for y in 0..out.height {
            for x in 0..out.width {
                let i = y as usize * out.width as usize + x as usize;
                let t_far = if out.real[i] && out.inv_z[i] > 0.0 { 1.0 / out.inv_z[i] as f64 } else { f64::INFINITY };
                let dir = cam.ray_direction(x as f64, y as f64);
                hits.clear();
                for (j, p) in preps.iter().enumerate() {
                    let Some((layer, tree)) = &p.fragments else { continue };
                    let ref_cam = input.cmd.warps[j].reference_camera;
                    let Some(seg) = Segment::new(origin, dir, t_far, &ref_cam) else { continue };
                    rays += 1;
                    let c = minmax::cast(&seg, tree, layer, EXTRUSION, OPACITY_THRESHOLD);
                    cells += c.cells_visited;
                    hits.extend(c.hits.into_iter().filter(|h| h.derived_depth < t_far).map(|h| (h, j)));
                }
                if hits.is_empty() {
                    continue;
                }
                hits.sort_by(|a, b| a.0.derived_depth.total_cmp(&b.0.derived_depth).then(a.1.cmp(&b.1)));
                let (mut c, mut t) = ([0.0f64; 3], 1.0f64);
                let mut last: Option<f64> = None;
                let mut stopped = false;
                for (h, _) in &hits {
                    let d = h.derived_depth;
                    if last.is_some_and(|l| (d - l).abs() <= EXTRUSION * (d + l)) {
                        continue;
                    }
                    last = Some(d);
                    let a = h.fragment.alpha as f64;
                    for (ck, fk) in c.iter_mut().zip(h.fragment.colour) {
                        *ck += t * a * fk as f64;
                    }
                    t *= 1.0 - a;
                    hits_used += 1;
                    if 1.0 - t >= OPACITY_THRESHOLD {
                        stopped = true;
                        break;
                    }
                }
                let behind = if stopped { [0.0; 3] } else { out.colour[i] };
                out.colour[i] = std::array::from_fn(|k| (c[k] + t * behind[k] as f64) as f32);
            }
        }
        let mut extra = serde_json::Map::new();
        extra.insert("rays".into(), json!(rays));
        extra.insert("cells_per_ray".into(), json!(if rays > 0 { cells as f64 / rays as f64 } else { 0.0 }));
        extra.insert("fragment_hits".into(), json!(hits_used));
        Counters { primitives: cells, extra }
    }

    /// The grid warp of the prepared images, with `fill` between if given.
    fn grid_warp(&self, input: &Input, fill: Option<&dyn HoleFill>, out: &mut DestPlanes) -> (Counters, Counters) {
        let preps = Self::prep(input);
        let images: Vec<&SampleImage> = preps.iter().map(|p| &p.image).collect();
        let grids: Vec<&Prepared> = preps.iter().map(|p| &p.grid).collect();
        let inner = Input { cmd: input.cmd, refs: &images, prepared: &grids };
        match fill {
            Some(f) => self.grid.reconstruct_and_fill(&inner, f, out),
            None => (self.grid.reconstruct(&inner, out), Counters::default()),
        }
    }

    /// Per-reference work: the image the grid warps (module doc), its grid
    /// and, for the ray cast, the fragments and their quadtree.
    fn prepare_with(&self, img: &SampleImage, layers: &Layers, ss: u32) -> Prepared {
        let mut image = img.clone();
        let mut fragments = None;
        if let Some(f) = &layers.fragments {
            match self.mode {
                Mode::RayCast => {
                    image.colour.clone_from(&f.opaque);
                    fragments = Some((f.clone(), MinMaxQuadtree::build(f)));
                }
                Mode::GlassDepth => {
                    for i in 0..image.len() {
                        if let Some(first) = f.at(i).first() {
                            image.z[i] = first.z;
                            image.valid.set(i, true);
                        }
                    }
                    image.slopes_from_depth();
                }
            }
        }
        let grid = self.grid.prepare(&image, ss);
        Box::new(Prep { image, grid, fragments })
    }

    /// The grid's counters, with its primitives as `grid_primitives`, and
    /// the cast's on top.
    fn merge(&self, grid: Counters, cast: Option<Counters>) -> Counters {
        let mut extra = grid.extra;
        extra.insert("grid_primitives".into(), Value::from(grid.primitives));
        match cast {
            None => Counters { primitives: grid.primitives, extra },
            Some(c) => {
                extra.extend(c.extra);
                Counters { primitives: c.primitives, extra }
            }
        }
    }
}

impl Reconstruction for SchollmeyerTransparent {
    fn info(&self) -> MethodInfo {
        match self.mode {
            Mode::RayCast => MethodInfo {
                name: "schollmeyer-transparent",
                description: "Schollmeyer A-buffer ray casting: grid warp of the opaque pixels, low-pass fill, then transparent fragments ray cast through a min-max depth quadtree and composited front to back",
                paper: "000 Schollmeyer et al. TVCG 2017 §4.2, §5.3, Fig. 7e",
                primitive: "quadtree cells visited",
                default_hole_fill: "low-pass",
            },
            Mode::GlassDepth => MethodInfo {
                name: "schollmeyer-glass-depth",
                description: "baseline of Schollmeyer Fig. 7d: grid warp of the composited colour where semi-transparent surfaces write depth (nearest fragment)",
                paper: "000 Schollmeyer et al. TVCG 2017 §5.3, Fig. 7d",
                primitive: "cells",
                default_hole_fill: "low-pass",
            },
        }
    }

    fn prepare(&self, img: &SampleImage, ss: u32) -> Prepared {
        self.prepare_with(img, &Layers::default(), ss)
    }

    fn prepare_layers(&self, img: &SampleImage, layers: &Layers, _camera: &Camera, ss: u32) -> Prepared {
        self.prepare_with(img, layers, ss)
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let (g, _) = self.grid_warp(input, None, out);
        let cast = (self.mode == Mode::RayCast).then(|| self.cast_all(input, &Self::prep(input), out));
        self.merge(g, cast)
    }

    fn reconstruct_and_fill(&self, input: &Input, fill: &dyn HoleFill, out: &mut DestPlanes) -> (Counters, Counters) {
        let (g, f) = self.grid_warp(input, Some(fill), out);
        let cast = (self.mode == Mode::RayCast).then(|| self.cast_all(input, &Self::prep(input), out));
        (self.merge(g, cast), f)
    }
}
