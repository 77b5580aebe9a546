//! Schollmeyer et al. (seed 000, TVCG 2017) as comparison methods: the
//! surface-estimation quadtree's three reductions, the adaptive grid warp
//! and the depth-aware low-pass hole fill (`docs/methods/schollmeyer.md`).
//! Scenes are exact fronto-parallel layers (`common`) or random
//! piecewise-planar depth images.

use postwarp::golden::planes::DestPlanes;
use postwarp::methods::schollmeyer::grid::{Grid, Schollmeyer};
use postwarp::methods::schollmeyer::low_pass_fill::LowPass;
use postwarp::methods::schollmeyer::quadtree::{Cell, QuadtreeParams, Reduction, estimate};
use postwarp::methods::{self, HoleFill, Input, NoFill, Prepared, Reconstruction};
use postwarp_rtl::{Camera, FrameCommands, SampleImage};
use proptest::prelude::*;

use crate::common;
use crate::common::*;

/// A sample image whose 1/Z is `inv_z(x, y)` (`None`: no surface).
fn depth_image(w: u32, h: u32, inv_z: impl Fn(u32, u32) -> Option<f64>) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for y in 0..h {
        for x in 0..w {
            if let Some(d) = inv_z(x, y) {
                let i = img.index(x, y);
                img.z[i] = (1.0 / d) as f32;
                img.valid.set(i, true);
            }
        }
    }
    img
}

/// Each sample with a surface is in exactly one cell, others in none.
fn assert_partition(img: &SampleImage, cells: &[Cell]) -> Result<(), TestCaseError> {
    let mut hits = vec![0u32; img.len()];
    for c in cells {
        for y in c.y0..c.y1 {
            for x in c.x0..c.x1 {
                hits[img.index(x, y)] += 1;
            }
        }
    }
    for (i, &n) in hits.iter().enumerate() {
        prop_assert_eq!(n, img.valid[i] as u32, "sample {}", i);
    }
    Ok(())
}

/// A plane `1/Z = a + bx·x + by·y` over a rectangle of the image (fractions
/// of its size), or a rectangle without surface.
#[derive(Clone, Debug)]
struct Patch {
    a: f64,
    bx: f64,
    by: f64,
    rect: (f64, f64, f64, f64),
    empty: bool,
}

fn patch() -> impl Strategy<Value = Patch> {
    (0.05f64..1.0, -0.01f64..0.01, -0.01f64..0.01, (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0), 0u8..8)
        .prop_map(|(a, bx, by, (x0, x1, y0, y1), e)| Patch {
            a,
            bx,
            by,
            rect: (x0.min(x1), x0.max(x1), y0.min(y1), y0.max(y1)),
            empty: e == 0,
        })
}

/// A random piecewise-planar depth image: a base plane, later patches on top.
fn piecewise_planar() -> impl Strategy<Value = SampleImage> {
    (2u32..48, 2u32..48, patch(), prop::collection::vec(patch(), 0..6)).prop_map(|(w, h, base, patches)| {
        let base = Patch { empty: false, ..base };
        depth_image(w, h, |x, y| {
            let (fx, fy) = (x as f64 / w as f64, y as f64 / h as f64);
            let mut p = &base;
            for q in &patches {
                if fx >= q.rect.0 && fx < q.rect.1 && fy >= q.rect.2 && fy < q.rect.3 {
                    p = q;
                }
            }
            let d = (p.a + p.bx * x as f64 + p.by * y as f64).max(0.01);
            (!p.empty).then_some(d)
        })
    })
}

proptest! {
    #![proptest_config(common::prop_config(48))]

    /// §4.1: the reductions are extensions of each other: irregular never
    /// yields more cells than partial, partial never more than cross; each
    /// grid covers every sample with a surface exactly once.
    #[test]
    fn irregular_le_partial_le_cross(img in piecewise_planar(), tile in prop::sample::select(vec![2u32, 4, 8, 32])) {
        let params = QuadtreeParams { tile, ..QuadtreeParams::default() };
        let [cross, partial, irregular] = Reduction::ALL.map(|r| estimate(&img, r, &params));
        for e in [&cross, &partial, &irregular] {
            assert_partition(&img, &e.cells)?;
        }
        prop_assert!(irregular.cells.len() <= partial.cells.len(), "{} > {}", irregular.cells.len(), partial.cells.len());
        prop_assert!(partial.cells.len() <= cross.cells.len(), "{} > {}", partial.cells.len(), cross.cells.len());
        prop_assert_eq!(cross.counts.rects + partial.counts.rects, 0);
    }
}

#[test]
fn a_single_plane_collapses_to_one_cell_per_tile() {
    // 128x96 samples of a slanted plane: 4 x 3 tiles of 32x32.
    let img = depth_image(128, 96, |x, y| Some(0.2 + 0.001 * x as f64 + 0.0005 * y as f64));
    for r in Reduction::ALL {
        let e = estimate(&img, r, &QuadtreeParams::default());
        assert_eq!(e.cells.len(), 12, "{r:?}");
    }
    // A fronto-parallel wall, ray cast.
    let wall = render(&at_x(32, 16, 0.0), 2, &[Layer { z: 4.0, x0: -100.0, x1: 100.0, colour: grey_stripes }]);
    for r in Reduction::ALL {
        assert_eq!(estimate(&wall, r, &QuadtreeParams::default()).cells.len(), 2, "{r:?}");
    }
}

