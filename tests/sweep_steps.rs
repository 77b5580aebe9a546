//! The three steps of a sweep (`postwarp sweep plan|run|merge`) on
//! `specs/ci-tiny.toml`, each step its own process: slices run in any
//! order, two at once and one by its Slurm array index, merge into the
//! one-process sweep's `results.csv` (every column but host time); a
//! missing slice is named; a corrupt point file is recomputed; bad
//! indices, missing plans and a plan that no longer matches its traces
//! are refused. The Slurm path itself is `tests/sweep_slurm.rs`.

use postwarp::report::csv;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tiny() -> String {
    root().join("specs/ci-tiny.toml").to_str().unwrap().to_string()
}

fn cmd(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_postwarp"));
    c.args(args).env_remove("SLURM_ARRAY_TASK_ID");
    c
}

fn postwarp(args: &[&str]) -> Output {
    cmd(args).output().unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = postwarp(args);
    assert!(o.status.success(), "postwarp {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn fails(args: &[&str]) -> String {
    let o = postwarp(args);
    assert!(!o.status.success(), "postwarp {args:?} succeeded: {}", String::from_utf8_lossy(&o.stdout));
    String::from_utf8(o.stderr).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `results.csv` without its host-time column, as text.
fn without_host_time(dir: &Path) -> String {
    let rows = csv::parse(&std::fs::read_to_string(dir.join("results.csv")).unwrap()).unwrap();
    let keep: Vec<usize> = (0..rows[0].len()).filter(|&i| rows[0][i] != "host_ms_per_frame").collect();
    assert_eq!(keep.len() + 1, rows[0].len(), "one host-time column");
    rows.iter().map(|r| csv::line(&keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>())).collect()
}

/// The one-process sweep, the reference for the merges.
fn local() -> &'static Path {
    static D: OnceLock<tempfile::TempDir> = OnceLock::new();
    D.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        ok(&["sweep", &tiny(), "--out", s(d.path()), "--jobs", "1"]);
        d
    })
    .path()
}

/// Points per slice in these tests (8 slices of ci-tiny's 40 points; the
/// counts below follow the plan, so registering a method moves no test).
const K: &str = "5";

/// The plan's points and its slices of [`K`].
fn counts() -> (usize, usize) {
    let n = planned_points(sliced()).len();
    (n, n.div_ceil(5))
}

fn planned_points(dir: &Path) -> Vec<String> {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("plan.json")).unwrap()).unwrap();
    let points: Vec<String> =
        v["points"].as_array().unwrap().iter().map(|p| p["hash"].as_str().unwrap().to_string()).collect();
    assert_eq!(v["points_total"].as_u64().unwrap() as usize, points.len());
    points
}

/// A sweep planned, its slices run in a scrambled order by separate
/// processes (two of them at once, one indexed by SLURM_ARRAY_TASK_ID), and
/// merged.
fn sliced() -> &'static Path {
    static D: OnceLock<tempfile::TempDir> = OnceLock::new();
    D.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let dir = s(d.path());
        let out = ok(&["sweep", "plan", &tiny(), "--out", dir]);
        let n = planned_points(d.path()).len();
        assert!(out.contains(&format!("{n} points on 2 traces (1 generated now), 0 stored already")), "{out}");
        let slices = n.div_ceil(5);
        assert!(slices >= 7, "{slices} slices: the tests name points up to 30 and slices up to 6");
        // Two slices at once, in two processes.
        let spawn = |i: &str| {
            cmd(&["sweep", "run", dir, "--index", i, "--points-per-task", K, "--jobs", "1"])
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        // The last slice (shorter when 5 does not divide the points) and slice 2.
        let last = slices - 1;
        let (a, b) = (spawn(&last.to_string()), spawn("2"));
        for c in [a, b] {
            let o = c.wait_with_output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        }
        for i in [4, 0, 5, 3].into_iter().chain(6..last) {
            let out = ok(&["sweep", "run", dir, "--index", &i.to_string(), "--points-per-task", K, "--jobs", "2"]);
            let head = format!("slice {i} of {slices} (points {}-", i * 5);
            assert!(out.contains(&head) && out.contains("5 computed"), "{out}");
        }
        // The index from a Slurm array task's environment.
        let o = cmd(&["sweep", "run", dir, "--points-per-task", K]).env("SLURM_ARRAY_TASK_ID", "1").output().unwrap();
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success() && out.contains(&format!("slice 1 of {slices} (points 5-9 of {n}")), "{out}");
        let out = ok(&["sweep", "merge", dir, "--points-per-task", K]);
        assert!(out.contains(&format!("merged {n} points")), "{out}");
        d
    })
    .path()
}

