//! The body of every fuzz target, in one place, so that `cargo fuzz`
//! (`fuzz/fuzz_targets/<name>.rs` calls [`run`]) and the stable replay test
//! `tests/fuzz_corpus.rs` (every file of `fuzz/corpus/<name>/` and
//! `fuzz/regressions/<name>/`) run exactly the same code on an input.
//!
//! Each target feeds arbitrary bytes to one input parser the way the tools
//! do and returns `Ok` (accepted) or `Err` (the message the tools would
//! print). The contract under test:
//! - no input panics, hangs or allocates without bound;
//! - every error names the input file (all of them are called
//!   [`INPUT_NAME`]`.<ext>` here);
//! - what is accepted keeps the parser's promises (asserted here, so a
//!   broken promise is a crash the fuzzer reports): a manifest prints back
//!   to the same trace, loaded images hold only finite numbers and positive
//!   depths where a surface is claimed, and so on.
//!
//! Targets ([`TARGETS`]): `trace_manifest` (the text of a trace),
//! `exr_image` (two bytes giving the expected width − 1 and height − 1,
//! then an OpenEXR file, read as a reference image and as ground truth),
//! `pfm`, `obj` (a mesh, then placed and hit by a few rays), `scene` (a scene
//! description naming only `bundled:` files, then its camera path and a
//! 4x3 render), `hw_config` (a hardware configuration file),
//! `middlebury_calib` (`calib.txt`), `results_csv` (a sweep's
//! `results.csv`, read as `postwarp chart` reads it, its charts drawn as
//! SVG) and `report_json` (a `report.json` of any version, read as
//! `postwarp::report::load` reads it).

use crate::import::middlebury::parse_calib;
use crate::import::pfm::parse_pfm;
use crate::path::CameraPath;
use crate::path::predict::predict_pose;
use crate::path::spline::SplinePath;
use crate::path::tracked::TrackedPath;
use crate::scene::Scene;
use crate::scene::description::compile_bundled_only;
use crate::scene::geometry::Ray;
use crate::scene::mesh::{MeshData, MeshInstance};
use crate::trace::{MAX_SIDE, decode_reference_image, decode_truth_image, format_manifest, parse_manifest};
use glam::{DQuat, DVec3};
use postwarp_rtl::{Camera, Intrinsics, Pose};
use std::path::Path;
use std::sync::Arc;

/// Every target, by the name of its directory under `fuzz/corpus/`.
pub const TARGETS: [&str; 9] = [
    "trace_manifest",
    "exr_image",
    "pfm",
    "obj",
    "scene",
    "hw_config",
    "middlebury_calib",
    "results_csv",
    "report_json",
];

/// Stem of the file name every target gives its input in messages.
pub const INPUT_NAME: &str = "fuzz-input";

/// Run target `name` on `data`. Panics on an unknown name.
pub fn run(name: &str, data: &[u8]) -> Result<(), String> {
    match name {
        "trace_manifest" => trace_manifest(data),
        "exr_image" => exr_image(data),
        "pfm" => pfm(data),
        "obj" => obj(data),
        "scene" => scene(data),
        "hw_config" => hw_config(data),
        "middlebury_calib" => middlebury_calib(data),
        "results_csv" => results_csv(data),
        "report_json" => report_json(data),
        _ => panic!("unknown fuzz target `{name}` (known: {})", TARGETS.join(", ")),
    }
}

fn text<'a>(data: &'a [u8], file: &Path) -> Result<&'a str, String> {
    std::str::from_utf8(data).map_err(|e| format!("{}: not UTF-8 text ({e})", file.display()))
}

/// A trace manifest: parse; accepted ones must print back to the same trace
/// and give frame commands.
pub fn trace_manifest(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.trace");
    let t = parse_manifest(text(data, file)?, file).map_err(|e| {
        assert!(e.line.is_some(), "a manifest error names no line: {e}");
        e.to_string()
    })?;
    let printed = format_manifest(&t);
    let back = parse_manifest(&printed, file).unwrap_or_else(|e| panic!("printed manifest does not parse: {e}"));
    assert_eq!(back, t, "print then parse changed the trace");
    for i in 0..t.derived.len() {
        assert_eq!(t.frame_commands(i).warps.len(), t.derived[i].references.len());
    }
    Ok(())
}

