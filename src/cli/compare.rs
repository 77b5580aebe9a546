//! `postwarp compare`: every comparison method on the traces given, as one
//! table (`docs/methods.md`).

use crate::methods::{hole_fill, hole_fills, reconstruction, reconstructions};
use crate::run::compare::{Pair, run_compare};
use std::path::PathBuf;

/// Flags of `postwarp compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directories (or their `postwarp.trace` manifests).
    #[arg(required = true)]
    pub traces: Vec<PathBuf>,
    /// Output directory: `<trace>/<method>+<fill>/` per run, `compare.csv`,
    /// `compare.md` (must not exist, unless --force; written under a
    /// temporary name beside it and renamed when complete).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
    /// Methods to run, comma-separated [default: every method].
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Hole fills, comma-separated: `default` (each method's own), `all`, or
    /// names; a fill listed twice for a method (`default,epipolar` for
    /// mark-aa) runs once.
    #[arg(long, value_delimiter = ',', default_value = "default")]
    pub hole_fills: Vec<String>,
    /// Runs per frame; `host_ms` is their median.
    #[arg(long, default_value_t = 3)]
    pub runs: u32,
    /// Also score FLIP (`flip_mean`, `flip_mean_common`; otherwise null):
    /// two single-threaded evaluations per frame, the costliest metric.
    #[arg(long)]
    pub flip: bool,
}

/// The (method, hole fill) pairs the flags select, in listing order.
pub fn pairs(a: &Args) -> anyhow::Result<Vec<Pair>> {
    let names: Vec<String> = if a.methods.is_empty() {
        reconstructions().iter().map(|m| m.info().name.to_string()).collect()
    } else {
        a.methods.clone()
    };
    let mut out = Vec::new();
    for n in &names {
        let mut fills: Vec<String> = Vec::new();
        for f in &a.hole_fills {
            let add: Vec<String> = match f.as_str() {
                "default" => vec![reconstruction(n)?.info().default_hole_fill.to_string()],
                "all" => hole_fills().iter().map(|f| f.info().name.to_string()).collect(),
                name => vec![name.to_string()],
            };
            for f in add {
                if !fills.contains(&f) {
                    fills.push(f);
                }
            }
        }
        for f in fills {
            out.push((reconstruction(n)?, hole_fill(&f)?));
        }
    }
    Ok(out)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let pairs = pairs(&a)?;
    let inputs: Vec<&std::path::Path> = a.traces.iter().map(PathBuf::as_path).collect();
    let out = crate::io_util::OutDir::create(&a.out, a.force, &inputs)?;
    let rows = run_compare(&a.traces, &pairs, a.runs, a.flip, out.path())?;
    out.commit()?;
    print!("{}", crate::run::compare::markdown(&rows));
    println!("wrote {} and {}", a.out.join("compare.md").display(), a.out.join("compare.csv").display());
    Ok(())
}
