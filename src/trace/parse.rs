//! Manifest parser: text → [`Trace`]. One statement per line; every error
//! names the file, the line and what was expected.

use super::*;
use glam::{DQuat, DVec3};
use postwarp_rtl::{Intrinsics, Pose};
use std::collections::BTreeMap;

/// Parse manifest `text` read from `file` (used in messages). Image paths are
/// not checked here (see [`Trace::open`]).
pub fn parse_manifest(text: &str, file: &Path) -> Result<Trace, TraceError> {
    // An error on the last line of a text cut off mid-line is the cut.
    let cut = check_complete(text).err().map(|(n, m)| TraceError::at(file, Some(n), m));
    match (parse_statements(text, file), cut) {
        (Err(e), Some(c)) if e.line >= c.line => Err(c),
        (Ok(_), Some(c)) => Err(c),
        (r, _) => r,
    }
}

fn parse_statements(text: &str, file: &Path) -> Result<Trace, TraceError> {
    let err = |line: usize, msg: String| TraceError::at(file, Some(line), msg);
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    match lines.next() {
        Some((_, first)) => parse_version(first.trim()).map_err(|m| err(1, m))?,
        None => return Err(err(1, "empty file; expected the version line `postwarp-trace 1`".into())),
    }
    let mut display: Option<Display> = None;
    let mut notes = Vec::new();
    let mut references = Vec::new();
    let mut derived = Vec::new();
    let mut derived_lines = Vec::new();
    let mut last_line = 1;
    for (n, raw) in lines {
        last_line = n;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (keyword, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let rest = rest.trim();
        match keyword {
            "note" => notes.push(rest.to_string()),
            "display" => {
                if display.is_some() {
                    return Err(err(n, "second `display` statement; expected exactly one".into()));
                }
                display = Some(parse_display(rest).map_err(|m| err(n, m))?);
            }
            "reference" | "derived" => {
                let Some(d) = display else {
                    return Err(err(n, format!("`{keyword}` before `display`; expected `display` first")));
                };
                let (index, fields) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
                let expected = if keyword == "reference" { references.len() } else { derived.len() };
                match index.parse::<usize>() {
                    Ok(i) if i == expected => {}
                    _ => {
                        return Err(err(
                            n,
                            format!("{keyword} index `{index}`; expected {expected} (indices count up from 0)"),
                        ));
                    }
                }
                let mut f = Fields::parse(fields).map_err(|m| err(n, m))?;
                if keyword == "reference" {
                    references.push(parse_reference(&mut f, d).map_err(|m| err(n, m))?);
                } else {
                    derived.push(parse_derived(&mut f, d).map_err(|m| err(n, m))?);
                    derived_lines.push(n);
                }
                f.finish().map_err(|m| err(n, m))?;
            }
            other => {
                return Err(err(
                    n,
                    format!("unknown statement `{other}`; expected one of `note`, `display`, `reference`, `derived`"),
                ));
            }
        }
    }
    let Some(display) = display else {
        return Err(err(last_line, "no `display` statement; expected one".into()));
    };
    for (d, &n) in derived.iter().zip(&derived_lines) {
        for &r in &d.references {
            if r >= references.len() {
                return Err(err(
                    n,
                    format!("refs names reference {r}; the trace has {} reference frames", references.len()),
                ));
            }
        }
    }
    if references.is_empty() {
        return Err(err(last_line, "no `reference` statement; expected at least one reference frame".into()));
    }
    if derived.is_empty() {
        return Err(err(last_line, "no `derived` statement; expected at least one derived frame".into()));
    }
    Ok(Trace { display, notes, references, derived, dir: PathBuf::new(), manifest: file.to_path_buf() })
}

/// A manifest is complete only if its last line ends with a line break:
/// a copy cut off mid-line (the last orientation cut mid-number, the
/// frames after it gone) is an error at the cut, not a shorter trace.
fn check_complete(text: &str) -> Result<(), (usize, String)> {
    if text.is_empty() || text.ends_with('\n') {
        return Ok(());
    }
    Err((
        text.lines().count().max(1),
        "the last line has no line break at its end: the file looks cut off (truncated); expected every line, the \
         last one included, to end with a newline"
            .into(),
    ))
}

fn parse_version(first: &str) -> Result<(), String> {
    if first.starts_with('\u{feff}') {
        return Err(format!(
            "line 1 starts with a UTF-8 byte-order mark (U+FEFF); expected `postwarp-trace {TRACE_VERSION}` as plain \
             UTF-8 (save the file without a BOM)"
        ));
    }
    let Some(v) = first.strip_prefix("postwarp-trace") else {
        return Err(format!("first line is `{first}`; expected the version line `postwarp-trace {TRACE_VERSION}`"));
    };
    match v.trim().parse::<u32>() {
        Ok(TRACE_VERSION) => Ok(()),
        Ok(other) => Err(format!("unsupported trace version {other}; this build reads version {TRACE_VERSION}")),
        Err(_) => Err(format!("version `{}` is not a number; expected `postwarp-trace {TRACE_VERSION}`", v.trim())),
    }
}

fn parse_display(rest: &str) -> Result<Display, String> {
    let mut f = Fields::parse(rest)?;
    let width = f.side("width")?;
    let height = f.side("height")?;
    let supersample: u32 = f.num("supersample")?;
    if !(1..=MAX_SUPERSAMPLE).contains(&supersample) {
        return Err(format!("supersample = {supersample}; expected 1 to {MAX_SUPERSAMPLE} samples per pixel per axis"));
    }
    f.finish()?;
    check_samples(width, height, supersample)?;
    Ok(Display { width, height, supersample })
}

fn check_samples(w: u32, h: u32, ss: u32) -> Result<(), String> {
    let n = w as u64 * h as u64 * (ss as u64).pow(2);
    if n > MAX_SAMPLES {
        return Err(format!("{w}x{h} pixels at {ss}x{ss} samples is {n} samples; at most {MAX_SAMPLES} are accepted"));
    }
    Ok(())
}

fn parse_reference(f: &mut Fields, d: Display) -> Result<ReferenceFrame, String> {
    let time_s = f.float("time")?;
    let image = f.path("image")?;
    let size = f.take("size")?;
    let (w, h) = size.split_once('x').ok_or_else(|| format!("size = `{size}`; expected WIDTHxHEIGHT, e.g. 268x187"))?;
    let parse_side = |s: &str, what: &str| -> Result<u32, String> {
        let v: u32 = s.parse().map_err(|_| format!("size {what} `{s}` is not a whole number"))?;
        check_side(what, v)
    };
    let (width, height) = (parse_side(w, "width")?, parse_side(h, "height")?);
    check_samples(width, height, d.supersample)?;
    let camera = parse_camera(f, width, height)?;
    Ok(ReferenceFrame { time_s, camera, image })
}

fn parse_derived(f: &mut Fields, d: Display) -> Result<DerivedFrame, String> {
    let time_s = f.float("time")?;
    let refs = f.take("refs")?;
    let mut references = Vec::new();
    for r in refs.split(',') {
        let i: usize =
            r.parse().map_err(|_| format!("refs = `{refs}`; expected reference indices separated by commas"))?;
        if references.contains(&i) {
            return Err(format!("refs = `{refs}` names reference {i} twice"));
        }
        references.push(i);
    }
    if references.len() > MAX_REFS_PER_FRAME {
        return Err(format!(
            "refs = `{refs}` names {} reference frames; a derived frame warps at most {MAX_REFS_PER_FRAME}",
            references.len()
        ));
    }
    let truth = if f.has("truth") { Some(f.path("truth")?) } else { None };
    let camera = parse_camera(f, d.width, d.height)?;
    Ok(DerivedFrame { time_s, camera, references, truth })
}

fn parse_camera(f: &mut Fields, width: u32, height: u32) -> Result<Camera, String> {
    let fx = f.float("fx")?;
    let fy = f.float("fy")?;
    if fx <= 0.0 || fy <= 0.0 {
        return Err(format!("focal lengths fx = {fx}, fy = {fy}; expected positive values in pixels"));
    }
    let cx = f.float("cx")?;
    let cy = f.float("cy")?;
    let p = f.floats::<3>("position")?;
    let q = f.floats::<4>("orientation")?;
    let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if (norm - 1.0).abs() > 1e-6 {
        return Err(format!("orientation has length {norm}; expected a unit quaternion qx,qy,qz,qw"));
    }
    Ok(Camera {
        intrinsics: Intrinsics { width, height, fx, fy, cx, cy },
        pose: Pose { position: DVec3::from_array(p), orientation: DQuat::from_xyzw(q[0], q[1], q[2], q[3]) },
    })
}

fn check_side(what: &str, v: u32) -> Result<u32, String> {
    if v == 0 || v > MAX_SIDE {
        return Err(format!("{what} = {v}; expected 1 to {MAX_SIDE} pixels"));
    }
    Ok(v)
}

/// `key=value` fields of one statement.
struct Fields {
    map: BTreeMap<String, String>,
}

impl Fields {
    fn parse(s: &str) -> Result<Fields, String> {
        let mut map = BTreeMap::new();
        for tok in s.split_whitespace() {
            let (k, v) = tok.split_once('=').ok_or_else(|| format!("`{tok}` is not a key=value field"))?;
            if map.insert(k.to_string(), v.to_string()).is_some() {
                return Err(format!("field `{k}` given twice"));
            }
        }
        Ok(Fields { map })
    }

    fn has(&self, key: &str) -> bool {
        self.map.contains_key(key)
    }

    fn take(&mut self, key: &str) -> Result<String, String> {
        self.map.remove(key).ok_or_else(|| format!("missing field `{key}=`"))
    }

    fn num<T: std::str::FromStr>(&mut self, key: &str) -> Result<T, String> {
        let v = self.take(key)?;
        v.parse().map_err(|_| format!("{key} = `{v}` is not a valid number"))
    }

    fn side(&mut self, key: &str) -> Result<u32, String> {
        let v = self.take(key)?;
        let n: u32 = v.parse().map_err(|_| format!("{key} = `{v}`; expected a whole number of pixels"))?;
        check_side(key, n)
    }

    fn float(&mut self, key: &str) -> Result<f64, String> {
        let v: f64 = self.num(key)?;
        if !v.is_finite() {
            return Err(format!("{key} = {v}; expected a finite number"));
        }
        Ok(v)
    }

    fn floats<const N: usize>(&mut self, key: &str) -> Result<[f64; N], String> {
        let v = self.take(key)?;
        let parts: Vec<&str> = v.split(',').collect();
        if parts.len() != N {
            return Err(format!("{key} = `{v}`; expected {N} numbers separated by commas"));
        }
        let mut out = [0.0; N];
        for (o, p) in out.iter_mut().zip(parts) {
            *o = p
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite())
                .ok_or_else(|| format!("{key}: `{p}` is not a finite number"))?;
        }
        Ok(out)
    }

    fn path(&mut self, key: &str) -> Result<PathBuf, String> {
        let v = self.take(key)?;
        if v.is_empty() {
            return Err(format!("{key} is empty; expected a path relative to the manifest"));
        }
        Ok(PathBuf::from(v))
    }

    fn finish(self) -> Result<(), String> {
        match self.map.keys().next() {
            None => Ok(()),
            Some(k) => Err(format!("unknown field `{k}`")),
        }
    }
}

/// 1-based line of the first statement mentioning file `name`.
pub(super) fn line_mentioning(text: &str, name: &Path) -> Option<usize> {
    let name = name.to_string_lossy();
    let needles = [format!("image={name}"), format!("truth={name}")];
    text.lines().position(|l| l.split_whitespace().any(|t| needles.iter().any(|n| t == n))).map(|i| i + 1)
}

/// 1-based line of statement `keyword i`.
pub(super) fn statement_line(text: &str, keyword: &str, i: usize) -> Option<usize> {
    text.lines()
        .position(|l| {
            let mut t = l.split_whitespace();
            t.next() == Some(keyword) && t.next() == Some(&i.to_string())
        })
        .map(|n| n + 1)
}
