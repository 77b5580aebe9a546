//! Didyk et al.'s adaptive grid warping (`didyk`, `didyk-2ref`; seed 002,
//! VMV 2010 §3.2–3.4) on constructed cases whose answers are known without
//! the method: a brute-force check of the subdivision on random depth
//! images, a constant-disparity plane, vertex depths, the two-reference
//! preference, and the exact shift of a fronto-parallel plane.

use glam::{DQuat, DVec3};
use postwarp::methods::didyk::grid::{
    Cell, DisparityMipMap, PixelDisparity, adaptive_grid, pixel_disparity, top_level,
};
use postwarp::methods::didyk::inpaint::DidykInpaint;
use postwarp::methods::didyk::{Didyk, DidykParams, TextureFilter, VertexDepths, WarpedLayer, warp_reference};
use postwarp::methods::{Input, MethodFrame, NoFill, Prepared, Reconstruction, render as run_method};
use postwarp_rtl::{Camera, FrameCommands, Intrinsics, Pose, SampleImage, WarpSetup};

use crate::common::{Layer, camera, grey_stripes, red, render};

/// xorshift64*: a tiny deterministic generator for the random images.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A camera of `w x h` pixels at `pos` turned by `yaw` degrees about y.
fn turned(w: u32, h: u32, pos: DVec3, yaw: f64) -> Camera {
    let mut c = camera(w, h, pos);
    c.pose.orientation = DQuat::from_rotation_y(yaw.to_radians());
    c
}

/// A random depth image: rectangles of constant depth, a smooth ramp, a
/// little noise, and holes with no surface.
fn random_depths(rng: &mut Rng, w: u32, h: u32) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for i in 0..img.len() {
        let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
        img.z[i] = (8.0 + 2.0 * (x / w as f64) + (y / h as f64)) as f32;
        img.valid.set(i, true);
        img.colour[i] = [rng.unit() as f32, rng.unit() as f32, rng.unit() as f32];
    }
    for _ in 0..rng.below(12) + 3 {
        let (x0, y0) = (rng.below(w as u64) as u32, rng.below(h as u64) as u32);
        let (x1, y1) =
            ((x0 + 1 + rng.below(w as u64 / 2) as u32).min(w), (y0 + 1 + rng.below(h as u64 / 2) as u32).min(h));
        let kind = rng.below(6);
        let z = [1.5, 2.0, 3.0, 5.0, 10.0][rng.below(5) as usize] as f32;
        for y in y0..y1 {
            for x in x0..x1 {
                let i = img.index(x, y);
                match kind {
                    0 => img.valid.set(i, false),
                    1 => img.z[i] = z + 0.02 * rng.unit() as f32,
                    _ => img.z[i] = z,
                }
            }
        }
    }
    img
}

/// Per-axis extent of the disparities of `cell` (∞ with an unmeasured
/// sample), and whether all / none of its samples are drawable: rule 2 by
/// brute force.
fn brute(d: &[PixelDisparity], w: u32, c: &Cell) -> (f32, bool, bool) {
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    let (mut all, mut none) = (true, true);
    for y in c.y0..c.y1 {
        for x in c.x0..c.x1 {
            match d[(y * w + x) as usize] {
                PixelDisparity::None => all = false,
                PixelDisparity::Unmeasured => {
                    none = false;
                    lo = [f32::NEG_INFINITY; 2];
                    hi = [f32::INFINITY; 2];
                }
                PixelDisparity::At(v) => {
                    none = false;
                    for a in 0..2 {
                        lo[a] = lo[a].min(v[a]);
                        hi[a] = hi[a].max(v[a]);
                    }
                }
            }
        }
    }
    let range = if none { 0.0 } else { (hi[0] - lo[0]).max(hi[1] - lo[1]) };
    (range, all, none)
}

