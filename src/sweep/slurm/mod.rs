//! `postwarp sweep SPEC --out DIR --slurm`: the three steps of a sweep with
//! Slurm as the engine: plan here, run the slices as a job array, merge in
//! a job that depends on the array.
//!
//! Rules:
//! 1. The plan (and any generated trace) is made here, on the submitting
//!    host. Only the slices (at `--points-per-task` K) that hold a point not
//!    stored yet are submitted: `sbatch --parsable --array=LIST[%N]
//!    DIR/slurm/array.sh`, then `sbatch --parsable
//!    --dependency=afterok:ARRAY --kill-on-invalid-dep=yes
//!    DIR/slurm/merge.sh`. With nothing missing, nothing is submitted and
//!    the merge runs here.
//! 2. `DIR`, the `postwarp` executable, the specification and its existing
//!    traces must be on a file system every node mounts at the same path.
//! 3. Waiting polls `squeue --states=all` (no accounting needed), every
//!    [`poll_interval`]. Success
//!    is decided by the files: every planned point stored, and a
//!    `results.csv` equal to the merge of the stored points. A slice whose
//!    points are missing when the array has ended has failed: it is named
//!    with its task's state and its log, the merge job is cancelled, and
//!    the run fails; a rerun resubmits only such slices.
//! 4. `--no-wait` returns once both jobs are submitted, printing their ids
//!    and the command to merge later.

pub mod queue;
pub mod scripts;

use super::merge::{self, MergeOutcome};
use super::plan_file::{self, Prepared};
use super::{Spec, slice, store};
use anyhow::{Context, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How to run a sweep through Slurm.
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// Points per array task (at least 1).
    pub points_per_task: usize,
    /// At most this many tasks at once (`--array=...%N`); `None`: no limit.
    pub max_parallel: Option<usize>,
    /// Partition of both jobs (`sbatch --partition`).
    pub partition: Option<String>,
    /// Further sbatch options for both jobs, each one argument.
    pub sbatch_args: Vec<String>,
    /// Wait for the jobs (else return once they are submitted).
    pub wait: bool,
    /// Threads for planning here (rendering generated traces).
    pub jobs: usize,
    /// Progress bars (on a terminal only).
    pub progress: bool,
}

/// What a Slurm sweep did.
#[derive(Clone, Debug)]
pub struct SlurmOutcome {
    /// Points in the plan.
    pub points: usize,
    /// Points already stored before submitting.
    pub stored: usize,
    /// Generated traces rendered while planning.
    pub traces_generated: usize,
    /// Slices in the plan at this K.
    pub slices: usize,
    /// Slices submitted (those with a missing point).
    pub submitted: Vec<usize>,
    /// The array's job id, if anything was submitted.
    pub array_job: Option<String>,
    /// The merge job's id, if anything was submitted.
    pub merge_job: Option<String>,
    /// The merge, unless `--no-wait` returned before it.
    pub merged: Option<MergeOutcome>,
    /// `DIR/slurm/logs`.
    pub logs: PathBuf,
}

/// The last non-empty line of a log, shortened, for messages.
fn last_line(log: &Path) -> Option<String> {
    let text = std::fs::read_to_string(log).ok()?;
    let l = text.lines().map(str::trim).rfind(|l| !l.is_empty())?;
    Some(if l.chars().count() > 200 { format!("{}...", l.chars().take(200).collect::<String>()) } else { l.into() })
}

/// The slices holding a point not stored (by this build, under its key).
fn slices_missing(p: &Prepared, out: &Path, k: usize) -> (Vec<usize>, usize) {
    let mut slices = Vec::new();
    let mut stored = 0;
    for (i, q) in p.points.iter().enumerate() {
        if store::load(out, &q.hash, &q.key).is_some() {
            stored += 1;
        } else if slices.last() != Some(&slice::of_point(i, k)) {
            slices.push(slice::of_point(i, k));
        }
    }
    (slices, stored)
}

