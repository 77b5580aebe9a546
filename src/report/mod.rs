//! Reports: `report.json`'s contents as typed structs, written and read by
//! every command through the same code (`docs/report.md`), the printed
//! tables, the pictures (heat-map, hole mask) and CSV fields.
//!
//! - [`GoldenReport`] (`postwarp golden`), [`MethodReport`] (`postwarp
//!   golden --method`), [`SimulateReport`] (`postwarp simulate`); sweeps
//!   and `postwarp size` read the in-memory report of the run, `compare`
//!   its `mean`; [`load`] reads any of them from a file, older versions
//!   included.
//! - Every key is described once, next to its struct, with unit, meaning
//!   and how `total` and `mean` reduce it ([`keys`]); `docs/report.md`'s
//!   key lists are generated from these tables ([`docs`]).
//!
//! Rules:
//! 1. `report_version` is [`REPORT_VERSION`]; `kind` says which command
//!    wrote the report. Keys are added freely; a rename bumps the version.
//! 2. Every byte is deterministic for a given trace and configuration
//!    except host times (`host_ms`, `golden_host_ms`, `prepare_ms`).
//!    Non-finite numbers are written as `null`.
//! 3. `total` and `mean` are reduced from `frames` by the key rules of
//!    [`keys`], the same in every report; ratios are derived from counters
//!    at report time, never stored by the engines.
//! 4. Version 1 (files without `report_version`) reads through [`load`]:
//!    renamed keys get their new names (`kernels_over_4x4` →
//!    `kernels_over_limit`, `bandwidth_gbps_at_target_rate` →
//!    `dram_gbps_at_target_rate`, `dest_cache.hit_rate` →
//!    `dest_cache_hit_rate`), and `total` and `mean` are computed again
//!    from the frames by the version-2 rules (version 1 summed histograms
//!    in `mean` and averaged only some keys).
//! 5. Version 2 reads through [`load`] with the hardware knobs renamed
//!    since (`config.max_fragments` → `config.abuffer_fragments`, the
//!    golden model's name for the same knob); version 3 is otherwise
//!    version 2.
//! 6. Version 4 changes one meaning: `dest_cache.misses_compulsory`
//!    counts tiles loaded for their first use in a warp, by the schedule's
//!    prefetch or on demand (tiles), where versions 1–3 counted look-ups
//!    that missed on first use (accesses); without a prefetch the two are
//!    the same number. Older files read unchanged, their new keys 0.
//! 7. Version 5 scores FLIP only when asked (`--flip`, issue 20): the
//!    header's `flip` says whether it did, and without it `flip_mean` and
//!    `flip_mean_common` are `null`. Older files read with `flip` = true
//!    (they always scored it).

pub mod budget;
pub mod csv;
pub mod docs;
pub mod dram;
pub mod dram_trace;
pub mod golden;
pub mod hardware;
pub mod images;
pub mod keys;
mod legacy;
pub mod method;
pub mod quality;
pub mod simulate;
pub mod table;
pub mod timeline;

pub use golden::GoldenReport;
pub use method::MethodReport;
pub use simulate::SimulateReport;

use anyhow::{Context, bail};
use keys::{KeyDoc, Reduce, scalar};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::path::Path;

/// The version of `report.json` this build writes (module rule 1).
pub const REPORT_VERSION: u32 = 5;

/// Which command wrote a report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReportKind {
    /// `postwarp golden`.
    Golden,
    /// `postwarp golden --method`.
    Method,
    /// `postwarp simulate`.
    Simulate,
}

/// Any report.
// A report is read once per file and matched at once: boxing the larger
// variants would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Report {
    /// `postwarp golden`.
    Golden(GoldenReport),
    /// `postwarp golden --method`.
    Method(MethodReport),
    /// `postwarp simulate`.
    Simulate(SimulateReport),
}

/// `total` and `mean` of `frames` by the key rules; `extra` adds keys to
/// `total` (e.g. `frames`) before it is read into `T`.
pub(crate) fn reduce<F: Serialize, T: DeserializeOwned, M: DeserializeOwned>(
    frames: &[F],
    keys: &[KeyDoc],
    extra: impl FnOnce(&mut Map<String, Value>),
) -> (T, M) {
    let values: Vec<Value> = frames.iter().map(|f| serde_json::to_value(f).expect("frames serialize")).collect();
    let refs: Vec<&Value> = values.iter().collect();
    let mut t = Map::new();
    extra(&mut t);
    t.extend(keys::total(&refs, keys));
    let m = keys::mean(&refs, keys, frames.len());
    let total = serde_json::from_value(Value::Object(t)).expect("the total has the total struct's keys");
    let mean = serde_json::from_value(Value::Object(m)).expect("the mean has the mean struct's keys");
    (total, mean)
}

