//! The sweep specification (TOML, `docs/sweep.md`) → [`Spec`]: traces,
//! methods, hole fills and knob axes, checked key by key. Every error
//! names the file, the key, its line and what was expected
//! ([`SpecError`]).
//!
//! Rules:
//! 1. Top level: `name`, `runs`, `images`, `flip`, and either the group keys
//!    (`traces`, `methods`, `hole_fills`, `[golden]`, `[hardware]`) for one
//!    group, or `[[sweep]]` tables, each a group. The sweep is the union of
//!    the groups' points.
//! 2. Any knob or generated-trace field may be a list: an axis. A scalar is
//!    an axis of one value. Lists may not be empty.
//! 3. Unknown keys, values of the wrong type or out of range, unknown
//!    method and hole-fill names are refused.

use super::knobs;
use super::spec_error::{KeyPath, Locator, SpecError};
use super::trace_fields::{self, TRACE_FIELDS};
use crate::tracegen::TraceSpec;
use std::path::{Path, PathBuf};

/// A parsed, checked sweep specification.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// The specification file (relative paths in it are relative to its
    /// directory).
    pub file: PathBuf,
    /// The file's text (for the positions of errors found later).
    pub text: String,
    /// Name in chart titles and the `spec` column (default: the file stem).
    pub name: String,
    /// Timed runs per frame of CPU methods; host time is their median.
    pub runs: u32,
    /// Write each point's frames, heat-maps and report under `DIR/images/`.
    pub images: bool,
    /// Score FLIP at every point (`flip_mean`, `flip_mean_common`; default
    /// false, the columns empty).
    pub flip: bool,
    /// The groups; points are the union of theirs.
    pub groups: Vec<Group>,
}

/// One cross product: traces × methods × hole fills × knob axes.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// Where the group is in the file (`sweep[i]`, or the top level).
    pub at: KeyPath,
    /// Trace entries.
    pub traces: Vec<TraceEntry>,
    /// Methods in order, no repeats.
    pub methods: Vec<MethodChoice>,
    /// Hole-fill choices in order, no repeats.
    pub hole_fills: Vec<FillChoice>,
    /// `[golden]` axes, in canonical knob order.
    pub golden: Vec<Axis>,
    /// `[hardware]` axes, `preset` first, then canonical knob order.
    pub hardware: Vec<Axis>,
}

/// A key and its values (one value = not varied).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Knob or field name.
    pub key: String,
    /// Values in the order given.
    pub values: Vec<toml::Value>,
}

/// A method of the sweep.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MethodChoice {
    /// A registered reconstruction (`postwarp methods`).
    Reconstruction(String),
    /// The cycle-level hardware model (`postwarp simulate`).
    Hardware,
}

impl MethodChoice {
    /// The name in the `method` column.
    pub fn name(&self) -> &str {
        match self {
            MethodChoice::Reconstruction(n) => n,
            MethodChoice::Hardware => "hardware",
        }
    }
}

/// A hole-fill choice.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FillChoice {
    /// The one the method's paper uses (`MethodInfo::default_hole_fill`).
    Default,
    /// A registered hole fill.
    Named(String),
}

/// A `[[traces]]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceEntry {
    /// Where the entry is in the file.
    pub at: KeyPath,
    /// `name`, if given (the label in the `trace` column and chart names).
    pub name: Option<String>,
    /// What the entry is.
    pub source: EntrySource,
    /// Axes: `frames` for an existing trace; the [`TRACE_FIELDS`] given for
    /// a generated one, in canonical order.
    pub axes: Vec<Axis>,
}

/// An existing trace or a scene to render.
#[derive(Clone, Debug, PartialEq)]
pub enum EntrySource {
    /// `path = "..."`.
    Existing {
        /// As written in the specification.
        given: String,
        /// Resolved against the specification's directory.
        path: PathBuf,
    },
    /// `scene = "..."`.
    Generated {
        /// As written: a built-in scene name or a scene file.
        given: String,
        /// The scene file resolved against the specification's directory;
        /// `None` for a built-in scene.
        file: Option<PathBuf>,
    },
}

