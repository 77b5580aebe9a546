//! `report.json` against its description: every key a report holds is
//! described with a unit in the tables of `src/report/`, `docs/report.md`'s
//! key lists are those tables, older files read as the current version,
//! and `sweep`, `size` and `chart` read report values only through the
//! shared structs.

use postwarp::report::keys::{KeyDoc, undescribed};
use postwarp::report::{Report, golden, method, simulate};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().unwrap();
    assert!(o.status.success(), "postwarp {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn check(report: &Value, keys: &[KeyDoc], what: &str) {
    let mut missing = Vec::new();
    undescribed(report, keys, "", &mut missing);
    assert!(missing.is_empty(), "{what}: keys without a described unit in src/report/: {missing:?}");
}

#[test]
fn the_docs_key_lists_are_the_tables() {
    let path = root().join("docs/report.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let want = postwarp::report::docs::regenerate(&page).expect("docs/report.md lacks the generated-part marks");
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    assert!(
        page == want,
        "docs/report.md's key lists differ from src/report/; run UPDATE_DOCS=1 cargo test --test suite report_docs::"
    );
}

/// Every key of a written report (golden, simulate, and every comparison
/// method with every hole fill) has a row with a unit.
#[test]
fn every_key_written_is_described_with_a_unit() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    let trace = root().join("traces/occluders").display().to_string();
    postwarp(&["golden", &trace, "--out", &d("g")]);
    check(&read(&dir.path().join("g/report.json")), &golden::report_keys(), "golden");
    postwarp(&["golden", &trace, "--out", &d("gg"), "--reconstruction", "general"]);
    check(&read(&dir.path().join("gg/report.json")), &golden::report_keys(), "golden general");
    postwarp(&["simulate", &trace, "--out", &d("s")]);
    let s = read(&dir.path().join("s/report.json"));
    check(&s, &simulate::report_keys(), "simulate");
    // The objects that nest further were walked.
    assert!(s["frames"][0]["units"]["fetch"]["stall"].is_u64());
    assert!(s["mean"]["dram_gbps_by_client"]["tile_fill"].is_f64());
    // Methods: on a one-frame trace, through the same code (no files).
    let t = postwarp::trace::Trace::open(&root().join("traces/occluders")).unwrap();
    let mut t1 = t.clone();
    t1.derived.truncate(1);
    let quiet = indicatif::ProgressBar::hidden();
    for rec in postwarp::methods::reconstructions() {
        let fill = postwarp::methods::hole_fill(rec.info().default_hole_fill).unwrap();
        let r = postwarp::run::method::measure_method(&t1, rec.as_ref(), fill.as_ref(), 1, true, None, &quiet).unwrap();
        check(&serde_json::to_value(&r.report).unwrap(), &method::report_keys(), rec.info().name);
    }
    let rec = postwarp::methods::reconstruction("forward-splat").unwrap();
    for fill in postwarp::methods::hole_fills() {
        let r = postwarp::run::method::measure_method(&t1, rec.as_ref(), fill.as_ref(), 1, true, None, &quiet).unwrap();
        check(&serde_json::to_value(&r.report).unwrap(), &method::report_keys(), fill.info().name);
    }
}

/// Version-1 files (tests/data/reports/v1/) read as version 2: renamed
/// keys under their new names, total and mean recomputed by the key rules.
#[test]
fn version_1_reports_read_as_version_2() {
    let v1 = root().join("tests/data/reports/v1");
    let old = read(&v1.join("simulate-occluders.json"));
    let Report::Simulate(s) = postwarp::report::load(&v1.join("simulate-occluders.json")).unwrap() else {
        panic!("not read as a simulate report")
    };
    assert_eq!(s.report_version, postwarp::report::REPORT_VERSION);
    assert!(s.flip, "version 1 always scored FLIP");
    for (f, o) in s.frames.iter().zip(old["frames"].as_array().unwrap()) {
        assert_eq!(f.counters.kernels_over_limit, o["kernels_over_4x4"].as_u64().unwrap());
        assert_eq!(f.rates.dram_gbps_at_target_rate, o["bandwidth_gbps_at_target_rate"].as_f64().unwrap());
        assert_eq!(f.rates.dest_cache_hit_rate, o["dest_cache"]["hit_rate"].as_f64());
        assert_eq!(f.counters.cycles, o["cycles"].as_u64().unwrap());
    }
    assert_eq!(s.mean.rates.dram_gbps_at_target_rate, old["mean"]["bandwidth_gbps_at_target_rate"].as_f64().unwrap());
    assert_eq!(s.total.identical_frames, old["total"]["identical_frames"].as_u64().unwrap());
    assert_eq!(s.total.vs_golden.differing_samples, old["total"]["differing_samples"].as_u64().unwrap());
    // Version 1 had no mean of the unit cycles; version 2 has every counter.
    let n = s.frames.len() as f64;
    let busy: u64 = s.frames.iter().map(|f| f.counters.units.raster.busy).sum();
    assert_eq!(s.mean.counters.units.raster.busy, busy as f64 / n);

    let old = read(&v1.join("golden-occluders.json"));
    let Report::Golden(g) = postwarp::report::load(&v1.join("golden-occluders.json")).unwrap() else { panic!() };
    // Version 1 summed the kernel histogram in `mean`; version 2 averages it.
    let sum_v1: f64 = old["mean"]["kernel_sizes"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r.as_array().unwrap())
        .map(|x| x.as_f64().unwrap())
        .sum();
    let mean_v2: f64 = g.mean.counters.kernel_sizes.iter().flatten().sum();
    assert!((mean_v2 * g.frames.len() as f64 - sum_v1).abs() < 1e-6 * sum_v1, "{mean_v2} vs {sum_v1}");
    assert_eq!(g.total.frames, 6);
    assert_eq!(g.mean.scores.psnr_luma_db, old["mean"]["psnr_luma_db"].as_f64());

    let Report::Method(m) = postwarp::report::load(&v1.join("method-smit-point-occluders.json")).unwrap() else {
        panic!()
    };
    assert_eq!(m.method, "smit-point");
    assert!(m.flip && g.flip);
    assert!(m.mean.reconstruction.get("fragments").is_some(), "version 1 had no mean of the method counters");
    assert!(m.total.reconstruction.get("mean_splat_side").is_none(), "a per-frame mean is not summed");
}