/// The header keys every report starts with.
pub(crate) fn header_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "report_version",
            "—",
            Reduce::Once,
            "version of this layout (5); files without it are version 1 (`docs/report.md`, reading older files)",
        ),
        scalar(
            "kind",
            "—",
            Reduce::Once,
            "the command that wrote it: `golden`, `method` (`golden --method`) or `simulate`",
        ),
        scalar("trace", "—", Reduce::Once, "path of the trace manifest"),
        scalar(
            "flip",
            "—",
            Reduce::Once,
            "true if FLIP was scored (`--flip`); false: `flip_mean` and `flip_mean_common` are null",
        ),
    ]
}

/// The keys of `total`: `frames`, then the frame keys that are summed or
/// maxed (objects keep only such keys).
pub(crate) fn total_keys(frame: Vec<KeyDoc>) -> Vec<KeyDoc> {
    let mut k = vec![scalar("frames", "frames", Reduce::Once, "derived frames in the report")];
    k.extend(frame.into_iter().filter(|k| matches!(k.reduce, Reduce::Sum | Reduce::Max)));
    k
}

/// The keys of `mean`: the frame keys but the per-frame ones.
pub(crate) fn mean_keys(frame: Vec<KeyDoc>) -> Vec<KeyDoc> {
    frame.into_iter().filter(|k| k.reduce != Reduce::Once).collect()
}

/// Read a report from the text of file `path` (any version this build
/// knows; module rule 4). Errors name the file.
pub fn parse(text: &str, path: &Path) -> anyhow::Result<Report> {
    let v: Value = serde_json::from_str(text).with_context(|| format!("{}: not a JSON report", path.display()))?;
    let version = match v.get("report_version") {
        None => 1,
        Some(n) => match n.as_u64() {
            Some(n) if n >= 1 => n,
            _ => bail!("{}: report_version = {n}; expected a whole number >= 1", path.display()),
        },
    };
    let mut v = v;
    if version < REPORT_VERSION_U64 {
        rename_config_knobs(&mut v);
    }
    // Before version 5 every report scored FLIP (module rule 7).
    if version < 5
        && let Some(o) = v.as_object_mut()
    {
        o.entry("flip").or_insert(Value::Bool(true));
    }
    let r = match version {
        1 => legacy::upgrade(v).with_context(|| format!("{}: reading a version-1 report", path.display()))?,
        2..=REPORT_VERSION_U64 => {
            from_value(v).with_context(|| format!("{}: not a version-{version} report", path.display()))?
        }
        n => bail!(
            "{}: report_version {n} was written by a newer postwarp; this build reads versions 1 to {REPORT_VERSION}",
            path.display()
        ),
    };
    Ok(r)
}

const REPORT_VERSION_U64: u64 = REPORT_VERSION as u64;

/// Give the hardware knobs of an older report's `config` their current
/// names (module rule 5).
fn rename_config_knobs(v: &mut Value) {
    let Some(config) = v.get_mut("config").and_then(Value::as_object_mut) else { return };
    for (old, new) in postwarp_rtl::config::RENAMED_KNOBS {
        if let Some(x) = config.remove(*old) {
            config.entry(*new).or_insert(x);
        }
    }
}

fn from_value(v: Value) -> anyhow::Result<Report> {
    let kind: ReportKind = serde_json::from_value(v.get("kind").cloned().unwrap_or(Value::Null))
        .context("`kind`: expected `golden`, `method` or `simulate`")?;
    Ok(match kind {
        ReportKind::Golden => Report::Golden(serde_json::from_value(v)?),
        ReportKind::Method => Report::Method(serde_json::from_value(v)?),
        ReportKind::Simulate => Report::Simulate(serde_json::from_value(v)?),
    })
}

/// Read the report in file `path` (a `report.json`, or a folder holding
/// one).
pub fn load(path: &Path) -> anyhow::Result<Report> {
    let file = if path.is_dir() { path.join("report.json") } else { path.to_path_buf() };
    let text = crate::io_util::read_text(&file, "report (report.json)")?;
    parse(&text, &file)
}

/// Write `report` as `report.json` in `dir` (pretty, one trailing line
/// break), atomically.
pub fn write<R: Serialize>(report: &R, dir: &Path) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(report)? + "\n";
    let path = dir.join("report.json");
    crate::io_util::write_bytes_atomically(&path, text.as_bytes())?;
    Ok(())
}
