//! The non-diffuse study's tools end to end (`docs/non-diffuse.md`): the
//! new methods run by name through `golden --method` and `compare` on a
//! gallery trace; `postwarp score` gives back a run's whole-image scores
//! exactly and adds the non-diffuse mask's; the committed stability specs
//! of this study vary one stress key.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().expect("run postwarp")
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A tiny gallery trace: 48x36 pixels, 1x1 samples, 2 derived frames.
fn gallery(dir: &Path) -> PathBuf {
    let out = dir.join("gallery");
    let s = out.to_str().unwrap();
    let args = ["make-trace", "--scene", "gallery", "--out", s, "--width", "48", "--height", "36"];
    ok(&postwarp(&[&args[..], &["--frames", "2", "--supersample", "1", "--fragments", "2"]].concat()));
    out
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn both_methods_run_by_name_and_score_separates_the_mask() {
    let d = tempfile::tempdir().unwrap();
    let trace = gallery(d.path());
    let t = trace.to_str().unwrap();
    let mut runs = Vec::new();
    for (m, unit) in [("schollmeyer-transparent", "quadtree cells visited"), ("lochmann-raytree", "gradient steps")] {
        let out = d.path().join(m);
        ok(&postwarp(&["golden", t, "--method", m, "--runs", "1", "--flip", "--out", out.to_str().unwrap()]));
        let r = report(&out);
        assert_eq!(r["method"], m);
        assert_eq!(r["primitive"], unit);
        assert!(r["mean"]["primitives"].as_f64().unwrap() > 0.0, "{m} did its work: {}", r["mean"]);
        runs.push(out);
    }
    let csv = d.path().join("score.csv");
    let text =
        ok(&postwarp(&["score", runs[0].to_str().unwrap(), runs[1].to_str().unwrap(), "--csv", csv.to_str().unwrap()]));
    assert!(text.contains("| schollmeyer-transparent + low-pass |"), "{text}");
    assert!(text.contains("| lochmann-raytree + pull-push |"), "{text}");
    let csv = std::fs::read_to_string(csv).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    let col = |name: &str| rows[0].iter().position(|c| *c == name).unwrap();
    for (row, run) in rows[1..].iter().zip(&runs) {
        let mean = &report(run)["mean"];
        for m in ["psnr_luma_db", "ssim_luma", "flip_mean"] {
            let whole: f64 = row[col(&format!("whole_{m}"))].parse().unwrap();
            let want = mean[m].as_f64().unwrap();
            assert!((whole - want).abs() <= 1e-9 * want.abs().max(1.0), "{m}: score {whole} vs report {want}");
            let mask: f64 = row[col(&format!("mask_{m}"))].parse().unwrap();
            let rest: f64 = row[col(&format!("rest_{m}"))].parse().unwrap();
            assert!(mask.is_finite() && rest.is_finite());
        }
        let share: f64 = row[col("mask_share")].parse().unwrap();
        assert!(share > 0.1 && share < 0.9, "{share}");
    }

    // compare runs them by name too, beside their baselines.
    let cmp = d.path().join("cmp");
    ok(&postwarp(&[
        "compare",
        t,
        "--methods",
        "schollmeyer-transparent,schollmeyer-glass-depth,lochmann-raytree,lochmann-naive",
        "--runs",
        "1",
        "--out",
        cmp.to_str().unwrap(),
    ]));
    let table = std::fs::read_to_string(cmp.join("compare.csv")).unwrap();
    for m in ["schollmeyer-transparent", "schollmeyer-glass-depth", "lochmann-raytree", "lochmann-naive"] {
        assert!(table.contains(m), "{m} missing from compare.csv");
    }
}

#[test]
fn a_trace_without_the_mask_scores_the_whole_image_only() {
    let d = tempfile::tempdir().unwrap();
    let room = root().join("traces/room");
    let out = d.path().join("g");
    ok(&postwarp(&["golden", room.to_str().unwrap(), "--out", out.to_str().unwrap()]));
    let text = ok(&postwarp(&["score", "--trace", room.to_str().unwrap(), out.to_str().unwrap()]));
    let row = text.lines().find(|l| l.starts_with("| mark-aa")).unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let psnr: f64 = cells[2].parse().unwrap();
    let want = report(&out)["mean"]["psnr_luma_db"].as_f64().unwrap();
    assert!((psnr - want).abs() < 0.005, "{psnr} vs {want}");
    assert_eq!(cells[5], "–", "no mask: {row}");
    // A missing frame is an error naming it.
    std::fs::remove_file(out.join("frame-0002.png")).unwrap();
    let o = postwarp(&["score", out.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("frame-0002.png"));
}

#[test]
fn the_non_diffuse_stability_specs_vary_one_stress_key() {
    use postwarp::sweep::trace_fields::{STRESS_FIELDS, TRACE_FIELDS, get};
    use postwarp::sweep::trace_set::VariantSource;
    for name in ["stability-nondiffuse-distance", "stability-nondiffuse-share"] {
        let spec = postwarp::sweep::Spec::load(&root().join(format!("specs/{name}.toml"))).unwrap();
        let plan = postwarp::sweep::plan::plan(&spec).unwrap();
        let specs: Vec<&postwarp::tracegen::TraceSpec> = plan
            .traces
            .iter()
            .map(|v| match &v.source {
                VariantSource::Generated { spec, .. } => spec,
                VariantSource::Existing { .. } => panic!("{name} renders its traces"),
            })
            .collect();
        assert!(specs.len() >= 5, "{name}");
        let varying: Vec<&str> =
            TRACE_FIELDS.iter().map(|f| f.0).filter(|k| specs.iter().any(|s| get(s, k) != get(specs[0], k))).collect();
        assert_eq!(varying.len(), 1, "{name}: {varying:?}");
        assert!(STRESS_FIELDS.contains(&varying[0]));
    }
}

#[test]
fn a_sweep_with_images_is_scored_again_over_the_mask_and_charted() {
    let d = tempfile::tempdir().unwrap();
    let spec = d.path().join("s.toml");
    std::fs::write(
        &spec,
        "name = \"nd\"\nruns = 1\nimages = true\nmethods = [\"mark-aa\", \"lochmann-naive\"]\n[[traces]]\nscene = \"gallery\"\n\
         width = 32\nheight = 24\nsupersample = 1\nframes = 1\nderived_offset_x = [0.0, 0.3, 0.6]\n",
    )
    .unwrap();
    let dir = d.path().join("o");
    ok(&postwarp(&["sweep", spec.to_str().unwrap(), "--out", dir.to_str().unwrap()]));
    let masked = d.path().join("masked.csv");
    ok(&postwarp(&["score", "--sweep", dir.to_str().unwrap(), "--region", "mask", "--csv", masked.to_str().unwrap()]));
    let whole = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let mask = std::fs::read_to_string(&masked).unwrap();
    assert_eq!(whole.lines().count(), mask.lines().count());
    assert_eq!(whole.lines().next(), mask.lines().next(), "the same columns");
    assert!(mask.lines().skip(1).all(|l| l.starts_with("nd-mask,")), "{mask}");
    assert_ne!(whole, mask.replace("nd-mask,", "nd,"), "the region's metrics differ from the whole image's");
    let charts = d.path().join("charts");
    ok(&postwarp(&["chart", masked.to_str().unwrap(), "--out", charts.to_str().unwrap()]));
    assert!(charts.join("stability.gallery.psnr_luma_db-vs-derived_offset_x_units.svg").is_file());
    let e =
        postwarp(&["score", "--sweep", dir.to_str().unwrap(), "--region", "glass", "--csv", masked.to_str().unwrap()]);
    assert!(!e.status.success() && String::from_utf8_lossy(&e.stderr).contains("expected one of whole, mask, rest"));
}
