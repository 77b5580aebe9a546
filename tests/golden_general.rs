//! The general reconstruction (TR98 §7.1: triangle mesh + edge splats) on
//! small constructed scenes, ray cast exactly by a few lines here:
//! fronto-parallel layers (as in `golden_rules.rs`) and bounded planes in
//! any orientation.

use glam::DVec3;
use postwarp::golden::config::{GoldenConfig, Reconstruction};
use postwarp::golden::frame::{GoldenFrame, GoldenStats, prepare_reference, warp_frame};
use postwarp::golden::general::{GeneralOptions, warp_reference_general_with};
use postwarp::golden::planes::DestPlanes;
use postwarp::golden::transform::WarpContext;
use postwarp_rtl::{Camera, FrameCommands, Pose, SampleImage};

use crate::common::*;

/// A bounded plane: `centre + a·u + b·v`, `|a| <= hu`, `|b| <= hv`.
#[derive(Clone, Copy)]
struct Panel {
    centre: DVec3,
    u: DVec3,
    v: DVec3,
    hu: f64,
    hv: f64,
}

/// Ray cast one panel from any camera; colour from the panel coordinates;
/// exact 1/Z slopes (1/Z is affine on a plane, so central differences are
/// exact; the loader's same-surface test is off, since at a grazing angle
/// the panel's 1/Z changes by more than its threshold per sample).
fn render_panel(cam: &Camera, ss: u32, p: &Panel) -> SampleImage {
    let s = cam.sample_grid(ss);
    let k = s.intrinsics;
    let n = p.u.cross(p.v);
    let mut img = SampleImage::empty(k.width, k.height);
    for y in 0..k.height {
        for x in 0..k.width {
            let d = s.ray_direction(x as f64, y as f64); // camera z = 1 per unit t
            let t = n.dot(p.centre - s.pose.position) / n.dot(d);
            if !(t.is_finite() && t > 0.0) {
                continue;
            }
            let q = s.pose.position + d * t - p.centre;
            let (a, b) = (q.dot(p.u), q.dot(p.v));
            if a.abs() <= p.hu && b.abs() <= p.hv {
                let i = img.index(x, y);
                img.z[i] = t as f32;
                let c = 0.5 + 0.4 * (a * 3.0).sin() as f32;
                img.colour[i] = [c, 0.5, 1.0 - c];
                img.object_id[i] = 1;
                img.valid.set(i, true);
            }
        }
    }
    img.slopes_from_depth_with(f64::INFINITY);
    img
}

fn background() -> Layer {
    Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: grey_stripes }
}

fn general(cfg: GoldenConfig) -> GoldenConfig {
    GoldenConfig { reconstruction: Reconstruction::General, ..cfg }
}

fn run(derived: &Camera, refs: &[(Camera, SampleImage)], ss: u32, cfg: &GoldenConfig) -> GoldenFrame {
    let cams: Vec<(usize, Camera)> = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
    let cmd = FrameCommands::new(0, *derived, ss, &cams);
    let prepared: Vec<_> = refs.iter().map(|(_, img)| prepare_reference(img, ss, cfg)).collect();
    let r: Vec<_> = prepared.iter().collect();
    warp_frame(&cmd, &r, cfg)
}

/// Warp reference `this` of `refs` alone into a fresh derived frame with
/// explicit switches (no hole fill, no A-buffer): the intermediate state.
fn warp_one(
    derived: &Camera,
    refs: &[Camera],
    this: usize,
    img: &SampleImage,
    ss: u32,
    cfg: &GoldenConfig,
    opts: &GeneralOptions,
) -> (DestPlanes, GoldenStats) {
    let cams: Vec<(usize, Camera)> = refs.iter().copied().enumerate().collect();
    let cmd = FrameCommands::new(0, *derived, ss, &cams);
    let dst = derived.sample_grid(ss);
    let ctx = WarpContext::new(
        cmd.warps[this].setup,
        cmd.warps[this].reference_camera,
        dst,
        refs.iter().map(|c| c.pose.position).collect(),
        this,
        cfg.better_margin,
    );
    let mut d = DestPlanes::new(dst.intrinsics.width, dst.intrinsics.height);
    let mut st = GoldenStats::default();
    d.begin_warp();
    warp_reference_general_with(&ctx, img, this as u8, cfg, opts, &mut d, &mut st);
    (d, st)
}

