//! Property suite: the 3D warp and the occlusion-compatible traversal
//! (`docs/invariants.md`, "Warp").
//!
//! - Warping a sample to a random derived camera lands where projecting its
//!   3D point lands, and warping it back returns it.
//! - The forward eight-sheet order (golden `traversal::order` and the
//!   hardware sequencer's `OrderKey`) never visits a sample after one that may
//!   occlude it: on every epipolar half-line, the sample nearer the other
//!   camera comes later (exactly collinear pairs, all pairs of the image),
//!   and inside a sheet every 8-neighbour visited later lies along `D`.
//!   Epipoles: inside and outside the image, in front and behind, at
//!   infinity, on sample centres and between them.

use glam::{DQuat, DVec2, DVec3};
use postwarp::golden::transform::WarpContext;
use postwarp::golden::traversal as golden;
use postwarp_rtl::camera::{Epipole, EpipoleKind};
use postwarp_rtl::traversal::OrderKey;
use postwarp_rtl::units::transform::TransformUnit;
use postwarp_rtl::{Camera, Intrinsics, Pose, WarpSetup};
use proptest::prelude::*;

use crate::common;
use crate::common::props::{epipole_strategy, finite};

/// A camera 1 to 10 units from the origin, looking at a point up to 3 units
/// from it, with any roll, any image size from 8 to 2000 samples, focal
/// lengths from 20 to 2000 samples and an off-centre principal point.
fn camera_strategy() -> impl Strategy<Value = Camera> {
    let intrinsics = (8u32..2000, 8u32..2000, 20.0f64..2000.0, 0.8f64..1.25, 0.3f64..0.7, 0.3f64..0.7);
    let unit = (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_map(|(x, y, z)| DVec3::new(x, y, z))
        .prop_filter("a direction", |v| v.length() > 0.1)
        .prop_map(|v| v.normalize());
    (intrinsics, unit, 1.0f64..10.0, prop::array::uniform3(-3.0f64..3.0), 0.0f64..std::f64::consts::TAU).prop_map(
        |((w, h, fx, aspect, u, v), dir, dist, target, roll)| {
            let position = dir * dist;
            let up = if dir.y.abs() > 0.9 { DVec3::X } else { DVec3::Y };
            let pose = Pose::look_at(position, DVec3::from(target), up);
            let orientation = pose.orientation * DQuat::from_rotation_z(roll);
            let intrinsics =
                Intrinsics { width: w, height: h, fx, fy: fx * aspect, cx: u * w as f64, cy: v * h as f64 };
            Camera { intrinsics, pose: Pose { position, orientation } }
        },
    )
}

/// Relative closeness: `|a − b| <= tol · max(1, |a|)`.
fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(1.0)
}

proptest! {
    #![proptest_config(common::prop_config(2000))]

    /// Tolerances: 1e-7 relative (to max(1, |value|)) for positions and
    /// 1e-9 for 1/Z, against a double-precision warp whose conditioning is
    /// about the focal length (≤ 2500) times the depth ratio.
    #[test]
    fn a_warped_sample_lands_on_its_projection_and_warps_back(
        r in camera_strategy(),
        d in camera_strategy(),
        (u, v) in (0.0f64..1.0, 0.0f64..1.0),
        z in 0.05f64..30.0,
    ) {
        let k = r.intrinsics;
        let (x, y) = (u * (k.width - 1) as f64, v * (k.height - 1) as f64);
        let p = r.unproject(x, y, z);
        let Some((q, z2)) = d.project(p) else { return Err(TestCaseError::reject("behind the derived camera")) };
        prop_assume!(z2 > 1e-2 && z2 < 1e4 && q.length() < 1e7);

        let fw = WarpSetup::new(&r, &d).warp(x, y, 1.0 / z);
        prop_assert!(fw.w > 0.0);
        prop_assert!(close(fw.position.x, q.x, 1e-7) && close(fw.position.y, q.y, 1e-7),
            "warp {:?} vs projection {q:?}", fw.position);
        prop_assert!(close(fw.inv_z, 1.0 / z2, 1e-9), "1/Z {} vs {}", fw.inv_z, 1.0 / z2);

        let back = WarpSetup::new(&d, &r).warp(fw.position.x, fw.position.y, fw.inv_z);
        prop_assert!(back.w > 0.0);
        prop_assert!(close(back.position.x, x, 1e-7) && close(back.position.y, y, 1e-7),
            "({x}, {y}) came back as {:?}", back.position);
        prop_assert!(close(back.inv_z, 1.0 / z, 1e-9));

        // The golden transform and the hardware transform unit warp with
        // the same arithmetic: the same bits.
        let s = WarpSetup::new(&r, &d);
        let g = WarpContext::new(s, r, d, vec![r.pose.position], 0, 0.0).transform(x, y, 1.0 / z).expect("in front");
        let h = TransformUnit::new(s, r, d, vec![r.pose.position], 0, 0.0).warp(x, y, 1.0 / z).expect("in front");
        prop_assert_eq!(g.pos, fw.position);
        prop_assert_eq!(h.pos, fw.position);
        prop_assert_eq!((g.inv_z.to_bits(), g.e.to_bits()), (h.inv_z.to_bits(), h.e.to_bits()));
    }
}

// ---------------------------------------------------------------- traversal

/// Visit position of every sample `y·w + x`, from the golden order and from
/// sorting the hardware sequencer's ranks.
fn ranks(w: u32, h: u32, e: &Epipole) -> (Vec<u64>, Vec<u64>) {
    let mut g = vec![u64::MAX; (w * h) as usize];
    for (k, (x, y)) in golden::order(w, h, e).into_iter().enumerate() {
        g[(y * w + x) as usize] = k as u64;
    }
    let r = OrderKey::new(w, h, e);
    let mut by_rank: Vec<(u64, u32)> = (0..w * h).map(|i| (r.key(i % w, i / w), i)).collect();
    by_rank.sort_unstable();
    let mut hw = vec![u64::MAX; (w * h) as usize];
    for (k, (_, i)) in by_rank.into_iter().enumerate() {
        hw[i as usize] = k as u64;
    }
    (g, hw)
}