#[test]
fn reports_round_trip_and_newer_versions_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let trace = root().join("traces/occluders").display().to_string();
    let out = dir.path().join("s");
    postwarp(&["simulate", &trace, "--out", &out.display().to_string()]);
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    let Report::Simulate(s) = postwarp::report::load(&out).unwrap() else { panic!() };
    assert_eq!(serde_json::to_string_pretty(&s).unwrap() + "\n", text, "read and written again, byte for byte");
    let (now, next) = (postwarp::report::REPORT_VERSION, postwarp::report::REPORT_VERSION + 1);
    let newer = text.replacen(&format!("\"report_version\": {now}"), &format!("\"report_version\": {next}"), 1);
    assert_ne!(newer, text);
    let e = postwarp::report::parse(&newer, Path::new("x/report.json")).unwrap_err().to_string();
    assert!(e.contains(&format!("x/report.json: report_version {next} was written by a newer postwarp")), "{e}");
    // Version 4 (before FLIP was optional) always scored it.
    assert!(!s.flip, "simulate without --flip");
    let v4 = text.replacen(&format!("\"report_version\": {now}"), "\"report_version\": 4", 1).replacen(
        "\"flip\": false,\n",
        "",
        1,
    );
    assert!(!v4.contains("\"flip\""), "the key removed");
    let Report::Simulate(s4) = postwarp::report::parse(&v4, Path::new("v4.json")).unwrap() else { panic!() };
    assert!(s4.flip);
    // Version 3 (before the prefetch) reads, its new keys 0.
    let v3 = text.replacen(&format!("\"report_version\": {now}"), "\"report_version\": 3", 1);
    let Report::Simulate(s3) = postwarp::report::parse(&v3, Path::new("v3.json")).unwrap() else { panic!() };
    assert_eq!(s3.report_version, 3);
    // Version 2 called the hardware's `abuffer_fragments` `max_fragments`.
    let v2 = text
        .replacen(&format!("\"report_version\": {now}"), "\"report_version\": 2", 1)
        .replace(&format!("\"abuffer_fragments\": {}", s.config["abuffer_fragments"]), "\"max_fragments\": 2");
    assert!(v2.contains("\"max_fragments\": 2"));
    let Report::Simulate(old) = postwarp::report::parse(&v2, Path::new("v2.json")).unwrap() else { panic!() };
    assert_eq!((old.config.get("abuffer_fragments"), old.config.get("max_fragments")), (Some(&2.into()), None));
    let e = postwarp::report::parse("{", Path::new("x/report.json")).unwrap_err().to_string();
    assert!(e.starts_with("x/report.json: not a JSON report"), "{e}");
}

/// `sweep` (points, results, store), `size` and `chart` read report values
/// only through the shared structs: no JSON indexing, no untyped number
/// reads, no report key names of their own.
#[test]
fn sweep_size_and_chart_read_reports_only_through_the_structs() {
    let mut files: Vec<PathBuf> =
        ["src/sweep/point.rs", "src/sweep/results.rs", "src/sweep/store.rs"].iter().map(|f| root().join(f)).collect();
    for dir in ["src/size", "src/chart"] {
        for e in std::fs::read_dir(root().join(dir)).unwrap() {
            files.push(e.unwrap().path());
        }
    }
    let forbidden = [".as_f64()", ".as_u64()", ".get(\"", "\"mean\"", "\"total\"", "\"frames\"]"];
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        // Tests inside a file may build inputs by hand.
        let code = text.split("#[cfg(test)]").next().unwrap();
        for (n, line) in code.lines().enumerate() {
            // A struct formatting its own fields says so at the line's end.
            if line.ends_with("// own field") {
                continue;
            }
            // `x["key"]`: JSON indexing (an array literal `["a", …]` is fine).
            let indexing = line
                .match_indices("[\"")
                .any(|(i, _)| line[..i].chars().last().is_some_and(|c| c.is_alphanumeric() || "_)]".contains(c)));
            assert!(
                !indexing,
                "{}:{}: JSON indexing: read report values through src/report/\n{line}",
                f.display(),
                n + 1
            );
            for pat in forbidden {
                assert!(
                    !line.contains(pat),
                    "{}:{}: `{pat}`: read report values through src/report/ (and results through sweep::results::read_csv)\n{line}",
                    f.display(),
                    n + 1
                );
            }
        }
    }
}