#[test]
fn grid_refines_exactly_where_disparity_varies_by_more_than_the_threshold() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut checked_splits = 0;
    for case in 0..24 {
        let (w, h) = (20 + rng.below(60) as u32, 12 + rng.below(50) as u32);
        let img = random_depths(&mut rng, w, h);
        // Half the cases: a horizontal baseline (the paper's stereo pair);
        // the others: a general motion with a turn.
        let (src, dst) = if case % 2 == 0 {
            (camera(w, h, DVec3::ZERO), camera(w, h, DVec3::new(0.1 + 0.2 * rng.unit(), 0.0, 0.0)))
        } else {
            let p = DVec3::new(rng.unit() - 0.5, 0.3 * rng.unit(), 0.5 * rng.unit());
            (camera(w, h, DVec3::ZERO), turned(w, h, p * 0.4, 10.0 * rng.unit() - 5.0))
        };
        let setup = WarpSetup::new(&src, &dst);
        let threshold = [3.0f32, 1.0, 0.5][case % 3];
        let max_cell = [64u32, 16, 8][case / 8];
        let d: Vec<PixelDisparity> = (0..img.len())
            .map(|i| {
                let (x, y) = (i as u32 % w, i as u32 / w);
                pixel_disparity(&setup, x, y, img.valid[i].then_some(img.z[i]))
            })
            .collect();
        let top = top_level(max_cell);
        let mip = DisparityMipMap::from_reference(&setup, &img, top);
        let mut cells = Vec::new();
        let st = adaptive_grid(&mip, threshold, &mut cells);
        assert_eq!(st.leaves as usize, cells.len());

        let mut owner = vec![0u32; img.len()];
        for c in &cells {
            // Aligned on its level, clipped to the image.
            let s = 1u32 << c.level;
            assert!(c.level <= top);
            assert_eq!((c.x0 % s, c.y0 % s), (0, 0), "case {case}: {c:?}");
            assert_eq!((c.x1, c.y1), ((c.x0 + s).min(w), (c.y0 + s).min(h)), "case {case}: {c:?}");
            for y in c.y0..c.y1 {
                for x in c.x0..c.x1 {
                    owner[(y * w + x) as usize] += 1;
                }
            }
            // A leaf is drawable and within the threshold, or 1x1.
            let (range, all, _) = brute(&d, w, c);
            assert!(all, "case {case}: leaf {c:?} holds a sample with nothing to draw");
            assert!(range <= threshold || c.level == 0, "case {case}: leaf {c:?} range {range} > {threshold}");
            // It could not be merged with its siblings: the parent fails.
            if c.level < top {
                let p = c.level + 1;
                let ps = 1u32 << p;
                let (px, py) = (c.x0 / ps * ps, c.y0 / ps * ps);
                let parent = Cell { x0: px, y0: py, x1: (px + ps).min(w), y1: (py + ps).min(h), level: p };
                let (prange, pall, pnone) = brute(&d, w, &parent);
                assert!(!pnone && (!pall || prange > threshold), "case {case}: {c:?} could merge into {parent:?}");
                checked_splits += 1;
            }
        }
        // Every drawable sample is in exactly one leaf, nothing else is.
        for (i, &n) in owner.iter().enumerate() {
            let want = !matches!(d[i], PixelDisparity::None) as u32;
            assert_eq!(n, want, "case {case}: sample {i} in {n} leaves");
        }
    }
    assert!(checked_splits > 1000, "the random images should exercise subdivision ({checked_splits})");
}

/// One frame of `rec` with `fill` from `refs` (camera, image) to `derived`.
fn frame(
    rec: &dyn Reconstruction,
    fill: &dyn postwarp::methods::HoleFill,
    derived: &Camera,
    ss: u32,
    refs: &[(Camera, &SampleImage)],
) -> MethodFrame {
    let cams: Vec<(usize, Camera)> = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
    let cmd = FrameCommands::new(0, *derived, ss, &cams);
    let imgs: Vec<&SampleImage> = refs.iter().map(|(_, i)| *i).collect();
    let prepared: Vec<Prepared> = imgs.iter().map(|i| rec.prepare(i, ss)).collect();
    let p: Vec<&Prepared> = prepared.iter().collect();
    let input = Input { cmd: &cmd, refs: &imgs, prepared: &p };
    run_method(rec, fill, &input, input.empty_frame())
}

