//! `DIR/slurm/array.sh` and `DIR/slurm/merge.sh`: the batch scripts of a
//! sweep's job array and of its merge job. They hold the absolute paths of
//! the `postwarp` executable and of `DIR` (both must be on a file system
//! every node mounts at the same path) and the points per task, so that
//! `sbatch --array=LIST DIR/slurm/array.sh` resubmits slices by hand.

use anyhow::bail;
use std::path::Path;

/// Logs, relative to `DIR/slurm/`: `logs/<array job>_<slice>.out` and
/// `logs/merge-<job>.out` (stdout and stderr together).
pub const LOGS: &str = "logs";

/// `s` quoted for a POSIX shell.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// Refuse a path that a `#SBATCH --output=` line cannot hold.
pub fn check_path(what: &str, p: &Path) -> anyhow::Result<String> {
    let s = p.to_str().ok_or_else(|| anyhow::anyhow!("{what} {}: not valid UTF-8", p.display()))?;
    if let Some(c) = s.chars().find(|c| c.is_whitespace() || *c == '%' || *c == '"' || *c == '\\') {
        bail!(
            "{what} {s}: Slurm's #SBATCH --output line cannot hold {c:?} (whitespace, %, \" and \\ are refused): \
             use a directory without it"
        );
    }
    Ok(s.to_string())
}

/// The text of `array.sh`.
pub fn array_script(exe: &str, dir: &str, per_task: usize) -> String {
    format!(
        "#!/bin/sh\n\
         # One task of a postwarp sweep job array, written by `postwarp sweep --slurm`\n\
         # (docs/sweep.md): task I runs slice I ({per_task} points) of {dir}/plan.json.\n\
         # Resubmit slices by hand: sbatch --array=LIST {dir}/slurm/array.sh\n\
         #SBATCH --job-name=postwarp-sweep\n\
         #SBATCH --output={dir}/slurm/{LOGS}/%A_%a.out\n\
         exec {} sweep run {} --points-per-task {per_task} --jobs \"${{SLURM_CPUS_PER_TASK:-1}}\"\n",
        shell_quote(exe),
        shell_quote(dir)
    )
}

/// Seconds the merge job looks again for points a shared file system shows
/// late ([`crate::sweep::merge`] rule 3).
pub const MERGE_WAIT_S: u64 = 60;

/// The text of `merge.sh`.
pub fn merge_script(exe: &str, dir: &str, per_task: usize) -> String {
    format!(
        "#!/bin/sh\n\
         # The merge of a postwarp sweep, written by `postwarp sweep --slurm` (docs/sweep.md):\n\
         # results.csv and charts/ from {dir}/points, once every array task has succeeded.\n\
         #SBATCH --job-name=postwarp-merge\n\
         #SBATCH --output={dir}/slurm/{LOGS}/merge-%j.out\n\
         exec {} sweep merge {} --points-per-task {per_task} --wait-for-points {MERGE_WAIT_S}\n",
        shell_quote(exe),
        shell_quote(dir)
    )
}

/// sbatch options `--sbatch-arg` may not set: postwarp sets them itself.
const OWN: &[(&str, &str)] = &[
    ("--array", "the slices are postwarp's"),
    ("-a", "the slices are postwarp's"),
    ("--output", "postwarp names the logs (DIR/slurm/logs)"),
    ("-o", "postwarp names the logs (DIR/slurm/logs)"),
    ("--error", "postwarp names the logs (DIR/slurm/logs)"),
    ("-e", "postwarp names the logs (DIR/slurm/logs)"),
    ("--dependency", "postwarp makes the merge depend on the array"),
    ("-d", "postwarp makes the merge depend on the array"),
    ("--parsable", "postwarp reads the job ids"),
    ("--wait", "postwarp waits itself (or not, with --no-wait)"),
    ("-W", "postwarp waits itself (or not, with --no-wait)"),
    ("--wrap", "postwarp writes the scripts"),
];

/// Check the `--sbatch-arg` values.
pub fn check_sbatch_args(args: &[String]) -> anyhow::Result<()> {
    for a in args {
        if !a.starts_with('-') {
            bail!("--sbatch-arg {a}: expected an sbatch option (starting with -), e.g. --sbatch-arg=--time=1:00:00");
        }
        let name = a.split('=').next().unwrap_or(a);
        let short = if name.len() > 2 && !name.starts_with("--") { &name[..2] } else { name };
        if let Some((_, why)) = OWN.iter().find(|(o, _)| *o == name || *o == short) {
            bail!("--sbatch-arg {a}: not allowed, {why}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_quote_paths_and_name_the_slice_logs() {
        let a = array_script("/opt/it's/postwarp", "/shared/out", 4);
        assert!(a.starts_with("#!/bin/sh\n"));
        assert!(a.contains("#SBATCH --output=/shared/out/slurm/logs/%A_%a.out\n"), "{a}");
        assert!(a.contains("exec '/opt/it'\\''s/postwarp' sweep run '/shared/out' --points-per-task 4 --jobs"), "{a}");
        let m = merge_script("/p", "/shared/out", 4);
        assert!(m.contains("sweep merge '/shared/out' --points-per-task 4 --wait-for-points 60"), "{m}");
        assert!(m.contains("#SBATCH --output=/shared/out/slurm/logs/merge-%j.out"), "{m}");
    }

    #[test]
    fn paths_and_sbatch_args_slurm_cannot_take_are_refused() {
        assert!(check_path("--out", Path::new("/a b")).is_err());
        assert!(check_path("--out", Path::new("/a%b")).is_err());
        assert_eq!(check_path("--out", Path::new("/a/b-c_d.e")).unwrap(), "/a/b-c_d.e");
        assert!(check_sbatch_args(&["--time=10".into(), "--qos=short".into(), "-N1".into()]).is_ok());
        for bad in ["--output=x", "-ox", "--array=1", "--dependency=afterok:1", "time=10", "--wait"] {
            assert!(check_sbatch_args(&[bad.into()]).is_err(), "{bad}");
        }
    }
}
