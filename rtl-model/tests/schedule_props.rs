//! The tile manager's schedule (`schedule.rs`) as properties over small
//! generated references and warps: the fetch plan (rule 1), off-screen
//! culling and tile retirement (rules 2–3), and the release order (rule 4)
//! against a brute-force computation, sample by sample, from the hole
//! fill's own tap positions.
//!
//! Culling and retirement are checked for being conservative, which is
//! what the schedule promises ("a conservative bound costs cache space and
//! time, never correctness"): every derived sample a kernel of line `k`
//! can cover makes line `k` live and lies in a tile that retires no
//! earlier than after line `k`. A kernel's box is the bounding box of its
//! corners, each the mean of four warped samples of its 3x3
//! neighbourhood, one of its exact edge corners, or its own warped
//! position (`units::kernel_setup` rules 2–4), so the bounding box of all
//! of those contains it; the rasterizer covers the sample centres inside
//! the box, clipped further (`units::raster`).

use crate::common;

use crate::common::{Warp, config, image};
use glam::DVec3;
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::schedule::release_order;
use postwarp_rtl::traversal::{Line, Major, forward_lines};
use postwarp_rtl::units::hole_fill::{HoleFillParams, HoleFillUnit};
use proptest::prelude::*;

/// A generated reference and warp.
#[derive(Clone, Debug)]
struct Scene {
    w: u32,
    h: u32,
    /// Rectangles (x0, y0, x1, y1) of surfaces at a depth; later ones win.
    rects: Vec<(u32, u32, u32, u32, f32)>,
    /// Derived camera position and yaw.
    pos: (f64, f64, f64),
    yaw: f64,
    tile: u32,
}

fn scene() -> impl Strategy<Value = Scene> {
    (6u32..=20, 6u32..=16).prop_flat_map(|(w, h)| {
        let rect = (0..w, 0..h, 1..=w, 1..=h, 1.5f32..12.0)
            .prop_map(move |(x0, y0, dx, dy, z)| (x0, y0, (x0 + dx).min(w), (y0 + dy).min(h), z));
        (
            Just(w),
            Just(h),
            prop::collection::vec(rect, 1..5),
            (-1.0f64..1.0, -0.6f64..0.6, -0.8f64..0.8),
            -0.4f64..0.4,
            prop_oneof![Just(2u32), Just(4), Just(8)],
        )
            .prop_map(|(w, h, rects, pos, yaw, tile)| Scene { w, h, rects, pos, yaw, tile })
    })
}

fn build(s: &Scene) -> Warp {
    let img = image(s.w, s.h, |x, y| {
        s.rects.iter().rev().find(|r| (r.0..r.2).contains(&x) && (r.1..r.3).contains(&y)).map(|r| (r.4, [0.5; 3]))
    });
    let cfg = postwarp_rtl::config::EngineConfig { tile_size: s.tile, ..config() };
    Warp::new(&img, DVec3::new(s.pos.0, s.pos.1, s.pos.2), s.yaw, cfg)
}

/// `(lines, length)` of a sheet of axis `major` in a `w x h` image.
fn extent(major: Major, w: u32, h: u32) -> (i64, i64) {
    match major {
        Major::Row => (h as i64, w as i64),
        Major::Column => (w as i64, h as i64),
    }
}

fn at(major: Major, line: i64, a: i64) -> (u32, u32) {
    match major {
        Major::Row => (a as u32, line as u32),
        Major::Column => (line as u32, a as u32),
    }
}

