//! Property suite: reconstruction kernels (`docs/invariants.md`, "Kernel
//! corners").
//!
//! A planar surface fills a small reference image; the derived camera moves
//! by a small random motion (translation up to 8 % of the plane's depth,
//! rotation up to 3°, same intrinsics: about 1:1 sample density). Every
//! reference sample's kernel is set up and rasterized by the golden model
//! (`golden::kernel_setup` + `golden::raster`) and by the hardware units
//! (`units::kernel_setup` + `units::raster`), for discontinuity thresholds
//! from 100 % to 140 %. Then:
//! - no kernel exceeds the 4x4 stamp;
//! - no cracks: every derived sample centre inside the warped footprint of
//!   the reference image (by a margin of 0.01 samples, for the `f32` depth
//!   and slopes of the reference) is covered by some kernel, because
//!   neighbouring kernels share their corners;
//! - nothing is drawn farther than 1.5 samples outside the footprint;
//! - the golden and hardware kernels cover the same samples.

use glam::{DQuat, DVec2, DVec3};
use postwarp::golden::config::OverLimit;
use postwarp::golden::kernel_setup as gk;
use postwarp::golden::raster::rect;
use postwarp::golden::transform::{Transformed, WarpContext};
use postwarp_rtl::units::kernel_setup as hk;
use postwarp_rtl::units::raster as hw_raster;
use postwarp_rtl::units::transform::{self as hw_transform, TransformUnit};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage, WarpSetup};
use proptest::prelude::*;
use std::collections::BTreeSet;

use crate::common;

/// Reference image side (samples).
const N: u32 = 20;
/// Stamp side.
const LIMIT: u32 = 4;

/// A plane `Z = z0 + a·X + b·Y` in the reference camera's frame.
#[derive(Clone, Copy, Debug)]
struct Plane {
    z0: f64,
    a: f64,
    b: f64,
}

fn camera(f: f64, position: DVec3, orientation: DQuat) -> Camera {
    let c = (N as f64 - 1.0) / 2.0;
    Camera {
        intrinsics: Intrinsics { width: N, height: N, fx: f, fy: f, cx: c, cy: c },
        pose: Pose { position, orientation },
    }
}

/// Exact 1/Z of the plane at reference image point `(x, y)`.
fn inv_z(cam: &Camera, p: Plane, x: f64, y: f64) -> f64 {
    let k = &cam.intrinsics;
    (1.0 - p.a * (x - k.cx) / k.fx - p.b * (y - k.cy) / k.fy) / p.z0
}

/// The plane as the reference frame stores it (`f32` depth and slopes).
fn reference(cam: &Camera, p: Plane) -> SampleImage {
    let mut img = SampleImage::empty(N, N);
    let k = cam.intrinsics;
    for y in 0..N {
        for x in 0..N {
            let i = img.index(x, y);
            img.z[i] = (1.0 / inv_z(cam, p, x as f64, y as f64)) as f32;
            img.inv_z_slopes[i] = [(-p.a / (k.fx * p.z0)) as f32, (-p.b / (k.fy * p.z0)) as f32];
            img.colour[i] = [x as f32 / N as f32, y as f32 / N as f32, 0.5];
            img.valid.set(i, true);
        }
    }
    img
}

/// Signed distances of `q` to the edges of the convex quad `c` (positive
/// inside).
fn edge_distances(c: &[DVec2; 4], q: DVec2) -> [f64; 4] {
    let area: f64 = (0..4).map(|k| c[k].perp_dot(c[(k + 1) % 4])).sum();
    let s = area.signum();
    std::array::from_fn(|k| {
        let (p0, p1) = (c[k], c[(k + 1) % 4]);
        s * (p1 - p0).perp_dot(q - p0) / (p1 - p0).length()
    })
}

struct Coverage {
    golden: BTreeSet<(u32, u32)>,
    hardware: BTreeSet<(u32, u32)>,
    over_limit: Vec<((u32, u32), (u32, u32))>,
}

