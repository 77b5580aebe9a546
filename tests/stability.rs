//! Stability sweeps (docs/stability.md) at tiny sizes: at the extreme of
//! every stressor no method panics, no metric is NaN and every image has
//! real samples; a stress sweep writes its stability chart; every bundled
//! `specs/stability-*.toml` is a valid specification varying one stress
//! key. The failure-point rule is unit-tested in `src/chart/stability.rs`.

use postwarp::report::csv;
use postwarp::sweep::trace_fields::{STRESS_FIELDS, TRACE_FIELDS, get};
use postwarp::sweep::trace_set::VariantSource;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().unwrap()
}

fn sweep(spec_text: &str, dir: &Path) -> Vec<Vec<String>> {
    let spec = dir.join("spec.toml");
    std::fs::write(&spec, spec_text).unwrap();
    let out = dir.join("out");
    let o = postwarp(&["sweep", spec.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    csv::parse(&std::fs::read_to_string(out.join("results.csv")).unwrap()).unwrap()
}

/// The extreme value of every stressor of the bundled specifications, on
/// the scene its specification uses.
const EXTREMES: &[(&str, &str, &str)] = &[
    ("distance", "room", "derived_offset_x = 1.6"),
    ("roll", "room", "derived_roll = 90.0"),
    ("forward", "room", "derived_offset_z = 1.5"),
    ("backward", "room", "derived_offset_z = -0.3"),
    ("prediction", "room", "prediction = 2.0"),
    ("grazing", "slants", "path_offset_y = -1.55"),
    ("depth-bits", "slants", "depth_bits = 2"),
    ("depth-range", "slants", "depth_bits = 16\ndepth_range_scale = 16384.0"),
    ("thin", "specs/scenes/fence.toml", "rod_scale = 0.125"),
    ("thin-hairball-thin", "hairball", "rod_radius_scale = 0.125"),
    ("thin-hairball-wide", "hairball", "rod_radius_scale = 16.0"),
];

#[test]
fn every_method_survives_the_extreme_of_every_stressor() {
    let d = tempfile::tempdir().unwrap();
    let mut spec =
        String::from("name = \"extremes\"\nruns = 1\nflip = true\nmethods = \"all\"\nhole_fills = \"default\"\n");
    for (name, scene, knob) in EXTREMES {
        // A scene file is named from the repository root (the spec is in a temporary directory).
        let scene = if scene.ends_with(".toml") { root().join(scene).display().to_string() } else { scene.to_string() };
        spec += &format!(
            "\n[[traces]]\nname = \"{name}\"\nscene = \"{scene}\"\nwidth = 16\nheight = 12\nsupersample = 1\nframes = 1\n{knob}\n"
        );
    }
    let rows = sweep(&spec, d.path());
    let (h, rows) = rows.split_first().unwrap();
    let col = |n: &str| h.iter().position(|c| c == n).unwrap();
    let (trace, method, psnr, ssim, flip, holes) =
        (col("trace"), col("method"), col("psnr_luma_db"), col("ssim_luma"), col("flip_mean"), col("hole_fraction"));
    let methods = postwarp::methods::reconstructions().len();
    assert_eq!(rows.len(), EXTREMES.len() * methods);
    for r in rows {
        let what = format!("{} on {}", r[method], r[trace]);
        for c in [psnr, ssim, flip, holes] {
            let v: f64 = r[c].parse().unwrap_or_else(|_| panic!("{what}: `{}` = `{}`", h[c], r[c]));
            assert!(v.is_finite(), "{what}: {} is {v}", h[c]);
        }
        let holes: f64 = r[holes].parse().unwrap();
        assert!(holes < 1.0, "{what}: no real sample at all (hole fraction {holes})");
    }
}

#[test]
fn a_stress_sweep_writes_its_stability_chart() {
    let d = tempfile::tempdir().unwrap();
    let spec = "name = \"tiny-roll\"\nruns = 1\nmethods = [\"mark-aa\", \"forward-splat\"]\n\n[[traces]]\n\
                scene = \"room\"\nwidth = 16\nheight = 12\nsupersample = 1\nframes = 1\nderived_roll = [0.0, 45.0]\n";
    let rows = sweep(spec, d.path());
    assert_eq!(rows.len(), 1 + 2 * 2);
    let charts = d.path().join("out/charts");
    for ext in ["svg", "png"] {
        let f = charts.join(format!("stability.room.psnr_luma_db-vs-derived_roll_deg.{ext}"));
        assert!(f.is_file(), "{} missing", f.display());
    }
    let svg = std::fs::read_to_string(charts.join("stability.room.psnr_luma_db-vs-derived_roll_deg.svg")).unwrap();
    assert!(svg.contains("threshold 25 dB") && svg.contains("mark-aa"), "legend");
    // `postwarp chart` draws the same bytes from the CSV.
    let again = d.path().join("again");
    let csv_path = d.path().join("out/results.csv");
    let o = postwarp(&["chart", csv_path.to_str().unwrap(), "--out", again.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let name = "stability.room.psnr_luma_db-vs-derived_roll_deg.png";
    assert_eq!(std::fs::read(charts.join(name)).unwrap(), std::fs::read(again.join(name)).unwrap());

    // Rectangle overlap: mark-aa's axis-aligned rectangles around footprints
    // turned by 45° cover about twice the area, so each destination sample
    // is composited about twice as often; forward-splat has no such count.
    let (h, rows) = rows.split_first().unwrap();
    let col = |n: &str| h.iter().position(|c| c == n).unwrap();
    let (method, roll, writes) = (col("method"), col("derived_roll_deg"), col("composite_writes_per_sample"));
    let at = |m: &str, r: &str| rows.iter().find(|x| x[method] == m && x[roll] == r).unwrap()[writes].clone();
    let (w0, w45): (f64, f64) = (at("mark-aa", "0").parse().unwrap(), at("mark-aa", "45").parse().unwrap());
    assert!(w0 >= 1.0 && w45 > 1.5 * w0, "writes per sample {w0} at 0°, {w45} at 45°");
    assert_eq!(at("forward-splat", "0"), "");
}

#[test]
fn bundled_stability_specs_vary_exactly_one_stress_key() {
    let mut n = 0;
    for e in std::fs::read_dir(root().join("specs")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with("stability-") {
            continue;
        }
        n += 1;
        let spec = postwarp::sweep::Spec::load(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        let plan = postwarp::sweep::plan::plan(&spec).unwrap();
        assert!(plan.traces.len() >= 3, "{name}: at least 3 stress values");
        // Exactly one generated-trace key takes more than one value, and it is a stress key.
        let specs: Vec<&postwarp::tracegen::TraceSpec> = plan
            .traces
            .iter()
            .map(|v| match &v.source {
                VariantSource::Generated { spec, .. } => spec,
                VariantSource::Existing { .. } => panic!("{name}: a stability sweep renders its traces"),
            })
            .collect();
        let varying: Vec<&str> =
            TRACE_FIELDS.iter().map(|f| f.0).filter(|k| specs.iter().any(|s| get(s, k) != get(specs[0], k))).collect();
        assert_eq!(varying.len(), 1, "{name}: varies {varying:?}");
        assert!(STRESS_FIELDS.contains(&varying[0]) || varying[0] == "prediction", "{name}: varies {varying:?}");
    }
    assert!(n >= 9, "expected the bundled stability specs, found {n}");
}

#[test]
fn bad_stress_values_are_refused_with_the_key() {
    let d = tempfile::tempdir().unwrap();
    let spec = d.path().join("bad.toml");
    std::fs::write(&spec, "methods = \"mark-aa\"\n[[traces]]\nscene = \"room\"\nderived_roll = [0.0, 200.0]\n")
        .unwrap();
    let o = postwarp(&["sweep", spec.to_str().unwrap(), "--out", d.path().join("o").to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("derived_roll[1]") && err.contains("[-180, 180]"), "{err}");
}

/// Every `stability-*.csv` in `results` charted by `postwarp chart` gives
/// exactly the committed `stability.*` charts of `charts`, and no other.
fn check_committed_charts(results: &str, charts: &str) {
    let d = tempfile::tempdir().unwrap();
    let committed = root().join(charts);
    let mut n = 0;
    for e in std::fs::read_dir(root().join(results)).unwrap() {
        let csv_path = e.unwrap().path();
        let name = csv_path.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with("stability-") {
            continue;
        }
        let out = d.path().join(&name);
        let o = postwarp(&["chart", csv_path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for f in std::fs::read_dir(&out).unwrap() {
            let f = f.unwrap().path();
            let file = f.file_name().unwrap().to_string_lossy().into_owned();
            if !file.starts_with("stability.") {
                continue;
            }
            n += 1;
            assert_eq!(
                std::fs::read(&f).unwrap(),
                std::fs::read(committed.join(&file)).unwrap_or_default(),
                "run: postwarp chart {results}/{name} --out OUT and copy OUT/stability.* to {charts}/ ({file})"
            );
        }
    }
    assert_eq!(n, std::fs::read_dir(&committed).unwrap().count(), "a committed chart in {charts} no CSV gives");
}

#[test]
fn committed_stability_charts_are_postwarp_chart_output() {
    check_committed_charts("docs/results", "docs/charts/stability");
}

/// The non-diffuse study's charts over the specular and transparent pixels
/// (`postwarp score --sweep ... --region mask`, `docs/non-diffuse.md`).
#[test]
fn committed_non_diffuse_region_charts_are_postwarp_chart_output() {
    check_committed_charts("docs/results/non-diffuse", "docs/charts/non-diffuse");
}