fn two_layers() -> [Layer; 2] {
    [Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: grey_stripes }, Layer { z: 3.0, x0: -0.3, x1: 0.2, colour: red }]
}

/// Run `rec` + `fill` on one derived camera from references `refs`.
fn warp(
    rec: &dyn Reconstruction,
    fill: &dyn HoleFill,
    derived: &Camera,
    refs: &[(Camera, SampleImage)],
    ss: u32,
) -> methods::MethodFrame {
    let cams: Vec<(usize, Camera)> = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
    let cmd = FrameCommands::new(0, *derived, ss, &cams);
    let prepared: Vec<Prepared> = refs.iter().map(|(_, img)| rec.prepare(img, ss)).collect();
    let p: Vec<&Prepared> = prepared.iter().collect();
    let imgs: Vec<&SampleImage> = refs.iter().map(|(_, img)| img).collect();
    let input = Input { cmd: &cmd, refs: &imgs, prepared: &p };
    methods::render(rec, fill, &input, input.empty_frame())
}

#[test]
fn a_depth_step_is_never_bridged_by_a_cell() {
    let cam = at_x(40, 20, 0.0);
    let img = render(&cam, 2, &two_layers());
    for r in Reduction::ALL {
        let grid = Grid::new(&img, r, &QuadtreeParams::default());
        for gc in &grid.cells {
            let c = gc.cell;
            let layer = img.object_id[img.index(c.x0, c.y0)];
            let want = 1.0 / img.z[img.index(c.x0, c.y0)] as f64;
            for y in c.y0..c.y1 {
                for x in c.x0..c.x1 {
                    assert_eq!(img.object_id[img.index(x, y)], layer, "{r:?}: cell {c:?} spans the step");
                }
            }
            for &v in &gc.v {
                let v = grid.vertices[v as usize];
                assert!(
                    (v.inv_z / want - 1.0).abs() < 1e-6,
                    "{r:?}: cell {c:?} vertex {v:?} takes another layer's depth"
                );
            }
        }
        // Warped with parallax (the near layer moves 4x as far as the far
        // one), no derived sample lies between the layers: no rubber sheet.
        for x in [-0.15, 0.15] {
            let f = warp(&Schollmeyer::new(r), &NoFill, &at_x(40, 20, x), &[(cam, img.clone())], 2);
            let mut holes = 0;
            for i in 0..f.samples.len() {
                if !f.samples.real[i] {
                    holes += 1;
                    continue;
                }
                let z = 1.0 / f.samples.inv_z[i];
                assert!((z - 3.0).abs() < 1e-3 || (z - 10.0).abs() < 1e-3, "{r:?} x {x}: sample {i} at Z = {z}");
            }
            assert!(holes > 20, "{r:?} x {x}: a disocclusion opens ({holes} holes)");
        }
    }
}

#[test]
fn vertices_at_a_discontinuity_sit_on_pixels() {
    // The near layer's edges are vertical steps: at a corner with both
    // layers around it, the vertex takes only its own layer's samples and
    // its depth is fetched on the pixel column, never between the layers.
    let cam = at_x(40, 20, 0.0);
    let img = render(&cam, 2, &two_layers());
    let (w, h) = (img.width as i64, img.height as i64);
    let layer = |x: i64, y: i64| (x >= 0 && y >= 0 && x < w && y < h).then(|| img.object_id[(y * w + x) as usize]);
    for r in Reduction::ALL {
        let grid = Grid::new(&img, r, &QuadtreeParams::default());
        let mut at_step = 0;
        for gc in &grid.cells {
            for &vi in &gc.v {
                let v = grid.vertices[vi as usize];
                let (cx, cy) = ((v.pos.x + 0.5) as i64, (v.pos.y + 0.5) as i64);
                let around = [(cx - 1, cy - 1), (cx, cy - 1), (cx - 1, cy), (cx, cy)].map(|(x, y)| layer(x, y));
                let layers: Vec<u32> = around.iter().flatten().copied().collect();
                if !layers.iter().any(|&l| l != layers[0]) {
                    continue;
                }
                at_step += 1;
                assert_eq!(v.fetch.x.fract(), 0.0, "{r:?}: vertex {v:?} fetches between the layers");
                let own: Vec<u32> =
                    (0..4).filter(|k| v.component & (1 << k) != 0).map(|k| around[k].unwrap()).collect();
                assert!(own.iter().all(|&l| l == own[0]), "{r:?}: vertex {v:?} joins both layers");
            }
        }
        assert!(at_step >= 4 * 20, "{r:?}: {at_step} vertices at the steps");
    }
}

fn blue(_: f64) -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

