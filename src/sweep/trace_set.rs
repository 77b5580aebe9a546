//! The traces of a sweep: each `[[traces]]` entry expands to one variant
//! per combination of its axes; generated variants are rendered once into
//! `DIR/traces/<hash>/` and reused.
//!
//! Rules:
//! 1. A variant's label is the entry's `name` (default: the trace
//!    directory's name, or the scene's name), followed by
//!    `_<key>=<value>` for every axis of the entry with more than one
//!    value. Labels name the rows of `results.csv` and the chart files;
//!    two different variants may not share one.
//! 2. A generated trace's directory is named by a hash of the scene's text
//!    and every [`TraceSpec`] field. It is rendered into a temporary
//!    directory and renamed into place, so a directory under its final
//!    name is complete; it is reused as it is if the same build rendered
//!    it (`built-by` holds [`super::build::build_id`]), else rendered again.
//! 3. An existing trace with `frames = N` uses its first N derived frames.

use super::hash::{Fnv, trace_identity};
use super::spec::{Axis, EntrySource, TraceEntry};
use super::spec_error::KeyPath;
use super::trace_fields::{self, TRACE_FIELDS};
use crate::scene::Scene;
use crate::trace::{Display, Trace};
use crate::tracegen::TraceSpec;
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

/// One trace of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceVariant {
    /// Label (module rule 1).
    pub label: String,
    /// The `[[traces]]` entry it comes from.
    pub at: KeyPath,
    /// Where it comes from.
    pub source: VariantSource,
}

/// An existing trace or a trace to render.
#[derive(Clone, Debug, PartialEq)]
pub enum VariantSource {
    /// An existing trace directory.
    Existing {
        /// As written in the specification.
        given: String,
        /// Resolved path.
        path: PathBuf,
        /// Derived frames used (the first N), or all.
        frames: Option<usize>,
    },
    /// A scene rendered with a trace specification.
    Generated {
        /// Scene as written: built-in name or file.
        given: String,
        /// Resolved scene file (`None`: built-in).
        file: Option<PathBuf>,
        /// Every trace-generation knob.
        spec: TraceSpec,
    },
}

/// Text of a TOML scalar for labels and CSV cells (strings without quotes).
pub fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Every combination of `axes` (first axis outermost), as `(key, value)`
/// lists.
pub fn combinations(axes: &[Axis]) -> Vec<Vec<(&str, &toml::Value)>> {
    let mut out: Vec<Vec<(&str, &toml::Value)>> = vec![Vec::new()];
    for a in axes {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                a.values.iter().map(move |v| {
                    let mut c = prefix.clone();
                    c.push((a.key.as_str(), v));
                    c
                })
            })
            .collect();
    }
    out
}

fn base_name(e: &TraceEntry) -> String {
    if let Some(n) = &e.name {
        return n.clone();
    }
    let p = match &e.source {
        EntrySource::Existing { path, .. } => path.clone(),
        EntrySource::Generated { given, file: None } => return given.clone(),
        EntrySource::Generated { file: Some(f), .. } => f.with_extension(""),
    };
    let p =
        if p.file_name().is_some_and(|n| n == "postwarp.trace") { p.parent().unwrap_or(&p).to_path_buf() } else { p };
    let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "trace".into());
    if name == "." || name == ".." { "trace".into() } else { name }
}

/// The variants of one `[[traces]]` entry; the error says which
/// combination is invalid.
pub fn variants(e: &TraceEntry) -> Result<Vec<TraceVariant>, String> {
    let base = base_name(e);
    let mut out = Vec::new();
    for combo in combinations(&e.axes) {
        let mut label = base.clone();
        for (k, v) in &combo {
            if e.axes.iter().any(|a| a.key == *k && a.values.len() > 1) {
                label += &format!("_{k}={}", value_text(v));
            }
        }
        let source = match &e.source {
            EntrySource::Existing { given, path } => {
                let frames =
                    combo.iter().find(|(k, _)| *k == "frames").and_then(|(_, v)| v.as_integer()).map(|n| n as usize);
                VariantSource::Existing { given: given.clone(), path: path.clone(), frames }
            }
            EntrySource::Generated { given, file } => {
                let mut spec = TraceSpec::default();
                for (k, v) in &combo {
                    trace_fields::set(&mut spec, k, v)?;
                }
                let desc = combo.iter().map(|(k, v)| format!("{k} = {}", value_text(v))).collect::<Vec<_>>().join(", ");
                spec.validate().map_err(|e| format!("{desc}: {e}"))?;
                spec.reference_intrinsics().map_err(|e| format!("{desc}: {e}"))?;
                VariantSource::Generated { given: given.clone(), file: file.clone(), spec }
            }
        };
        out.push(TraceVariant { label, at: e.at.clone(), source });
    }
    Ok(out)
}

/// A trace ready to run: on disk, with its identity.
#[derive(Clone, Debug)]
pub struct ReadyTrace {
    /// The variant.
    pub variant: TraceVariant,
    /// Trace directory.
    pub dir: PathBuf,
    /// The path shown in `results.csv`: as written in the specification,
    /// or `traces/<hash>` (relative to the output directory) if generated.
    pub shown: String,
    /// Content identity ([`trace_identity`]).
    pub identity: String,
    /// Display size and super-sampling.
    pub display: Display,
    /// Derived frames used.
    pub frames: usize,
}

impl ReadyTrace {
    /// Open the trace, keeping only the derived frames used.
    pub fn open(&self) -> anyhow::Result<Trace> {
        let mut t = Trace::open(&self.dir)?;
        t.derived.truncate(self.frames);
        Ok(t)
    }