#[test]
fn slices_merged_in_any_order_give_the_one_process_csv() {
    assert_eq!(without_host_time(sliced()), without_host_time(local()));
    // Same rows, same points, same chart files.
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d.join("charts"))
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(sliced()), names(local()));
    assert_eq!(planned_points(sliced()), planned_points(local()), "the whole sweep writes the same plan");
    // The merged host times are the stored ones: merging again is the same bytes.
    let before = std::fs::read(sliced().join("results.csv")).unwrap();
    let d = tempfile::tempdir().unwrap();
    crate::common::copy_dir(sliced(), d.path());
    ok(&["sweep", "merge", s(d.path())]);
    assert_eq!(std::fs::read(d.path().join("results.csv")).unwrap(), before);
}

#[test]
fn a_missing_slice_is_named_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    crate::common::copy_dir(sliced(), d.path());
    std::fs::remove_file(d.path().join("results.csv")).unwrap();
    let points = planned_points(d.path());
    // Points 11 and 13 are slice 2 at 5 per task, slices 5 and 6 at 2.
    for i in [11, 13] {
        std::fs::remove_file(d.path().join("points").join(format!("{}.json", points[i]))).unwrap();
    }
    let (n, slices) = counts();
    let e = fails(&["sweep", "merge", s(d.path()), "--points-per-task", K]);
    assert!(e.contains(&format!("2 of {n} planned points are not stored")) && e.contains("(2 absent)"), "{e}");
    assert!(e.contains(&format!("they are in 1 of {slices} slices: 2\n  slice 2 (points 10-14): 2 missing")), "{e}");
    assert!(e.contains(&format!("postwarp sweep run {} --index I --points-per-task 5", s(d.path()))), "{e}");
    let e = fails(&["sweep", "merge", s(d.path()), "--points-per-task", "2"]);
    let by_two = n.div_ceil(2);
    assert!(
        e.contains(&format!("in 2 of {by_two} slices: 5-6")) && e.contains("slice 6 (points 12-13): 1 missing"),
        "{e}"
    );
    assert!(!d.path().join("results.csv").exists(), "no results.csv while points are missing");
    let out = ok(&["sweep", "run", s(d.path()), "--index", "2", "--points-per-task", K]);
    assert!(out.contains("3 skipped (stored earlier), 2 computed"), "{out}");
    ok(&["sweep", "merge", s(d.path())]);
    assert_eq!(without_host_time(d.path()), without_host_time(local()));
}

#[test]
fn a_corrupt_point_file_is_recomputed() {
    let d = tempfile::tempdir().unwrap();
    crate::common::copy_dir(sliced(), d.path());
    let points = planned_points(d.path());
    let file = |i: usize| d.path().join("points").join(format!("{}.json", points[i]));
    let text = std::fs::read_to_string(file(7)).unwrap();
    std::fs::write(file(7), &text[..text.len() / 2]).unwrap(); // torn
    std::fs::write(file(30), "").unwrap(); // empty
    let (n, _) = counts();
    let e = fails(&["sweep", "merge", s(d.path()), "--points-per-task", K]);
    assert!(e.contains(&format!("2 of {n} planned points are not stored")) && e.contains("(2 unreadable)"), "{e}");
    assert!(e.contains("slices: 1,6"), "{e}");
    let out = ok(&["sweep", "run", s(d.path()), "--index", "1", "--points-per-task", K]);
    assert!(out.contains("4 skipped (stored earlier), 1 computed") && out.contains("1 stored points were unreadable"));
    // Rewritten whole: the same point as before it was torn, host time aside.
    let point = |t: &str| {
        let mut v: serde_json::Value = serde_json::from_str(t).unwrap();
        v["metrics"]["host_ms_per_frame"] = serde_json::Value::Null;
        v
    };
    assert_eq!(point(&std::fs::read_to_string(file(7)).unwrap()), point(&text));
    // The whole sweep recomputes one too, and rewrites nothing else.
    let other = std::fs::read(file(0)).unwrap();
    let out = ok(&["sweep", &tiny(), "--out", s(d.path()), "--jobs", "1"]);
    assert!(out.contains(&format!("{n} points, {} skipped", n - 1)) && out.contains("1 computed"), "{out}");
    assert_eq!(std::fs::read(file(0)).unwrap(), other);
    assert_eq!(without_host_time(d.path()), without_host_time(local()));
}

