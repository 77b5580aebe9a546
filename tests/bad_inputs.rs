//! Malformed and edge-case inputs as a new user gives them, one test per
//! class of issue 17: nothing hangs, nothing is accepted silently, every
//! message names the path and prints once. (Manifest truncation, FIFO and
//! directory images: `trace_format.rs`; interrupted and concurrent runs:
//! `interrupted_runs.rs`; report keys: `report_docs.rs`.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).current_dir(dir).output().unwrap()
}

/// The command fails with one `error:` line holding every `needle`.
fn fails(args: &[&str], dir: &Path, needles: &[&str]) -> String {
    let o = postwarp(args, dir);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{args:?} succeeded: {err}");
    assert_eq!(err.matches("error:").count(), 1, "{args:?}: one error, printed once: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` missing in: {err}");
    }
    err
}

fn ok(args: &[&str], dir: &Path) -> String {
    let o = postwarp(args, dir);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn negative_numbers_reach_the_flags_own_checks() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    fails(&["make-trace", "--scene", "room", "--out", "o", "--width", "-1"], p, &["'-1'", "--width"]);
    fails(&["make-trace", "--scene", "room", "--out", "o", "--display-hfov", "-5"], p, &["--display-hfov -5"]);
    let t = root().join("traces/occluders").display().to_string();
    fails(&["golden", &t, "--out", "o", "--threshold", "-1"], p, &["threshold = -1"]);
    fails(&["golden", &t, "--out", "o", "--method", "forward-splat", "--runs", "-3"], p, &["'-3'", "--runs"]);
    assert!(!p.join("o").exists(), "nothing written");
}

#[cfg(unix)]
#[test]
fn only_regular_files_are_inputs_and_messages_name_the_path_once() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    assert!(Command::new("mkfifo").arg(p.join("fifo")).status().unwrap().success());
    std::fs::create_dir(p.join("adir")).unwrap();
    std::os::unix::fs::symlink(p.join("loop"), p.join("loop")).unwrap();
    let t = root().join("traces/occluders").display().to_string();
    for input in ["fifo", "adir", "loop"] {
        let what = match input {
            "fifo" => "is a FIFO (named pipe)",
            "adir" => "is a directory",
            _ => "symbolic link that cannot be resolved",
        };
        // Each would block (FIFO) or be reported as missing before. A
        // FIFO is given with a writer that ends a blocking open (bounded:
        // a run that opened it reads an empty file and fails the check).
        let check = |args: &[&str], needles: &[&str]| {
            let run = || fails(args, p, needles);
            if input == "fifo" { common::fifo::unblocked(&p.join("fifo"), run) } else { run() }
        };
        let e = check(&["make-trace", "--scene", input, "--out", "o"], &[what]);
        assert_eq!(e.matches(input).count(), 1, "the path once: {e}");
        check(&["simulate", &t, "--out", "o", "--config", input], &[what, "hardware configuration"]);
        check(&["golden", &t, "--out", "o", "--config", input], &[what, "golden-model configuration"]);
        check(&["chart", input, "--out", "o"], &[what, "results CSV"]);
    }
    // A FIFO as the trace itself.
    let fifo = p.join("fifo");
    common::fifo::unblocked(&fifo, || {
        fails(&["info", "fifo"], p, &["fifo: is a FIFO (named pipe); expected the trace manifest"])
    });
    common::fifo::unblocked(&fifo, || fails(&["golden", "fifo", "--out", "o"], p, &["is a FIFO"]));
    // A UTF-8 byte-order mark is named, not invisible.
    std::fs::write(p.join("bom.toml"), "\u{feff}tile_size = 8\n").unwrap();
    fails(
        &["simulate", &t, "--out", "o", "--config", "bom.toml"],
        p,
        &["bom.toml: line 1 starts with a UTF-8 byte-order mark"],
    );
    // An output file over a directory names the file.
    fails(&["simulate", "--dump-config", "adir"], p, &["adir: is a directory; expected a file name to write"]);
    assert!(!p.join("o").exists());
}

