//! `postwarp sweep --slurm` against a real Slurm cluster: `specs/ci-tiny.toml`
//! through `sbatch` job arrays gives the local run's `results.csv` (every
//! column but host time); a task killed mid-run is reported with its slice
//! and log and makes the run fail, and the rerun resubmits that slice only;
//! `--no-wait` returns at once and the merge job still writes the results;
//! with every point stored nothing is submitted.
//!
//! Whether it runs is decided by `POSTWARP_SLURM`, never by guessing:
//! - `1`: run against the cluster `sbatch` reaches (CI: `.ci/run` starts a
//!   single-node one with `.ci/slurm` and sets it). If Slurm is missing or
//!   its controller does not answer, the test fails, loudly.
//! - unset or `0`: reported as ignored, with the reason. (A developer's
//!   `cargo test` never submits jobs to a cluster it happens to reach.)
//!
//! The harness is libtest-mimic's (`harness = false` in Cargo.toml), the
//! one that can report a test ignored at run time with its reason.

use libtest_mimic::{Arguments, Completion, Failed, Trial};
use postwarp::report::csv;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

const GATE: &str = "POSTWARP_SLURM";

fn main() -> ExitCode {
    let args = Arguments::from_args();
    let trials = vec![Trial::ignorable_test("slurm_sweep_equals_a_local_run_and_resubmits_a_killed_task", || {
        gated(slurm_sweep)
    })];
    libtest_mimic::run(&args, trials).exit_code()
}

fn gated(body: fn()) -> Result<Completion, Failed> {
    match std::env::var(GATE).as_deref() {
        Ok("1") => {}
        Ok("0") | Err(_) => {
            return Ok(Completion::ignored_with(format!(
                "needs a Slurm cluster: {GATE}=1 runs it against the one sbatch reaches (.ci/run starts one with \
                 .ci/slurm and sets {GATE}=1)"
            )));
        }
        Ok(v) => return Err(format!("{GATE}=`{v}`: expected 1 (run against Slurm) or 0 (ignore)").into()),
    }
    let v = Command::new("sbatch")
        .arg("--version")
        .output()
        .map_err(|e| format!("{GATE}=1 but sbatch cannot be run ({e}): is Slurm installed and on PATH?"))?;
    if !v.status.success() {
        return Err(format!("{GATE}=1 but `sbatch --version` failed: {}", String::from_utf8_lossy(&v.stderr)).into());
    }
    let ping = Command::new("scontrol").arg("ping").output().map_err(|e| format!("scontrol: {e}"))?;
    let said = String::from_utf8_lossy(&ping.stdout);
    if !ping.status.success() || !said.contains("UP") {
        return Err(format!(
            "{GATE}=1 but the Slurm controller does not answer (scontrol ping: {} {})",
            said.trim(),
            String::from_utf8_lossy(&ping.stderr).trim()
        )
        .into());
    }
    body();
    Ok(Completion::Completed)
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_postwarp"));
    c.env_remove("SLURM_ARRAY_TASK_ID");
    c
}

fn ok(args: &[&str]) -> String {
    let o = bin().args(args).output().unwrap();
    assert!(
        o.status.success(),
        "postwarp {args:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn without_host_time(dir: &Path) -> String {
    let rows = csv::parse(&std::fs::read_to_string(dir.join("results.csv")).unwrap()).unwrap();
    let keep: Vec<usize> = (0..rows[0].len()).filter(|&i| rows[0][i] != "host_ms_per_frame").collect();
    assert_eq!(keep.len() + 1, rows[0].len(), "one host-time column");
    rows.iter().map(|r| csv::line(&keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>())).collect()
}

fn planned_points(dir: &Path) -> Vec<String> {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("plan.json")).unwrap()).unwrap();
    v["points"].as_array().unwrap().iter().map(|p| p["hash"].as_str().unwrap().to_string()).collect()
}

fn point_file(dir: &Path, hash: &str) -> PathBuf {
    dir.join("points").join(format!("{hash}.json"))
}