fn red_in_row(s: &[[f32; 3]], w: usize, y: usize) -> usize {
    (0..w).filter(|&x| s[y * w + x] == RED).count()
}

#[test]
fn the_identity_warp_reproduces_the_reference_exactly() {
    for ss in [1, 2] {
        let cfg = general(GoldenConfig::default());
        let cam = at_x(24, 16, 0.0);
        let layers = [background(), Layer { z: 5.0, x0: -0.3, x1: 0.2, colour: red }];
        let img = render(&cam, ss, &layers);
        let prepared = prepare_reference(&img, ss, &cfg).samples;
        let out = run(&cam, &[(cam, img)], ss, &cfg);
        assert_eq!(out.stats.hole_samples + out.stats.empty_samples, 0, "ss {ss}");
        assert_eq!(out.samples.colour, prepared.colour, "ss {ss}: every sample is its reference sample");
        assert!(out.covered.all());
        assert!(out.stats.mesh_triangles > 0 && out.stats.edge_splats > 0, "{:?}", out.stats);
        assert_eq!(out.stats.suppressed_splats, 0);
        assert_eq!(out.stats.kernels_over_limit, 0);
    }
}

#[test]
fn a_one_sample_wide_line_needs_the_edge_splats() {
    // Plate 3. f = 50 samples at ss = 1, line one sample wide at Z = 5
    // (0.1 scene units), background at Z = 10. The camera moves 0.5 right:
    // the line shifts 5 samples, the background 2.5, so the line is
    // separated from both neighbours (warped gaps 3.5 and 1.5 > 1.4·E).
    let cfg = general(GoldenConfig { hole_fill: false, abuffer_fragments: 0, ..GoldenConfig::default() });
    let (r, d) = (at_x(24, 16, 0.0), at_x(24, 16, 0.5));
    let line = Layer { z: 5.0, x0: 0.0, x1: 0.1, colour: red };
    let img = render(&r, 1, &[background(), line]);
    for y in 0..16 {
        assert_eq!(red_in_row(&img.colour, 24, y), 1, "the reference line is one sample wide");
    }
    let mesh_only = GeneralOptions { edge_splats: false, ..GeneralOptions::default() };
    let (bare, st) = warp_one(&d, &[r], 0, &img, 1, &cfg, &mesh_only);
    assert_eq!(st.edge_splats, 0);
    assert!(st.mesh_triangles > 0);
    let rows_with_line = (0..16).filter(|&y| red_in_row(&bare.colour, 24, y) > 0).count();
    assert_eq!(rows_with_line, 0, "the mesh alone shaves the line away");
    let reddish = bare.colour.iter().filter(|c| c[0] > 0.6 && c[1] < 0.3).count();
    assert_eq!(reddish, 0, "not even blended into the background");

    let (full, st) = warp_one(&d, &[r], 0, &img, 1, &cfg, &GeneralOptions::default());
    assert!(st.edge_splats > 0);
    for y in 0..16 {
        assert!(red_in_row(&full.colour, 24, y) >= 1, "row {y} lost the line");
    }
    // The same through the whole frame pipeline, at ss = 1 and 2 (the line
    // one sample wide in both: 0.05 scene units at ss = 2, motion halved).
    for (ss, width, shift) in [(1, 0.1, 0.5), (2, 0.05, 0.25)] {
        let line = Layer { z: 5.0, x0: 0.0, x1: width, colour: red };
        let (r, d) = (at_x(24, 16, 0.0), at_x(24, 16, shift));
        let img = render(&r, ss, &[background(), line]);
        let out = run(&d, &[(r, img)], ss, &general(GoldenConfig::default()));
        let w = 24 * ss as usize;
        for y in 0..16 * ss as usize {
            assert!(red_in_row(&out.samples.colour, w, y) >= 1, "ss {ss}: row {y} lost the line");
        }
        assert!(out.stats.edge_splats > 0);
    }
}