    /// The value of trace column `key` ([`TRACE_FIELDS`] keys and `scene`)
    /// as CSV text; empty where unknown (an existing trace's generation
    /// knobs).
    pub fn field(&self, key: &str) -> String {
        match (key, &self.variant.source) {
            ("width", _) => self.display.width.to_string(),
            ("height", _) => self.display.height.to_string(),
            ("supersample", _) => self.display.supersample.to_string(),
            ("frames", _) => self.frames.to_string(),
            ("scene", VariantSource::Generated { given, .. }) => given.clone(),
            (k, VariantSource::Generated { spec, .. }) => trace_fields::get(spec, k),
            _ => String::new(),
        }
    }
}

/// Super-sampling of a variant, known before it is rendered.
pub fn supersample(v: &TraceVariant) -> anyhow::Result<u32> {
    match &v.source {
        VariantSource::Existing { path, .. } => Ok(Trace::open(path)?.display.supersample),
        VariantSource::Generated { spec, .. } => Ok(spec.supersample),
    }
}

fn scene_text(given: &str, file: Option<&Path>) -> anyhow::Result<String> {
    match file {
        None => {
            Scene::builtin_source(given).map(str::to_string).with_context(|| format!("no built-in scene `{given}`"))
        }
        Some(f) => std::fs::read_to_string(f).with_context(|| format!("reading scene {}", f.display())),
    }
}

/// Directory name of a generated trace (module rule 2).
pub fn generated_hash(given: &str, file: Option<&Path>, spec: &TraceSpec) -> anyhow::Result<String> {
    let mut h = Fnv::default();
    h.field(b"postwarp sweep generated trace v1");
    h.field(given.as_bytes());
    h.field(scene_text(given, file)?.as_bytes());
    let default = TraceSpec::default();
    for (k, _, _, _) in TRACE_FIELDS {
        let v = trace_fields::get(spec, k);
        if trace_fields::STRESS_FIELDS.contains(k) && v == trace_fields::get(&default, k) {
            continue;
        }
        h.field(k.as_bytes());
        h.field(v.as_bytes());
    }
    Ok(h.hex())
}

/// The file of a generated trace's directory naming the build that rendered it.
const BUILT_BY: &str = "built-by";

/// True if the generated trace directory `dir` must be rendered: it has no
/// manifest, or another build rendered it (module rule 2).
pub fn needs_render(dir: &Path) -> bool {
    !dir.join("postwarp.trace").is_file()
        || std::fs::read_to_string(dir.join(BUILT_BY)).ok().as_deref() != Some(super::build::build_id())
}

/// Make `v` ready: open it, or render it into `out/traces/<hash>/` unless
/// it is there already (module rule 2).
pub fn materialize(v: &TraceVariant, out: &Path) -> anyhow::Result<ReadyTrace> {
    let (dir, shown, frames) = match &v.source {
        VariantSource::Existing { given, path, frames } => (path.clone(), given.clone(), *frames),
        VariantSource::Generated { given, file, spec } => {
            let hash = generated_hash(given, file.as_deref(), spec)?;
            let dir = out.join("traces").join(&hash);
            if needs_render(&dir) {
                // Rendered under a temporary name and renamed when complete;
                // an older, unfinished or other build's folder is replaced
                // whole, and temporaries of a killed sweep are removed.
                let staged = crate::io_util::OutDir::create(&dir, true, &[])?;
                let tmp = staged.path();
                let scene = match file {
                    None => Scene::builtin(given)?,
                    Some(f) => Scene::from_file(f)?,
                };
                let command = format!("postwarp sweep (trace {}, scene {given}, {spec:?})", v.label);
                crate::tracegen::make_trace_with(&scene, spec, tmp, &command, false)
                    .with_context(|| format!("rendering trace {}", v.label))?;
                let built_by = tmp.join(BUILT_BY);
                std::fs::write(&built_by, super::build::build_id())
                    .with_context(|| format!("writing {}", built_by.display()))?;
                staged.commit()?;
            }
            (dir, format!("traces/{hash}"), None)
        }
    };
    let trace = Trace::open(&dir)?;
    let n = trace.derived.len();
    let frames = match frames {
        None => n,
        Some(f) if f <= n => f,
        Some(f) => bail!("frames = {f}: the trace {} has only {n} derived frames", dir.display()),
    };
    Ok(ReadyTrace { variant: v.clone(), identity: trace_identity(&trace)?, display: trace.display, dir, shown, frames })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(key: &str, values: Vec<toml::Value>) -> Axis {
        Axis { key: key.into(), values }
    }

    #[test]
    fn variants_multiply_axes_and_label_only_what_varies() {
        let e = TraceEntry {
            at: KeyPath::default(),
            name: None,
            source: EntrySource::Generated { given: "room".into(), file: None },
            axes: vec![
                axis("width", vec![toml::Value::Integer(32), toml::Value::Integer(48)]),
                axis("frames", vec![toml::Value::Integer(2)]),
                axis("prediction", vec![toml::Value::Float(0.0), toml::Value::Float(0.4)]),
            ],
        };
        let v = variants(&e).unwrap();
        let labels: Vec<&str> = v.iter().map(|v| v.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "room_width=32_prediction=0.0",
                "room_width=32_prediction=0.4",
                "room_width=48_prediction=0.0",
                "room_width=48_prediction=0.4"
            ]
        );
        let VariantSource::Generated { spec, .. } = &v[3].source else { panic!() };
        assert_eq!((spec.width, spec.frames, spec.prediction_s), (48, 2, 0.4));
        let h = |s: &TraceSpec| generated_hash("room", None, s).unwrap();
        let VariantSource::Generated { spec: s0, .. } = &v[0].source else { panic!() };
        assert_ne!(h(s0), h(spec));
        assert_eq!(h(spec), h(&spec.clone()));
    }
}