#[test]
fn low_pass_fills_a_disocclusion_with_background() {
    // A red near layer over a blue far one; the derived camera moves right,
    // so a disocclusion opens between the red layer and the blue one
    // (plus a strip at the image border no reference saw).
    let layers =
        [Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: blue }, Layer { z: 2.0, x0: -0.2, x1: 0.2, colour: red }];
    let cam = at_x(32, 24, 0.0);
    let img = render(&cam, 2, &layers);
    let derived = at_x(32, 24, 0.2);
    let rec = Schollmeyer::new(Reduction::Irregular);
    let bare = warp(&rec, &NoFill, &derived, &[(cam, img.clone())], 2);
    let d = &bare.samples;
    let w = d.width as usize;
    // Holes with real samples on both sides of their row: inside the image.
    let inner = (0..d.len())
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            !d.real[i] && (0..x).any(|k| d.real[y * w + k]) && (x + 1..w).any(|k| d.real[y * w + k])
        })
        .count();
    assert!(inner >= 7 * 48, "disocclusion of {inner} samples");
    let filled = warp(&rec, &LowPass, &derived, &[(cam, img)], 2);
    let f = &filled.samples;
    for i in 0..f.len() {
        assert!(f.real[i] || f.hole[i], "sample {i} left empty");
        if f.hole[i] {
            let c = f.colour[i];
            assert!(c[0] < 0.02 && c[2] > 0.98, "sample {i} filled with {c:?}, not the blue background");
        }
    }
    assert_eq!(f.hole.count_ones(), d.real.count_zeros());
}

#[test]
fn low_pass_never_changes_real_samples() {
    let cam = at_x(40, 20, 0.0);
    let refs =
        [(at_x(40, 20, -0.2), render(&at_x(40, 20, -0.2), 2, &two_layers())), (cam, render(&cam, 2, &two_layers()))];
    for derived in [at_x(40, 20, 0.3), at_x(40, 20, -0.4)] {
        let rec = Schollmeyer::new(Reduction::Partial);
        let bare = warp(&rec, &NoFill, &derived, &refs, 2).samples;
        let cams: Vec<(usize, Camera)> = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
        let cmd = FrameCommands::new(0, derived, 2, &cams);
        let imgs: Vec<&SampleImage> = refs.iter().map(|(_, img)| img).collect();
        let prepared: Vec<Prepared> = refs.iter().map(|(_, img)| rec.prepare(img, 2)).collect();
        let p: Vec<&Prepared> = prepared.iter().collect();
        let input = Input { cmd: &cmd, refs: &imgs, prepared: &p };
        let mut d: DestPlanes = bare.clone();
        let counters = LowPass.fill(&input, &mut d);
        assert!(bare.real.count_zeros() > 0, "the scene has holes");
        assert_eq!(d.real, bare.real);
        for i in bare.real.iter_ones() {
            assert_eq!((d.colour[i], d.inv_z[i], d.source[i]), (bare.colour[i], bare.inv_z[i], bare.source[i]));
            assert!(!d.hole[i]);
        }
        assert_eq!(d.hole.count_ones(), bare.real.count_zeros(), "{counters:?}");
    }
}

#[test]
fn registered_with_the_low_pass_fill_as_default() {
    for name in ["schollmeyer-cross", "schollmeyer-partial", "schollmeyer-irregular"] {
        let m = methods::reconstruction(name).unwrap();
        assert_eq!(m.info().default_hole_fill, "low-pass");
        assert_eq!(m.info().primitive, "cells");
    }
    assert_eq!(methods::hole_fill("low-pass").unwrap().info().name, "low-pass");
}

#[test]
fn texture_filtering_is_linear_on_surfaces_and_nearest_at_steps() {
    // A sub-sample shift (the far layer moves 0.1 samples, the near one
    // 0.33): lookups fall between reference samples. Inside a layer they
    // are bilinear; next to the step the nearest sample of the cell's own
    // layer is read, so no derived sample mixes red with grey.
    let cam = at_x(40, 20, 0.0);
    let img = render(&cam, 2, &two_layers());
    for r in Reduction::ALL {
        let f = warp(&Schollmeyer::new(r), &NoFill, &at_x(40, 20, 0.01), &[(cam, img.clone())], 2);
        let extra = &f.reconstruction.extra;
        let count = |k: &str| extra[k].as_u64().unwrap_or_else(|| panic!("{r:?}: no counter {k}"));
        assert!(count("linear_fragments") > 1000, "{r:?}: {extra:?}");
        assert!(count("nearest_fragments") > 0, "{r:?}: {extra:?}");
        let mut mixed_grey = 0;
        for i in 0..f.samples.len() {
            if !f.samples.real[i] {
                continue;
            }
            let [cr, cg, cb] = f.samples.colour[i];
            let red = cr == 1.0 && cg == 0.0 && cb == 0.0;
            let grey = cr == cg && cg == cb;
            assert!(red || grey, "{r:?}: sample {i} mixes the layers: {:?}", f.samples.colour[i]);
            // Bilinear inside the striped far layer gives greys between
            // its two stripe values.
            mixed_grey += (grey && cr > 0.3 + 1e-4 && cr < 0.5 - 1e-4) as u32;
        }
        assert!(mixed_grey > 0, "{r:?}: no interpolated grey: linear filtering did not happen");
    }
}
