//! `postwarp sweep` and `postwarp chart` end to end on `specs/ci-tiny.toml`
//! (one frame of room, two of a generated 32x24 slants, every registered
//! method at two thresholds, the hardware model at two cache sizes):
//! results independent of the thread count, resuming, spec errors that
//! name the key, charts that are valid files of the stated size and the
//! same bytes for the same CSV.

use postwarp::chart::pareto::{Better, pareto_front};
use postwarp::chart::scatter::{HEIGHT, WIDTH};
use postwarp::report::csv;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().unwrap()
}

fn sweep(spec: &Path, out: &Path, jobs: usize) -> String {
    let o = postwarp(&["sweep", spec.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", &jobs.to_string()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

/// Points of `specs/ci-tiny.toml` with the methods registered now: on each
/// of its 2 traces, every reconstruction once, and twice (2 thresholds)
/// when it takes the golden knobs; plus 2 hardware points.
fn tiny_points() -> usize {
    let g = postwarp::golden::config::GoldenConfig::default();
    let per_trace: usize = postwarp::methods::reconstructions()
        .iter()
        .map(|m| if m.with_golden_config(&g).is_some() { 2 } else { 1 })
        .sum();
    2 * per_trace + 2
}

fn tiny() -> PathBuf {
    root().join("specs/ci-tiny.toml")
}

/// One run of the tiny spec on one thread, shared by the tests.
fn base() -> &'static Path {
    static BASE: OnceLock<tempfile::TempDir> = OnceLock::new();
    BASE.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let out = sweep(&tiny(), d.path(), 1);
        assert!(out.contains(&format!("{} points, 0 skipped", tiny_points())), "{out}");
        d
    })
    .path()
}

fn rows(dir: &Path) -> Vec<Vec<String>> {
    csv::parse(&std::fs::read_to_string(dir.join("results.csv")).unwrap()).unwrap()
}

/// The CSV without its host-time columns, as text.
fn without_host_time(rows: &[Vec<String>]) -> String {
    let keep: Vec<usize> = (0..rows[0].len()).filter(|&i| !rows[0][i].starts_with("host_")).collect();
    assert!(keep.len() < rows[0].len(), "there is a host-time column");
    rows.iter().map(|r| csv::line(&keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>())).collect()
}

fn col(rows: &[Vec<String>], name: &str) -> usize {
    rows[0].iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"))
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let a = rows(base());
    let d = tempfile::tempdir().unwrap();
    sweep(&tiny(), d.path(), 2);
    let b = rows(d.path());
    assert_eq!(a.len(), 1 + tiny_points(), "a header and a row per point");
    assert_eq!(without_host_time(&a), without_host_time(&b));
    // Every CPU point has a host time, every hardware point cycles.
    let (m, host, cycles) = (col(&a, "method"), col(&a, "host_ms_per_frame"), col(&a, "cycles_per_frame"));
    for r in &a[1..] {
        let hw = r[m] == "hardware";
        assert_eq!(r[host].is_empty(), hw, "{r:?}");
        assert_eq!(r[cycles].is_empty(), !hw, "{r:?}");
    }
}

#[test]
fn the_hardware_rows_equal_the_golden_model_and_score_like_mark_aa() {
    let a = rows(base());
    let (m, thr, psnr) = (col(&a, "method"), col(&a, "threshold_ratio_of_e"), col(&a, "psnr_luma_db"));
    let (trace, same) = (col(&a, "trace"), col(&a, "golden_identical_frames"));
    let aa = a[1..].iter().find(|r| r[m] == "mark-aa" && r[trace] == "room" && r[thr] == "1.4").unwrap();
    let hw: Vec<&Vec<String>> = a[1..].iter().filter(|r| r[m] == "hardware").collect();
    assert_eq!(hw.len(), 2);
    for r in hw {
        assert_eq!(r[same], "1", "bit-identical to the golden model on its one frame");
        assert_eq!(r[thr], "1.4");
        assert_eq!(r[psnr], aa[psnr], "hardware quality = mark-aa at the same knobs");
    }
    // The thresholds multiplied the golden-model methods only.
    assert_eq!(a[1..].iter().filter(|r| r[m] == "forward-splat").count(), 2, "one per trace");
    assert_eq!(a[1..].iter().filter(|r| r[m] == "mark-aa").count(), 4, "two thresholds per trace");
}