/// Two bytes (expected width − 1, height − 1), then an OpenEXR file, read
/// as a reference image and as ground truth; the result is the reference's
/// (a truth error is only checked to name the file).
pub fn exr_image(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.exr");
    let [w, h, exr @ ..] = data else {
        return Err(format!("{}: shorter than the two size bytes", file.display()));
    };
    let (w, h) = (u32::from(*w) + 1, u32::from(*h) + 1);
    let n = (w * h) as usize;
    let reference = decode_reference_image(exr, file, (w, h)).map(|r| {
        let s = &r.samples;
        assert_eq!((s.width, s.height, s.z.len(), s.colour.len(), s.valid.len()), (w, h, n, n, n));
        for i in 0..n {
            assert!(s.colour[i].iter().all(|c| c.is_finite()), "colour {:?}", s.colour[i]);
            assert!(s.inv_z_slopes[i].iter().all(|c| c.is_finite()), "slopes {:?}", s.inv_z_slopes[i]);
            if s.valid[i] {
                assert!(s.z[i].is_finite() && s.z[i] > 0.0, "depth {} where a surface is claimed", s.z[i]);
            } else {
                assert_eq!(s.z[i], 0.0, "depth without a surface is read as 0");
            }
        }
    });
    let truth = decode_truth_image(exr, file, (w, h)).map(|t| {
        assert_eq!((t.width, t.height, t.colour.len(), t.known.len()), (w, h, n, n));
        assert!(t.colour.iter().flatten().all(|c| c.is_finite()));
    });
    if let Err(e) = truth {
        assert!(e.to_string().contains(INPUT_NAME), "a truth image error does not name the file: {e}");
    }
    reference.map_err(|e| e.to_string())
}

/// A Portable Float Map.
pub fn pfm(data: &[u8]) -> Result<(), String> {
    let img = parse_pfm(data, Path::new("fuzz-input.pfm")).map_err(|e| e.to_string())?;
    assert!((1..=MAX_SIDE).contains(&img.width) && (1..=MAX_SIDE).contains(&img.height));
    assert!(img.channels == 1 || img.channels == 3);
    assert_eq!(img.data.len(), img.width as usize * img.height as usize * img.channels);
    Ok(())
}

/// A Wavefront OBJ mesh, placed at unit size and hit by a 5x5 grid of rays
/// from each of the six axis directions.
pub fn obj(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.obj");
    let named = |e: String| format!("{}: {e}", file.display());
    let mesh = Arc::new(MeshData::from_obj_bytes(data).map_err(named)?);
    let m = MeshInstance::new(mesh, DVec3::new(10.0, 20.0, 30.0), 1.0, DVec3::ZERO).map_err(named)?;
    let b = m.bounds();
    assert!(b.min.is_finite() && b.max.is_finite(), "bounds {b:?}");
    let (centre, reach) = ((b.min + b.max) / 2.0, (b.max - b.min).max_element() + 1.0);
    for axis in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z] {
        let (u, v) = (axis.any_orthonormal_vector(), axis.cross(axis.any_orthonormal_vector()));
        for i in 0..25 {
            let (a, c) = ((i % 5) as f64 / 4.0 - 0.5, (i / 5) as f64 / 4.0 - 0.5);
            let origin = centre - axis * 2.0 * reach + (u * a + v * c) * reach;
            if let Some(hit) = m.intersect(&Ray { origin, dir: axis }, f64::INFINITY) {
                assert!(hit.t.is_finite() && hit.t > 0.0, "t = {}", hit.t);
                assert!((hit.normal.length() - 1.0).abs() < 1e-6, "normal {:?}", hit.normal);
            }
        }
    }
    Ok(())
}