proptest! {
    #![proptest_config(common::prop_config(96))]

    /// Rule 1: intervals lie on the image; a line is live iff it has a
    /// need; a live line needs the interval of the next line of its sheet
    /// (its own at the image's edge); every sample kernel setup's line
    /// buffer reads for a live line (its line and the two beside it,
    /// widened by one at both ends) is fetched by an interval no later
    /// than the need; and every interval lies within one line of a live
    /// line of its axis, inside their widened extents.
    #[test]
    fn the_fetch_plan_streams_each_live_lines_neighbourhood_before_its_need(s in scene()) {
        let wp = build(&s);
        let sc = &wp.sched;
        let (w, h) = (s.w, s.h);
        for iv in &sc.fetch {
            let (lines, len) = extent(iv.major, w, h);
            prop_assert!(iv.lo <= iv.hi && (iv.hi as i64) < len && (iv.line as i64) < lines, "{:?}", iv);
            prop_assert!(iv.step == 1 || iv.step == -1);
        }
        // The first interval streaming each sample.
        let mut first = vec![usize::MAX; (w * h) as usize];
        for (k, iv) in sc.fetch.iter().enumerate() {
            for j in 0..iv.len() {
                let (x, y) = iv.at(j);
                let f = &mut first[(y * w + x) as usize];
                *f = (*f).min(k);
            }
        }
        for (k, l) in sc.lines.iter().enumerate() {
            prop_assert_eq!(sc.live[k], sc.need[k].is_some(), "line {}", k);
            let Some(need) = sc.need[k] else { continue };
            let (lines, len) = extent(l.major, w, h);
            let next = l.line as i64 + l.line_step as i64;
            let want = if (0..lines).contains(&next) { next } else { l.line as i64 };
            prop_assert_eq!((sc.fetch[need].major, sc.fetch[need].line as i64), (l.major, want), "need of line {}", k);
            for c in l.line as i64 - 1..=l.line as i64 + 1 {
                if !(0..lines).contains(&c) {
                    continue;
                }
                for a in (l.lo as i64 - 1).max(0)..=(l.hi as i64 + 1).min(len - 1) {
                    let (x, y) = at(l.major, c, a);
                    let i = (y * w + x) as usize;
                    if wp.samples.valid[i] {
                        prop_assert!(first[i] <= need, "line {} reads ({}, {}) fetched by {} > need {}", k, x, y, first[i], need);
                    }
                }
            }
        }
        for iv in &sc.fetch {
            let near: Vec<&Line> = sc.lines.iter().zip(&sc.live)
                .filter(|(l, live)| **live && l.major == iv.major && (l.line as i64 - iv.line as i64).abs() <= 1)
                .map(|p| p.0)
                .collect();
            prop_assert!(!near.is_empty(), "{:?} is no live line's neighbour", iv);
            let lo = near.iter().map(|l| l.lo as i64 - 1).min().unwrap().max(0);
            let hi = near.iter().map(|l| l.hi as i64 + 1).max().unwrap();
            prop_assert!(iv.lo as i64 >= lo && iv.hi as i64 <= hi, "{:?} beyond its lines' widened extents", iv);
        }
    }

    /// Rules 2–3: every derived sample a kernel of line `k` can cover
    /// (module doc) makes line `k` live and is in a tile whose retirement
    /// line is at least `k`; a tile's retirement line is live.
    #[test]
    fn culling_and_retirement_are_conservative(s in scene()) {
        check_conservative(&s)?;
    }

    /// Rule 4 on the hole fill's own order and taps: the release order is
    /// every tile once, each with the last visit (1-based, in fill order)
    /// of a sample in it or of a sample with a tap in it, sorted.
    #[test]
    fn the_release_order_is_the_brute_force_per_sample_last_visit(
        w in 1u32..20,
        h in 1u32..20,
        e in (-30.0f64..30.0, -30.0f64..30.0, prop_oneof![Just(0.0f64), Just(1.0), Just(-1.0), -2.0f64..2.0]),
        tile in prop_oneof![Just(1u32), Just(2), Just(3), Just(4), Just(8)],
        far in 0u32..6,
    ) {
        let lines = forward_lines(w, h, &Epipole { h: DVec3::new(e.0, e.1, e.2) });
        check_release_order(&lines, w, h, tile, far)?;
    }

    /// The same on arbitrary line lists (release order is defined for any
    /// visiting order of lines, `schedule::release_order`).
    #[test]
    fn the_release_order_is_the_brute_force_on_any_lines(
        w in 1u32..16,
        h in 1u32..16,
        raw in prop::collection::vec((any::<bool>(), any::<u32>(), any::<u32>(), any::<u32>(), any::<bool>(), any::<bool>()), 0..12),
        tile in prop_oneof![Just(1u32), Just(2), Just(3), Just(4)],
        far in 0u32..6,
    ) {
        let lines: Vec<Line> = raw
            .into_iter()
            .map(|(row, line, a, b, fwd, down)| {
                let major = if row { Major::Row } else { Major::Column };
                let (n, len) = extent(major, w, h);
                let (a, b) = (a % len as u32, b % len as u32);
                Line {
                    sheet: 0,
                    major,
                    line: line % n as u32,
                    lo: a.min(b),
                    hi: a.max(b),
                    step: if fwd { 1 } else { -1 },
                    line_step: if down { 1 } else { -1 },
                }
            })
            .collect();
        check_release_order(&lines, w, h, tile, far)?;
    }
}