#[test]
fn the_interior_of_a_textured_plane_is_interpolated_without_holes() {
    // A striped plane at Z = 10 (stripes of 0.3 and 0.5, 1.25 samples
    // wide); the camera moves 0.09 right: every derived centre lands 0.45
    // of the way from one reference sample of a row to the next.
    let base = GoldenConfig { hole_fill: false, abuffer_fragments: 0, ..GoldenConfig::default() };
    let (r, d) = (at_x(24, 16, 0.0), at_x(24, 16, 0.09));
    let img = render(&r, 1, &[background()]);
    let out = run(&d, &[(r, img.clone())], 1, &general(base.clone()));
    assert_eq!(out.stats.empty_samples, 0, "no holes inside the plane");
    assert!(out.samples.real.all());
    let (w, h) = (24usize, 16usize);
    let mut blends = 0;
    // The last row lies on the mesh's bottom edge (not owned, rule 3) and
    // the last column past the last vertex: those come from edge splats.
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let (a, b) = (img.colour[y * w + x][0], img.colour[y * w + x + 1][0]);
            let got = out.samples.colour[y * w + x][0];
            assert!((got - (0.55 * a + 0.45 * b)).abs() < 1e-5, "({x},{y}): {got} between {a} and {b}");
            if a != b {
                assert!(got != a && got != b);
                blends += 1;
            }
        }
    }
    assert!(blends > 0, "the stripes give some blended samples");
    assert!(out.stats.splats_rejected_by_mesh > 0, "border splats lose to the mesh at the same depth");
    // The anti-aliased path (flat rectangles) never blends.
    let aa = run(&d, &[(r, img.clone())], 1, &base);
    assert!(aa.samples.colour.iter().all(|c| c[0] == 0.3 || c[0] == 0.5));

    // Moving toward the plane and sideways: magnified 10/9.2, at
    // non-integer offsets; still no hole, and most samples are blends.
    let d = camera(24, 16, DVec3::new(0.07, -0.03, 0.8));
    let out = run(&d, &[(r, img)], 1, &general(base));
    assert_eq!(out.stats.empty_samples, 0, "{:?}", out.stats);
    let mid = out.samples.colour.iter().filter(|c| c[0] > 0.3 && c[0] < 0.5).count();
    assert!(mid > 0, "interpolated colours inside the surface");
    assert!(out.stats.mesh_triangles > 2 * 20 * 13);
}

