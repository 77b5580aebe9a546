//! What the Slurm path of `postwarp sweep` costs over the local path, in
//! one run: `specs/ci-tiny.toml` (40 points) timed end to end (plan, points,
//! merge; a fresh output directory each time) locally and through
//! `--slurm`, alternately, each the median of `REPS` runs:
//!
//! - serial: local `--jobs 1` against `--slurm --points-per-task 1
//!   --max-parallel 1` (one task at a time): the difference over the points
//!   is the cost of one array task (scheduling, starting postwarp, loading
//!   the plan), which is what `--points-per-task` must amortise;
//! - whole machine: local `--jobs N` (N = available cores) against
//!   `--slurm --points-per-task 1` and `--points-per-task ceil(points/N)`
//!   (one task per core): the overhead per point a user sees.
//!
//! Also the part of a task's cost outside the scheduler: `sweep run` of a
//! slice whose point is stored (a process that loads the plan, checks the
//! trace and finds nothing to do).
//!
//! Run: `cargo bench --bench sweep_slurm` on a host that can submit to a
//! Slurm cluster (e.g. the single-node one of `.ci/slurm`: `.ci/slurm start
//! /tmp/slurm && export SLURM_CONF=/tmp/slurm/slurm.conf`). The sweeps go
//! to a temporary directory under `POSTWARP_BENCH_DIR` (default: the
//! system's temporary directory), which on a real cluster must be on the
//! file system the nodes share, as must this checkout (the `postwarp`
//! executable). Without `sbatch` it says so and measures nothing. `REPS` is
//! 3; set `POSTWARP_BENCH_REPS` to change it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn postwarp(args: &[&str]) -> f64 {
    let t = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).env_remove("SLURM_ARRAY_TASK_ID").output().unwrap();
    let s = t.elapsed().as_secs_f64();
    assert!(
        o.status.success(),
        "postwarp {args:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    s
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    if !Command::new("sbatch").arg("--version").output().is_ok_and(|o| o.status.success()) {
        eprintln!("sweep_slurm: not measured: no usable sbatch on PATH (see the header of benches/sweep_slurm.rs)");
        return;
    }
    let reps: usize = std::env::var("POSTWARP_BENCH_REPS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let spec = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("specs/ci-tiny.toml");
    let spec = spec.to_str().unwrap();
    let tmp = match std::env::var_os("POSTWARP_BENCH_DIR") {
        Some(d) => tempfile::tempdir_in(d).expect("a temporary directory in POSTWARP_BENCH_DIR"),
        None => tempfile::tempdir().unwrap(),
    };
    let mut run_no = 0;
    let mut fresh = |label: &str| -> PathBuf {
        run_no += 1;
        tmp.path().join(format!("{label}-{run_no}"))
    };
    let s = |p: &Path| p.to_str().unwrap().to_string();

    // The plan's size, from one local run (also warms the file cache).
    let first = fresh("warm");
    postwarp(&["sweep", spec, "--out", &s(&first), "--jobs", &cores.to_string()]);
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(first.join("plan.json")).unwrap()).unwrap();
    let n = plan["points_total"].as_u64().unwrap() as usize;
    let per_core = n.div_ceil(cores);

    let cases: Vec<(String, Vec<String>)> = vec![
        ("local --jobs 1".into(), vec!["--jobs".into(), "1".into()]),
        (
            "slurm --points-per-task 1 --max-parallel 1".into(),
            ["--slurm", "--points-per-task", "1", "--max-parallel", "1"].map(String::from).to_vec(),
        ),
        (format!("local --jobs {cores}"), vec!["--jobs".into(), cores.to_string()]),
        ("slurm --points-per-task 1".into(), ["--slurm", "--points-per-task", "1"].map(String::from).to_vec()),
        (
            format!("slurm --points-per-task {per_core}"),
            vec!["--slurm".into(), "--points-per-task".into(), per_core.to_string()],
        ),
    ];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
    for _ in 0..reps {
        for (i, (_, extra)) in cases.iter().enumerate() {
            let out = fresh("run");
            let mut args: Vec<String> = vec!["sweep".into(), spec.into(), "--out".into(), s(&out)];
            args.extend(extra.iter().cloned());
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            times[i].push(postwarp(&a));
        }
    }
    let t: Vec<f64> = times.into_iter().map(median).collect();
    // A task's cost outside the scheduler: a slice with nothing to do.
    let idle: Vec<f64> =
        (0..reps.max(3)).map(|_| postwarp(&["sweep", "run", &s(&first), "--index", "0", "--jobs", "1"])).collect();
    let idle = median(idle);

    println!(
        "sweep_slurm: specs/ci-tiny.toml, {n} points, {cores} cores, release build, median of {reps} runs each \
         (end to end: plan, points, merge)"
    );
    println!("{:<48} {:>6} {:>8} {:>9} {:>22}", "path", "tasks", "wall s", "s/point", "overhead s/point");
    let tasks = [0, n, 0, n, n.div_ceil(per_core)];
    let base = [0, 0, 2, 2, 2];
    for (i, (label, _)) in cases.iter().enumerate() {
        let over = if label.starts_with("slurm") {
            format!("{:+.3} (vs {})", (t[i] - t[base[i]]) / n as f64, cases[base[i]].0)
        } else {
            "-".into()
        };
        let tk = if tasks[i] == 0 { "-".to_string() } else { tasks[i].to_string() };
        println!("{label:<48} {tk:>6} {:>8.2} {:>9.3} {over:>22}", t[i], t[i] / n as f64);
    }
    println!(
        "one array task costs {:.3} s (serial Slurm minus serial local, per task of 1 point), of which {:.3} s is \
         outside the scheduler (`sweep run` of a stored slice: start, load the plan, check the trace)",
        (t[1] - t[0]) / n as f64,
        idle
    );
}