#[test]
fn plane_at_constant_disparity_is_drawn_as_the_starting_cells() {
    // 64x48 pixels at 2x2 samples: 128x96 samples, 64-sample starting cells
    // -> 2x2 cells; a fronto-parallel plane under a sideways move has one
    // disparity everywhere, so nothing is split.
    let ss = 2;
    let layers = [Layer { z: 4.0, x0: -100.0, x1: 100.0, colour: grey_stripes }];
    let src = camera(64, 48, DVec3::ZERO);
    let img = render(&src, ss, &layers);
    let derived = camera(64, 48, DVec3::new(0.13, -0.05, 0.0));
    for rec in [Didyk::single(), Didyk::two_ref()] {
        let f = frame(&rec, &NoFill, &derived, ss, &[(src, &img)]);
        assert_eq!(f.reconstruction.primitives, 4, "{}", rec.info().name);
        assert_eq!(f.reconstruction.extra["splits"], 0);
        assert_eq!(f.reconstruction.extra["leaf_cells_1x1"], 0);
    }
    // A depth step of more than the threshold splits only along the step.
    let step = [
        Layer { z: 4.0, x0: -100.0, x1: 0.05, colour: grey_stripes },
        Layer { z: 8.0, x0: 0.05, x1: 100.0, colour: grey_stripes },
    ];
    let img = render(&src, ss, &step);
    let f = frame(&Didyk::single(), &NoFill, &derived, ss, &[(src, &img)]);
    let quads = f.reconstruction.primitives;
    // Parallax 100·0.13/4 = 3.25 vs 1.625 samples: a 1.6-sample jump, under
    // the threshold; at 5x the move it is 8 samples and the step splits.
    assert_eq!(quads, 4);
    let far = camera(64, 48, DVec3::new(0.65, 0.0, 0.0));
    let f = frame(&Didyk::single(), &NoFill, &far, ss, &[(src, &img)]);
    // The step lies between sample columns 64 and 65 (near plane for
    // x < 63.5 + 1.25): the right starting cells split down a column of
    // cells holding x = 64 and 65, each split leaving its right half whole:
    // 2 left cells + 3 + 6 + 12 + 24 + 48 halves of 32..2 + 192 1x1 cells.
    assert_eq!(f.reconstruction.primitives, 2 + 3 + 6 + 12 + 24 + 48 + 192);
    assert_eq!(f.reconstruction.extra["leaf_cells_1x1"], 192);
}

#[test]
fn vertex_depth_is_the_nearest_of_its_four_samples() {
    let mut rng = Rng(77);
    for _ in 0..8 {
        let (w, h) = (5 + rng.below(30) as u32, 3 + rng.below(20) as u32);
        let img = random_depths(&mut rng, w, h);
        let v = VertexDepths::new(&img);
        assert_eq!((v.columns, v.rows), (w + 1, h + 1));
        for vy in 0..=h {
            for vx in 0..=w {
                let mut zs = Vec::new();
                for (x, y) in [
                    (vx as i64 - 1, vy as i64 - 1),
                    (vx as i64, vy as i64 - 1),
                    (vx as i64 - 1, vy as i64),
                    (vx as i64, vy as i64),
                ] {
                    if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
                        let i = img.index(x as u32, y as u32);
                        if img.valid[i] {
                            zs.push(img.z[i]);
                        }
                    }
                }
                let nearest = zs.iter().copied().fold(None, |m: Option<f32>, z| Some(m.map_or(z, |m| m.min(z))));
                assert_eq!(v.at(vx, vy), nearest.map(|z| 1.0 / z), "vertex ({vx}, {vy})");
            }
        }
    }
    // And the stretch it causes (§3.3): a background sample next to a
    // foreground one has its shared corners at the foreground's depth, so
    // its quad stretches over the disocclusion and leaves no hole.
    let ss = 1;
    let layers = [
        Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: grey_stripes },
        Layer { z: 2.0, x0: -0.3, x1: 0.2, colour: red },
    ];
    let src = camera(40, 10, DVec3::ZERO);
    let img = render(&src, ss, &layers);
    let derived = camera(40, 10, DVec3::new(0.2, 0.0, 0.0));
    let f = frame(&Didyk::single(), &NoFill, &derived, ss, &[(src, &img)]);
    let naive = postwarp::methods::forward_splat(&FrameCommands::new(0, derived, ss, &[(0, src)]), &[&img]);
    let holes = |real: &bitvec::vec::BitVec| (0..400).filter(|&k| k % 40 < 36 && !real[k]).count();
    assert!(holes(&naive.samples.real) >= 30, "the forward splat leaves the disocclusion open");
    assert_eq!(holes(&f.samples.real), 0, "the grid stretches across it");
}