#[test]
fn a_resumed_sweep_recomputes_only_missing_points() {
    let d = tempfile::tempdir().unwrap();
    crate::common::copy_dir(base(), d.path());
    let points = d.path().join("points");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&points).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert_eq!(files.len(), tiny_points());
    let before: Vec<Vec<u8>> = files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    let csv_before = rows(d.path());
    std::fs::remove_file(&files[3]).unwrap();
    let out = sweep(&tiny(), d.path(), 2);
    let n = tiny_points();
    assert!(
        out.contains(&format!("{n} points, {} skipped", n - 1)) && out.contains("1 computed; 0 traces generated"),
        "{out}"
    );
    for (i, f) in files.iter().enumerate() {
        let now = std::fs::read(f).unwrap();
        if i != 3 {
            assert_eq!(now, before[i], "{} was rewritten", f.display());
        }
    }
    let csv_after = rows(d.path());
    assert_eq!(without_host_time(&csv_before), without_host_time(&csv_after));
    // Host times of the loaded points are the stored ones.
    let host = col(&csv_before, "host_ms_per_frame");
    let point = col(&csv_before, "point");
    let recomputed = files[3].file_stem().unwrap().to_str().unwrap();
    for (a, b) in csv_before.iter().zip(&csv_after).skip(1) {
        if a[point] != recomputed {
            assert_eq!(a[host], b[host]);
        }
    }
    // Nothing missing: nothing computed.
    let out = sweep(&tiny(), d.path(), 1);
    assert!(out.contains(&format!("{n} points, {n} skipped")) && out.contains("0 computed"), "{out}");

    // A point stored, or a trace rendered, by another build of the program
    // is made again (its key is the same; the code may not be).
    let text = std::fs::read_to_string(&files[5]).unwrap();
    // The binary's build identity, as it stored it (this test process is another executable).
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let build = v["build"].as_str().expect("the point file names its build").to_string();
    assert_eq!(build.len(), 16);
    let stored_by = |t: &str| t.replace(&format!("\"build\": \"{build}\""), "\"build\": \"0000000000000000\"");
    assert_ne!(stored_by(&text), text);
    std::fs::write(&files[5], stored_by(&text)).unwrap();
    let traces: Vec<PathBuf> = std::fs::read_dir(d.path().join("traces")).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(traces.len(), 1, "the generated slants trace");
    assert_eq!(std::fs::read_to_string(traces[0].join("built-by")).unwrap(), build);
    let out = sweep(&tiny(), d.path(), 1);
    assert!(
        out.contains("1 computed; 0 traces generated") && out.contains("1 stored points were made by another build"),
        "{out}"
    );
    std::fs::write(traces[0].join("built-by"), "0000000000000000").unwrap();
    let out = sweep(&tiny(), d.path(), 1);
    assert!(out.contains("1 traces generated"), "{out}");
    assert_eq!(std::fs::read_to_string(traces[0].join("built-by")).unwrap(), build);
    assert_eq!(without_host_time(&rows(d.path())), without_host_time(&csv_before), "same results");
}

fn spec_error(text: &str) -> String {
    let d = tempfile::tempdir().unwrap();
    let spec = d.path().join("bad.toml");
    let room = root().join("traces/room");
    std::fs::write(&spec, text.replace("ROOM", room.to_str().unwrap())).unwrap();
    let o = postwarp(&["sweep", spec.to_str().unwrap(), "--out", d.path().join("out").to_str().unwrap()]);
    assert!(!o.status.success());
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(e.contains("bad.toml:"), "names the file: {e}");
    assert!(!d.path().join("out").exists(), "nothing written for a bad spec");
    e
}

