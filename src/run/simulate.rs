//! `postwarp simulate`: run the hardware model and the golden model on the
//! same trace, compare them, score against ground truth, write frames and
//! `report.json`.
//!
//! Rules:
//! 1. The hardware configuration's functional knobs drive the golden model
//!    too (`hw_config::golden_config_for`); the trace's super-sampling
//!    overrides the configuration's (noted in the report as
//!    `supersample_from_trace`).
//! 2. Per frame: cycles, DRAM bytes (total and per client), destination
//!    and source cache counters, tile loads and evictions per reference,
//!    rectangles by size, A-buffer counters, hole samples, unit cycles;
//!    `vs_golden` and `vs_truth`. Ratios (frame rate at the clock,
//!    bandwidth at the target rate, hit rate) are derived here.
//! 3. `frame_rate_at_clock_hz = clock_hz / (cycles · views)`: the one
//!    warper renders every view of a frame time. `bandwidth_gbps_at_target_rate
//!    = (DRAM bytes per frame) · views · target_frame_rate_hz / 1e9`. Both
//!    are for the trace's frame size (the configuration's display size is
//!    the preset's target, not used to scale).
//! 4. The hardware model is diffuse (TR98): on a v2 trace it warps the
//!    reference images' composited colour and ignores the transparent
//!    fragment and ray-tree layers, which the report names
//!    (`ignored_layers`).

use crate::golden::frame::{PreparedReference, Warper, prepare_reference};
use crate::metrics::psnr::psnr_rgb;
use crate::picture::{to_srgb8, write_png};
use crate::run::hw_config::golden_config_for;
use crate::run::hw_config_toml::to_json;
use crate::trace::Trace;
use anyhow::Context;
use bitvec::vec::BitVec;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, FrameStats, HwReference, UNITS};
use postwarp_rtl::mem::Client;
use serde_json::{Map, Value, json};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// What a simulation produced.
pub struct SimulateRun {
    /// `report.json` contents.
    pub report: Value,
    /// The printed summary.
    pub summary: String,
}

/// Run `trace` on the hardware model configured by `cfg`, writing the
/// frames and `report.json` into `out`, with a progress bar on a terminal.
pub fn run_simulate(trace: &Trace, cfg: &EngineConfig, out: &Path) -> anyhow::Result<SimulateRun> {
    let bar = crate::progress::bar(trace.derived.len() as u64, "simulate");
    let r = measure_hardware(trace, cfg, Some(out), &bar)?;
    bar.finish_and_clear();
    Ok(r)
}