/// A `w x h` sample image of a plane at depth `z`, each sample its own
/// random colour.
fn textured_plane(rng: &mut Rng, w: u32, h: u32, z: f32) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for i in 0..img.len() {
        img.z[i] = z;
        img.valid.set(i, true);
        img.colour[i] = [rng.unit() as f32, rng.unit() as f32, rng.unit() as f32];
    }
    img
}

#[test]
fn fronto_parallel_plane_moves_by_the_exact_shift() {
    // Plane Z = 5 on a 2x2 sample grid (fx = 100 per sample); the derived
    // camera moves by (0.2, −0.1): the image moves by (−4, +2) samples.
    let mut rng = Rng(5);
    let ss = 2;
    let (w, h) = (30u32, 20u32);
    let src = camera(w, h, DVec3::ZERO);
    let img = textured_plane(&mut rng, 2 * w, 2 * h, 5.0);
    let derived = camera(w, h, DVec3::new(0.2, -0.1, 0.0));
    for filter in [TextureFilter::Bilinear, TextureFilter::Nearest] {
        for form in [Didyk::single(), Didyk::two_ref()] {
            let rec = Didyk { params: DidykParams { filter, ..DidykParams::default() }, ..form };
            let f = frame(&rec, &NoFill, &derived, ss, &[(src, &img)]);
            let d = &f.samples;
            for y in 0..2 * h {
                for x in 0..2 * w {
                    let k = (y * 2 * w + x) as usize;
                    let (sx, sy) = (x as i64 + 4, y as i64 - 2);
                    if sx < 2 * w as i64 && sy >= 0 {
                        assert!(d.real[k], "{filter:?} ({x}, {y}) empty");
                        assert_eq!(d.colour[k], img.colour[img.index(sx as u32, sy as u32)], "{filter:?} ({x}, {y})");
                        assert!((d.inv_z[k] - 0.2).abs() < 1e-6);
                        assert_eq!(d.source[k], 0);
                    } else {
                        assert!(!d.real[k], "{filter:?} ({x}, {y}) should be off the warped image");
                    }
                }
            }
        }
    }
}

/// Layer `j` of a frame, drawn on its own.
fn layer(derived: &Camera, ss: u32, src: &Camera, img: &SampleImage) -> WarpedLayer {
    let cmd = FrameCommands::new(0, *derived, ss, &[(0, *src)]);
    let k = derived.sample_grid(ss).intrinsics;
    let mut l = WarpedLayer::new(k.width, k.height);
    warp_reference(&cmd.warps[0].setup, img, &VertexDepths::new(img), &DidykParams::default(), &mut l);
    l
}