/// Poll `ready` every 50 ms for up to two minutes.
fn wait_until<T>(what: &str, mut ready: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(t) = ready() {
            return t;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn squeue(args: &[&str]) -> String {
    let o = Command::new("squeue").args(args).output().unwrap();
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Cancels the jobs it holds when the test ends, passed or not.
#[derive(Default)]
struct Jobs(Vec<String>);

impl Drop for Jobs {
    fn drop(&mut self) {
        for j in &self.0 {
            let _ = Command::new("scancel").arg(j).output();
        }
    }
}

/// The job ids in `postwarp sweep --slurm` output.
fn job_ids(out: &str) -> (String, String) {
    let line = out.lines().find(|l| l.starts_with("submitted array job ")).unwrap_or_else(|| panic!("{out}"));
    let array = line["submitted array job ".len()..].split(':').next().unwrap().to_string();
    let merge = line.split("merge job ").nth(1).unwrap().split(' ').next().unwrap().to_string();
    (array, merge)
}

fn slurm_sweep() {
    let tiny = root().join("specs/ci-tiny.toml");
    let tiny = s(&tiny);
    let tmp = tempfile::tempdir().unwrap();
    let local = tmp.path().join("local");
    let dir = tmp.path().join("slurm");
    let mut jobs = Jobs::default();

    ok(&["sweep", tiny, "--out", s(&local), "--jobs", "2"]);
    let n = planned_points(&local).len();
    let k = n.div_ceil(2); // two slices
    let ks = k.to_string();
    let slurm_args = ["sweep", tiny, "--out", s(&dir), "--slurm", "--points-per-task", &ks, "--max-parallel", "1"];

    // 1. A run whose running task is killed after its first point.
    let mut child = bin().args(slurm_args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in std::io::BufReader::new(stdout).lines() {
            let line = line.unwrap();
            if line.starts_with("submitted array job ") {
                let _ = tx.send(line.clone());
            }
            all += &line;
            all.push('\n');
        }
        all
    });
    let submitted = rx.recv_timeout(Duration::from_secs(120)).expect("the array is submitted");
    let (array, merge) = job_ids(&submitted);
    jobs.0.extend([array.clone(), merge.clone()]);
    assert!(submitted.contains(&format!("2 of 2 slices (0-1), {k} points per task, {n} points to run")), "{submitted}");
    let points = planned_points(&dir);
    assert_eq!(points.len(), n);
    let running: usize = wait_until("a running array task", || {
        squeue(&["-h", "-t", "R", "-j", &array, "-o", "%i"])
            .lines()
            .find_map(|l| l.trim().strip_prefix(&format!("{array}_")).and_then(|t| t.parse().ok()))
    });
    let slice: Vec<&String> = points.iter().skip(running * k).take(k).collect();
    wait_until("the running task's first point", || slice.iter().any(|h| point_file(&dir, h).is_file()).then_some(()));
    let kill = Command::new("scancel").arg(format!("{array}_{running}")).output().unwrap();
    assert!(kill.status.success(), "{}", String::from_utf8_lossy(&kill.stderr));
    let o = child.wait_with_output().unwrap();
    let out = reader.join().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "the run with a killed task failed: {out}{err}");
    let stored = slice.iter().filter(|h| point_file(&dir, h).is_file()).count();
    assert!(stored >= 1 && stored < k, "killed mid-run: {stored} of {k} points of slice {running} stored");
    let log = dir.join("slurm/logs").join(format!("{array}_{running}.out"));
    let last = (running * k + k).min(n) - 1;
    assert!(
        err.contains("1 of 2 submitted slices failed")
            && err.contains(&format!("merge job {merge} cancelled"))
            && err.contains(&format!(
                "slice {running} (points {}-{last}): CANCELLED, {} missing; log {}",
                running * k,
                k - stored,
                log.display()
            ))
            && err.contains("run the same command again to resubmit only the failed slices"),
        "{err}"
    );
    assert!(log.is_file(), "{} exists", log.display());
    assert!(!dir.join("results.csv").exists(), "no results.csv while a slice is missing");
    let other = 1 - running;
    let other_files: Vec<PathBuf> = points.iter().skip(other * k).take(k).map(|h| point_file(&dir, h)).collect();
    assert!(other_files.iter().all(|f| f.is_file()), "the other slice finished");
    let other_bytes: Vec<Vec<u8>> = other_files.iter().map(|f| std::fs::read(f).unwrap()).collect();

    // 2. The rerun submits the killed slice only, and the merge job merges.
    let out = ok(&slurm_args);
    let (array2, merge2) = job_ids(&out);
    jobs.0.extend([array2.clone(), merge2.clone()]);
    assert!(
        out.contains(&format!("1 of 2 slices ({running}), {k} points per task, {} points to run", k - stored)),
        "{out}"
    );
    assert!(
        out.contains(&format!(
            "{} stored already, {} computed by Slurm in 1 of 2 slices",
            n - (k - stored),
            k - stored
        )),
        "{out}"
    );
    let after: Vec<Vec<u8>> = other_files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    assert!(after == other_bytes, "the slice that had finished was not run again");
    assert!(dir.join("slurm/logs").join(format!("merge-{merge2}.out")).is_file());
    assert_eq!(without_host_time(&dir), without_host_time(&local), "Slurm and local runs give the same CSV");
    let rows = csv::parse(&std::fs::read_to_string(dir.join("results.csv")).unwrap()).unwrap();
    let (m, host) = (
        rows[0].iter().position(|c| c == "method").unwrap(),
        rows[0].iter().position(|c| c == "host_ms_per_frame").unwrap(),
    );
    assert!(rows[1..].iter().all(|r| (r[m] == "hardware") == r[host].is_empty()), "CPU points timed by the tasks");

    // 3. --no-wait: submitted, returned; the merge job writes results.csv.
    std::fs::remove_file(&other_files[0]).unwrap();
    std::fs::remove_file(dir.join("results.csv")).unwrap();
    let out = ok(&[&slurm_args[..], &["--no-wait"]].concat());
    let (array3, merge3) = job_ids(&out);
    jobs.0.extend([array3.clone(), merge3.clone()]);
    assert!(out.contains(&format!("not waiting: array job {array3} (1 of 2 slices), merge job {merge3}")), "{out}");
    assert!(out.contains(&format!("postwarp sweep merge {} --points-per-task {k}", s(&dir))), "{out}");
    let both = format!("{array3},{merge3}");
    wait_until("the jobs to end", || {
        let q = squeue(&["-h", "-t", "all", "-j", &both, "-o", "%T"]);
        q.lines().all(|st| ["COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"].contains(&st.trim())).then_some(())
    });
    assert_eq!(without_host_time(&dir), without_host_time(&local), "the merge job wrote results.csv");
    let out = ok(&["sweep", "merge", s(&dir), "--points-per-task", &ks]);
    assert!(out.contains(&format!("merged {n} points")), "{out}");

    // 4. Everything stored: nothing to submit, merged here.
    let out = ok(&slurm_args);
    assert!(out.contains("all stored already (2 slices of") && out.contains("nothing submitted, merged here"), "{out}");
    assert_eq!(without_host_time(&dir), without_host_time(&local));
}