/// `postwarp chart` on a results.csv with a non-numeric, NaN or infinite
/// metric cell, a ragged row or nothing in it: an error at file:line; with
/// a cost of 1.7e308 it draws its charts (the axis code is bounded: the
/// tick search is ours, `chart::axis`).
#[test]
fn chart_rejects_bad_cells_and_draws_any_finite_number() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let good = std::fs::read_to_string(root().join("docs/results/speed-accuracy.csv")).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header.iter().position(|h| *h == "host_ms_per_frame").unwrap();
    let with = |cell: &str| {
        let mut rows: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        let mut f: Vec<&str> = lines[1].split(',').collect();
        f[col] = cell;
        rows[1] = f.join(",");
        rows.join("\n") + "\n"
    };
    for (name, text, needle) in [
        ("text.csv", with("fast"), "text.csv:2: column `host_ms_per_frame` is `fast`"),
        ("nan.csv", with("NaN"), "nan.csv:2: column `host_ms_per_frame` is `NaN`"),
        ("inf.csv", with("inf"), "inf.csv:2: column `host_ms_per_frame` is `inf`"),
        (
            "ragged.csv",
            format!("{good}a,b\n"),
            &format!("ragged.csv:{}: 2 cells; the header has {}", lines.len() + 1, header.len()),
        ),
        ("empty.csv", String::new(), "empty.csv:1: empty file"),
        ("header.csv", format!("{}\n", lines[0]), "header.csv:2: no rows"),
    ] {
        std::fs::write(p.join(name), text).unwrap();
        fails(&["chart", name, "--out", "charts"], p, &[needle]);
        assert!(!p.join("charts").exists(), "{name}: a rejected CSV writes nothing");
    }
    std::fs::write(p.join("big.csv"), with("1.7e308")).unwrap();
    let out = ok(&["chart", "big.csv", "--out", "charts"], p);
    // As many charts as the committed CSV gives (an SVG and a PNG each).
    let n = 2 * postwarp::chart::charts_from_csv(&good).unwrap().len();
    assert!(out.contains(&format!("{n} chart files")), "{out}");
    let svg = std::fs::read_to_string(p.join("charts/room.psnr_luma_db-vs-host_ms_per_frame.svg")).unwrap();
    assert!(svg.contains("1e280"), "the huge cost is on the (log) axis, ticked by powers of ten");
    // Drawn again: refused without --force, replaced whole with it.
    fails(&["chart", "big.csv", "--out", "charts"], p, &["charts: already exists; give --force"]);
    ok(&["chart", "big.csv", "--out", "charts", "--force"], p);
}

/// `size --out FILE` is refused before any candidate runs; `size`'s config
/// file says what its quality figure was scored against.
#[test]
fn size_checks_out_first_and_says_what_it_scored_against() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    std::fs::write(p.join("file"), "x").unwrap();
    let t = root().join("traces/occluders").display().to_string();
    let e = fails(&["size", &t, "--min-psnr", "20", "--out", "file"], p, &["file: exists and is not a folder"]);
    assert!(!e.contains("size: quality"), "no candidate ran before the check: {e}");
    std::fs::create_dir(p.join("full")).unwrap();
    std::fs::write(p.join("full/x"), "x").unwrap();
    fails(&["size", &t, "--min-psnr", "20", "--out", "full"], p, &["full: already exists; give --force"]);
}

/// The golden table: `psnr_cov` is `inf` only over covered pixels, and the
/// mean row's kernels are per frame (the report's mean), not a sum.
#[test]
fn the_golden_mean_row_is_a_mean() {
    let d = tempfile::tempdir().unwrap();
    let t = root().join("traces/occluders").display().to_string();
    let out = ok(&["golden", &t, "--out", "g"], d.path());
    let row = |label: &str| -> Vec<f64> {
        let line = out.lines().filter(|l| l.split_whitespace().next() == Some(label)).nth(1).unwrap();
        line.split_whitespace().skip(1).map(|c| c.parse().unwrap()).collect()
    };
    let kernels: Vec<f64> = (0..6).map(|k| row(&k.to_string())[5]).collect();
    let mean = row("mean")[5];
    let want = kernels.iter().sum::<f64>() / 6.0;
    assert!((mean - want).abs() < 0.06, "mean row kernels {mean}, mean of the frames {want}");
}