/// Run `trace` on the hardware model configured by `cfg` beside the golden
/// model and build the report; with `out`, also write the frame files and
/// `report.json` there. `bar` advances once per frame.
pub fn measure_hardware(
    trace: &Trace,
    cfg: &EngineConfig,
    out: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<SimulateRun> {
    let mut cfg = cfg.clone();
    let ss = trace.display.supersample;
    let from_trace = cfg.supersample != ss;
    cfg.supersample = ss;
    let mut engine = Engine::new(cfg.clone()).map_err(|e| anyhow::anyhow!("hardware configuration: {e}"))?;
    let gcfg = golden_config_for(&cfg);
    if let Some(out) = out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    }
    let (w, h) = (trace.display.width, trace.display.height);
    let last_use = trace.last_use();
    let mut refs: HashMap<usize, (HwReference, PreparedReference)> = HashMap::new();
    let mut warper = Warper::new();
    let mut frames = Vec::new();
    for (k, f) in trace.derived.iter().enumerate() {
        for &r in &f.references {
            if let std::collections::hash_map::Entry::Vacant(e) = refs.entry(r) {
                let loaded = trace.load_reference(r)?;
                e.insert((HwReference::new(&loaded.samples, &cfg), prepare_reference(&loaded.samples, ss, &gcfg)));
            }
        }
        let cmd = trace.frame_commands(k);
        let hw_refs: Vec<&HwReference> = f.references.iter().map(|r| &refs[r].0).collect();
        let g_refs: Vec<&PreparedReference> = f.references.iter().map(|r| &refs[r].1).collect();
        let t = Instant::now();
        let hw = engine.run_frame(&cmd, &hw_refs);
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let golden = warper.warp_frame(&cmd, &g_refs, &gcfg);
        let golden_ms = t.elapsed().as_secs_f64() * 1e3;
        let differing = differing_samples(&hw, &golden.samples);
        let all = BitVec::repeat(true, hw.pixels.len());
        let psnr = psnr_rgb(&pixels8(&hw.pixels), &pixels8(&golden.pixels), &all);
        let vs_truth = match super::score::score_frame(trace, k, (w, h), &hw.pixels, &hw.covered, out)? {
            None => Value::Null,
            Some(q) => serde_json::to_value(q)?,
        };
        if let Some(out) = out {
            write_png(&out.join(format!("frame-{k:04}.png")), w, h, &hw.pixels)?;
        }
        let mut e = frame_json(k, &hw.stats, &cfg);
        e.insert(
            "vs_golden".into(),
            json!({"identical": differing == 0 && hw.pixels == golden.pixels, "differing_samples": differing,
                   "psnr_db": if psnr.is_finite() { json!(psnr) } else { Value::Null }}),
        );
        e.insert("vs_truth".into(), vs_truth);
        e.insert("host_ms".into(), json!(host_ms));
        e.insert("golden_host_ms".into(), json!(golden_ms));
        frames.push(Value::Object(e));
        refs.retain(|r, _| last_use[r] > k);
        bar.inc(1);
    }
    let total = total_entry(&frames);
    let mean = mean_entry(&frames, &cfg);
    let summary = summary_table(&frames, &mean);
    let report = json!({
        "trace": trace.manifest.display().to_string(),
        "method": "mark-hw",
        "config": to_json(&cfg),
        "supersample_from_trace": from_trace,
        "ignored_layers": trace.layer_kinds(),
        "frames": frames,
        "total": total,
        "mean": mean,
    });
    if let Some(out) = out {
        let text = serde_json::to_string_pretty(&report)? + "\n";
        crate::io_util::write_bytes_atomically(&out.join("report.json"), text.as_bytes())?;
    }
    Ok(SimulateRun { report, summary })
}

