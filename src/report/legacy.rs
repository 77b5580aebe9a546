//! Reading version-1 reports (files without `report_version`, written
//! before the typed reports): module rule 4 of [`super`].

use super::golden::{GoldenFrame, GoldenReferences};
use super::hardware::{HwCounters, HwRates};
use super::method::{MethodFrame, MethodHeader, MethodReferences};
use super::quality::Truth;
use super::simulate::{HwFrame, VsGolden};
use super::{GoldenReport, MethodReport, Report, SimulateReport};
use anyhow::{Context, anyhow};
use serde::Deserialize;
use serde_json::Value;

/// A version-1 simulate frame: the counters under their version-2 names
/// (after [`rename`]); the rates are derived again.
#[derive(Deserialize)]
struct V1HwFrame {
    index: usize,
    #[serde(flatten)]
    counters: HwCounters<u64>,
    vs_golden: VsGolden,
    vs_truth: Option<Truth<u64>>,
    host_ms: f64,
    golden_host_ms: f64,
}

fn string(v: &Value, key: &str) -> anyhow::Result<String> {
    v.get(key).and_then(Value::as_str).map(str::to_string).ok_or_else(|| anyhow!("`{key}`: expected a string"))
}

/// Version-1 keys of a simulate frame under their version-2 names.
fn rename(f: &mut Value) {
    let Some(m) = f.as_object_mut() else { return };
    if let Some(v) = m.remove("kernels_over_4x4") {
        m.insert("kernels_over_limit".into(), v);
    }
    m.remove("bandwidth_gbps_at_target_rate");
    if let Some(Value::Object(d)) = m.get_mut("dest_cache") {
        d.remove("hit_rate");
    }
}

/// A version-1 report as this version's.
pub fn upgrade(mut v: Value) -> anyhow::Result<Report> {
    let trace = string(&v, "trace")?;
    let method = string(&v, "method")?;
    let frames = v.get_mut("frames").map(Value::take).ok_or_else(|| anyhow!("`frames`: missing"))?;
    let Value::Array(frames) = frames else { return Err(anyhow!("`frames`: expected an array")) };
    if method == "mark-hw" {
        let config = v.get("config").and_then(Value::as_object).ok_or_else(|| anyhow!("`config`: missing"))?;
        let cfg = crate::run::hw_config_toml::from_json_map(config).context("`config`")?;
        let from_trace = v.get("supersample_from_trace").and_then(Value::as_bool).unwrap_or(false);
        let mut out = Vec::new();
        for (i, mut f) in frames.into_iter().enumerate() {
            rename(&mut f);
            let f: V1HwFrame = serde_json::from_value(f).with_context(|| format!("`frames[{i}]`"))?;
            out.push(HwFrame {
                index: f.index,
                rates: HwRates::of(&f.counters.as_f64(), &cfg),
                counters: f.counters,
                vs_golden: f.vs_golden,
                vs_truth: f.vs_truth,
                host_ms: f.host_ms,
                golden_host_ms: f.golden_host_ms,
            });
        }
        return Ok(Report::Simulate(SimulateReport::new(trace, true, &cfg, from_trace, out)));
    }
    if let Some(fill) = v.get("hole_fill").and_then(Value::as_str) {
        let header = MethodHeader {
            trace,
            flip: true,
            method,
            hole_fill: fill.to_string(),
            paper: string(&v, "paper")?,
            primitive: string(&v, "primitive")?,
            runs: v.get("runs").and_then(Value::as_u64).ok_or_else(|| anyhow!("`runs`: expected a number"))? as u32,
        };
        let references: MethodReferences = serde_json::from_value(v["references"].take()).context("`references`")?;
        let frames: Vec<MethodFrame> = serde_json::from_value(Value::Array(frames)).context("`frames`")?;
        return Ok(Report::Method(MethodReport::new(header, references, frames)));
    }
    let config = serde_json::from_value(v["config"].take()).context("`config`")?;
    let references: GoldenReferences = serde_json::from_value(v["references"].take()).context("`references`")?;
    let frames: Vec<GoldenFrame> = serde_json::from_value(Value::Array(frames)).context("`frames`")?;
    Ok(Report::Golden(GoldenReport::new(trace, true, method, config, references, frames)))
}
