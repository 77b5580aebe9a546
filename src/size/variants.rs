//! The trace at each super-sampling `postwarp size` tries.
//!
//! Rules:
//! 1. A trace whose manifest has a `note made by: postwarp make-trace ...`
//!    line with a built-in scene (or a scene file that still exists) is
//!    rendered again at every super-sampling of [`SUPERSAMPLES`] with the
//!    same flags, through the sweep's generated-trace path
//!    ([`trace_set::materialize`]: `DIR/traces/<hash>/`, reused by later
//!    runs). At the trace's own super-sampling the trace itself is used.
//! 2. Any other trace (imported, or made by an unknown command) keeps its
//!    super-sampling; the reason is reported.
//! 3. `make-trace` renders ground truth at the trace's own
//!    super-sampling, so a regenerated set scores every super-sampling
//!    against the truth of the highest one (4): the same reference for
//!    every candidate.
//! 4. `frames` keeps the first N derived frames (a regenerated trace is
//!    rendered with N frames).

use crate::cli::make_trace::parse_made_by;
use crate::scene::Scene;
use crate::sweep::spec_error::KeyPath;
use crate::sweep::trace_set::{TraceVariant, VariantSource, materialize};
use crate::trace::Trace;
use anyhow::bail;
use std::path::{Path, PathBuf};

/// Super-samplings tried, ascending (samples per pixel along each axis).
/// 3 is left out: no candidate tile size (4, 8, 16 samples) is a multiple
/// of it. 4 is the A-buffer's limit (a 16-bit coverage mask).
pub const SUPERSAMPLES: &[u32] = &[1, 2, 4];

/// One super-sampling of the trace, ready to run.
pub struct SsTrace {
    /// Super-samples per pixel along each axis (samples).
    pub supersample: u32,
    /// The trace, limited to the frames used.
    pub trace: Trace,
    /// Its directory.
    pub dir: PathBuf,
}

/// Where the super-samplings came from.
#[derive(Clone, Debug, PartialEq)]
pub enum SsSource {
    /// Rendered again with the trace's `make-trace` flags (module rule 1).
    Regenerated {
        /// The `make-trace` command line of the manifest.
        command: String,
        /// Where the rendered traces are cached.
        cache: PathBuf,
    },
    /// The trace's own super-sampling only (module rule 2).
    Fixed {
        /// Why the trace could not be rendered again.
        reason: String,
    },
}

impl SsSource {
    /// One line for the printed report.
    pub fn describe(&self, ss: &[u32]) -> String {
        let list = ss.iter().map(u32::to_string).collect::<Vec<_>>().join(", ");
        match self {
            SsSource::Regenerated { cache, .. } => format!(
                "super-samples {list}: the trace was made by `postwarp make-trace`, rendered again at each into {} and scored against the truth rendered at {}",
                cache.display(),
                ss.last().copied().unwrap_or(0)
            ),
            SsSource::Fixed { reason } => format!("super-samples fixed to the trace's ({list}): {reason}"),
        }
    }
}

fn open(dir: &Path, frames: Option<usize>) -> anyhow::Result<Trace> {
    let mut t = Trace::open(dir)?;
    if let Some(n) = frames {
        if n == 0 || n > t.derived.len() {
            bail!("--frames {n}: expected 1 to {} (the trace's derived frames)", t.derived.len());
        }
        t.derived.truncate(n);
    }
    Ok(t)
}

/// The trace at each super-sampling (module rules); `out` holds the
/// rendered traces under `out/traces/`.
pub fn ss_traces(path: &Path, frames: Option<usize>, out: &Path) -> anyhow::Result<(Vec<SsTrace>, SsSource)> {
    let base = open(path, frames)?;
    let own = base.display.supersample;
    let dir = base.dir.clone();
    let fixed = |reason: String, base: Trace| {
        Ok((vec![SsTrace { supersample: own, trace: base, dir: dir.clone() }], SsSource::Fixed { reason }))
    };
    let Some(command) = base.notes.iter().find_map(|n| n.strip_prefix("made by: ")).map(str::to_string) else {
        return fixed("its manifest has no `note made by:` line".into(), base);
    };
    let Some(args) = parse_made_by(&command) else {
        return fixed(format!("it was made by `{command}`, not a `postwarp make-trace` this build reads"), base);
    };
    let file = if Scene::builtin_source(&args.scene).is_some() {
        None
    } else if Path::new(&args.scene).is_file() {
        Some(PathBuf::from(&args.scene))
    } else {
        return fixed(format!("its scene file `{}` is not found", args.scene), base);
    };
    let mut spec = args.spec();
    if let Some(n) = frames {
        spec.frames = n;
    }
    let mut out_traces = Vec::new();
    for &ss in SUPERSAMPLES {
        if ss == own {
            out_traces.push(SsTrace { supersample: ss, trace: open(path, frames)?, dir: dir.clone() });
            continue;
        }
        let mut s = spec.clone();
        s.supersample = ss;
        let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "trace".into());
        let v = TraceVariant {
            label: format!("{name}_supersample={ss}"),
            at: KeyPath::default(),
            source: VariantSource::Generated { given: args.scene.clone(), file: file.clone(), spec: s },
        };
        eprintln!("size: trace {} (rendered once, then reused)", v.label);
        let ready = materialize(&v, out)?;
        out_traces.push(SsTrace { supersample: ss, trace: ready.open()?, dir: ready.dir });
    }
    // Rule 3: one ground truth for every super-sampling (an absolute path,
    // since each trace joins it to its own directory).
    let (hi_dir, hi_truth): (PathBuf, Vec<Option<PathBuf>>) = {
        let hi = out_traces.last().expect("SUPERSAMPLES is not empty");
        (std::path::absolute(&hi.trace.dir)?, hi.trace.derived.iter().map(|f| f.truth.clone()).collect())
    };
    for t in &mut out_traces {
        for (f, truth) in t.trace.derived.iter_mut().zip(&hi_truth) {
            f.truth = truth.as_ref().map(|p| hi_dir.join(p));
        }
    }
    Ok((out_traces, SsSource::Regenerated { command, cache: out.join("traces") }))
}