#[test]
fn bad_specs_are_refused_naming_the_key() {
    let e = spec_error("methods = \"all\"\n[[traces]]\npath = \"ROOM\"\n[golden]\nthreshhold = 2\n");
    assert!(e.contains("bad.toml:5:1: golden.threshhold: unknown golden knob"), "{e}");
    let e = spec_error("methods = [\"mark-aa\", \"mark-zz\"]\n[[traces]]\npath = \"ROOM\"\n");
    assert!(e.contains("methods[1]: unknown method `mark-zz`") && e.contains("forward-splat"), "{e}");
    let e = spec_error("methods = \"all\"\n[[traces]]\nscene = \"room\"\nwidth = [32, \"wide\"]\n");
    assert!(e.contains("traces[0].width[1]: expected a whole number of pixels"), "{e}");
    let e = spec_error("methods = \"hardware\"\n[[traces]]\npath = \"ROOM\"\n[hardware]\ndest_cache_bytes = 100\n");
    assert!(e.contains("hardware: the combination preset = mark1998, dest_cache_bytes = 100: dest_cache_bytes"), "{e}");
    let e = spec_error("methods = \"all\"\nhole_fills = \"sometimes\"\n[[traces]]\npath = \"ROOM\"\n");
    assert!(e.contains("bad.toml:2:1: hole_fills: unknown hole fill `sometimes`"), "{e}");
    let e = spec_error("methods = \"all\"\nruns = 0\n[[traces]]\npath = \"ROOM\"\n");
    assert!(e.contains("runs: expected a whole number of runs"), "{e}");
}

#[test]
fn the_pareto_front_on_hand_made_points() {
    // (cost, quality): the front by increasing cost, each step better.
    let p = [(3.0, 30.0), (1.0, 10.0), (2.0, 10.0), (2.0, 20.0), (5.0, 29.0), (4.0, 35.0)];
    assert_eq!(pareto_front(&p, Better::Higher), vec![1, 3, 0, 5]);
    // FLIP: lower is better.
    let f = [(1.0, 0.5), (2.0, 0.3), (3.0, 0.4), (4.0, 0.1)];
    assert_eq!(pareto_front(&f, Better::Lower), vec![0, 1, 3]);
}

fn check_svg(path: &Path) {
    let s = std::fs::read_to_string(path).unwrap();
    assert!(s.starts_with(&format!("<svg width=\"{WIDTH}\" height=\"{HEIGHT}\"")), "{}", path.display());
    assert!(s.trim_end().ends_with("</svg>"), "{}", path.display());
    assert_eq!(s.matches("<text").count(), s.matches("</text>").count());
    assert!(s.contains("Pareto front"));
}

fn check_png(path: &Path) {
    let img = image::open(path).unwrap();
    assert_eq!((img.width(), img.height()), (WIDTH, HEIGHT), "{}", path.display());
    // Not blank: the plot has dark pixels (axes, text, markers).
    let dark = img.to_rgb8().pixels().filter(|p| p.0.iter().all(|&c| c < 80)).count();
    assert!(dark > 1000, "{}: {dark} dark pixels", path.display());
}

