//! `postwarp sweep`: run a sweep specification (docs/sweep.md) in this
//! process or through Slurm, or drive its three steps (`plan`, `run`,
//! `merge`) one at a time.

use crate::sweep::merge::merge;
use crate::sweep::slurm::{SlurmOptions, SlurmOutcome};
use crate::sweep::{Options, Spec, plan_file, pool, run_sweep, slice, slurm};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Flags of `postwarp sweep`.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct Args {
    /// One step of a sweep (plan, run, merge) instead of the whole sweep.
    #[command(subcommand)]
    pub step: Option<Step>,
    /// The whole sweep.
    #[command(flatten)]
    pub whole: Whole,
}

/// Flags of the whole sweep, `postwarp sweep SPEC --out DIR`.
#[derive(clap::Args, Debug)]
pub struct Whole {
    /// Sweep specification (TOML, docs/sweep.md). A file named like a step
    /// (plan, run, merge) is given as ./plan.
    #[arg(required = true)]
    pub spec: Option<PathBuf>,
    /// Output directory: results.csv, charts/, plan.json, points/ (finished
    /// points, reused on a rerun), traces/ (generated traces); with
    /// --slurm also slurm/ (job scripts and logs). With --slurm it must be
    /// on a file system every node shares.
    #[arg(long, required = true)]
    pub out: Option<PathBuf>,
    /// Worker threads [default: all cores]. Results other than host time
    /// do not depend on it. With --slurm: threads for planning here
    /// (rendering generated traces); each array task uses
    /// SLURM_CPUS_PER_TASK (default 1).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run the points as a Slurm job array and merge them in a job that
    /// depends on it; only slices with missing points are submitted.
    #[arg(long)]
    pub slurm: bool,
    /// Slurm partition of the array and the merge job.
    #[arg(long, requires = "slurm")]
    pub partition: Option<String>,
    /// At most this many array tasks run at once (--array=...%N) [default:
    /// no limit].
    #[arg(long, requires = "slurm")]
    pub max_parallel: Option<usize>,
    /// Points per array task (points) [default: 1]: a task costs the
    /// scheduler's latency plus starting postwarp, so give each task at
    /// least 20 times that much work (docs/sweep.md, "Points per task").
    #[arg(long, requires = "slurm")]
    pub points_per_task: Option<usize>,
    /// A further sbatch option for both jobs, e.g. --sbatch-arg=--time=2:00:00
    /// (repeatable; one option per flag).
    #[arg(long = "sbatch-arg", requires = "slurm", allow_hyphen_values = true, value_name = "ARG")]
    pub sbatch_args: Vec<String>,
    /// Return once the jobs are submitted, printing their ids and the
    /// command to merge later.
    #[arg(long, requires = "slurm")]
    pub no_wait: bool,
}

/// The steps of a sweep.
#[derive(clap::Subcommand, Debug)]
pub enum Step {
    /// Plan a sweep: render its generated traces (as the whole sweep does)
    /// and write DIR/plan.json, the ordered points with their hashes.
    Plan(PlanArgs),
    /// Run the points of one slice of a planned sweep (slice I = points
    /// I*K to I*K+K-1), storing each in DIR/points/ as it finishes; points
    /// stored already are skipped.
    Run(RunArgs),
    /// Check that every planned point is stored (else name the slices
    /// missing and exit non-zero) and write results.csv and the charts.
    Merge(MergeArgs),
}

/// Flags of `postwarp sweep plan`.
#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    /// Sweep specification (TOML, docs/sweep.md).
    pub spec: PathBuf,
    /// Output directory (on a file system every node shares, if slices run
    /// on other machines).
    #[arg(long)]
    pub out: PathBuf,
    /// Threads rendering generated traces [default: all cores].
    #[arg(long)]
    pub jobs: Option<usize>,
}

/// Flags of `postwarp sweep run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// A planned sweep directory (`postwarp sweep plan`).
    pub dir: PathBuf,
    /// The slice to run [default: $SLURM_ARRAY_TASK_ID].
    #[arg(long)]
    pub index: Option<usize>,
    /// Points per slice (points); every run and merge of one sweep must
    /// use the same value.
    #[arg(long, default_value_t = 1)]
    pub points_per_task: usize,
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub jobs: Option<usize>,
}

/// Flags of `postwarp sweep merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// A planned sweep directory (`postwarp sweep plan`).
    pub dir: PathBuf,
    /// Points per slice (points), to name the slices of missing points.
    #[arg(long, default_value_t = 1)]
    pub points_per_task: usize,
    /// If points are missing, look again every second for up to this long
    /// (s), for shared file systems that show other nodes' files late.
    #[arg(long, default_value_t = 0, value_name = "SECONDS")]
    pub wait_for_points: u64,
}

fn options(jobs: Option<usize>) -> anyhow::Result<Options> {
    let mut opts = Options::default();
    if let Some(j) = jobs {
        anyhow::ensure!(j >= 1, "--jobs {j}: expected at least 1 thread");
        opts.jobs = j;
    }
    Ok(opts)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    match a.step {
        Some(Step::Plan(p)) => plan(p),
        Some(Step::Run(r)) => run_slice(r),
        Some(Step::Merge(m)) => merge_step(m),
        None => whole(a.whole),
    }
}