#[test]
fn two_references_prefer_the_one_whose_quads_are_not_torn() {
    // A red strip at Z = 2 before a striped wall at Z = 10; references at
    // x = 0 (A) and x = 0.4 (B), derived half way (fx = 50: parallax 1
    // sample on the wall, 5 on the strip). Moving right from A
    // uncovers wall right of the strip, which A tears a quad across; B sees
    // it. Left of the strip it is the other way round.
    let ss = 1;
    let (w, h) = (48u32, 6u32);
    let layers = [
        Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: grey_stripes },
        Layer { z: 2.0, x0: -0.3, x1: 0.1, colour: red },
    ];
    let (ca, cb, derived) =
        (camera(w, h, DVec3::ZERO), camera(w, h, DVec3::new(0.4, 0.0, 0.0)), camera(w, h, DVec3::new(0.2, 0.0, 0.0)));
    let (ia, ib) = (render(&ca, ss, &layers), render(&cb, ss, &layers));
    let (la, lb) = (layer(&derived, ss, &ca, &ia), layer(&derived, ss, &cb, &ib));
    let two = frame(&Didyk::two_ref(), &NoFill, &derived, ss, &[(ca, &ia), (cb, &ib)]);
    let one = frame(&Didyk::single(), &NoFill, &derived, ss, &[(ca, &ia), (cb, &ib)]);
    let (mut prefer_b, mut prefer_a, mut changed) = (0, 0, 0);
    let d = &two.samples;
    for k in 0..(w * h) as usize {
        assert!(la.covered[k] || lb.covered[k]);
        if !(la.covered[k] && lb.covered[k]) {
            continue;
        }
        // Rule 8's blend, source from the larger weight.
        let (wa, wb) = (la.weight[k], lb.weight[k]);
        assert_eq!(d.source[k], (wb > wa) as u8, "sample {k}");
        for c in 0..3 {
            let want = (wa * la.colour[k][c] + wb * lb.colour[k][c]) / (wa + wb);
            assert!((d.colour[k][c] - want).abs() < 1e-5, "sample {k}");
        }
        // Where one reference is torn and the other is not, the output is
        // (almost) the untorn one.
        let near = |c: [f32; 3], other: [f32; 3]| {
            (0..3).all(|i| (d.colour[k][i] - c[i]).abs() <= 0.05 * (c[i] - other[i]).abs() + 1e-6)
        };
        if wa < 0.02 && wb > 0.25 {
            prefer_b += 1;
            assert!(near(lb.colour[k], la.colour[k]), "sample {k}: {:?} vs B {:?}", d.colour[k], lb.colour[k]);
            changed += (0..3).any(|c| (one.samples.colour[k][c] - d.colour[k][c]).abs() > 0.1) as u32;
        }
        if wb < 0.02 && wa > 0.25 {
            prefer_a += 1;
            assert!(near(la.colour[k], lb.colour[k]), "sample {k}: {:?} vs A {:?}", d.colour[k], la.colour[k]);
        }
    }
    // Each side of the strip: a 4-sample tear (parallax 5 − 1) per row,
    // across which the 2-sample cells next to the strip stretch 3x:
    // w = 3^-4 = 0.012.
    assert!(prefer_b >= 3 * h && prefer_a >= 3 * h, "A torn: {prefer_b}, B torn: {prefer_a}");
    assert!(changed >= h, "the single form shows A's tear there ({changed})");
    // Against the truth seen from the derived camera, two references do
    // better than one.
    let truth = render(&derived, ss, &layers);
    let err = |f: &MethodFrame| -> f64 {
        (0..truth.len())
            .map(|k| (0..3).map(|c| (f.samples.colour[k][c] - truth.colour[k][c]).abs() as f64).sum::<f64>())
            .sum()
    };
    // (Not much better: both still squash the wall's texture in the large
    // cells whose corners take the strip's depth.)
    assert!(err(&two) < 0.8 * err(&one), "two refs {} vs one {}", err(&two), err(&one));
}

#[test]
fn no_panic_on_awkward_frames() {
    // Samples with no surface, behind the derived camera, off the image;
    // the derived camera turned away, inside the scene, or at a reference.
    let mut rng = Rng(3);
    let img = random_depths(&mut rng, 40, 30);
    let src = camera(20, 15, DVec3::ZERO);
    let deriveds = [
        turned(20, 15, DVec3::new(0.0, 0.0, 0.0), 0.0),
        turned(20, 15, DVec3::new(0.0, 0.0, 9.0), 0.0),
        turned(20, 15, DVec3::new(0.3, 0.1, 2.5), 60.0),
        turned(20, 15, DVec3::new(0.0, 0.0, -1.0), 180.0),
        turned(20, 15, DVec3::new(5.0, 0.0, 0.0), 95.0),
        Camera {
            intrinsics: Intrinsics { width: 7, height: 3, fx: 4.0, fy: 40.0, cx: 3.0, cy: 1.0 },
            pose: Pose { position: DVec3::new(0.0, 0.0, 1.0), orientation: DQuat::IDENTITY },
        },
    ];
    let empty = SampleImage::empty(40, 30);
    for d in &deriveds {
        for rec in [Didyk::single(), Didyk::two_ref()] {
            let f = frame(&rec, &DidykInpaint, d, 2, &[(src, &img), (src, &empty)]);
            assert!(f.samples.colour.iter().flatten().all(|c| c.is_finite()));
            assert!(f.pixels.iter().flatten().all(|c| c.is_finite()));
            // Deterministic: the same frame twice gives the same samples.
            let g = frame(&rec, &DidykInpaint, d, 2, &[(src, &img), (src, &empty)]);
            assert_eq!(f.samples, g.samples);
        }
    }
}
