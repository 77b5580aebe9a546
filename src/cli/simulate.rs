//! `postwarp simulate`: the cycle-level hardware model on a trace, checked
//! against the golden model.

use crate::report::dram_trace::{DramTraceFormat, DramTraceWriter};
use crate::run::hw_config_toml::{dump, load};
use crate::run::simulate::run_simulate;
use crate::trace::Trace;
use anyhow::Context;
use std::path::PathBuf;

/// Flags of `postwarp simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest).
    #[arg(required_unless_present_any = ["dump_config", "budget"], requires = "out")]
    pub trace: Option<PathBuf>,
    /// Output directory: frame-NNNN.png/.exr, diff-NNNN.png, report.json
    /// (must not exist, unless --force; written under a temporary name
    /// beside it and renamed when complete).
    #[arg(long, requires = "trace")]
    pub out: Option<PathBuf>,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
    /// Hardware knobs as TOML (keys as in docs/units.md; `preset = "NAME"` picks the base).
    #[arg(long, conflicts_with = "preset")]
    pub config: Option<PathBuf>,
    /// A named configuration: mark1998 (default), hmd2026 or fixed-minimal (`docs/precision.md`).
    #[arg(long)]
    pub preset: Option<String>,
    /// Write the configuration (--config / --preset) to FILE as TOML that
    /// --config reads back: every knob, each with its unit and meaning in
    /// a comment (`-` = standard output). Without a trace, nothing runs.
    #[arg(long, value_name = "FILE")]
    pub dump_config: Option<PathBuf>,
    /// Print the SRAM and arithmetic budget of the configuration (--config /
    /// --preset) alone: its display and a reference 1.6725 times as wide
    /// (docs/budget.md), before anything runs. Without a trace, nothing
    /// runs; every run with a trace (flag or not) carries the budget sized
    /// for the trace in its summary and report.json.
    #[arg(long)]
    pub budget: bool,
    /// Also write timeline-NNNN.json per frame: the frame's pipeline in the
    /// Chrome trace event format (open in ui.perfetto.dev or
    /// chrome://tracing; docs/units.md, "Timeline").
    #[arg(long, requires = "out")]
    pub timeline: bool,
    /// Timeline resolution (cycles): runs of one state shorter than this
    /// are merged into `mixed` intervals, counters are sampled per window
    /// of this many cycles (rounded up to 64).
    #[arg(long, value_name = "CYCLES", default_value_t = crate::report::timeline::DEFAULT_RESOLUTION,
          value_parser = clap::value_parser!(u64).range(1..=1 << 32), requires = "timeline")]
    pub timeline_resolution: u64,
    /// Also score FLIP (`flip_mean`, `flip_mean_common`; otherwise null):
    /// two single-threaded evaluations per frame, the costliest metric.
    #[arg(long)]
    pub flip: bool,
    /// Also write every DRAM request of the run to FILE, for open-loop
    /// replay in a DRAM simulator: one line or packet per burst, frames in
    /// order, times continuing across frames; gzip if FILE ends in `.gz`
    /// (docs/memory-layout.md, "Request traces").
    #[arg(long, value_name = "FILE", requires = "out")]
    pub dram_trace: Option<PathBuf>,
    /// Format of --dram-trace: dramsim3 (`0xADDR READ|WRITE CYCLE`),
    /// ramulator2 (`LD|ST 0xADDR`) or gem5 (protobuf packet trace).
    #[arg(long, value_name = "FORMAT", value_enum, default_value = "dramsim3", requires = "dram_trace")]
    pub dram_trace_format: DramTraceFormat,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let cfg = load(a.config.as_deref(), a.preset.as_deref())?;
    if let Some(file) = &a.dump_config {
        let from = match (&a.config, &a.preset) {
            (Some(c), _) => format!("--config {}", c.display()),
            (None, Some(p)) => format!("--preset {p}"),
            (None, None) => "the default preset mark1998".into(),
        };
        let text = dump(&cfg, &format!("postwarp simulate configuration, from {from}"));
        if file.as_os_str() == "-" {
            print!("{text}");
        } else {
            crate::io_util::write_bytes_atomically(file, text.as_bytes())
                .with_context(|| "--dump-config: cannot write the configuration")?;
            eprintln!("wrote {}", file.display());
        }
    }
    if a.budget {
        print!("{}", crate::report::budget::text(&postwarp_rtl::budget::Budget::of(&cfg)));
    }
    let (Some(trace), Some(out)) = (&a.trace, &a.out) else { return Ok(()) };
    let trace = Trace::open(trace)?;
    let staged = crate::io_util::OutDir::create(out, a.force, &[&trace.manifest])?;
    // Created before the run, so an unwritable FILE fails at once.
    let mut dram_trace = match &a.dram_trace {
        Some(file) => Some(DramTraceWriter::create(file, a.dram_trace_format, cfg.dram_burst_bytes, cfg.clock_hz)?),
        None => None,
    };
    let r = run_simulate(
        &trace,
        &cfg,
        a.flip,
        staged.path(),
        a.timeline.then_some(a.timeline_resolution),
        dram_trace.as_mut(),
    )?;
    let transactions = dram_trace.map(DramTraceWriter::finish).transpose()?;
    let dir = staged.commit()?;
    print!("{}", r.summary);
    let total = &r.report.total;
    println!(
        "{}: {} frames on the hardware model; {} of {} identical to the golden model",
        trace.manifest.display(),
        trace.derived.len(),
        total.identical_frames,
        total.frames
    );
    println!("report: {}", dir.join("report.json").display());
    if let (Some(file), Some(n)) = (&a.dram_trace, transactions) {
        println!("DRAM trace: {} ({n} transactions)", file.display());
    }
    Ok(())
}
