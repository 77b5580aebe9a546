//! The baseline methods (`src/methods/{pull_push,stretch,rubber_sheet}.rs`,
//! `docs/methods/baselines.md`), through the registry as `postwarp golden
//! --method/--hole-fill` runs them:
//! - `pull-push` leaves no empty sample when the frame has a real one,
//!   never changes a real sample, fills a one-colour frame with exactly that
//!   colour, and fills inside the range of the real colours;
//! - `stretch` copies, without blending, the first real sample on the
//!   background side of a disocclusion, and its direction follows the
//!   epipole (front, behind, at infinity);
//! - `rubber-sheet` leaves no hole where a reference covers the view, and
//!   bridges a depth discontinuity with interpolated colours where
//!   `mark-aa` leaves a hole.

use glam::DVec3;
use postwarp::golden::planes::DestPlanes;
use postwarp::methods::{self, HoleFill, Input, MethodFrame, NoFill, Prepared};
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::{FrameCommands, SampleImage};
use proptest::prelude::*;

use crate::common;
use crate::common::props::epipole_strategy;
use crate::common::{Layer, at_x, prop_config, render as cast};

/// Frame commands for a `w x h`-sample derived frame at ss = 1 with one
/// warp whose derived-image epipole is `e` (the cameras do not matter to a
/// hole fill, only the epipole).
fn commands(w: u32, h: u32, e: Epipole) -> FrameCommands {
    let c = at_x(w, h, 0.0);
    let mut cmd = FrameCommands::new(0, c, 1, &[(0, c)]);
    cmd.warps[0].setup.epipole_derived = e;
    cmd
}

/// Run hole fill `name` on `d` with the epipoles of `cmd`.
fn fill(name: &str, cmd: &FrameCommands, d: &mut DestPlanes) -> methods::Counters {
    let f = methods::hole_fill(name).expect("registered");
    let input = Input { cmd, refs: &[], prepared: &[] };
    f.fill(&input, d)
}

fn count(c: &methods::Counters, key: &str) -> u64 {
    c.extra[key].as_u64().unwrap_or_else(|| panic!("counter {key}"))
}

/// A random frame: real samples (≥ 1) with random colours, the rest empty.
fn masked_frame(constant: Option<[f32; 3]>) -> impl Strategy<Value = DestPlanes> {
    (1u32..40, 1u32..40, 0.0f64..1.0).prop_flat_map(move |(w, h, density)| {
        let n = (w * h) as usize;
        (prop::collection::vec((0.0f64..1.0, prop::array::uniform3(0.0f32..1.0)), n), 0..n).prop_map(
            move |(v, forced)| {
                let mut d = DestPlanes::new(w, h);
                for (i, (r, colour)) in v.into_iter().enumerate() {
                    if r < density || i == forced {
                        d.real.set(i, true);
                        d.colour[i] = constant.unwrap_or(colour);
                        d.inv_z[i] = 0.5 + colour[0];
                        d.source[i] = (i % 2) as u8;
                    }
                }
                d
            },
        )
    })
}

fn assert_reals_unchanged(before: &DestPlanes, after: &DestPlanes) {
    assert_eq!(before.real, after.real);
    for i in before.real.iter_ones() {
        assert_eq!(before.colour[i], after.colour[i], "real sample {i} colour");
        assert_eq!(before.inv_z[i], after.inv_z[i], "real sample {i} 1/Z");
        assert_eq!(before.source[i], after.source[i], "real sample {i} source");
        assert!(!after.hole[i], "real sample {i} flagged hole");
    }
}