/// Run `spec` into `out` through Slurm (module rules). Prints one line to
/// stdout once the jobs are submitted (their ids), before waiting.
pub fn run(spec: &Spec, out: &Path, o: &SlurmOptions) -> anyhow::Result<SlurmOutcome> {
    anyhow::ensure!(o.points_per_task >= 1, "--points-per-task must be at least 1");
    anyhow::ensure!(o.max_parallel != Some(0), "--max-parallel must be at least 1");
    scripts::check_sbatch_args(&o.sbatch_args)?;
    queue::client_version()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let out = std::fs::canonicalize(out).with_context(|| format!("the absolute path of {}", out.display()))?;
    let dir = scripts::check_path("--out", &out)?;
    let exe = std::env::current_exe().context("the path of the postwarp executable")?;
    let exe = exe.to_str().with_context(|| format!("{}: not valid UTF-8", exe.display()))?.to_string();
    let k = o.points_per_task;

    let pool = super::pool(o.jobs)?;
    let p = plan_file::prepare(spec, &out, &pool, o.progress)?;
    let n = p.points.len();
    let slices = slice::count(n, k);
    let (todo, stored) = slices_missing(&p, &out, k);
    let logs = out.join("slurm").join(scripts::LOGS);
    let mut outcome = SlurmOutcome {
        points: n,
        stored,
        traces_generated: p.traces_generated,
        slices,
        submitted: todo.clone(),
        array_job: None,
        merge_job: None,
        merged: None,
        logs: logs.clone(),
    };
    if todo.is_empty() {
        outcome.merged = Some(merge::merge(&p, &out, k, Duration::ZERO)?);
        return Ok(outcome);
    }
    let last = *todo.last().expect("a slice to submit");
    if let Some(max) = queue::max_array_size().filter(|&max| last >= max) {
        bail!(
            "slice {last} is beyond this cluster's MaxArraySize ({max}: array indices 0 to {}): {n} points at \
             {k} per task make {slices} slices; use --points-per-task {} or more",
            max - 1,
            n.div_ceil(max)
        );
    }

    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let array_sh = out.join("slurm").join("array.sh");
    let merge_sh = out.join("slurm").join("merge.sh");
    for (path, text) in
        [(&array_sh, scripts::array_script(&exe, &dir, k)), (&merge_sh, scripts::merge_script(&exe, &dir, k))]
    {
        write_script(path, &text)?;
    }
    let mut common: Vec<String> = Vec::new();
    if let Some(part) = &o.partition {
        common.push(format!("--partition={part}"));
    }
    common.extend(o.sbatch_args.iter().cloned());
    let mut array_args = vec![format!(
        "--array={}{}",
        slice::compress(&todo),
        o.max_parallel.map_or(String::new(), |m| format!("%{m}"))
    )];
    array_args.extend(common.iter().cloned());
    let array = queue::submit(&array_args, &array_sh)?;
    let mut merge_args = vec![format!("--dependency=afterok:{array}"), "--kill-on-invalid-dep=yes".to_string()];
    merge_args.extend(common);
    let merge_job = match queue::submit(&merge_args, &merge_sh) {
        Ok(j) => j,
        Err(e) => {
            queue::cancel(&array);
            return Err(e.context(format!("submitting the merge job (array job {array} cancelled)")));
        }
    };
    println!(
        "submitted array job {array}: {} of {slices} slices ({}), {k} points per task, {} points to run; \
         merge job {merge_job} after it; logs in {}",
        todo.len(),
        slice::compress(&todo),
        n - stored,
        logs.display()
    );
    outcome.array_job = Some(array.clone());
    outcome.merge_job = Some(merge_job.clone());
    if !o.wait {
        return Ok(outcome);
    }
    outcome.merged = Some(wait(&p, &out, k, &todo, &array, &merge_job, o.progress)?);
    Ok(outcome)
}

