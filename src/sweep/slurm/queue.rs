//! The Slurm commands `postwarp sweep --slurm` calls (`sbatch`, `squeue`,
//! `scancel`, `scontrol`) and the parsing of what they print. Nothing here
//! needs accounting (`sacct`): job states come from `squeue --states=all`,
//! which shows finished jobs for `MinJobAge` (300 s by default) after they
//! end, and the points on disk are what decides success.

use anyhow::{Context, bail};
use std::path::Path;
use std::process::{Command, Output};

fn run(program: &str, args: &[&str]) -> anyhow::Result<Output> {
    Command::new(program).args(args).output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            anyhow::anyhow!(
                "`{program}` is not on PATH: --slurm needs the Slurm client commands (sbatch, squeue, scancel) \
                 of a host that can submit jobs"
            )
        } else {
            anyhow::Error::new(e).context(format!("running {program}"))
        }
    })
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).trim().to_string()
}

/// `sbatch --version` (for example `slurm-wlm 22.05.8`), or why the client
/// cannot be used.
pub fn client_version() -> anyhow::Result<String> {
    let o = run("sbatch", &["--version"])?;
    if !o.status.success() {
        bail!("sbatch --version failed: {}", text(&o.stderr));
    }
    Ok(text(&o.stdout))
}

/// `MaxArraySize` from `scontrol show config` text: array indices must be
/// below it.
pub fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "MaxArraySize").then(|| v.trim().parse().ok()).flatten()
    })
}

/// The cluster's `MaxArraySize`, if `scontrol` tells it.
pub fn max_array_size() -> Option<usize> {
    let o = run("scontrol", &["show", "config"]).ok()?;
    o.status.success().then(|| parse_max_array_size(&String::from_utf8_lossy(&o.stdout))).flatten()
}

/// The job id in `sbatch --parsable` output (`ID` or `ID;CLUSTER`).
pub fn parse_job_id(out: &str) -> Option<String> {
    let id = out.lines().map(str::trim).rfind(|l| !l.is_empty())?.split(';').next()?.trim();
    (!id.is_empty() && id.bytes().all(|b| b.is_ascii_digit())).then(|| id.to_string())
}

/// Submit `script` with `sbatch --parsable ARGS SCRIPT`; the job id.
pub fn submit(args: &[String], script: &Path) -> anyhow::Result<String> {
    let script_s = script.to_string_lossy();
    let mut all: Vec<&str> = vec!["--parsable"];
    all.extend(args.iter().map(String::as_str));
    all.push(&script_s);
    let o = run("sbatch", &all)?;
    let shown = format!("sbatch {}", all.join(" "));
    if !o.status.success() {
        bail!("{shown} failed ({}): {}", o.status, text(&o.stderr));
    }
    let out = String::from_utf8_lossy(&o.stdout);
    parse_job_id(&out).with_context(|| format!("{shown}: expected a job id, got `{}`", out.trim()))
}

/// Cancel `job` (a job, an array or one task `ID_I`); errors are ignored
/// (the job may have ended).
pub fn cancel(job: &str) {
    let _ = run("scancel", &[job]);
}

/// One line of `squeue`: a job, an array task, or pending array tasks.
#[derive(Clone, Debug, PartialEq)]
pub struct JobState {
    /// The job id (an array's job id for its tasks).
    pub job: String,
    /// The array task index, if the line is one task.
    pub task: Option<usize>,
    /// Slurm's state: PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, TIMEOUT, ...
    pub state: String,
    /// Slurm's reason (None, NonZeroExitCode, DependencyNeverSatisfied, ...).
    pub reason: String,
}

/// States after which a job does not run again.
const TERMINAL: &[&str] = &[
    "COMPLETED",
    "FAILED",
    "CANCELLED",
    "TIMEOUT",
    "NODE_FAIL",
    "PREEMPTED",
    "BOOT_FAIL",
    "DEADLINE",
    "OUT_OF_MEMORY",
    "SPECIAL_EXIT",
    "REVOKED",
];

impl JobState {
    /// True once the job (or task) has ended for good.
    pub fn ended(&self) -> bool {
        TERMINAL.contains(&self.state.as_str())
    }
}

/// Parse `squeue -h -o %i|%T|%r` lines: `12`, `12_3`, `12_[4-9%2]`.
pub fn parse_states(out: &str) -> Vec<JobState> {
    out.lines()
        .filter_map(|l| {
            let mut f = l.trim().splitn(3, '|');
            let (id, state, reason) = (f.next()?.trim(), f.next()?.trim(), f.next().unwrap_or("").trim());
            if id.is_empty() || state.is_empty() {
                return None;
            }
            let (job, task) = match id.split_once('_') {
                Some((j, t)) => (j, t.parse().ok()),
                None => (id, None),
            };
            Some(JobState { job: job.to_string(), task, state: state.to_string(), reason: reason.to_string() })
        })
        .collect()
}

/// The states of `jobs` (and their array tasks) that the controller still
/// knows, finished ones included. Jobs it has forgotten are absent.
pub fn states(jobs: &[&str]) -> anyhow::Result<Vec<JobState>> {
    let list = jobs.join(",");
    let o = run("squeue", &["-h", "--states=all", "-j", &list, "-o", "%i|%T|%r"])?;
    let err = text(&o.stderr);
    if !o.status.success() {
        // Every job purged: the controller answers "Invalid job id specified".
        if err.contains("Invalid job id") {
            return Ok(Vec::new());
        }
        bail!("squeue -j {list} failed ({}): {err}", o.status);
    }
    Ok(parse_states(&String::from_utf8_lossy(&o.stdout)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_parse_into_jobs_and_tasks() {
        let s = parse_states(
            "12_[4-9%2]|PENDING|JobArrayTaskLimit\n12_0|RUNNING|None\n12_1|FAILED|NonZeroExitCode\n\
             13|CANCELLED|DependencyNeverSatisfied\n\nbroken\n",
        );
        assert_eq!(s.len(), 4);
        assert_eq!((s[0].job.as_str(), s[0].task, s[0].ended()), ("12", None, false));
        assert_eq!((s[1].task, s[1].ended()), (Some(0), false));
        assert_eq!((s[2].task, s[2].state.as_str(), s[2].ended()), (Some(1), "FAILED", true));
        assert_eq!((s[3].job.as_str(), s[3].task, s[3].reason.as_str()), ("13", None, "DependencyNeverSatisfied"));
    }

    #[test]
    fn sbatch_and_scontrol_output_parse() {
        assert_eq!(parse_job_id("4242\n").as_deref(), Some("4242"));
        assert_eq!(parse_job_id("4242;cluster\n").as_deref(), Some("4242"));
        assert_eq!(parse_job_id("sbatch: warning: x\n77\n").as_deref(), Some("77"));
        assert_eq!(parse_job_id("Submitted batch job 5\n"), None);
        assert_eq!(parse_max_array_size("MaxArraySize            = 1001\nMaxJobCount = 10000\n"), Some(1001));
        assert_eq!(parse_max_array_size("MaxJobCount = 10000\n"), None);
    }
}