proptest! {
    #![proptest_config(prop_config(64))]

    #[test]
    fn pull_push_leaves_no_hole_and_keeps_real_samples(d in masked_frame(None)) {
        let before = d.clone();
        let mut d = d;
        let cmd = commands(d.width, d.height, Epipole { h: DVec3::new(1.0, 0.0, 0.0) });
        let c = fill("pull-push", &cmd, &mut d);
        let empty = (0..d.len()).filter(|&i| !d.real[i] && !d.hole[i]).count();
        prop_assert_eq!(empty, 0);
        prop_assert_eq!(count(&c, "filled") as usize, before.len() - before.real.count_ones());
        prop_assert_eq!(count(&c, "unreached"), 0);
        assert_reals_unchanged(&before, &d);
        // A convex mix: inside the range of the real colours, per channel.
        for ch in 0..3 {
            let vals = || before.real.iter_ones().map(|i| before.colour[i][ch]);
            let (lo, hi) = (vals().fold(f32::MAX, f32::min), vals().fold(f32::MIN, f32::max));
            for i in d.hole.iter_ones() {
                prop_assert!(d.colour[i][ch] >= lo && d.colour[i][ch] <= hi, "sample {} channel {}", i, ch);
            }
        }
    }

    #[test]
    fn pull_push_fills_a_one_colour_frame_with_that_colour_exactly(
        (colour, d) in prop::array::uniform3(0.0f32..1.0)
            .prop_flat_map(|c| masked_frame(Some(c)).prop_map(move |d| (c, d))),
    ) {
        let mut d = d;
        let cmd = commands(d.width, d.height, Epipole { h: DVec3::ZERO });
        fill("pull-push", &cmd, &mut d);
        for i in 0..d.len() {
            prop_assert!(d.real[i] || d.hole[i]);
            prop_assert_eq!(d.colour[i], colour, "sample {}", i);
        }
    }

    #[test]
    fn stretch_copies_real_colours_only_and_keeps_real_samples(d in masked_frame(None), e in epipole_strategy()) {
        let before = d.clone();
        let mut d = d;
        let cmd = commands(d.width, d.height, e);
        let c = fill("stretch", &cmd, &mut d);
        assert_reals_unchanged(&before, &d);
        let reals: Vec<[f32; 3]> = before.real.iter_ones().map(|i| before.colour[i]).collect();
        for i in d.hole.iter_ones() {
            prop_assert!(reals.contains(&d.colour[i]), "sample {} has a colour no real sample has", i);
        }
        let targets = (before.len() - before.real.count_ones()) as u64;
        prop_assert_eq!(count(&c, "filled") + count(&c, "unreached"), targets);
        prop_assert_eq!(count(&c, "filled"), d.hole.count_ones() as u64);
    }
}

#[test]
fn pull_push_on_a_frame_without_real_samples_fills_nothing() {
    let mut d = DestPlanes::new(6, 4);
    let c = fill("pull-push", &commands(6, 4, Epipole { h: DVec3::X }), &mut d);
    assert_eq!((count(&c, "filled"), count(&c, "unreached")), (0, 24));
    assert!(d.hole.not_any());
}

/// Background: a colour ramp (every sample its own colour), blue-free.
fn ramp(x: f64) -> [f32; 3] {
    [((x + 3.0) / 6.0) as f32, 0.25, 0.0]
}

fn blue(_: f64) -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

/// Run reconstruction `rec` + hole fill `hf` on one derived frame.
fn run(rec: &str, hf: &str, cmd: &FrameCommands, refs: &[&SampleImage]) -> MethodFrame {
    let rec = methods::reconstruction(rec).expect("registered");
    let hf: Box<dyn HoleFill> =
        if hf == "none" { Box::new(NoFill) } else { methods::hole_fill(hf).expect("registered") };
    let prepared: Vec<Prepared> = refs.iter().map(|r| rec.prepare(r, cmd.supersample)).collect();
    let prepared: Vec<&Prepared> = prepared.iter().collect();
    let input = Input { cmd, refs, prepared: &prepared };
    methods::render(rec.as_ref(), hf.as_ref(), &input, input.empty_frame())
}