fn whole(w: Whole) -> anyhow::Result<()> {
    let (Some(spec_path), Some(out)) = (w.spec, w.out) else {
        anyhow::bail!("expected SPEC --out DIR (or a step: plan, run, merge)")
    };
    let spec = Spec::load(&spec_path)?;
    let opts = options(w.jobs)?;
    let start = Instant::now();
    if w.slurm {
        let so = SlurmOptions {
            points_per_task: w.points_per_task.unwrap_or(1),
            max_parallel: w.max_parallel,
            partition: w.partition,
            sbatch_args: w.sbatch_args,
            wait: !w.no_wait,
            jobs: opts.jobs,
            progress: opts.progress,
        };
        let o = slurm::run(&spec, &out, &so)?;
        return print_slurm(&spec, &out, &so, &o, start);
    }
    let o = run_sweep(&spec, &out, &opts)?;
    println!(
        "{}: {} points, {} skipped (finished earlier, loaded from {}), {} computed; {} traces generated; {} threads, {:.1} s",
        spec.file.display(),
        o.points,
        o.skipped,
        out.join("points").display(),
        o.computed,
        o.traces_generated,
        opts.jobs,
        start.elapsed().as_secs_f64()
    );
    if o.stale > 0 {
        println!(
            "{} stored points were made by another build of postwarp (or under another key, or unreadable) and were \
             run again",
            o.stale
        );
    }
    println!("results: {}", o.results.display());
    println!("charts: {} files in {}", o.charts.len(), out.join("charts").display());
    Ok(())
}

fn print_slurm(spec: &Spec, out: &Path, so: &SlurmOptions, o: &SlurmOutcome, start: Instant) -> anyhow::Result<()> {
    let k = so.points_per_task;
    match (&o.array_job, &o.merged) {
        (None, Some(m)) => println!(
            "{}: {} points, all stored already ({} slices of {k}): nothing submitted, merged here; {} traces \
             generated; {:.1} s\nresults: {}\ncharts: {} files in {}",
            spec.file.display(),
            o.points,
            o.slices,
            o.traces_generated,
            start.elapsed().as_secs_f64(),
            m.results.display(),
            m.charts.len(),
            out.join("charts").display()
        ),
        (Some(array), Some(m)) => println!(
            "{}: {} points, {} stored already, {} computed by Slurm in {} of {} slices ({k} points per task; array \
             job {array}, merge job {}); {} traces generated; {:.1} s\nresults: {}\ncharts: {} files in {}",
            spec.file.display(),
            o.points,
            o.stored,
            o.points - o.stored,
            o.submitted.len(),
            o.slices,
            o.merge_job.as_deref().unwrap_or("?"),
            o.traces_generated,
            start.elapsed().as_secs_f64(),
            m.results.display(),
            m.charts.len(),
            out.join("charts").display()
        ),
        (Some(array), None) => {
            let merge_job = o.merge_job.as_deref().unwrap_or("?");
            let dir = std::fs::canonicalize(out).unwrap_or_else(|_| out.to_path_buf());
            println!(
                "not waiting: array job {array} ({} of {} slices), merge job {merge_job} (writes results.csv when \
                 every task has succeeded)\nfollow them: squeue -j {array},{merge_job}\nmerge later (names the slices \
                 that failed, if any): postwarp sweep merge {} --points-per-task {k}\nresubmit failed slices: run \
                 the same command again",
                o.submitted.len(),
                o.slices,
                dir.display()
            );
        }
        (None, None) => unreachable!("nothing submitted means merged here"),
    }
    Ok(())
}

fn plan(a: PlanArgs) -> anyhow::Result<()> {
    let spec = Spec::load(&a.spec)?;
    let opts = options(a.jobs)?;
    let start = Instant::now();
    let p = plan_file::prepare(&spec, &a.out, &pool(opts.jobs)?, opts.progress)?;
    let stored = p.points.iter().filter(|q| crate::sweep::store::load(&a.out, &q.hash, &q.key).is_some()).count();
    println!(
        "{}: {} points on {} traces ({} generated now), {} stored already; plan: {}; {:.1} s",
        spec.file.display(),
        p.points.len(),
        p.traces.len(),
        p.traces_generated,
        stored,
        a.out.join(plan_file::PLAN_FILE).display(),
        start.elapsed().as_secs_f64()
    );
    println!(
        "next: postwarp sweep run {} --index I --points-per-task K (I from 0 to ceil({}/K)-1, in any order, \
         anywhere that sees this directory), then postwarp sweep merge {}",
        a.out.display(),
        p.points.len(),
        a.out.display()
    );
    Ok(())
}

fn run_slice(a: RunArgs) -> anyhow::Result<()> {
    let index = slice::index_from_env(a.index)?;
    let opts = options(a.jobs)?;
    let start = Instant::now();
    let p = plan_file::load(&a.dir)?;
    let o = slice::run_slice(&p, &a.dir, index, a.points_per_task, &pool(opts.jobs)?, opts.progress)?;
    println!(
        "slice {} of {} (points {}-{} of {}, {} per task): {} skipped (stored earlier), {} computed; {} threads, {:.1} s",
        o.index,
        o.slices,
        o.points.start,
        o.points.end - 1,
        p.points.len(),
        a.points_per_task,
        o.run.skipped,
        o.run.computed,
        opts.jobs,
        start.elapsed().as_secs_f64()
    );
    if o.run.stale > 0 {
        println!(
            "{} stored points were unreadable, of another key or made by another build of postwarp, and were run again",
            o.run.stale
        );
    }
    Ok(())
}

fn merge_step(a: MergeArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let p = plan_file::load(&a.dir)?;
    let m = merge(&p, &a.dir, a.points_per_task, Duration::from_secs(a.wait_for_points))?;
    println!(
        "merged {} points: {}; charts: {} files in {}; {:.1} s",
        m.points,
        m.results.display(),
        m.charts.len(),
        a.dir.join("charts").display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