const GLOBAL_KEYS: &[&str] = &["name", "runs", "images", "flip"];
const GROUP_KEYS: &[&str] = &["traces", "methods", "hole_fills", "golden", "hardware"];

struct Parser<'a> {
    loc: Locator<'a>,
    dir: PathBuf,
}

impl Spec {
    /// Read and check the specification file `path`.
    pub fn load(path: &Path) -> Result<Spec, SpecError> {
        let text = std::fs::read_to_string(path).map_err(|e| SpecError {
            file: path.to_path_buf(),
            key: String::new(),
            at: None,
            message: format!("cannot read the sweep specification: {e}"),
        })?;
        Spec::parse(&text, path)
    }

    /// Check specification text; `file` names it in errors and anchors
    /// relative paths.
    pub fn parse(text: &str, file: &Path) -> Result<Spec, SpecError> {
        let p = Parser {
            loc: Locator::new(file, text),
            dir: file.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf(),
        };
        let table: toml::Table =
            toml::from_str(text).map_err(|e| p.loc.syntax(e.span().map(|s| s.start), e.message().trim()))?;
        let mut spec = p.spec(&table, file)?;
        spec.text = text.to_string();
        Ok(spec)
    }

    /// An error at `at` in this specification.
    pub fn error(&self, at: &KeyPath, message: impl Into<String>) -> SpecError {
        Locator::new(&self.file, &self.text).error(at, message)
    }

    /// Directory that relative paths in the specification start from.
    pub fn dir(&self) -> &Path {
        self.file.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."))
    }
}

/// A value as written, cut to 40 characters for messages.
fn describe(v: &toml::Value) -> String {
    let s = v.to_string();
    if s.chars().count() > 40 { format!("{}...", s.chars().take(40).collect::<String>()) } else { s }
}