#[test]
fn stretch_copies_the_first_background_sample_of_a_disocclusion() {
    // Derived camera 0.1 to the right of the reference, ss = 1, fx = 50:
    // the background (Z = 5) moves 1 sample left, the red strip (Z = 1.25)
    // 4: a 3-sample gap opens right of the strip; the epipole is at
    // infinity toward −x, so holes fill from +x (the background side).
    let layers = [
        Layer { z: 5.0, x0: -100.0, x1: 100.0, colour: ramp },
        Layer { z: 1.25, x0: -0.1, x1: 0.1, colour: common::red },
    ];
    let (w, h) = (40, 6);
    let reference = at_x(w, h, 0.0);
    let img = cast(&reference, 1, &layers);
    let cmd = FrameCommands::new(0, at_x(w, h, 0.1), 1, &[(0, reference)]);
    assert!(matches!(cmd.warps[0].setup.epipole_derived.kind(), postwarp_rtl::camera::EpipoleKind::Infinity { .. }));
    let plain = run("forward-splat", "none", &cmd, &[&img]);
    let f = run("forward-splat", "stretch", &cmd, &[&img]);
    let d = &f.samples;
    assert_reals_unchanged(&plain.samples, d);
    let reals: Vec<[f32; 3]> = d.real.iter_ones().map(|i| d.colour[i]).collect();
    let mut gap = 0;
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = y * w as usize + x;
            if d.real[i] {
                continue;
            }
            // The first real sample to the right on this row, found here by a plain scan.
            match (x + 1..w as usize).map(|k| y * w as usize + k).find(|&k| d.real[k]) {
                Some(k) => {
                    assert!(d.hole[i], "({x}, {y}) unfilled");
                    assert_eq!(d.colour[i], d.colour[k], "({x}, {y}) copies ({}, {y})", k % w as usize);
                    assert_ne!(d.colour[i], common::RED, "({x}, {y}) took the foreground");
                    assert!(reals.contains(&d.colour[i]));
                    gap += 1;
                }
                // The right border column: nothing behind it.
                None => assert!(!d.hole[i] && x == w as usize - 1, "({x}, {y})"),
            }
        }
    }
    assert_eq!(gap, 3 * h as usize, "the disocclusion is 3 samples wide");
    assert_eq!(count(&f.hole_fill, "filled"), gap as u64);
    assert_eq!(count(&f.hole_fill, "unreached"), h as u64);
}

/// A 21x21 frame: a real ring on the border, each sample coloured by its
/// position (`[x/32, y/32, 0.5]`), and a real 3x3 blob at (9..12, 9..12)
/// coloured red; all else empty.
fn ring_and_blob() -> DestPlanes {
    let n = 21;
    let mut d = DestPlanes::new(n, n);
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) as usize;
            if x == 0 || y == 0 || x == n - 1 || y == n - 1 {
                d.real.set(i, true);
                d.colour[i] = [x as f32 / 32.0, y as f32 / 32.0, 0.5];
            } else if (9..12).contains(&x) && (9..12).contains(&y) {
                d.real.set(i, true);
                d.colour[i] = common::RED;
            }
        }
    }
    d
}

/// The ring sample whose colour `c` is.
fn decode(c: [f32; 3]) -> (f64, f64) {
    assert_eq!(c[2], 0.5, "not a ring colour: {c:?}");
    ((c[0] * 32.0).round() as f64, (c[1] * 32.0).round() as f64)
}

