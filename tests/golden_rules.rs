//! The golden model's rules on small constructed scenes (TR98 §5–9):
//! fronto-parallel layers, ray cast exactly by a few lines here, so the
//! expected images are known independently of the warper and the renderer.

use postwarp::golden::config::GoldenConfig;
use postwarp::golden::frame::{prepare_reference, warp_frame};
use postwarp_rtl::{Camera, FrameCommands, SampleImage};

use crate::common::*;

fn blue_to_green(x: f64) -> [f32; 3] {
    let t = (x * 0.5 + 0.5).clamp(0.0, 1.0) as f32;
    [0.0, t, 1.0 - t]
}

fn background() -> Layer {
    Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: grey_stripes }
}

fn run(
    derived: &Camera,
    refs: &[(Camera, SampleImage)],
    ss: u32,
    cfg: &GoldenConfig,
) -> postwarp::golden::frame::GoldenFrame {
    let cams: Vec<(usize, Camera)> = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
    let cmd = FrameCommands::new(0, *derived, ss, &cams);
    let prepared: Vec<_> = refs.iter().map(|(_, img)| prepare_reference(img, ss, cfg)).collect();
    let r: Vec<_> = prepared.iter().collect();
    warp_frame(&cmd, &r, cfg)
}

#[test]
fn derived_frame_at_the_reference_camera_reproduces_it_exactly() {
    let cfg = GoldenConfig::default();
    let cam = at_x(24, 16, 0.0);
    let layers = [background(), Layer { z: 5.0, x0: -0.3, x1: 0.2, colour: red }];
    let img = render(&cam, 2, &layers);
    let prepared = prepare_reference(&img, 2, &cfg).samples;
    let out = run(&cam, &[(cam, img)], 2, &cfg);
    assert_eq!(out.stats.hole_samples + out.stats.empty_samples, 0);
    assert_eq!(out.samples.colour, prepared.colour, "every sample is its reference sample");
    assert!(out.covered.all());
    let pixels = postwarp::picture::box_filter(48, 32, 2, &prepared.colour);
    for (a, b) in out.pixels.iter().zip(&pixels) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 1e-6, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn without_the_abuffer_the_identity_warp_returns_the_original_samples() {
    // With the A-buffer on, per-sample texture inside one surface fragment is
    // averaged (by design, as in TR98's test-bed); without it, every sample
    // comes back exactly.
    let cfg = GoldenConfig { abuffer_fragments: 0, ..GoldenConfig::default() };
    let cam = at_x(24, 16, 0.0);
    let img = render(&cam, 2, &[background(), Layer { z: 5.0, x0: -0.3, x1: 0.2, colour: red }]);
    let out = run(&cam, &[(cam, img.clone())], 2, &cfg);
    assert_eq!(out.samples.colour, img.colour);
    for i in 0..img.len() {
        assert_eq!(1.0 / out.samples.inv_z[i], img.z[i], "sample {i}: depth");
    }
}

#[test]
fn a_translated_plane_lands_where_the_equation_says() {
    // f = 50 px at 2x2 → 100 samples; Z = 10, B = 0.2 → shift 100·0.2/10 = 2 samples left.
    let cfg = GoldenConfig { hole_fill: false, ..GoldenConfig::default() };
    let (r, d) = (at_x(24, 16, 0.0), at_x(24, 16, 0.2));
    let img = render(&r, 2, &[background()]);
    let prepared = prepare_reference(&img, 2, &cfg).samples;
    let out = run(&d, &[(r, img)], 2, &cfg);
    let w = 48;
    for y in 0..32 {
        for x in 0..w - 2 {
            assert_eq!(out.samples.colour[y * w + x], prepared.colour[y * w + x + 2], "({x},{y})");
        }
        for x in w - 2..w {
            assert!(!out.samples.real[y * w + x], "({x},{y}) has no source");
        }
    }
    assert_eq!(out.stats.kernels_over_limit, 0);
}

#[test]
fn a_one_sample_wide_line_survives_the_warp() {
    // Plate 3: a red line one sample wide (0.01 at Z = 5 is 0.2 px = 0.4
    // samples... use exactly one sample: width 5/100 = 0.05).
    let cfg = GoldenConfig::default();
    let (r, d) = (at_x(24, 16, 0.0), at_x(24, 16, 0.037));
    let line = Layer { z: 5.0, x0: 0.0, x1: 0.05, colour: red };
    let img = render(&r, 2, &[background(), line]);
    let red_in = |s: &[[f32; 3]], w: usize, y: usize| (0..w).filter(|&x| s[y * w + x] == [1.0, 0.0, 0.0]).count();
    for y in 0..32 {
        assert_eq!(red_in(&img.colour, 48, y), 1, "the reference line is one sample wide");
    }
    let out = run(&d, &[(r, img)], 2, &GoldenConfig { abuffer_fragments: 0, ..cfg.clone() });
    for y in 0..32 {
        assert!(red_in(&out.samples.colour, 48, y) >= 1, "row {y} lost the line");
    }
}

#[test]
fn a_disocclusion_is_filled_from_the_background_side() {
    // Plate 4 / Fig. 15: the camera moves right, the red box (Z = 2) moves
    // left more than the background (Z = 10): a hole opens at the box's right
    // edge. It must be filled from the background there (blue-green), never red.
    let cfg = GoldenConfig::default();
    let (r, d) = (at_x(32, 16, 0.0), at_x(32, 16, 0.1));
    let bg = Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: blue_to_green };
    let fg = Layer { z: 2.0, x0: -0.2, x1: 0.1, colour: red };
    let out = run(&d, &[(r, render(&r, 2, &[bg, fg]))], 2, &cfg);
    assert!(out.stats.hole_samples > 0, "a hole must open");
    let s = &out.samples;
    for i in 0..s.len() {
        if s.hole[i] {
            assert!(s.colour[i][0] < 0.05, "hole sample {i} took foreground red: {:?}", s.colour[i]);
            assert!(s.colour[i][1] + s.colour[i][2] > 0.9, "hole sample {i} is not background: {:?}", s.colour[i]);
        }
    }
    // Without the fill those samples are empty (black).
    let bare = run(&d, &[(r, render(&r, 2, &[bg, fg]))], 2, &GoldenConfig { hole_fill: false, ..cfg });
    assert_eq!(bare.stats.empty_samples, out.stats.hole_samples + out.stats.empty_samples);
}

#[test]
fn two_references_cover_each_others_holes() {
    let cfg = GoldenConfig::default();
    // References left and right of the derived camera, with a wider field
    // of view so the derived frame's borders are seen too.
    let wide = |x: f64| at_x(44, 16, x);
    let (a, b) = (wide(-0.1), wide(0.1));
    let d = at_x(32, 16, 0.0);
    let bg = Layer { z: 10.0, x0: -100.0, x1: 100.0, colour: blue_to_green };
    let fg = Layer { z: 2.0, x0: -0.2, x1: 0.1, colour: red };
    let one = run(&d, &[(a, render(&a, 2, &[bg, fg]))], 2, &cfg);
    assert!(one.stats.hole_samples > 0, "one reference leaves a hole");
    let both = run(&d, &[(a, render(&a, 2, &[bg, fg])), (b, render(&b, 2, &[bg, fg]))], 2, &cfg);
    assert_eq!(both.stats.hole_samples + both.stats.empty_samples, 0, "{:?}", both.stats);
    assert!(both.covered.all());
}