/// Rules 2–3 on one scene (see the property); the number of kernels
/// that cover some sample.
fn check_conservative(s: &Scene) -> Result<usize, TestCaseError> {
    let wp = build(s);
    let (sc, tu) = (&wp.sched, &wp.tu);
    let (w, h) = (s.w as i64, s.h as i64);
    let tw = s.w.div_ceil(s.tile) as i64;
    let valid = |x: i64, y: i64| (0..w).contains(&x) && (0..h).contains(&y) && wp.samples.valid[(y * w + x) as usize];
    let inv_z = |x: i64, y: i64| wp.inv_z[(y * w + x) as usize];
    let mut kernels = 0;
    for (k, l) in sc.lines.iter().enumerate() {
        for (x, y) in l.samples() {
            let (x, y) = (x as i64, y as i64);
            if !valid(x, y) {
                continue;
            }
            let Some(own) = tu.warp(x as f64, y as f64, inv_z(x, y)) else { continue };
            let mut pts = vec![own.pos];
            for (dx, dy) in (-1..=1).flat_map(|dx| (-1..=1).map(move |dy| (dx, dy))) {
                if valid(x + dx, y + dy)
                    && let Some(n) = tu.warp((x + dx) as f64, (y + dy) as f64, inv_z(x + dx, y + dy))
                {
                    pts.push(n.pos);
                }
            }
            let slopes = wp.samples.inv_z_slopes[(y * w + x) as usize];
            for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                if let Some(c) = tu.edge_corner(x as f64, y as f64, inv_z(x, y), slopes, sx, sy) {
                    pts.push(c);
                }
            }
            let x0 = pts.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
            let x1 = pts.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
            let y0 = pts.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
            let y1 = pts.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
            // Sample centres c with lo <= c < hi, on the image.
            let cx = ((x0.ceil() as i64).max(0), (x1.ceil() as i64 - 1).min(w - 1));
            let cy = ((y0.ceil() as i64).max(0), (y1.ceil() as i64 - 1).min(h - 1));
            if cx.0 > cx.1 || cy.0 > cy.1 {
                continue;
            }
            kernels += 1;
            prop_assert!(sc.live[k], "line {} covers ({}..={}, {}..={}) but is dead", k, cx.0, cx.1, cy.0, cy.1);
            for ty in cy.0 / s.tile as i64..=cy.1 / s.tile as i64 {
                for tx in cx.0 / s.tile as i64..=cx.1 / s.tile as i64 {
                    let t = (ty * tw + tx) as usize;
                    prop_assert!(
                        sc.retire[t].is_some_and(|l| l as usize >= k),
                        "tile {} written by line {} retires after {:?}",
                        t,
                        k,
                        sc.retire[t]
                    );
                }
            }
        }
    }
    for t in sc.retire.iter().flatten() {
        prop_assert!(sc.live[*t as usize], "retirement line {} is dead", t);
    }
    Ok(kernels)
}

#[test]
fn the_conservative_check_sees_kernels_and_dead_lines() {
    // Half the plane warps off the image: some lines are dead, the others
    // put kernels on it.
    let s = Scene { w: 16, h: 8, rects: vec![(0, 0, 16, 8, 4.0)], pos: (0.8, 0.0, 0.0), yaw: 0.0, tile: 4 };
    let wp = build(&s);
    assert!(wp.sched.live.iter().any(|&l| l) && wp.sched.live.iter().any(|&l| !l), "{:?}", wp.sched.live);
    assert!(check_conservative(&s).unwrap() > 0);
}

fn check_release_order(lines: &[Line], w: u32, h: u32, tile: u32, far: u32) -> Result<(), TestCaseError> {
    let params = HoleFillParams { far_distance: 4, far_offset: far, max_distance: 63 };
    let got = release_order(lines, (w, h), tile, &HoleFillUnit::tap_offsets(&params));
    let tw = w.div_ceil(tile);
    let mut last = vec![0u64; (tw * h.div_ceil(tile)) as usize];
    let tile_of = |x: u32, y: u32| ((y / tile) * tw + x / tile) as usize;
    let mut visit = 0u64;
    for l in lines {
        for (x, y) in l.samples() {
            visit += 1;
            let own = &mut last[tile_of(x, y)];
            *own = (*own).max(visit);
            for (tx, ty) in HoleFillUnit::tap_positions(l, x, y, &params) {
                if (0..w as i64).contains(&tx) && (0..h as i64).contains(&ty) {
                    let e = &mut last[tile_of(tx as u32, ty as u32)];
                    *e = (*e).max(visit);
                }
            }
        }
    }
    let mut want: Vec<(u64, u32)> = last.iter().enumerate().map(|(t, &v)| (v, t as u32)).collect();
    want.sort_unstable();
    prop_assert_eq!(got, want);
    Ok(())
}