impl Parser<'_> {
    fn err(&self, at: &KeyPath, msg: impl Into<String>) -> SpecError {
        self.loc.error(at, msg)
    }

    fn spec(&self, t: &toml::Table, file: &Path) -> Result<Spec, SpecError> {
        let top = KeyPath::default();
        let name = match t.get("name") {
            None => file.file_stem().map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned()),
            Some(v) => match v.as_str() {
                Some(s) if !s.trim().is_empty() => s.to_string(),
                _ => {
                    return Err(self.err(&top.key("name"), format!("expected a non-empty string, got {}", describe(v))));
                }
            },
        };
        let runs = match t.get("runs") {
            None => 3,
            Some(v) => match v.as_integer() {
                Some(n) if (1..=1000).contains(&n) => n as u32,
                _ => {
                    return Err(self.err(
                        &top.key("runs"),
                        format!("expected a whole number of runs from 1 to 1000, got {}", describe(v)),
                    ));
                }
            },
        };
        let images = match t.get("images") {
            None => false,
            Some(v) => v
                .as_bool()
                .ok_or_else(|| self.err(&top.key("images"), format!("expected true or false, got {}", describe(v))))?,
        };
        let flip = match t.get("flip") {
            None => false,
            Some(v) => v
                .as_bool()
                .ok_or_else(|| self.err(&top.key("flip"), format!("expected true or false, got {}", describe(v))))?,
        };
        let groups = if let Some(sweeps) = t.get("sweep") {
            if let Some(k) = t.keys().find(|k| GROUP_KEYS.contains(&k.as_str())) {
                return Err(self.err(
                    &top.key(k),
                    "with [[sweep]] tables, every group key (traces, methods, hole_fills, golden, hardware) goes inside a [[sweep]] table",
                ));
            }
            self.unknown_keys(t, &top, &[GLOBAL_KEYS, &["sweep"]].concat())?;
            let at = top.key("sweep");
            let arr = sweeps.as_array().filter(|a| !a.is_empty()).ok_or_else(|| {
                self.err(&at, "expected one or more [[sweep]] tables (traces, methods, hole_fills, golden, hardware)")
            })?;
            let mut groups = Vec::new();
            for (i, g) in arr.iter().enumerate() {
                let gt = g.as_table().ok_or_else(|| self.err(&at.index(i), "expected a [[sweep]] table"))?;
                self.unknown_keys(gt, &at.index(i), GROUP_KEYS)?;
                groups.push(self.group(gt, at.index(i))?);
            }
            groups
        } else {
            self.unknown_keys(t, &top, &[GLOBAL_KEYS, GROUP_KEYS, &["sweep"]].concat())?;
            vec![self.group(t, top)?]
        };
        Ok(Spec { file: file.to_path_buf(), text: String::new(), name, runs, images, flip, groups })
    }

    fn unknown_keys(&self, t: &toml::Table, at: &KeyPath, allowed: &[&str]) -> Result<(), SpecError> {
        match t.keys().find(|k| !allowed.contains(&k.as_str())) {
            Some(k) => Err(self.err(&at.key(k), format!("unknown key (expected one of: {})", allowed.join(", ")))),
            None => Ok(()),
        }
    }

    fn group(&self, t: &toml::Table, at: KeyPath) -> Result<Group, SpecError> {
        let tr = at.key("traces");
        let traces = match t.get("traces") {
            None => return Err(self.err(&tr, "missing: expected [[traces]] tables, each with `path` (an existing trace) or `scene` (one to generate)")),
            Some(v) => v.as_array().filter(|a| !a.is_empty()).ok_or_else(|| {
                self.err(&tr, "expected one or more [[traces]] tables, each with `path` or `scene`")
            })?,
        };
        let traces = traces
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let t =
                    v.as_table().ok_or_else(|| self.err(&tr.index(i), "expected a table with `path` or `scene`"))?;
                self.trace(t, tr.index(i))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let methods = self.methods(t.get("methods"), &at.key("methods"))?;
        let hole_fills = self.hole_fills(t.get("hole_fills"), &at.key("hole_fills"))?;
        let golden = self.knob_table(t.get("golden"), &at.key("golden"), true)?;
        let hardware = self.knob_table(t.get("hardware"), &at.key("hardware"), false)?;
        for g in &golden {
            if let Some(h) = knobs::hardware_name(&g.key) {
                if hardware.iter().any(|a| a.key == h) {
                    return Err(self.err(
                        &at.key("hardware").key(h),
                        format!("also set as golden.{}: a functional knob is set in [golden] (applies to golden-model methods and to `hardware`) or in [hardware] (hardware only), not both", g.key),
                    ));
                }
            }
        }
        Ok(Group { at, traces, methods, hole_fills, golden, hardware })
    }

    /// A list of strings, or one string.
    fn names(&self, v: &toml::Value, at: &KeyPath) -> Result<Vec<(KeyPath, String)>, SpecError> {
        let one = |v: &toml::Value, at: KeyPath| match v.as_str() {
            Some(s) => Ok((at, s.to_string())),
            None => Err(self.err(&at, format!("expected a name in quotes, got {}", describe(v)))),
        };
        match v {
            toml::Value::Array(a) if a.is_empty() => Err(self.err(at, "expected at least one name")),
            toml::Value::Array(a) => a.iter().enumerate().map(|(i, x)| one(x, at.index(i))).collect(),
            _ => Ok(vec![one(v, at.clone())?]),
        }
    }

    fn methods(&self, v: Option<&toml::Value>, at: &KeyPath) -> Result<Vec<MethodChoice>, SpecError> {
        let registered: Vec<String> =
            crate::methods::reconstructions().iter().map(|m| m.info().name.to_string()).collect();
        let v = v.ok_or_else(|| {
            self.err(at, "missing: expected \"all\" (every registered method), `hardware`, or a list of method names")
        })?;
        let mut out: Vec<MethodChoice> = Vec::new();
        let mut push = |m: MethodChoice| {
            if !out.contains(&m) {
                out.push(m);
            }
        };
        for (at, name) in self.names(v, at)? {
            match name.as_str() {
                "all" => registered.iter().for_each(|n| push(MethodChoice::Reconstruction(n.clone()))),
                "hardware" => push(MethodChoice::Hardware),
                n if registered.iter().any(|r| r == n) => push(MethodChoice::Reconstruction(n.to_string())),
                n => {
                    return Err(self.err(
                        &at,
                        format!("unknown method `{n}` (expected \"all\", \"hardware\" or one of: {}; `postwarp methods` lists them)", registered.join(", ")),
                    ));
                }
            }
        }
        Ok(out)
    }

    fn hole_fills(&self, v: Option<&toml::Value>, at: &KeyPath) -> Result<Vec<FillChoice>, SpecError> {
        let registered: Vec<String> = crate::methods::hole_fills().iter().map(|m| m.info().name.to_string()).collect();
        let Some(v) = v else { return Ok(vec![FillChoice::Default]) };
        let mut out: Vec<FillChoice> = Vec::new();
        let mut push = |f: FillChoice| {
            if !out.contains(&f) {
                out.push(f);
            }
        };
        for (at, name) in self.names(v, at)? {
            match name.as_str() {
                "default" => push(FillChoice::Default),
                "all" => registered.iter().for_each(|n| push(FillChoice::Named(n.clone()))),
                n if registered.iter().any(|r| r == n) => push(FillChoice::Named(n.to_string())),
                n => {
                    return Err(self.err(
                        &at,
                        format!(
                            "unknown hole fill `{n}` (expected \"default\", \"all\" or one of: {})",
                            registered.join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(out)
    }

    /// Values of an axis: a list (not empty) or one value; each checked.
    fn axis(
        &self,
        key: &str,
        v: &toml::Value,
        at: &KeyPath,
        check: impl Fn(&toml::Value) -> Result<(), String>,
    ) -> Result<Axis, SpecError> {
        let values: Vec<(KeyPath, toml::Value)> = match v {
            toml::Value::Array(a) if a.is_empty() => {
                return Err(self.err(at, "expected a value or a non-empty list of values"));
            }
            toml::Value::Array(a) => a.iter().enumerate().map(|(i, x)| (at.index(i), x.clone())).collect(),
            _ => vec![(at.clone(), v.clone())],
        };
        for (at, x) in &values {
            if x.is_array() || x.is_table() {
                return Err(self.err(at, format!("expected a single value, got {}", describe(x))));
            }
            check(x).map_err(|e| self.err(at, e))?;
        }
        let mut vals: Vec<toml::Value> = Vec::new();
        for (_, x) in values {
            if !vals.contains(&x) {
                vals.push(x);
            }
        }
        Ok(Axis { key: key.to_string(), values: vals })
    }

    fn knob_table(&self, v: Option<&toml::Value>, at: &KeyPath, golden: bool) -> Result<Vec<Axis>, SpecError> {
        let Some(v) = v else { return Ok(Vec::new()) };
        let given = v.as_table().ok_or_else(|| self.err(at, "expected a table of knobs"))?;
        let mut t = toml::Table::new();
        for (k, v) in given {
            let name = if golden { k.as_str() } else { postwarp_rtl::config::current_knob_name(k) };
            if name != k && given.contains_key(name) {
                return Err(self
                    .err(&at.key(k), format!("is the old name of `{name}`, which is also given; keep `{name}` only")));
            }
            t.insert(name.to_string(), v.clone());
        }
        for k in t.keys() {
            let refused = if golden { knobs::golden_key_error(k) } else { knobs::hardware_key_error(k) };
            if let Some(e) = refused {
                return Err(self.err(&at.key(k), e));
            }
        }
        let order: Vec<&str> = if golden { knobs::golden_keys().collect() } else { knobs::hardware_keys().collect() };
        let mut axes = Vec::new();
        for k in order {
            if let Some(v) = t.get(k) {
                let check =
                    |x: &toml::Value| if golden { knobs::check_golden(k, x) } else { knobs::check_hardware(k, x) };
                axes.push(self.axis(k, v, &at.key(k), check)?);
            }
        }
        Ok(axes)
    }

    fn trace(&self, t: &toml::Table, at: KeyPath) -> Result<TraceEntry, SpecError> {
        let string = |k: &str| -> Result<Option<String>, SpecError> {
            match t.get(k) {
                None => Ok(None),
                Some(v) => match v.as_str() {
                    Some(s) if !s.trim().is_empty() => Ok(Some(s.to_string())),
                    _ => Err(self.err(&at.key(k), format!("expected a non-empty string, got {}", describe(v)))),
                },
            }
        };
        let name = string("name")?;
        if let Some(n) = &name {
            if n.contains(['/', '\\']) || n.starts_with('.') {
                return Err(self.err(
                    &at.key("name"),
                    "expected a name without `/`, `\\` or a leading `.` (it names chart files)",
                ));
            }
        }
        match (string("path")?, string("scene")?) {
            (Some(_), Some(_)) => {
                Err(self
                    .err(&at.key("scene"), "give `path` (an existing trace) or `scene` (one to generate), not both"))
            }
            (None, None) => {
                Err(self.err(&at, "expected `path` (an existing trace directory) or `scene` (a scene to render)"))
            }
            (Some(given), None) => {
                self.unknown_keys(t, &at, &["path", "name", "frames"])?;
                let path = self.dir.join(&given);
                if !path.exists() {
                    return Err(self.err(
                        &at.key("path"),
                        format!("no trace at {} (paths are relative to the specification's directory)", path.display()),
                    ));
                }
                let mut axes = Vec::new();
                if let Some(v) = t.get("frames") {
                    let check = |x: &toml::Value| trace_fields::set(&mut TraceSpec::default(), "frames", x);
                    axes.push(self.axis("frames", v, &at.key("frames"), check)?);
                }
                Ok(TraceEntry { at, name, source: EntrySource::Existing { given, path }, axes })
            }
            (None, Some(given)) => {
                let allowed: Vec<&str> =
                    ["scene", "name"].into_iter().chain(TRACE_FIELDS.iter().map(|f| f.0)).collect();
                self.unknown_keys(t, &at, &allowed)?;
                let file = if crate::scene::Scene::builtin_names().contains(&given.as_str()) {
                    None
                } else {
                    let f = self.dir.join(&given);
                    if !f.is_file() {
                        return Err(self.err(
                            &at.key("scene"),
                            format!(
                                "neither a built-in scene ({}) nor a scene file at {}",
                                crate::scene::Scene::builtin_names().join(", "),
                                f.display()
                            ),
                        ));
                    }
                    Some(f)
                };
                let mut axes = Vec::new();
                for (k, _, _, _) in TRACE_FIELDS {
                    if let Some(v) = t.get(*k) {
                        axes.push(self.axis(k, v, &at.key(k), |x| trace_fields::set(&mut TraceSpec::default(), k, x))?);
                    }
                }
                Ok(TraceEntry { at, name, source: EntrySource::Generated { given, file }, axes })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Spec, SpecError> {
        Spec::parse(text, &Path::new(env!("CARGO_MANIFEST_DIR")).join("specs/test.toml"))
    }

    #[test]
    fn a_spec_with_every_part_parses() {
        let s = parse(
            r#"
runs = 1
methods = ["all", "hardware", "mark-aa"]
hole_fills = ["default", "none", "none"]
[[traces]]
path = "../traces/room"
frames = [1, 2]
[[traces]]
scene = "slants"
width = [32, 48]
camera_path = "tracked"
[golden]
threshold = [1.4, 2.3]
[hardware]
preset = "hmd2026"
dest_cache_bytes = [65536, 131072]
"#,
        )
        .unwrap();
        assert_eq!((s.name.as_str(), s.runs, s.images, s.flip), ("test", 1, false, false));
        let g = &s.groups[0];
        assert_eq!(g.methods.last(), Some(&MethodChoice::Hardware));
        assert_eq!(g.methods.len(), crate::methods::reconstructions().len() + 1);
        assert_eq!(g.hole_fills, vec![FillChoice::Default, FillChoice::Named("none".into())]);
        assert_eq!(g.traces[0].axes[0].values.len(), 2);
        assert_eq!(g.traces[1].axes.iter().map(|a| a.key.as_str()).collect::<Vec<_>>(), ["width", "camera_path"]);
        assert_eq!(g.hardware.iter().map(|a| a.key.as_str()).collect::<Vec<_>>(), ["preset", "dest_cache_bytes"]);
    }

    #[test]
    fn a_renamed_hardware_knob_is_read_under_its_new_name() {
        let base = "methods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n[hardware]\n";
        let s = parse(&format!("{base}max_fragments = [1, 2]\n")).unwrap();
        assert_eq!(s.groups[0].hardware.iter().map(|a| a.key.as_str()).collect::<Vec<_>>(), ["abuffer_fragments"]);
        let e = parse(&format!("{base}max_fragments = 1\nabuffer_fragments = 2\n")).unwrap_err();
        assert!(e.message.contains("old name of `abuffer_fragments`"), "{e}");
    }

    #[test]
    fn errors_name_the_key_and_the_line() {
        let e =
            parse("methods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n[golden]\ntreshold = 2\n").unwrap_err();
        assert_eq!((e.key.as_str(), e.at.map(|a| a.0)), ("golden.treshold", Some(5)));
        assert!(e.message.contains("unknown golden knob"), "{e}");
        let e = parse("methods = [\"mark-aa\", \"nope\"]\n[[traces]]\npath = \"../traces/room\"\n").unwrap_err();
        assert_eq!(e.key, "methods[1]");
        assert!(e.message.contains("unknown method `nope`") && e.message.contains("mark-aa"), "{e}");
        let e = parse("methods = \"all\"\n[[traces]]\nscene = \"room\"\nwidth = [32, 0]\n").unwrap_err();
        assert_eq!(e.key, "traces[0].width[1]");
        assert!(e.message.contains("pixels"), "{e}");
        let e = parse("methods = \"all\"\nbogus = 1\n[[traces]]\npath = \"../traces/room\"\n").unwrap_err();
        assert_eq!((e.key.as_str(), e.at.map(|a| a.0)), ("bogus", Some(2)));
        let e = parse("methods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n[golden]\nthreshold = 2\n[hardware]\nthreshold = 3\n").unwrap_err();
        assert_eq!(e.key, "hardware.threshold");
        let e = parse("methods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n[hardware]\nsupersample = 1\n")
            .unwrap_err();
        assert!(e.message.contains("trace"), "{e}");
        let e = parse("methods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n[golden]\nhole_fill = false\n")
            .unwrap_err();
        assert!(e.message.contains("hole_fills"), "{e}");
        let e = parse("methods = \"all\"\n[[traces]]\npath = \"nowhere\"\n").unwrap_err();
        assert!(e.key == "traces[0].path" && e.message.contains("no trace"), "{e}");
        let e = parse("name = [\"é\"]\nmethods = \"all\"\n[[traces]]\npath = \"../traces/room\"\n").unwrap_err();
        assert_eq!(e.key, "name");
        let e = parse(&format!("runs = \"{}\"\nmethods = \"all\"\n", "é".repeat(50))).unwrap_err();
        assert!(e.message.ends_with("...") && e.key == "runs", "{e}");
        let e = parse("methods = \"all\"\n[[traces]\n").unwrap_err();
        assert!(e.key.is_empty() && e.at.is_some(), "{e}");
        let e = parse("[[sweep]]\nmethods = \"all\"\n[[sweep.traces]]\npath = \"../traces/room\"\n[[sweep]]\nmethods = \"all\"\n[[sweep.traces]]\nscene = \"room\"\nwdth = 3\n").unwrap_err();
        assert_eq!(e.key, "sweep[1].traces[0].wdth");
        assert!(e.to_string().contains("specs/test.toml:9:1: sweep[1].traces[0].wdth: unknown key"), "{e}");
    }
}
