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

/// A reference: its camera and its image.
type View = (Camera, SampleImage);

/// A red box before the background seen from x = -0.2 and x = 0.3 (24x16
/// pixels, 2x2 samples), with the cameras as frame commands name them.
fn two_references() -> (Vec<View>, Vec<(usize, Camera)>) {
    let layers = [background(), Layer { z: 4.0, x0: -0.4, x1: 0.1, colour: red }];
    let refs: Vec<View> =
        [-0.2, 0.3].iter().map(|&x| (at_x(24, 16, x), render(&at_x(24, 16, x), 2, &layers))).collect();
    let cams = refs.iter().enumerate().map(|(i, (c, _))| (i, *c)).collect();
    (refs, cams)
}

/// `Warper::keep_buffers(false)` frees the working buffers after a frame's
/// last warp and `Warper::trim_frames(true)` the frame's cache-only planes:
/// every frame is the same as a fresh warper's (memory planes, pixels,
/// counters), and a warper that freed its buffers warps the next frame the
/// same again. A trimmed frame's cache-only planes 6–8 are empty, and a
/// prepared reference has no `object_id` plane.
#[test]
fn freeing_the_working_buffers_changes_no_frame() {
    use postwarp::golden::frame::Warper;
    let cfg = GoldenConfig::default();
    let (refs, cams) = two_references();
    let prepared: Vec<_> = refs.iter().map(|(_, img)| prepare_reference(img, 2, &cfg)).collect();
    assert!(prepared.iter().all(|p| p.samples.object_id.is_empty() && p.samples.colour.len() == 48 * 32));
    let r: Vec<_> = prepared.iter().collect();
    let mut warper = Warper::new();
    // The last frame's camera is far beyond both references: a border
    // strip no reference saw goes to the fallback pass, which reads the
    // cache-only planes (so they must still be there when it runs).
    let frames = [(true, false, 0.05), (false, true, -0.1), (true, true, 0.2), (false, false, 0.0), (false, true, 2.5)];
    for (k, (keep, trim, x)) in frames.into_iter().enumerate() {
        let cmd = FrameCommands::new(k, at_x(24, 16, x), 2, &cams);
        let fresh = warp_frame(&cmd, &r, &cfg);
        warper.keep_buffers(keep);
        warper.trim_frames(trim);
        let out = warper.warp_frame(&cmd, &r, &cfg);
        let (a, b) = (&out.samples, &fresh.samples);
        assert_eq!((&a.colour, &a.inv_z, &a.slopes, &a.source), (&b.colour, &b.inv_z, &b.slopes, &b.source), "{k}");
        assert_eq!((&a.hole, &a.real, &a.fill_weight, &a.splat), (&b.hole, &b.real, &b.fill_weight, &b.splat), "{k}");
        assert_eq!((&out.pixels, &out.covered, &out.unseen), (&fresh.pixels, &fresh.covered, &fresh.unseen));
        assert_eq!(out.stats, fresh.stats, "frame {k}: counters");
        assert!(out.stats.kernel_sizes.iter().flatten().sum::<u64>() > 0, "frame {k}: something was warped");
        assert!(b.fill_colour.len() == b.len() && b.fill_distance.len() == b.len() && b.fill_valid.len() == b.len());
        if trim {
            assert!(a.fill_colour.is_empty() && a.fill_distance.is_empty() && a.fill_valid.is_empty(), "{k}");
        } else {
            assert_eq!(a, b, "frame {k}: every plane");
        }
        assert_eq!(out.stats.fallback_filled > 0, k == 4, "frame {k}: the fallback pass ran only in the last");
    }
}

/// `Warper::warp_frame_streamed` asks for each warp's reference once, in
/// warp order, just before that warp (the previous one's is already
/// dropped), and gives the frame `warp_frame` gives; the first error of the
/// source stops the frame and is what it returns.
#[test]
fn a_streamed_frame_asks_each_reference_once_and_equals_the_frame() {
    use postwarp::golden::frame::{PreparedReference, Warper};
    use std::rc::Rc;
    let cfg = GoldenConfig::default();
    let (refs, cams) = two_references();
    let cmd = FrameCommands::new(0, at_x(24, 16, 0.05), 2, &cams);
    let whole = run(&at_x(24, 16, 0.05), &refs, 2, &cfg);
    let mut asked = Vec::new();
    let mut alive: Vec<std::rc::Weak<PreparedReference>> = Vec::new();
    let out = Warper::new()
        .warp_frame_streamed(&cmd, &cfg, |j| {
            // The earlier warps' references are gone by the time the next is asked for.
            assert!(alive.iter().all(|w| w.upgrade().is_none()), "warp {j}: an earlier reference is still held");
            asked.push(j);
            let p = Rc::new(prepare_reference(&refs[j].1, 2, &cfg));
            alive.push(Rc::downgrade(&p));
            Ok::<_, String>(p)
        })
        .expect("no error");
    assert_eq!(asked, [0, 1]);
    assert_eq!((&out.samples, &out.pixels, &out.covered), (&whole.samples, &whole.pixels, &whole.covered));
    assert_eq!(out.stats, whole.stats);
    let mut asked = Vec::new();
    let err = Warper::new()
        .warp_frame_streamed(&cmd, &cfg, |j| {
            asked.push(j);
            if j == 0 { Ok(Rc::new(prepare_reference(&refs[0].1, 2, &cfg))) } else { Err(format!("no reference {j}")) }
        })
        .expect_err("the source failed");
    assert_eq!((err.as_str(), asked.as_slice()), ("no reference 1", &[0, 1][..]));
}

#[test]
fn timing_phases_changes_no_value_and_times_the_phases_that_ran() {
    use postwarp::golden::phase_times::{self, Phase};
    let cfg = GoldenConfig::default();
    let (a, b) = (at_x(24, 16, -0.1), at_x(24, 16, 0.1));
    let layers = [background(), Layer { z: 5.0, x0: -0.3, x1: 0.2, colour: red }];
    let refs = [(a, render(&a, 2, &layers)), (b, render(&b, 2, &layers))];
    let derived = at_x(24, 16, 0.05);
    // Other tests may time phases on their own threads; this thread's sums
    // are its own.
    phase_times::take();
    let off = run(&derived, &refs, 2, &cfg);
    let untimed = phase_times::take();
    phase_times::enable(true);
    let on = run(&derived, &refs, 2, &cfg);
    phase_times::enable(false);
    let timed = phase_times::take();
    assert_eq!(on.samples, off.samples);
    assert_eq!(on.pixels, off.pixels);
    assert_eq!(on.stats, off.stats);
    assert!(untimed.iter().all(|&(_, s)| s == 0.0), "nothing timed while off: {untimed:?}");
    let secs = |p: Phase| timed.iter().find(|(q, _)| *q == p).map(|&(_, s)| s).unwrap();
    for p in [Phase::Transform, Phase::PhaseA, Phase::PhaseB, Phase::Abuffer, Phase::Resolve] {
        assert!(secs(p) > 0.0, "{p:?} ran: {timed:?}");
    }
    assert_eq!(secs(Phase::General), 0.0, "the anti-aliased path's frame: {timed:?}");
    assert!(phase_times::take().iter().all(|&(_, s)| s == 0.0), "take resets");
}
