//! The points of a sweep: the union over groups of traces × methods ×
//! hole fills × knob combinations, each parameter multiplying only the
//! points it applies to, in a fixed order (the order of `results.csv`).
//!
//! Rules:
//! 1. Order: group, trace entry, trace variant, method, hole fill, golden
//!    combination, hardware combination (first axis outermost), as
//!    written in the specification.
//! 2. A CPU method runs with each hole fill of `hole_fills` (`default` =
//!    its paper's, [`MethodInfo::default_hole_fill`](crate::methods::MethodInfo)),
//!    and with each golden combination if it takes golden knobs.
//! 3. `hardware` runs with each combination of the golden knobs the
//!    hardware has ([`crate::run::hw_config::shared_knobs`]) and of `[hardware]`;
//!    hole fills do not apply to it (its epipolar fill is built in).
//! 4. Duplicates (the same trace variant and run reached twice) are kept
//!    once, at their first place.

use super::knobs;
use super::point::PointRun;
use super::spec::{FillChoice, Group, MethodChoice, Spec};
use super::spec_error::SpecError;
use super::trace_set::{self, TraceVariant, combinations, value_text};
use crate::golden::config::GoldenConfig;

/// A point before its trace is ready.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedPoint {
    /// Index into [`Plan::traces`].
    pub trace: usize,
    /// What runs.
    pub run: PointRun,
}

/// Every trace variant and point of a specification.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Trace variants, no repeats, in order of first use.
    pub traces: Vec<TraceVariant>,
    /// Points in order (module rule 1), no repeats.
    pub points: Vec<PlannedPoint>,
    /// `results.csv` knob columns: (column, `golden` or `hardware`, knob).
    pub knob_columns: Vec<(String, &'static str, String)>,
}

/// Plan `spec` (opens the manifests of existing traces for their
/// super-sampling, which hardware configurations take).
pub fn plan(spec: &Spec) -> Result<Plan, SpecError> {
    let loc = super::spec_error::Locator::new(&spec.file, &spec.text);
    let mut traces: Vec<TraceVariant> = Vec::new();
    let mut points: Vec<PlannedPoint> = Vec::new();
    for g in &spec.groups {
        for e in &g.traces {
            for v in trace_set::variants(e).map_err(|m| loc.error(&e.at, m))? {
                let idx = match traces.iter().position(|t| t.source == v.source && t.label == v.label) {
                    Some(i) => i,
                    None => {
                        if let Some(o) = traces.iter().find(|t| t.label == v.label) {
                            return Err(loc.error(
                                &e.at,
                                format!(
                                    "trace label `{}` is also used by {} for another trace: give one of them a `name`",
                                    v.label, o.at
                                ),
                            ));
                        }
                        traces.push(v.clone());
                        traces.len() - 1
                    }
                };
                let ss = trace_set::supersample(&v).map_err(|m| loc.error(&e.at, format!("{m:#}")))?;
                for run in group_runs(spec, g, ss).map_err(|m| loc.error(&g.at.key("hardware"), m))? {
                    let p = PlannedPoint { trace: idx, run };
                    if !points.contains(&p) {
                        points.push(p);
                    }
                }
            }
        }
    }
    Ok(Plan { traces, points, knob_columns: knob_columns(spec) })
}

