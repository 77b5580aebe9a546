//! Exact little scenes for the golden-model tests: fronto-parallel layers
//! ray cast in a few lines, so expected images are known independently of
//! the warper and of the scene renderer. Shared by `golden_rules.rs` and
//! `golden_general.rs`.
#![allow(dead_code)]

pub mod engine_runs;
pub mod fifo;
pub mod props;

use glam::{DQuat, DVec3};
use postwarp::golden::planes::DestPlanes;
use postwarp_rtl::dest_frame::DestSample;
use postwarp_rtl::{Camera, DestFrame, Intrinsics, Pose, SampleImage};

/// A fronto-parallel rectangle at depth `z`, `x0 <= X < x1`, all Y.
#[derive(Clone, Copy)]
pub struct Layer {
    pub z: f64,
    pub x0: f64,
    pub x1: f64,
    pub colour: fn(f64) -> [f32; 3],
}

pub fn grey_stripes(x: f64) -> [f32; 3] {
    let v = if (x * 4.0).floor() as i64 % 2 == 0 { 0.3 } else { 0.5 };
    [v, v, v]
}

pub fn red(_: f64) -> [f32; 3] {
    [1.0, 0.0, 0.0]
}

pub const RED: [f32; 3] = [1.0, 0.0, 0.0];

pub fn camera(w: u32, h: u32, pos: DVec3) -> Camera {
    Camera {
        intrinsics: Intrinsics {
            width: w,
            height: h,
            fx: 50.0,
            fy: 50.0,
            cx: (w as f64 - 1.0) / 2.0,
            cy: (h as f64 - 1.0) / 2.0,
        },
        pose: Pose { position: pos, orientation: DQuat::IDENTITY },
    }
}

pub fn at_x(w: u32, h: u32, x: f64) -> Camera {
    camera(w, h, DVec3::new(x, 0.0, 0.0))
}

/// Ray cast the layers from `cam` (identity orientation) at `ss x ss`
/// samples per pixel.
pub fn render(cam: &Camera, ss: u32, layers: &[Layer]) -> SampleImage {
    let s = cam.sample_grid(ss);
    let k = s.intrinsics;
    let mut img = SampleImage::empty(k.width, k.height);
    for y in 0..k.height {
        for x in 0..k.width {
            let d = s.ray_direction(x as f64, y as f64);
            let mut best: Option<(f64, usize)> = None;
            for (n, l) in layers.iter().enumerate() {
                let t = l.z - s.pose.position.z;
                let wx = s.pose.position.x + d.x * t;
                if t > 0.0 && wx >= l.x0 && wx < l.x1 && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, n));
                }
            }
            if let Some((t, n)) = best {
                let i = img.index(x, y);
                img.z[i] = t as f32;
                img.colour[i] = (layers[n].colour)(s.pose.position.x + d.x * t);
                img.object_id[i] = n as u32 + 1;
                img.valid.set(i, true);
            }
        }
    }
    img
}

/// Proptest configuration for the `props_*` suites: `default` cases, or the
/// number in the environment variable `PROPTEST_CASES` when it is set (to
/// run the suites harder than CI does: `PROPTEST_CASES=10000 cargo test
/// --test suite props_raster::`). Failing seeds are kept in
/// `tests/<suite>.proptest-regressions` and replayed first.
pub fn prop_config(default: u32) -> proptest::test_runner::Config {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default);
    proptest::test_runner::Config {
        cases,
        // Suites that discard impossible cases (a point behind a random
        // camera) reject a share of them: scale the limit with the cases.
        max_global_rejects: cases.max(1024),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..proptest::test_runner::Config::default()
    }
}

/// The golden model's derived planes as the hardware store holds them (the
/// planes both have; the golden mesh/splat bit has no hardware plane).
pub fn dest_frame(d: &DestPlanes) -> DestFrame {
    let samples = (0..d.colour.len())
        .map(|i| DestSample {
            colour: d.colour[i],
            inv_z: d.inv_z[i],
            slopes: d.slopes[i],
            fill_colour: d.fill_colour[i],
            fill_weight: d.fill_weight[i],
            source: d.source[i],
            fill_distance: d.fill_distance[i],
        })
        .collect();
    DestFrame {
        width: d.width,
        height: d.height,
        samples,
        hole: d.hole.clone(),
        real: d.real.clone(),
        fill_valid: d.fill_valid.clone(),
    }
}

/// Copy directory `from` (a trace, a sweep) into `to`, recursively.
pub fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()))
        } else {
            std::fs::copy(&p, to.join(e.file_name())).map(|_| ()).unwrap()
        }
    }
}