fn pixels8(p: &[[f32; 3]]) -> Vec<[u8; 3]> {
    to_srgb8(p).chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Samples whose memory planes differ between the engines (colour, 1/Z
/// where real, real and hole flags, source where real).
fn differing_samples(hw: &FrameOutput, g: &crate::golden::planes::DestPlanes) -> u64 {
    let f = &hw.frame;
    (0..f.len())
        .filter(|&i| {
            f.colour[i] != g.colour[i]
                || f.real[i] != g.real[i]
                || f.hole[i] != g.hole[i]
                || (f.real[i] && (f.inv_z[i] != g.inv_z[i] || f.source[i] != g.source[i]))
        })
        .count() as u64
}

/// Derived rates of one frame or of the mean (module rule 3).
fn rates(cycles: f64, bytes: f64, cfg: &EngineConfig) -> (Value, Value) {
    let fps = if cycles > 0.0 { cfg.clock_hz as f64 / (cycles * cfg.views as f64) } else { f64::INFINITY };
    let gbps = bytes * cfg.views as f64 * cfg.target_frame_rate_hz / 1e9;
    (json!(fps), json!(gbps))
}

fn frame_json(k: usize, s: &FrameStats, cfg: &EngineConfig) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("index".into(), json!(k));
    m.insert("cycles".into(), json!(s.cycles));
    m.insert("dram_read_bytes".into(), json!(s.dram.bytes_read));
    m.insert("dram_write_bytes".into(), json!(s.dram.bytes_written));
    let mut by = Map::new();
    for c in Client::ALL {
        by.insert(
            c.name().into(),
            json!({"read": s.dram.client_bytes_read[c.index()], "write": s.dram.client_bytes_written[c.index()]}),
        );
    }
    m.insert("dram_bytes_by_client".into(), Value::Object(by));
    m.insert("dram_requests".into(), json!(s.dram.requests));
    let d = &s.dest_cache;
    m.insert(
        "dest_cache".into(),
        json!({"accesses": d.accesses, "hits": d.hits, "misses_compulsory": d.misses_compulsory,
               "misses_capacity": d.misses_capacity, "spills": d.spills,
               "hit_rate": if d.accesses > 0 { json!(d.hits as f64 / d.accesses as f64) } else { Value::Null }}),
    );
    let sc = &s.source_cache;
    m.insert(
        "source_cache".into(),
        json!({"block_reads": sc.block_reads, "evictions": sc.evictions, "wait_cycles": sc.wait_cycles}),
    );
    m.insert("tile_loads".into(), json!(s.tile_loads));
    m.insert("tile_evictions".into(), json!(s.tile_evictions));
    let mut rects = Map::new();
    for (w, row) in s.rects.iter().enumerate() {
        for (h, &n) in row.iter().enumerate() {
            if n > 0 {
                rects.insert(format!("{w}x{h}"), json!(n));
            }
        }
    }
    m.insert("rects_by_size".into(), Value::Object(rects));
    m.insert("rects".into(), json!(s.rects.iter().flatten().sum::<u64>()));
    m.insert("kernels".into(), json!(s.kernels));
    m.insert("kernels_over_4x4".into(), json!(s.kernels_over_limit));
    m.insert("samples_transformed".into(), json!(s.samples_transformed));
    m.insert("culled_samples".into(), json!(s.culled_samples));
    m.insert("live_lines".into(), json!(s.live_lines));
    m.insert("dead_lines".into(), json!(s.dead_lines));
    m.insert(
        "composite".into(),
        json!({"filled": s.composite[0], "nearer": s.composite[1], "better": s.composite[2], "lost": s.composite[3]}),
    );
    m.insert("fragments_per_pixel".into(), json!(s.fragments_per_pixel));
    m.insert("forced_merges".into(), json!(s.forced_merges));
    m.insert("hole_samples".into(), json!(s.hole_samples));
    m.insert("empty_samples".into(), json!(s.empty_samples));
    m.insert("hole_fill_filled".into(), json!(s.hole_fill_filled));
    m.insert("hole_fill_unreached".into(), json!(s.hole_fill_unreached));
    let mut units = Map::new();
    for (name, u) in UNITS.iter().zip(&s.units) {
        units.insert((*name).into(), json!({"busy": u.busy, "stall": u.stall, "idle": u.idle}));
    }
    m.insert("units".into(), Value::Object(units));
    let (fps, gbps) = rates(s.cycles as f64, (s.dram.bytes_read + s.dram.bytes_written) as f64, cfg);
    m.insert("frame_rate_at_clock_hz".into(), fps);
    m.insert("bandwidth_gbps_at_target_rate".into(), gbps);
    m
}

/// Sum of every integer counter over frames (nested objects and arrays
/// element-wise); non-integer values are left out.
fn sum_values(vals: &[&Value]) -> Option<Value> {
    let first = vals.first()?;
    match first {
        Value::Number(n) if n.is_u64() => Some(json!(vals.iter().filter_map(|v| v.as_u64()).sum::<u64>())),
        Value::Array(_) => {
            let len = vals.iter().filter_map(|v| v.as_array()).map(Vec::len).max().unwrap_or(0);
            let mut out = Vec::new();
            for i in 0..len {
                let items: Vec<&Value> = vals.iter().filter_map(|v| v.as_array()?.get(i)).collect();
                out.push(sum_values(&items).unwrap_or(Value::Null));
            }
            Some(Value::Array(out))
        }
        Value::Object(_) => {
            let mut m = Map::new();
            let mut keys: Vec<&String> = vals.iter().filter_map(|v| v.as_object()).flat_map(|o| o.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let items: Vec<&Value> = vals.iter().filter_map(|v| v.get(k)).collect();
                if let Some(s) = sum_values(&items) {
                    m.insert(k.clone(), s);
                }
            }
            Some(Value::Object(m))
        }
        _ => None,
    }
}

const NOT_SUMMED: &[&str] = &["index", "vs_golden", "vs_truth", "host_ms", "golden_host_ms"];

fn total_entry(frames: &[Value]) -> Value {
    let mut m = Map::new();
    let Some(Value::Object(first)) = frames.first() else { return Value::Object(m) };
    for k in first.keys().filter(|k| !NOT_SUMMED.contains(&k.as_str())) {
        // Every frame has the same top-level keys; nested objects may not.
        let items: Vec<&Value> = frames.iter().filter_map(|f| f.get(k)).collect();
        if let Some(s) = sum_values(&items) {
            m.insert(k.clone(), s);
        }
    }
    m.insert("frames".into(), json!(frames.len()));
    m.insert("identical_frames".into(), json!(frames.iter().filter(|f| f["vs_golden"]["identical"] == true).count()));
    m.insert(
        "differing_samples".into(),
        json!(frames.iter().filter_map(|f| f["vs_golden"]["differing_samples"].as_u64()).sum::<u64>()),
    );
    Value::Object(m)
}

fn mean_of(frames: &[Value], path: &[&str]) -> Value {
    let nums: Vec<f64> =
        frames.iter().filter_map(|f| path.iter().try_fold(f, |v, k| v.get(*k)).and_then(Value::as_f64)).collect();
    if nums.is_empty() { Value::Null } else { json!(nums.iter().sum::<f64>() / nums.len() as f64) }
}

fn mean_entry(frames: &[Value], cfg: &EngineConfig) -> Value {
    let mut m = Map::new();
    for k in ["cycles", "dram_read_bytes", "dram_write_bytes", "kernels_over_4x4", "forced_merges", "hole_samples"] {
        m.insert(k.into(), mean_of(frames, &[k]));
    }
    for k in ["host_ms", "golden_host_ms"] {
        m.insert(k.into(), mean_of(frames, &[k]));
    }
    let mut vt = Map::new();
    if let Some(Value::Object(q)) = frames.iter().map(|f| &f["vs_truth"]).find(|v| v.is_object()) {
        for k in q.keys() {
            vt.insert(k.clone(), mean_of(frames, &["vs_truth", k]));
        }
    }
    m.insert("vs_truth".into(), if vt.is_empty() { Value::Null } else { Value::Object(vt) });
    m.insert("vs_golden".into(), json!({"psnr_db": mean_of(frames, &["vs_golden", "psnr_db"])}));
    let cycles = m["cycles"].as_f64().unwrap_or(0.0);
    let bytes = m["dram_read_bytes"].as_f64().unwrap_or(0.0) + m["dram_write_bytes"].as_f64().unwrap_or(0.0);
    let (fps, gbps) = rates(cycles, bytes, cfg);
    m.insert("frame_rate_at_clock_hz".into(), fps);
    m.insert("bandwidth_gbps_at_target_rate".into(), gbps);
    Value::Object(m)
}

/// The printed summary: one row per frame and the mean, same numbers as
/// `report.json`.
fn summary_table(frames: &[Value], mean: &Value) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>6} {:>10} {:>9} {:>9} {:>9} {:>8} {:>8} {:>7} {:>7} {:>9} {:>9}",
        "frame",
        "cycles",
        "fps@clk",
        "rd_MB",
        "wr_MB",
        "GB/s@tgt",
        "dc_hit%",
        "dc_cmp",
        "dc_cap",
        "=golden",
        "psnr_luma"
    );
    let f64_of = |v: &Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    for f in frames {
        let d = &f["dest_cache"];
        let _ = writeln!(
            s,
            "{:>6} {:>10} {:>9.1} {:>9.3} {:>9.3} {:>8.3} {:>8.2} {:>7} {:>7} {:>9} {:>9.2}",
            f["index"].to_string(),
            f["cycles"].to_string(),
            f64_of(f, "frame_rate_at_clock_hz"),
            f64_of(f, "dram_read_bytes") / 1e6,
            f64_of(f, "dram_write_bytes") / 1e6,
            f64_of(f, "bandwidth_gbps_at_target_rate"),
            100.0 * d["hit_rate"].as_f64().unwrap_or(f64::NAN),
            d["misses_compulsory"].to_string(),
            d["misses_capacity"].to_string(),
            if f["vs_golden"]["identical"] == true {
                "yes".to_string()
            } else {
                format!("no ({})", f["vs_golden"]["differing_samples"])
            },
            f["vs_truth"]["psnr_luma_db"].as_f64().unwrap_or(f64::NAN),
        );
    }
    let _ = writeln!(
        s,
        "{:>6} {:>10.0} {:>9.1} {:>9.3} {:>9.3} {:>8.3} {:>8} {:>7} {:>7} {:>9} {:>9.2}",
        "mean",
        f64_of(mean, "cycles"),
        f64_of(mean, "frame_rate_at_clock_hz"),
        f64_of(mean, "dram_read_bytes") / 1e6,
        f64_of(mean, "dram_write_bytes") / 1e6,
        f64_of(mean, "bandwidth_gbps_at_target_rate"),
        "",
        "",
        "",
        "",
        mean["vs_truth"]["psnr_luma_db"].as_f64().unwrap_or(f64::NAN),
    );
    s
}