/// The runs of group `g` on a trace of super-sampling `ss`.
fn group_runs(spec: &Spec, g: &Group, ss: u32) -> Result<Vec<PointRun>, String> {
    let golden_combos = combinations(&g.golden);
    let hw_golden_axes: Vec<_> = g.golden.iter().filter(|a| knobs::hardware_name(&a.key).is_some()).cloned().collect();
    let hw_golden_combos = combinations(&hw_golden_axes);
    let (preset_axis, hw_axes): (Vec<_>, Vec<_>) = g.hardware.iter().cloned().partition(|a| a.key == "preset");
    let presets: Vec<String> =
        preset_axis.first().map_or_else(|| vec!["mark1998".to_string()], |a| a.values.iter().map(value_text).collect());
    let hw_combos = combinations(&hw_axes);
    let mut out = Vec::new();
    for m in &g.methods {
        match m {
            MethodChoice::Reconstruction(name) => {
                let rec = crate::methods::reconstruction(name).map_err(|e| e.to_string())?;
                let takes_golden = rec.with_golden_config(&GoldenConfig::default()).is_some();
                let mut fills: Vec<String> = Vec::new();
                for f in &g.hole_fills {
                    let n = match f {
                        FillChoice::Default => match rec.info().default_hole_fill {
                            "" => "none".to_string(),
                            d => d.to_string(),
                        },
                        FillChoice::Named(n) => n.clone(),
                    };
                    if !fills.contains(&n) {
                        fills.push(n);
                    }
                }
                for fill in fills {
                    if takes_golden {
                        for c in &golden_combos {
                            let cfg =
                                knobs::golden_config(c).map_err(|e| format!("golden knobs {}: {e}", describe(c)))?;
                            out.push(PointRun::Method {
                                reconstruction: name.clone(),
                                hole_fill: fill.clone(),
                                golden: Some(cfg),
                                runs: spec.runs,
                                flip: spec.flip,
                            });
                        }
                    } else {
                        out.push(PointRun::Method {
                            reconstruction: name.clone(),
                            hole_fill: fill.clone(),
                            golden: None,
                            runs: spec.runs,
                            flip: spec.flip,
                        });
                    }
                }
            }
            MethodChoice::Hardware => {
                for gc in &hw_golden_combos {
                    for preset in &presets {
                        for hc in &hw_combos {
                            let config = knobs::hardware_config(Some(preset), hc, gc, ss).map_err(|e| {
                                let all: Vec<(&str, &toml::Value)> = gc.iter().chain(hc.iter()).copied().collect();
                                format!(
                                    "the combination preset = {preset}{}{}: {e}",
                                    if all.is_empty() { "" } else { ", " },
                                    describe(&all)
                                )
                            })?;
                            out.push(PointRun::Hardware { preset: preset.clone(), config, flip: spec.flip });
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}

fn describe(c: &[(&str, &toml::Value)]) -> String {
    c.iter().map(|(k, v)| format!("{k} = {}", value_text(v))).collect::<Vec<_>>().join(", ")
}

/// The knob columns of `results.csv`: every knob any group names, golden
/// knobs first, in canonical order; a golden and a hardware knob of the
/// same name and unit share a column.
fn knob_columns(spec: &Spec) -> Vec<(String, &'static str, String)> {
    let mut cols: Vec<(String, &'static str, String)> = Vec::new();
    for k in knobs::golden_keys() {
        if spec.groups.iter().any(|g| g.golden.iter().any(|a| a.key == k)) {
            cols.push((knobs::column(k, knobs::golden_unit(k)), "golden", k.to_string()));
        }
    }
    for k in knobs::hardware_keys() {
        if spec.groups.iter().any(|g| g.hardware.iter().any(|a| a.key == k)) {
            let c = knobs::column(k, knobs::hardware_unit(k));
            if !cols.iter().any(|x| x.0 == c) {
                cols.push((c, "hardware", k.to_string()));
            }
        }
    }
    cols
}

/// The value of knob column `(table, knob)` at a point, as CSV text;
/// empty where the knob does not apply.
pub fn knob_cell(run: &PointRun, table: &str, knob: &str) -> String {
    let text = |v: &serde_json::Value| match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Null => String::new(),
        other => other.to_string(),
    };
    match (run, table) {
        (PointRun::Method { golden: Some(cfg), .. }, "golden") => {
            text(&serde_json::to_value(cfg).expect("config serializes")[knob])
        }
        (PointRun::Hardware { preset, .. }, "hardware") if knob == "preset" => preset.clone(),
        (PointRun::Hardware { config, .. }, "hardware") => text(&crate::run::hw_config_toml::to_json(config)[knob]),
        (PointRun::Hardware { config, .. }, "golden") => match knobs::hardware_name(knob) {
            Some(h) => text(&crate::run::hw_config_toml::to_json(config)[h]),
            None => String::new(),
        },
        // The shared column of a golden knob named in [hardware] only.
        (PointRun::Method { golden: Some(cfg), .. }, "hardware") if knobs::hardware_name(knob).is_some() => {
            text(&serde_json::to_value(cfg).expect("config serializes")[knob])
        }
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn spec(text: &str) -> Spec {
        Spec::parse(text, &Path::new(env!("CARGO_MANIFEST_DIR")).join("specs/test.toml")).unwrap()
    }

    #[test]
    fn parameters_multiply_only_the_points_they_apply_to() {
        let s = spec(
            r#"
runs = 1
methods = ["mark-aa", "forward-splat", "hardware"]
hole_fills = ["default", "none"]
[[traces]]
path = "../traces/room"
[golden]
threshold = [1.4, 2.3]
warp_order = ["reverse", "forward"]
[hardware]
dest_cache_bytes = [65536, 131072]
"#,
        );
        let p = plan(&s).unwrap();
        let count = |m: &str| p.points.iter().filter(|x| x.run.method() == m).count();
        // mark-aa: 2 fills (its default is epipolar) x 2 thresholds x 2
        // orders; forward-splat: its default fill is `none`, so one point;
        // hardware: 2 thresholds (warp_order does not apply) x 2 caches.
        assert_eq!((count("mark-aa"), count("forward-splat"), count("hardware")), (8, 1, 4));
        let cols: Vec<&str> = p.knob_columns.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(cols, ["warp_order", "threshold_ratio_of_e", "dest_cache_bytes"]);
        let hw = p.points.iter().find(|x| x.run.method() == "hardware").unwrap();
        assert_eq!(knob_cell(&hw.run, "golden", "threshold"), "1.4");
        assert_eq!(knob_cell(&hw.run, "golden", "warp_order"), "");
        assert_eq!(knob_cell(&hw.run, "hardware", "dest_cache_bytes"), "65536");
        let fs = p.points.iter().find(|x| x.run.method() == "forward-splat").unwrap();
        assert_eq!(knob_cell(&fs.run, "golden", "threshold"), "");
    }

    #[test]
    fn duplicates_across_groups_and_fills_are_kept_once() {
        let s = spec(
            r#"
[[sweep]]
methods = ["forward-splat", "forward-splat"]
hole_fills = ["default", "none"]
[[sweep.traces]]
path = "../traces/room"
[[sweep]]
methods = "forward-splat"
[[sweep.traces]]
path = "../traces/room"
"#,
        );
        let p = plan(&s).unwrap();
        assert_eq!(p.traces.len(), 1);
        assert_eq!(p.points.len(), 1, "{:?}", p.points);
    }

    #[test]
    fn an_invalid_hardware_combination_names_it() {
        let s = spec("methods = \"hardware\"\n[[traces]]\npath = \"../traces/room\"\n[hardware]\ntile_size = [8, 2]\n");
        let e = plan(&s).unwrap_err();
        assert_eq!(e.key, "hardware");
        assert!(e.message.contains("tile_size = 2") && e.message.contains("kernel_limit"), "{e}");
    }
}