#[test]
fn stretch_direction_follows_the_epipole() {
    let e = (10.0, 10.0);
    // Front epipole at the centre: fill from the side away from it, i.e.
    // from the ring, along the line through the epipole.
    let mut d = ring_and_blob();
    let c = fill("stretch", &commands(21, 21, Epipole { h: DVec3::new(e.0, e.1, 1.0) }), &mut d);
    assert_eq!(count(&c, "unreached"), 0);
    for i in d.hole.iter_ones() {
        let (px, py) = ((i % 21) as f64 - e.0, (i / 21) as f64 - e.1);
        let (qx, qy) = decode(d.colour[i]);
        let (qx, qy) = (qx - e.0, qy - e.1);
        let len = (qx * qx + qy * qy).sqrt();
        assert!(px * qx + py * qy > 0.0, "sample {i}: source on the epipole's other side");
        assert!(len * len > px * px + py * py, "sample {i}: source nearer the epipole");
        // Within rounding of the epipolar line through the hole.
        assert!((px * qy - py * qx).abs() / (px * px + py * py).sqrt() <= 0.75, "sample {i}: source off the line");
    }
    // Behind: fill toward the epipole, i.e. from the blob that covers it.
    let mut d = ring_and_blob();
    let c = fill("stretch", &commands(21, 21, Epipole { h: DVec3::new(-e.0, -e.1, -1.0) }), &mut d);
    assert_eq!(count(&c, "unreached"), 0);
    assert!(d.hole.iter_ones().all(|i| d.colour[i] == common::RED));
    // At infinity along +x: fill from −x, along rows.
    let mut d = ring_and_blob();
    let c = fill("stretch", &commands(21, 21, Epipole { h: DVec3::new(1.0, 0.0, 0.0) }), &mut d);
    assert_eq!(count(&c, "unreached"), 0);
    for i in d.hole.iter_ones() {
        let (x, y) = (i % 21, i / 21);
        let want = if (9..12).contains(&y) && x >= 12 { common::RED } else { [0.0, y as f32 / 32.0, 0.5] };
        assert_eq!(d.colour[i], want, "({x}, {y})");
    }
    // And along −y: fill from +y, along columns.
    let mut d = ring_and_blob();
    fill("stretch", &commands(21, 21, Epipole { h: DVec3::new(0.0, -1.0, 0.0) }), &mut d);
    for i in d.hole.iter_ones() {
        let (x, y) = (i % 21, i / 21);
        let want = if (9..12).contains(&x) && y <= 8 { common::RED } else { [x as f32 / 32.0, 20.0 / 32.0, 0.5] };
        assert_eq!(d.colour[i], want, "({x}, {y})");
    }
}

/// A red foreground strip (Z = 1.25) before a blue background (Z = 5); a
/// reference 48x24 pixels at x = 0 whose view holds all of that of a
/// 24x12-pixel derived camera at x = 0.1, ss = 2.
fn strip_scene() -> (FrameCommands, SampleImage) {
    let layers = [
        Layer { z: 5.0, x0: -100.0, x1: 100.0, colour: blue },
        Layer { z: 1.25, x0: -0.05, x1: 0.15, colour: common::red },
    ];
    let reference = at_x(48, 24, 0.0);
    let img = cast(&reference, 2, &layers);
    let cmd = FrameCommands::new(0, at_x(24, 12, 0.1), 2, &[(0, reference)]);
    (cmd, img)
}

#[test]
fn rubber_sheets_leave_no_hole_inside_a_covering_reference() {
    let (cmd, img) = strip_scene();
    let f = run("rubber-sheet", "none", &cmd, &[&img]);
    let d = &f.samples;
    assert_eq!(d.real.count_ones(), d.len(), "every derived sample covered");
    assert!(f.covered.all());
    assert!(f.reconstruction.primitives > 0);
    assert_eq!(f.reconstruction.extra["dropped_missing"], 0);
}

#[test]
fn rubber_sheets_bridge_the_discontinuity_where_mark_aa_leaves_a_hole() {
    let (cmd, img) = strip_scene();
    let mark = run("mark-aa", "none", &cmd, &[&img]);
    let sheet = run("rubber-sheet", "none", &cmd, &[&img]);
    let holes: Vec<usize> = (0..mark.samples.len()).filter(|&i| !mark.samples.real[i]).collect();
    // Foreground moves 8 samples left, background 2: a 6-sample gap right
    // of the strip on every row (24 rows), less what Mark's kernels cover.
    assert!(holes.len() >= 4 * 24, "mark-aa left {} holes", holes.len());
    for &i in &holes {
        let (c, z) = (sheet.samples.colour[i], sheet.samples.inv_z[i]);
        assert!(sheet.samples.real[i], "sample {i}");
        // Interpolated: some red and some blue, depth between the layers.
        assert!(c[0] > 0.0 && c[0] < 1.0 && c[2] > 0.0 && c[2] < 1.0, "sample {i}: {c:?}");
        assert!(z > 0.2 && z < 0.8, "sample {i}: 1/Z {z}");
    }
}
