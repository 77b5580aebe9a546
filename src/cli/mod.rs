//! The `postwarp` command line. One file per subcommand; each parses its
//! flags with clap and calls into the library.

mod bench;
mod chart;
mod compare;
mod golden;
mod import;
pub mod info;
pub mod make_trace;
mod methods;
mod score;
mod simulate;
mod size;
mod sweep;

use clap::{Parser, Subcommand};

use std::process::ExitCode;

/// Post-rendering 3D image warping: traces, a CPU golden model and a
/// cycle-level hardware model of Mark's warper (UNC TR98-011).
#[derive(Parser, Debug)]
#[command(name = "postwarp", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print a summary of a trace: frames, resolutions, depth range, and the
    /// epipole of each derived frame relative to each of its references.
    Info(info::Args),
    /// Render a built-in (or user) scene along a camera path into a trace:
    /// reference frames at 5 Hz at predicted viewpoints, derived frames at
    /// 30 Hz with ground truth.
    MakeTrace(make_trace::Args),
    /// Convert a Middlebury 2014 stereo folder (im0.png, im1.png, disp0.pfm,
    /// calib.txt) into a trace: left view = reference, right camera = derived
    /// frame, right photo = ground truth.
    ImportMiddlebury(import::Args),
    /// Run the golden model (Mark's warper on the CPU) on a trace: derived
    /// frames as PNG and EXR, hole masks, difference heat-maps, report.json
    /// and a table of quality against ground truth.
    Golden(golden::Args),
    /// Run the cycle-level hardware model on a trace beside the golden
    /// model: derived frames as PNG, cycles, DRAM bytes per client, cache
    /// hits and misses, unit utilisation, report.json and a summary.
    Simulate(simulate::Args),
    /// List the comparison methods (reconstructions and hole fills) that
    /// `postwarp golden --method NAME [--hole-fill NAME]` runs, with the
    /// paper each comes from.
    Methods(methods::Args),
    /// Run every comparison method on the traces given, one after another,
    /// and write a table of primitives, host ms per frame and quality
    /// (compare.md, compare.csv) with each run's frames and report.
    Compare(compare::Args),
    /// Run the cross product of traces x methods x hole fills x knobs of a
    /// sweep specification (docs/sweep.md) in parallel, resumably, into
    /// results.csv (every parameter and metric) and quality-against-cost
    /// charts with their Pareto fronts; in this process, or with --slurm as
    /// a Slurm job array; or one step at a time (plan, run, merge).
    Sweep(sweep::Args),
    /// Find the smallest hardware configuration (super-samples, A-buffer
    /// fragments per pixel, destination cache, tile size) whose output
    /// meets a quality floor, and report its cycles and DRAM bandwidth
    /// (docs/size.md).
    ///
    /// Smallest means: first the fewest super-samples (1, 2, 4), then the
    /// fewest A-buffer fragments per pixel (1 to min(4, samples per pixel);
    /// 0, no A-buffer, is not smaller hardware and is not tried) whose mean
    /// luma PSNR (and SSIM, if given) over the frames meets the floor;
    /// only these two change the image. Then, for each tile size of 4, 8
    /// and 16 samples, the smallest destination cache of 8, 16, 32, ...
    /// tiles (tile_size² x 16 B each) with no capacity misses over all
    /// frames; the tile size whose cache has the fewest bytes wins (ties:
    /// fewer DRAM bytes per frame, then the smaller tile). Other knobs are
    /// the preset's. A trace made by `postwarp make-trace` is rendered
    /// again at 1, 2 and 4 super-samples (into DIR/traces) and every one is
    /// scored against the truth rendered at 4; any other trace keeps its
    /// own. Exits non-zero, with the best quality reached, if nothing
    /// meets the floor.
    Size(size::Args),
    /// Draw the charts of a sweep's results.csv again (same CSV, same
    /// bytes).
    Chart(chart::Args),
    /// Score the frames runs wrote (golden, golden --method, simulate,
    /// compare) against the trace's ground truth over the whole image and
    /// over the pixels its non-diffuse mask marks as specular or
    /// transparent (docs/non-diffuse.md).
    Score(score::Args),
    /// Time the standard frames: host seconds per frame (best and median of
    /// --repeats) and samples per second of each engine (golden, forward
    /// splat, hardware model) on the 640x480 2x2 frame, and of whole
    /// `golden` and `simulate` processes on it and on the bundled real
    /// pair, with their peak RSS per reference sample and the core count
    /// (docs/performance.md).
    Bench(bench::Args),
}

/// The command line's definition: every flag that takes a value accepts a
/// negative number as its value (so `--width -1` is refused by the flag's
/// own check, naming the flag, instead of as an unknown argument `-1`).
pub fn command() -> clap::Command {
    fn negatives(c: clap::Command) -> clap::Command {
        c.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a })
            .mut_subcommands(negatives)
    }
    negatives(<Cli as clap::CommandFactory>::command())
}

/// Parse `args` (the program name first) as [`command`] does.
pub fn parse_from<I, T>(args: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let m = command().try_get_matches_from(args)?;
    <Cli as clap::FromArgMatches>::from_arg_matches(&m)
}

/// Parse the process arguments and run; errors are printed to stderr.
pub fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing into a closed pipe would panic;
    // restore the default: the process ends when the reader goes away.
    #[cfg(unix)]
    // SAFETY: called once at start, before any thread; SIG_DFL is a valid
    // disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = match parse_from(std::env::args_os()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let result = run(cli);
    if let Some(file) = std::env::var_os(bench::PEAK_RSS_ENV) {
        bench::write_peak_rss(std::path::Path::new(&file));
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::MakeTrace(a) => make_trace::run(a),
        Command::ImportMiddlebury(a) => import::run(a),
        Command::Golden(a) => golden::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Methods(a) => methods::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Size(a) => size::run(a),
        Command::Chart(a) => chart::run(a),
        Command::Score(a) => score::run(a),
        Command::Bench(a) => bench::run(a),
    }
}