#[test]
fn edge_splats_of_a_poorly_sampled_surface_are_suppressed() {
    // A panel in the plane Z = 5, seen head-on from B (the origin) and at a
    // grazing angle from A (5 to the side, 1 in front of it). The derived
    // camera is next to B: A's samples cover up to ~14 derived samples each
    // (footprint > 2), and B samples the panel better.
    let panel = Panel { centre: DVec3::new(0.0, 0.0, 5.0), u: DVec3::X, v: DVec3::Y, hu: 2.0, hv: 1.2 };
    let b = camera(48, 32, DVec3::ZERO);
    let mut a = camera(64, 64, DVec3::new(5.0, 0.0, 4.0));
    a.pose = Pose::look_at(a.pose.position, panel.centre, DVec3::new(0.0, -1.0, 0.0));
    let d = camera(48, 32, DVec3::new(0.05, 0.02, 0.0));
    let (img_a, img_b) = (render_panel(&a, 1, &panel), render_panel(&b, 1, &panel));
    assert!(img_a.valid.count_ones() > 100 && img_b.valid.count_ones() > 500);
    let cfg = general(GoldenConfig { hole_fill: false, abuffer_fragments: 0, ..GoldenConfig::default() });
    let refs = [a, b];
    let opts = GeneralOptions::default();
    let (_, sa) = warp_one(&d, &refs, 0, &img_a, 1, &cfg, &opts);
    let (_, sb) = warp_one(&d, &refs, 1, &img_b, 1, &cfg, &opts);
    assert!(sa.suppressed_splats > 0, "A's edge splats are suppressed: {sa:?}");
    assert_eq!(sb.suppressed_splats, 0, "B's are not: {sb:?}");
    assert!(sb.edge_splats > 0 && sb.mesh_triangles > 0);
    // Without suppression, A draws exactly those splats.
    let (_, sn) = warp_one(&d, &refs, 0, &img_a, 1, &cfg, &GeneralOptions { suppression: false, ..opts });
    assert_eq!(sn.suppressed_splats, 0);
    assert_eq!(sn.edge_splats, sa.edge_splats + sa.suppressed_splats);
    // Without B among the references, nothing samples it better: no suppression.
    let (_, alone) = warp_one(&d, &[a], 0, &img_a, 1, &cfg, &opts);
    assert_eq!(alone.suppressed_splats, 0);
    // The whole frame, both orders: the counters add up, and almost every
    // panel sample comes from B (A's unsuppressed splats lose to B's mesh
    // by the mesh/splat rule).
    for (ia, refs) in [(0u8, [(a, img_a.clone()), (b, img_b.clone())]), (1, [(b, img_b.clone()), (a, img_a.clone())])] {
        let out = run(&d, &refs, 1, &general(GoldenConfig::default()));
        assert_eq!(out.stats.suppressed_splats, sa.suppressed_splats);
        assert_eq!(out.stats.edge_splats, sa.edge_splats + sb.edge_splats);
        let s = &out.samples;
        let from_a = (0..s.len()).filter(|&i| s.real[i] && s.source[i] == ia).count();
        assert!(from_a * 50 < img_b.valid.count_ones(), "order {ia}: {from_a} samples from A");
    }
}

#[test]
fn two_references_cover_each_others_holes_at_any_supersampling() {
    // As in golden_rules.rs, with the general path: a box in front of a
    // gradient; one reference leaves a disocclusion, filled from the
    // background side, and two references leave none.
    fn blue_to_green(x: f64) -> [f32; 3] {
        let t = (x * 0.5 + 0.5).clamp(0.0, 1.0) as f32;
        [0.0, t, 1.0 - t]
    }
    let bg = Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: blue_to_green };
    let fg = Layer { z: 2.0, x0: -0.2, x1: 0.1, colour: red };
    let (a, b) = (at_x(44, 16, -0.1), at_x(44, 16, 0.1));
    let d = at_x(32, 16, 0.0);
    for ss in [1, 2] {
        let cfg = general(GoldenConfig::default());
        let one = run(&d, &[(a, render(&a, ss, &[bg, fg]))], ss, &cfg);
        assert!(one.stats.hole_samples > 0, "ss {ss}: one reference leaves a hole");
        let s = &one.samples;
        for i in (0..s.len()).filter(|&i| s.hole[i]) {
            assert!(s.colour[i][0] < 0.05 && s.colour[i][1] + s.colour[i][2] > 0.9, "ss {ss}: hole {i} not background");
        }
        let both = run(&d, &[(a, render(&a, ss, &[bg, fg])), (b, render(&b, ss, &[bg, fg]))], ss, &cfg);
        assert_eq!(both.stats.hole_samples + both.stats.empty_samples, 0, "ss {ss}: {:?}", both.stats);
        assert!(both.covered.all());
        assert!(both.stats.mesh_triangles > 0 && both.stats.edge_splats > 0);
    }
}