/// `simulate`: the summary starts by naming the configuration, clock,
/// target rate and views; it writes EXR frames with depth, byte-identical
/// to the golden model's where the engines agree; `--dump-config` writes a
/// file `--config` reads back to the same run.
#[test]
fn simulate_names_its_configuration_and_writes_exr_frames() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let t = root().join("traces/occluders").display().to_string();
    let out = ok(&["simulate", &t, "--out", "s", "--preset", "hmd2026"], p);
    let first = out.lines().next().unwrap();
    assert!(first.starts_with("configuration: preset hmd2026; clock 1000 MHz, target 90 Hz x 2 views"), "{first}");
    assert!(out.contains("DRAM at the target rate (mean):") && out.contains("utilisation"), "{out}");
    ok(&["golden", &t, "--out", "g", "--abuffer-fragments", "3"], p);
    ok(&["simulate", &t, "--out", "m"], p);
    for k in 0..6 {
        let (a, b) = (p.join(format!("m/frame-{k:04}.exr")), p.join(format!("g/frame-{k:04}.exr")));
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap(), "frame {k}: EXR differs from golden");
    }
    let r = postwarp::trace::read_reference_image(&p.join("m/frame-0000.exr"), (256, 192)).unwrap();
    assert!(r.samples.valid.count_ones() > 0 && r.samples.depth_range().is_some(), "depth is in the EXR");
    ok(&["simulate", "--dump-config", "hmd.toml", "--preset", "hmd2026"], p);
    let text = std::fs::read_to_string(p.join("hmd.toml")).unwrap();
    let clock = postwarp_rtl::knob::find(postwarp_rtl::config::KNOBS, "clock_hz").unwrap();
    let want = format!("# {} (Hz)\nclock_hz = 1000000000", clock.description);
    assert!(text.contains(&want), "{text}");
    ok(&["simulate", &t, "--out", "s2", "--config", "hmd.toml"], p);
    let a = postwarp::report::load(&p.join("s")).unwrap();
    let b = postwarp::report::load(&p.join("s2")).unwrap();
    let (postwarp::report::Report::Simulate(a), postwarp::report::Report::Simulate(b)) = (a, b) else { panic!() };
    assert_eq!(a.config, b.config, "the dumped configuration is the preset");
    assert_eq!(a.total.counters, b.total.counters);
}

/// `info --json` holds the numbers the table prints.
#[test]
fn info_json_is_the_table() {
    let d = tempfile::tempdir().unwrap();
    let t = root().join("traces/occluders").display().to_string();
    let table = ok(&["info", &t], d.path());
    let j: serde_json::Value = serde_json::from_str(&ok(&["info", &t, "--json"], d.path())).unwrap();
    assert_eq!(j["references"].as_array().unwrap().len(), 2);
    assert_eq!(j["derived"].as_array().unwrap().len(), 6);
    assert_eq!(j["display"]["width"], 128);
    let e = &j["derived"][0]["warps"][0];
    let line = format!("move {:.4}, turn {:.2}", e["move_units"].as_f64().unwrap(), e["turn_deg"].as_f64().unwrap());
    assert!(table.contains(&line), "{line} not in\n{table}");
}

/// `simulate` decodes a frame's second reference beside its first and
/// converts it only when its warp comes: a bad second reference is still
/// one error naming its file and manifest line, whether its bytes are not
/// an image (found while decoding ahead) or its depth is bad (found when
/// converted).
#[test]
fn a_bad_second_reference_is_named_by_simulate() {
    use postwarp::trace::{SlopeSource, Trace, write_reference_image};
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let t = p.join("t");
    common::copy_dir(&root().join("traces/occluders"), &t);
    let trace = t.display().to_string();
    let mut img = Trace::open(&t).unwrap().load_reference(1).unwrap().samples;
    let i = img.valid.first_one().expect("a surface");
    img.z[i] = -1.0;
    let (x, y) = (i % img.width as usize, i / img.width as usize);
    write_reference_image(&t.join("ref/0001.exr"), &img, SlopeSource::Exact).unwrap();
    let at = format!("sample ({x}, {y})");
    fails(&["simulate", &trace, "--out", "o"], p, &["ref/0001.exr", &at, "Z = -1", "postwarp.trace:"]);
    std::fs::write(t.join("ref/0001.exr"), b"not an exr").unwrap();
    fails(&["simulate", &trace, "--out", "o2"], p, &["ref/0001.exr", "not a readable OpenEXR", "postwarp.trace:"]);
}