fn write_script(path: &Path, text: &str) -> anyhow::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    crate::io_util::write_atomically(path, |tmp| {
        std::fs::write(tmp, text)?;
        std::fs::set_permissions(tmp, std::fs::Permissions::from_mode(0o755))
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// How long the files of a task that succeeded may take to show here
/// (a shared file system's attribute cache).
const SETTLE: Duration = Duration::from_secs(60);

/// How long `squeue` may keep failing (a controller restarting) before the
/// wait gives up; the jobs go on regardless.
const LOST: Duration = Duration::from_secs(300);

/// Time between two `squeue` polls after waiting `waited`: a twentieth of
/// it, from 0.2 s to 30 s, so the end of a run is seen within 5 % of its
/// time (or 30 s) without polling a busy controller every second for hours.
pub fn poll_interval(waited: Duration) -> Duration {
    (waited / 20).clamp(Duration::from_millis(200), Duration::from_secs(30))
}

/// Wait for the array and the merge job (rule 3).
fn wait(
    p: &Prepared,
    out: &Path,
    k: usize,
    todo: &[usize],
    array: &str,
    merge_job: &str,
    progress: bool,
) -> anyhow::Result<MergeOutcome> {
    let missing_hashes: Vec<&str> = todo
        .iter()
        .flat_map(|&s| slice::range(s, k, p.points.len()).expect("a planned slice"))
        .map(|i| p.points[i].hash.as_str())
        .filter(|h| !store::point_file(out, h).is_file())
        .collect();
    let bar = if progress {
        crate::progress::bar(missing_hashes.len() as u64, "slurm")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut tasks: BTreeMap<usize, queue::JobState> = BTreeMap::new();
    let mut merge_state: Option<queue::JobState> = None;
    let mut array_ended = false;
    let waiting = Instant::now();
    let mut failing_since: Option<Instant> = None;
    loop {
        let states = match queue::states(&[array, merge_job]) {
            Ok(s) => {
                failing_since = None;
                s
            }
            Err(e) => {
                let since = *failing_since.get_or_insert_with(Instant::now);
                if since.elapsed() >= LOST {
                    bar.finish_and_clear();
                    return Err(e.context(format!(
                        "no answer from Slurm for {} s while waiting for array job {array} and merge job \
                         {merge_job}; they may still run: follow them with `squeue -j {array},{merge_job}`, then \
                         `postwarp sweep merge {} --points-per-task {k}`",
                        LOST.as_secs(),
                        out.display()
                    )));
                }
                std::thread::sleep(Duration::from_secs(2));
                continue;
            }
        };
        let mut array_active = false;
        for s in states {
            if s.job == array {
                array_active |= !s.ended();
                if let Some(t) = s.task {
                    tasks.insert(t, s);
                }
            } else if s.job == merge_job {
                merge_state = Some(s);
            }
        }
        if progress {
            bar.set_position(missing_hashes.iter().filter(|h| store::point_file(out, h).is_file()).count() as u64);
        }
        if !array_active && !array_ended {
            array_ended = true;
            let all_completed = todo.iter().all(|t| tasks.get(t).is_some_and(|s| s.state == "COMPLETED"));
            let settle = if all_completed { SETTLE } else { Duration::ZERO };
            if let Err(missing) = merge::stored_metrics(p, out, k, settle) {
                queue::cancel(merge_job);
                bar.finish_and_clear();
                bail!(failure_report(&missing, &tasks, array, merge_job, todo.len()));
            }
        }
        let merge_active = merge_state.as_ref().is_some_and(|s| !s.ended());
        if array_ended && !merge_active {
            break;
        }
        std::thread::sleep(poll_interval(waiting.elapsed()));
    }
    bar.finish_and_clear();
    // The merge job's results.csv must be the merge of the stored points.
    let metrics = merge::stored_metrics(p, out, k, Duration::ZERO).map_err(anyhow::Error::from)?;
    let expected = merge::csv_text(p, &metrics);
    let results = out.join("results.csv");
    let merge_log = out.join("slurm").join(scripts::LOGS).join(format!("merge-{merge_job}.out"));
    let completed = merge_state.as_ref().is_some_and(|s| s.state == "COMPLETED");
    let start = Instant::now();
    loop {
        if std::fs::read_to_string(&results).ok().as_deref() == Some(expected.as_str()) {
            break;
        }
        if !completed || start.elapsed() >= SETTLE {
            let state = merge_state.map_or("state unknown".to_string(), |s| format!("{} ({})", s.state, s.reason));
            bail!(
                "every point is stored, but merge job {merge_job} ({state}) did not write {} as the points give it; \
                 log {}{}; merge here with `postwarp sweep merge {} --points-per-task {k}`",
                results.display(),
                merge_log.display(),
                last_line(&merge_log).map_or(String::new(), |l| format!(": {l}")),
                out.display()
            );
        }
        std::thread::sleep(Duration::from_secs(1));
    }
    let mut charts: Vec<PathBuf> = std::fs::read_dir(out.join("charts"))
        .map(|d| {
            d.filter_map(Result::ok).map(|e| e.path()).filter(|p| !p.to_string_lossy().ends_with(".tmp")).collect()
        })
        .unwrap_or_default();
    charts.sort();
    Ok(MergeOutcome { points: p.points.len(), results, charts })
}

/// The error of a run whose slices did not all store their points.
fn failure_report(
    missing: &merge::MissingPoints,
    tasks: &BTreeMap<usize, queue::JobState>,
    array: &str,
    merge_job: &str,
    submitted: usize,
) -> String {
    let slices = missing.slices();
    let logs = missing.out.join("slurm").join(scripts::LOGS);
    let mut s = format!(
        "{} of {submitted} submitted slices failed (array job {array}; merge job {merge_job} cancelled): {} of {} \
         points are not stored",
        slices.len(),
        missing.missing.len(),
        missing.total
    );
    for &i in &slices {
        let r = slice::range(i, missing.per_task, missing.total).expect("a planned slice");
        let n = missing.missing.iter().filter(|(p, _)| r.contains(p)).count();
        let state = tasks.get(&i).map_or("state unknown".to_string(), |t| match t.reason.as_str() {
            "" | "None" => t.state.clone(),
            why => format!("{} ({why})", t.state),
        });
        let log = logs.join(format!("{array}_{i}.out"));
        s += &format!("\n  slice {i} (points {}-{}): {state}, {n} missing; log {}", r.start, r.end - 1, log.display());
        if let Some(l) = last_line(&log) {
            s += &format!(": {l}");
        }
    }
    s + "\nthe other slices' points are stored: run the same command again to resubmit only the failed slices"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polls_start_fast_and_slow_down_to_a_twentieth_of_the_wait() {
        assert_eq!(poll_interval(Duration::ZERO), Duration::from_millis(200));
        assert_eq!(poll_interval(Duration::from_secs(60)), Duration::from_secs(3));
        assert_eq!(poll_interval(Duration::from_secs(3 * 3600)), Duration::from_secs(30));
    }

    #[test]
    fn the_failure_report_names_each_slice_its_state_and_log() {
        let dir = tempfile::tempdir().unwrap();
        let logs = dir.path().join("slurm").join(scripts::LOGS);
        std::fs::create_dir_all(&logs).unwrap();
        std::fs::write(logs.join("7_1.out"), "slice 1 ...\nerror: slice 1: 1 of 4 points failed\n\n").unwrap();
        let missing = merge::MissingPoints {
            out: dir.path().to_path_buf(),
            total: 10,
            missing: vec![(5, "absent"), (9, "unreadable")],
            per_task: 4,
        };
        let mut tasks = BTreeMap::new();
        let state = |t, st: &str, why: &str| queue::JobState {
            job: "7".into(),
            task: Some(t),
            state: st.into(),
            reason: why.into(),
        };
        tasks.insert(1, state(1, "FAILED", "NonZeroExitCode"));
        tasks.insert(2, state(2, "TIMEOUT", "None"));
        let r = failure_report(&missing, &tasks, "7", "8", 3);
        assert!(
            r.starts_with("2 of 3 submitted slices failed (array job 7; merge job 8 cancelled): 2 of 10 points"),
            "{r}"
        );
        let log1 = logs.join("7_1.out");
        assert!(
            r.contains(&format!(
                "slice 1 (points 4-7): FAILED (NonZeroExitCode), 1 missing; log {}: error: slice 1: 1 of 4 points failed",
                log1.display()
            )),
            "{r}"
        );
        assert!(r.contains("slice 2 (points 8-9): TIMEOUT, 1 missing; log"), "{r}");
    }
}