/// An epipole whose coordinates are exact halves (finite) or an integer
/// direction (infinity), so that samples lie exactly on epipolar lines.
/// Returns the epipole and, for the exact tests, `(2ex, 2ey, sign(ew))` or
/// `(dx, dy, 0)`.
fn exact_epipole() -> impl Strategy<Value = (Epipole, (i64, i64, i64))> {
    prop_oneof![
        (-8i64..40, -8i64..40, prop::sample::select(vec![1.0f64, -1.0, 0.5, -2.0]))
            .prop_map(|(x2, y2, w)| (finite(x2 as f64 / 2.0, y2 as f64 / 2.0, w), (x2, y2, w.signum() as i64))),
        (-3i64..=3, -3i64..=3)
            .prop_filter("a direction", |&(a, b)| (a, b) != (0, 0))
            .prop_map(|(a, b)| (Epipole { h: DVec3::new(a as f64, b as f64, 0.0) }, (a, b, 0))),
    ]
}

/// True if sample `q` may occlude sample `p` in the warp: both lie on one
/// epipolar half-line and `q` is nearer the other camera (between `p` and a
/// front epipole; beyond `p` away from a behind one; further along an
/// epipole at infinity's direction).
fn may_occlude(p: (i64, i64), q: (i64, i64), e: (i64, i64, i64)) -> bool {
    if p == q {
        return false;
    }
    let u = (2 * (q.0 - p.0), 2 * (q.1 - p.1));
    let (v, front) = match e.2 {
        0 => ((e.0, e.1), false),
        s => ((s * (e.0 - 2 * p.0), s * (e.1 - 2 * p.1)), s > 0),
    };
    if v == (0, 0) || u.0 * v.1 - u.1 * v.0 != 0 || u.0 * v.0 + u.1 * v.1 <= 0 {
        return false;
    }
    // In front: `q` strictly before the epipole (beyond it is the other
    // half-line, a different ray).
    !front || u.0 * u.0 + u.1 * u.1 < v.0 * v.0 + v.1 * v.1
}

proptest! {
    #![proptest_config(common::prop_config(300))]

    /// The forward order visits a sample before any that may occlude it;
    /// the warp's order (ring bands and sweeps reordered, each sheet read
    /// backwards, `traversal.rs` rules 6–8) visits every one after them, so
    /// a sample is always composited against everything that may hide it
    /// in the same relative order, whatever order the sheets and bands
    /// come in (images of up to 30 samples: up to four ring bands of 8).
    #[test]
    fn no_sample_is_visited_after_one_that_may_occlude_it(
        w in 1u32..30,
        h in 1u32..30,
        (e, exact) in exact_epipole(),
    ) {
        let (g, hw) = ranks(w, h, &e);
        prop_assert_eq!(&g, &hw, "golden order and hardware rank disagree");
        let mut warp = vec![u64::MAX; (w * h) as usize];
        for (k, (x, y)) in golden::warp_order(w, h, &e).into_iter().enumerate() {
            warp[(y * w + x) as usize] = k as u64;
        }
        for pi in 0..w * h {
            for qi in 0..w * h {
                let (px, py) = ((pi % w) as i64, (pi / w) as i64);
                let (qx, qy) = ((qi % w) as i64, (qi / w) as i64);
                if may_occlude((px, py), (qx, qy), exact) {
                    prop_assert!(g[qi as usize] > g[pi as usize],
                        "({qx},{qy}) may occlude ({px},{py}) but is visited first; epipole {:?}", e.h);
                    prop_assert!(warp[qi as usize] < warp[pi as usize],
                        "({qx},{qy}) may occlude ({px},{py}) but the warp visits it later; epipole {:?}", e.h);
                }
            }
        }
    }

    /// Inside one sheet, an 8-neighbour `q` visited after `p` never lies
    /// against the traversal direction: `(q − p)·D(p) ≥ 0` (up to rounding).
    /// This is the discrete property the eight-sheet split exists for.
    #[test]
    fn later_neighbours_in_a_sheet_lie_along_the_traversal_direction(
        w in 1u32..24,
        h in 1u32..24,
        e in epipole_strategy(),
    ) {
        let mut sheet = vec![0usize; (w * h) as usize];
        let mut rank = vec![0usize; (w * h) as usize];
        let mut k = 0;
        for (s, sh) in golden::sheets(w, h, &e).iter().enumerate() {
            for &(x, y) in &sh.samples {
                sheet[(y * w + x) as usize] = s;
                rank[(y * w + x) as usize] = k;
                k += 1;
            }
        }
        prop_assert_eq!(k as u32, w * h, "every sample visited once");
        if matches!(e.kind(), EpipoleKind::Coincident) {
            return Ok(());
        }
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let pi = (y * w as i64 + x) as usize;
                let dir = e.direction_at(DVec2::new(x as f64, y as f64));
                for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w as i64 || qy >= h as i64 {
                        continue;
                    }
                    let qi = (qy * w as i64 + qx) as usize;
                    if sheet[qi] != sheet[pi] || rank[qi] < rank[pi] {
                        continue;
                    }
                    let along = dx as f64 * dir.x + dy as f64 * dir.y;
                    prop_assert!(along >= -1e-9 * dir.length(),
                        "({qx},{qy}) visited after ({x},{y}) against D = {dir:?}; epipole {:?}", e.h);
                }
            }
        }
    }
}