#[test]
fn bad_indices_and_unplanned_directories_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let e = fails(&["sweep", "run", s(d.path()), "--index", "0"]);
    assert!(e.contains("plan.json: no such file") && e.contains("postwarp sweep plan SPEC --out"), "{e}");
    let e = fails(&["sweep", "merge", s(d.path())]);
    assert!(e.contains("plan.json: no such file"), "{e}");
    let dir = sliced();
    let (n, slices) = counts();
    let e = fails(&["sweep", "run", s(dir), "--index", &slices.to_string(), "--points-per-task", K]);
    let want = format!("has {n} points, {slices} slices of 5 (indices 0 to {})", slices - 1);
    assert!(e.contains(&format!("slice {slices}: the plan in")) && e.contains(&want), "{e}");
    let e = fails(&["sweep", "run", s(dir)]);
    assert!(e.contains("no slice given: pass --index I") && e.contains("SLURM_ARRAY_TASK_ID"), "{e}");
    let o = cmd(&["sweep", "run", s(dir)]).env("SLURM_ARRAY_TASK_ID", "x1").output().unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("SLURM_ARRAY_TASK_ID=`x1`: expected a whole number"));
    let e = fails(&["sweep", "run", s(dir), "--index", "0", "--points-per-task", "0"]);
    assert!(e.contains("--points-per-task must be at least 1"), "{e}");
    // Slurm flags need --slurm.
    let e = fails(&["sweep", &tiny(), "--out", s(d.path()), "--points-per-task", "2"]);
    assert!(e.contains("--slurm"), "{e}");
    // A torn plan names its line.
    std::fs::write(d.path().join("plan.json"), "{\n  \"format\": 1,\n  \"build\"").unwrap();
    let e = fails(&["sweep", "merge", s(d.path())]);
    assert!(e.contains("plan.json:3:") && e.contains("not a sweep plan"), "{e}");
}

#[test]
fn a_plan_is_refused_once_its_traces_or_points_no_longer_match() {
    let d = tempfile::tempdir().unwrap();
    crate::common::copy_dir(&root().join("traces/room"), &d.path().join("room"));
    let spec = d.path().join("room.toml");
    std::fs::write(&spec, "runs = 1\nmethods = \"forward-splat\"\n[[traces]]\npath = \"room\"\nframes = 1\n").unwrap();
    let out = d.path().join("out");
    ok(&["sweep", "plan", s(&spec), "--out", s(&out)]);
    // An edited reference image (one bit of ref/0000.exr, which the manifest
    // names): the trace is no longer the planned one.
    let p = d.path().join("room/ref/0000.exr");
    let mut bytes = std::fs::read(&p).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&p, bytes).unwrap();
    let e = fails(&["sweep", "run", s(&out), "--index", "0"]);
    assert!(e.contains("trace room") && e.contains("changed since the sweep was planned"), "{e}");
    // A specification that now plans other points.
    let mut plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("plan.json")).unwrap()).unwrap();
    plan["spec"]["text"] = serde_json::Value::String(
        "runs = 2\nmethods = \"forward-splat\"\n[[traces]]\npath = \"room\"\nframes = 1\n".into(),
    );
    std::fs::write(out.join("plan.json"), serde_json::to_string(&plan).unwrap()).unwrap();
    let e = fails(&["sweep", "merge", s(&out)]);
    assert!(e.contains("the 1 planned points are not the 1 this build makes") && e.contains("again"), "{e}");
    // Planned by another build.
    plan["build"] = serde_json::Value::String("0000000000000000".into());
    std::fs::write(out.join("plan.json"), serde_json::to_string(&plan).unwrap()).unwrap();
    let e = fails(&["sweep", "run", s(&out), "--index", "0"]);
    assert!(e.contains("planned by another build of postwarp (0000000000000000"), "{e}");
}

#[test]
fn slurm_without_a_slurm_client_says_so() {
    let d = tempfile::tempdir().unwrap();
    let o =
        cmd(&["sweep", &tiny(), "--out", s(&d.path().join("out")), "--slurm"]).env("PATH", d.path()).output().unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("`sbatch` is not on PATH") && e.contains("Slurm client"), "{e}");
    let e = fails(&["sweep", &tiny(), "--out", s(d.path()), "--slurm", "--sbatch-arg=--output=x"]);
    assert!(e.contains("--sbatch-arg --output=x: not allowed, postwarp names the logs"), "{e}");
}

#[test]
fn docs_describe_every_flag_of_the_steps_and_the_slurm_path() {
    use clap::CommandFactory;
    let doc = std::fs::read_to_string(root().join("docs/sweep.md")).unwrap();
    let cli = postwarp::cli::Cli::command();
    let sweep = cli.find_subcommand("sweep").expect("postwarp sweep");
    let mut checked = 0;
    let steps = ["plan", "run", "merge"].map(|n| sweep.find_subcommand(n).unwrap_or_else(|| panic!("sweep {n}")));
    for c in std::iter::once(sweep).chain(steps) {
        for a in c.get_arguments() {
            let Some(long) = a.get_long() else { continue };
            if ["help", "version", "out"].contains(&long) {
                continue;
            }
            assert!(a.get_help().is_some(), "--{long} of `sweep {}` has a description", c.get_name());
            assert!(
                doc.contains(&format!("| `--{long}")),
                "docs/sweep.md has a row for --{long} (`sweep {}`)",
                c.get_name()
            );
            checked += 1;
        }
    }
    assert!(checked >= 12, "{checked} flags");
}