/// A scene description naming only `bundled:` files; then its spline path,
/// a predicted pose, the tracked path's placement and a 4x3 render at two
/// poses.
pub fn scene(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.toml");
    let origin = file.to_string_lossy();
    let text = text(data, file)?;
    compile_bundled_only(text, &origin).map_err(|e| e.to_string())?;
    // Only bundled files are named, so this reads no file either.
    let scene = Scene::from_toml_str(text, None, &origin).expect("compiles as it did without files");
    let w: Vec<(DVec3, DVec3)> = scene.spline.waypoints.iter().map(|w| (w.position, w.look_at)).collect();
    let path = SplinePath::new(&w, scene.spline.duration_s).map_err(|e| format!("{origin}: {e}"))?;
    let s = &scene.tracked.start;
    let start = Pose::look_at(s.position, s.look_at, DVec3::Y);
    let records: Vec<(f64, Pose)> = (0..3)
        .map(|i| {
            let p = Pose { position: DVec3::new(0.01 * i as f64, 0.0, 0.0), orientation: DQuat::IDENTITY };
            (0.1 * i as f64, p)
        })
        .collect();
    let tracked =
        TrackedPath::from_records(&records, start, scene.tracked.scale, 0.0).map_err(|e| format!("{origin}: {e}"))?;
    let intrinsics = Intrinsics::from_hfov(4, 3, 60.0);
    for pose in [path.pose(0.0), predict_pose(&path, path.duration() / 2.0, 0.4), tracked.pose(0.15)] {
        let img = scene.render(&Camera { intrinsics, pose }, 1);
        assert_eq!(img.len(), 12);
    }
    Ok(())
}

/// A hardware configuration file, validated; accepted ones report every knob.
pub fn hw_config(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.toml");
    let c = crate::run::hw_config_toml::from_text(text(data, file)?, file).map_err(|e| format!("{e:#}"))?;
    let json = crate::run::hw_config_toml::to_json(&c);
    assert_eq!(json.as_object().map(|m| m.len()), Some(postwarp_rtl::config::KNOBS.len()));
    // `simulate --dump-config` writes a file `--config` reads back to it.
    let dumped = crate::run::hw_config_toml::dump(&c, "fuzz");
    let back = crate::run::hw_config_toml::from_text(&dumped, file).unwrap_or_else(|e| panic!("{e:#}\n{dumped}"));
    assert_eq!(back, c, "dump then read changed the configuration");
    Ok(())
}

/// A Middlebury `calib.txt`; accepted ones give finite positive depths.
pub fn middlebury_calib(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.txt");
    let c = parse_calib(text(data, file)?, file).map_err(|e| e.to_string())?;
    for d in [0.0, 0.5, 17.0, 300.0, f32::INFINITY] {
        if let Some(z) = c.depth_m(d) {
            assert!(z.is_finite() && z > 0.0, "depth {z} for disparity {d}");
        }
    }
    let (l, r) = (c.left_camera(), c.right_camera());
    assert!(l.pose.position.is_finite() && r.pose.position.is_finite());
    Ok(())
}

/// A `results.csv`: read as `postwarp chart` reads it; accepted ones give
/// charts that draw (as SVG; bounded axes whatever the numbers).
pub fn results_csv(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.csv");
    let t = crate::sweep::results::read_csv(text(data, file)?).map_err(|e| format!("{}:{e}", file.display()))?;
    assert!(t.rows.iter().all(|r| r.cells.len() == t.header.len()), "a ragged row was accepted");
    let charts = crate::chart::charts_from_table(&t);
    for (_, c) in charts.iter().take(2) {
        crate::chart::scatter::render_svg(c).map_err(|e| format!("{}: {e}", file.display()))?;
    }
    for (_, c) in crate::chart::stability::stress_charts(&t).iter().take(1) {
        crate::chart::stability::render_svg(c).map_err(|e| format!("{}: {e}", file.display()))?;
    }
    Ok(())
}

/// A `report.json` of any version; accepted ones are version 2 and read
/// back to the same report when written again.
pub fn report_json(data: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz-input.json");
    let r = crate::report::parse(text(data, file)?, file).map_err(|e| format!("{e:#}"))?;
    let again = |v: serde_json::Value| {
        let text = serde_json::to_string(&v).expect("reports serialize");
        crate::report::parse(&text, file).unwrap_or_else(|e| panic!("a written report does not read back: {e:#}"))
    };
    let back = match &r {
        crate::report::Report::Golden(g) => again(serde_json::to_value(g).expect("serializes")),
        crate::report::Report::Method(m) => again(serde_json::to_value(m).expect("serializes")),
        crate::report::Report::Simulate(s) => again(serde_json::to_value(s).expect("serializes")),
    };
    assert_eq!(back, r, "write then read changed the report");
    Ok(())
}