fn rasterize(src: &Camera, dst: &Camera, img: &SampleImage, threshold: f64) -> Coverage {
    let setup = WarpSetup::new(src, dst);
    let ctx = WarpContext::new(setup, *src, *dst, vec![src.pose.position], 0, 0.0);
    let tu = TransformUnit::new(setup, *src, *dst, vec![src.pose.position], 0, 0.0);
    let iz = |i: usize| 1.0 / img.z[i] as f64;
    let gw: Vec<Option<Transformed>> =
        (0..img.len()).map(|i| ctx.transform((i as u32 % N) as f64, (i as u32 / N) as f64, iz(i))).collect();
    let hw: Vec<Option<hw_transform::Transformed>> =
        (0..img.len()).map(|i| tu.warp((i as u32 % N) as f64, (i as u32 / N) as f64, iz(i))).collect();
    let size = (N, N);
    let mut cov = Coverage { golden: BTreeSet::new(), hardware: BTreeSet::new(), over_limit: Vec::new() };
    let hgroup = |gx: i64, gy: i64| -> Option<hk::Group> {
        if gx < 0 || gy < 0 || gx + 1 >= N as i64 || gy + 1 >= N as i64 {
            return None;
        }
        let at = |x: i64, y: i64| hw[(y * N as i64 + x) as usize];
        Some(hk::group(at(gx, gy), at(gx + 1, gy), at(gx, gy + 1), at(gx + 1, gy + 1), threshold))
    };
    for y in 0..N {
        for x in 0..N {
            let i = img.index(x, y);
            // Golden.
            let t = gw[i].expect("the plane is in front of the derived camera");
            let at = |sx: u32, sy: u32| gw[img.index(sx, sy)];
            let (c, _) = gk::corners(&ctx, img, &t, |gx, gy| gk::group(at, gx, gy, threshold), x, y);
            let (x0, x1, y0, y1) = gk::bounding_box(&c);
            let r = rect(x0, x1, y0, y1, (t.pos.x, t.pos.y), LIMIT, OverLimit::Clip, size);
            if r.over_limit {
                cov.over_limit.push(((x, y), r.size));
            }
            r.for_each(|u, v| {
                cov.golden.insert((u, v));
            });
            // Hardware.
            let w = hw[i].expect("the plane is in front of the derived camera");
            let (xi, yi) = (x as i64, y as i64);
            let groups = [hgroup(xi - 1, yi - 1), hgroup(xi, yi - 1), hgroup(xi - 1, yi), hgroup(xi, yi)];
            let (c, _) = hk::corners(&tu, &w, x, y, iz(i), img.inv_z_slopes[i], groups);
            let (x0, x1, y0, y1) = hk::bounding_box(&c);
            hw_raster::rect(x0, x1, y0, y1, (w.pos.x, w.pos.y), LIMIT, size).for_each(|u, v| {
                cov.hardware.insert((u, v));
            });
        }
    }
    cov
}

fn motion() -> impl Strategy<Value = (DVec3, DQuat)> {
    let axis = (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0);
    (prop::array::uniform3(-0.08f64..0.08), axis, 0.0f64..3.0).prop_map(|(t, (ax, ay, az), deg)| {
        let a = DVec3::new(ax, ay, az);
        let q =
            if a.length() < 1e-3 { DQuat::IDENTITY } else { DQuat::from_axis_angle(a.normalize(), deg.to_radians()) };
        (DVec3::from(t), q)
    })
}

fn plane() -> impl Strategy<Value = Plane> {
    (2.0f64..20.0, -0.6f64..0.6, -0.6f64..0.6).prop_map(|(z0, a, b)| Plane { z0, a, b })
}

proptest! {
    #![proptest_config(common::prop_config(256))]

    #[test]
    fn planar_surfaces_warp_without_cracks_in_4x4_kernels(
        p in plane(),
        (t, q) in motion(),
        f in 15.0f64..40.0,
        threshold in prop_oneof![Just(1.0f64), Just(1.4), 1.0f64..1.4],
    ) {
        let src = camera(f, DVec3::ZERO, DQuat::IDENTITY);
        let dst = camera(f, t * p.z0, q);
        let img = reference(&src, p);
        let cov = rasterize(&src, &dst, &img, threshold);
        prop_assert!(cov.over_limit.is_empty(), "kernels over 4x4 (sample, size): {:?}", cov.over_limit);

        // The warped footprint of the reference image, corners exact.
        let setup = WarpSetup::new(&src, &dst);
        let e = N as f64 - 0.5;
        let foot: [DVec2; 4] = [(-0.5, -0.5), (e, -0.5), (e, e), (-0.5, e)]
            .map(|(x, y)| setup.warp(x, y, inv_z(&src, p, x, y)).position);
        let mut cracks = Vec::new();
        let mut outside = Vec::new();
        for v in 0..N {
            for u in 0..N {
                let d = edge_distances(&foot, DVec2::new(u as f64, v as f64));
                let covered = cov.golden.contains(&(u, v));
                if d.iter().all(|&d| d >= 0.01) && !covered {
                    cracks.push((u, v));
                }
                if covered && d.iter().any(|&d| d < -1.5) {
                    outside.push((u, v));
                }
            }
        }
        prop_assert!(cracks.is_empty(), "uncovered samples inside the footprint {foot:?}: {cracks:?}");
        prop_assert!(outside.is_empty(), "covered samples far outside the footprint {foot:?}: {outside:?}");
        prop_assert_eq!(&cov.golden, &cov.hardware, "golden and hardware kernels cover different samples");
    }
}