#[test]
fn charts_are_written_valid_and_the_same_bytes_for_the_same_csv() {
    let charts = base().join("charts");
    let mut names: Vec<String> =
        std::fs::read_dir(&charts).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    // room: 3 qualities x 4 costs; slants (CPU methods only): 3 x host time.
    assert_eq!(names.len(), 2 * (12 + 3), "{names:?}");
    assert!(names.contains(&"room.psnr_luma_db-vs-dram_achieved_gbps.svg".to_string()));
    assert!(names.contains(&"room.flip_mean-vs-dram_gbps_at_target_rate.svg".to_string()));
    assert!(names.contains(&"slants.psnr_luma_db-vs-host_ms_per_frame.png".to_string()));
    for n in &names {
        let p = charts.join(n);
        if n.ends_with(".svg") { check_svg(&p) } else { check_png(&p) }
    }
    let d = tempfile::tempdir().unwrap();
    let o = postwarp(&["chart", base().join("results.csv").to_str().unwrap(), "--out", d.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for n in &names {
        assert_eq!(std::fs::read(charts.join(n)).unwrap(), std::fs::read(d.path().join(n)).unwrap(), "{n}");
    }
}

#[test]
fn the_committed_charts_are_the_chart_commands_output_for_the_committed_csv() {
    let csv = std::fs::read_to_string(root().join("docs/results/speed-accuracy.csv")).unwrap();
    let dir = root().join("docs/charts/speed-accuracy");
    let charts = postwarp::chart::charts_from_csv(&csv).unwrap();
    let mut expected: Vec<String> = charts.iter().flat_map(|(s, _)| [format!("{s}.png"), format!("{s}.svg")]).collect();
    expected.sort();
    let mut present: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    present.sort();
    assert_eq!(present, expected, "run: postwarp chart docs/results/speed-accuracy.csv --out {}", dir.display());
    for (stem, chart) in &charts {
        let svg = postwarp::chart::scatter::render_svg(chart).unwrap();
        assert!(svg.as_bytes() == std::fs::read(dir.join(format!("{stem}.svg"))).unwrap(), "{stem}.svg is stale");
        let png = postwarp::chart::scatter::render_png(chart).unwrap();
        assert!(png == std::fs::read(dir.join(format!("{stem}.png"))).unwrap(), "{stem}.png is stale");
    }
    // Every chart docs/results.md shows exists.
    let md = std::fs::read_to_string(root().join("docs/results.md")).unwrap();
    for link in md.split("](charts/").skip(1) {
        let file = link.split(')').next().unwrap();
        assert!(root().join("docs/charts").join(file).is_file(), "docs/results.md links a missing {file}");
    }
}

#[test]
fn docs_describe_every_column_and_trace_key() {
    use postwarp::sweep::{point::METRIC_COLUMNS, trace_fields::TRACE_FIELDS};
    let doc = std::fs::read_to_string(root().join("docs/sweep.md")).unwrap();
    let named = |k: &str| doc.contains(&format!("| `{k}` |"));
    for c in ["spec", "trace", "trace_path", "scene", "method", "hole_fill", "runs", "point"] {
        assert!(named(c), "docs/sweep.md lacks a row for column `{c}`");
    }
    for (c, unit, desc, _) in METRIC_COLUMNS {
        assert!(named(c), "docs/sweep.md lacks a row for column `{c}`");
        assert!(!unit.is_empty() && !desc.is_empty());
    }
    for (key, unit, desc, col) in TRACE_FIELDS {
        assert!(named(key), "docs/sweep.md lacks a row for trace key `{key}`");
        assert!(named(col), "docs/sweep.md lacks a row for column `{col}`");
        assert!(!unit.is_empty() && !desc.is_empty());
    }
    for k in ["name", "runs", "images", "path", "frames", "methods", "hole_fills", "golden", "hardware"] {
        assert!(doc.contains(&format!("`{k}`")), "docs/sweep.md does not mention `{k}`");
    }
    // The header the code writes for a spec naming no knobs: every column documented.
    let spec = postwarp::sweep::Spec::load(&root().join("specs/speed-accuracy.toml")).unwrap();
    let plan = postwarp::sweep::plan::plan(&spec).unwrap();
    for c in postwarp::sweep::results::header(&plan) {
        assert!(named(&c) || doc.contains(&format!("`{c}`")), "column `{c}` is not in docs/sweep.md");
    }
}
