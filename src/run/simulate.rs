//! `postwarp simulate`: run the hardware model and the golden model on the
//! same trace, compare them, score against ground truth, write frames and
//! `report.json`.
//!
//! Rules:
//! 1. The hardware configuration's functional knobs drive the golden model
//!    too (`hw_config::golden_config_for`); the trace's super-sampling
//!    overrides the configuration's (noted in the report as
//!    `supersample_from_trace`).
//! 2. Per frame: the hardware counters ([`HwCounters`]: cycles, DRAM bytes
//!    in total and per client, destination and source cache counters, tile
//!    loads and evictions per reference, rectangles by size, A-buffer
//!    counters, hole samples, unit cycles), their rates ([`HwRates`]),
//!    `vs_golden` and `vs_truth`; `total` and `mean` by the report's key
//!    rules ([`SimulateReport::new`]).
//! 3. `frame_rate_at_clock_hz = clock_hz / (cycles · views)`: the one
//!    warper renders every view of a frame time.
//!    `dram_gbps_at_target_rate = (DRAM bytes per frame) · views ·
//!    target_frame_rate_hz / 1e9`, per client likewise;
//!    `dram_utilisation = bytes / (cycles · dram_peak_bytes_per_cycle)`.
//!    All are for the trace's frame size (the configuration's display size
//!    is the preset's target, not used to scale).
//! 4. Outputs per frame: `frame-NNNN.png` (resolved), `frame-NNNN.exr` (the
//!    derived samples with depth, as `postwarp golden` writes them),
//!    `diff-NNNN.png` with ground truth; then `report.json`.
//! 5. The hardware model is diffuse (TR98): on a v2 trace it warps the
//!    reference images' composited colour and ignores the transparent
//!    fragment and ray-tree layers, which the report names
//!    (`ignored_layers`).

use super::frame_exr::write_frame_exr;
use crate::golden::frame::{PreparedReference, Warper, prepare_reference, prepare_reference_owned};
use crate::metrics::psnr::{luma, psnr_plane, psnr_rgb};
use crate::picture::{to_srgb8, write_png};
use crate::report::SimulateReport;
use crate::report::dram_trace::DramTraceWriter;
use crate::report::hardware::{ByClient, HwCounters, HwRates};
use crate::report::quality::Truth;
use crate::report::simulate::{HwFrame, VsGolden};
use crate::report::timeline::{TimelineMeta, chrome_trace};
use crate::run::hw_config::golden_config_for;
use crate::trace::Trace;
use anyhow::Context;
use bitvec::vec::BitVec;
use postwarp_rtl::budget::Budget;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{FrameOutput, HwReference};
use postwarp_rtl::hw_reference::abuffer_params;
use postwarp_rtl::units::abuffer::{AbufferCounters, PackedReference, pack_reference};
use rayon::prelude::*;
use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::Path;
use std::rc::Rc;
use std::time::Instant;

/// What a simulation produced.
pub struct SimulateRun {
    /// `report.json` contents.
    pub report: SimulateReport,
    /// The printed summary.
    pub summary: String,
    /// With `arith = "fixed"`: per frame, luma PSNR of the hardware image
    /// against the golden model's image of the same configuration with
    /// `arith = "float"` (dB; +∞ where identical). Empty in float mode.
    pub vs_float_luma_db: Vec<f64>,
}

/// Run `trace` on the hardware model configured by `cfg`, writing the
/// frames and `report.json` into `out`, with a progress bar on a terminal.
/// With `timeline = Some(resolution)`, also `timeline-NNNN.json` per frame
/// (`report::timeline`, intervals and counters at that many cycles); with
/// `dram_trace`, every frame's DRAM requests appended to it in frame order
/// (`report::dram_trace`; the caller finishes it). FLIP is scored only
/// with `flip`.
pub fn run_simulate(
    trace: &Trace,
    cfg: &EngineConfig,
    flip: bool,
    out: &Path,
    timeline: Option<u64>,
    dram_trace: Option<&mut DramTraceWriter>,
) -> anyhow::Result<SimulateRun> {
    let bar = crate::progress::bar(trace.derived.len() as u64, "simulate");
    let r = measure(trace, cfg, flip, Some(out), &bar, timeline, dram_trace)?;
    bar.finish_and_clear();
    Ok(r)
}

/// Run `trace` on the hardware model configured by `cfg` beside the golden
/// model and build the report; with `out`, also write the frame files and
/// `report.json` there (FLIP only with `flip`). `bar` advances once per
/// frame.
pub fn measure_hardware(
    trace: &Trace,
    cfg: &EngineConfig,
    flip: bool,
    out: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<SimulateRun> {
    measure(trace, cfg, flip, out, bar, None, None)
}

fn measure(
    trace: &Trace,
    cfg: &EngineConfig,
    flip: bool,
    out: Option<&Path>,
    bar: &indicatif::ProgressBar,
    timeline: Option<u64>,
    mut dram_trace: Option<&mut DramTraceWriter>,
) -> anyhow::Result<SimulateRun> {
    let mut cfg = cfg.clone();
    let ss = trace.display.supersample;
    let from_trace = cfg.supersample != ss;
    cfg.supersample = ss;
    let mut engine = crate::dram::engine(cfg.clone()).map_err(|e| anyhow::anyhow!("hardware configuration: {e}"))?;
    engine.record_timeline(timeline.is_some() && out.is_some());
    engine.record_requests(dram_trace.is_some());
    let gcfg = golden_config_for(&cfg);
    if let Some(out) = out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    }
    let (w, h) = (trace.display.width, trace.display.height);
    let last_use = trace.last_use();
    // Fixed mode: the FP64 golden model of the same configuration, the
    // reference the datapath's own error is measured against, with its
    // own prepared references (fetch rounds them in fixed mode).
    let float_gcfg = (gcfg.arith == "fixed").then(|| {
        let mut g = gcfg.clone();
        g.arith = "float".into();
        g
    });
    // Each engine's references, made when a warp first needs them and
    // dropped after the last warp that reads them. A reference is loaded
    // (its image decoded on all threads) just before the golden model's
    // first warp of it, packed for the hardware model and prepared for the
    // golden model, then let go; the golden model drops its prepared form
    // as soon as that warp is done if no later warp reads it, so a
    // one-frame run holds one reference's loaded or prepared form at a
    // time. The hardware model's reference (valid bits and depth map; its
    // records are expanded a block at a time as a warp runs,
    // `postwarp_rtl::ref_blocks`) is made from the packed form after the
    // golden model has warped the frame.
    // The process's peak memory: `docs/performance.md`.
    let mut golden_refs: HashMap<usize, Rc<PreparedReference>> = HashMap::new();
    let mut float_refs: HashMap<usize, PreparedReference> = HashMap::new();
    let mut packed: HashMap<usize, Packed> = HashMap::new();
    let mut hw_refs: HashMap<usize, HwReference> = HashMap::new();
    let mut warper = Warper::new();
    let mut float_warper = Warper::new();
    warper.trim_frames(true);
    float_warper.trim_frames(true);
    let mut vs_float_luma_db = Vec::new();
    let mut frames = Vec::new();
    for (k, f) in trace.derived.iter().enumerate() {
        let cmd = trace.frame_commands(k);
        // The golden model first: its working buffers (the last frame's,
        // `Warper::keep_buffers`) and the references this frame is the
        // last to use go before the hardware model's are expanded.
        let last = k + 1 == trace.derived.len();
        warper.keep_buffers(!last);
        float_warper.keep_buffers(!last);
        let mut loading = std::time::Duration::ZERO;
        let t = Instant::now();
        let golden = warper.warp_frame_streamed(&cmd, &gcfg, |j| -> anyhow::Result<Rc<PreparedReference>> {
            let r = f.references[j];
            if let Entry::Vacant(prepared) = golden_refs.entry(r) {
                let t = Instant::now();
                let raw = trace.load_reference(r)?.samples;
                let (float, hw) = rayon::join(
                    || float_gcfg.as_ref().map(|g| prepare_reference(&raw, ss, g)),
                    || {
                        let mut c = AbufferCounters::default();
                        (pack_reference(&raw, &abuffer_params(&cfg), &mut c), c)
                    },
                );
                packed.insert(r, hw);
                float_refs.extend(float.map(|p| (r, p)));
                // Last: the loaded planes become the golden model's.
                prepared.insert(Rc::new(prepare_reference_owned(raw, ss, &gcfg)));
                loading += t.elapsed();
            }
            let read_again = last_use[&r] > k || f.references[j + 1..].contains(&r);
            Ok(if read_again { Rc::clone(&golden_refs[&r]) } else { golden_refs.remove(&r).expect("prepared above") })
        })?;
        let golden_ms = (t.elapsed() - loading).as_secs_f64() * 1e3;
        let float = float_gcfg.as_ref().map(|g| {
            let f_refs: Vec<&PreparedReference> = f.references.iter().filter_map(|r| float_refs.get(r)).collect();
            float_warper.warp_frame(&cmd, &f_refs, g).pixels
        });
        float_refs.retain(|r, _| last_use[r] > k);
        // The hardware model's references not yet expanded (those loaded
        // for this frame), in parallel.
        let expand: Vec<(usize, Packed)> = packed.drain().collect();
        let expanded: Vec<(usize, HwReference)> =
            expand.into_par_iter().map(|(r, (p, c))| (r, HwReference::from_packed(p, c, &cfg))).collect();
        hw_refs.extend(expanded);
        let refs: Vec<&HwReference> = f.references.iter().map(|r| &hw_refs[r]).collect();
        let t = Instant::now();
        let hw = engine.run_frame(&cmd, &refs);
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        hw_refs.retain(|r, _| last_use[r] > k);
        if let Some(w) = dram_trace.as_deref_mut() {
            w.frame(&hw.requests, hw.stats.cycles)?;
        }
        let differing = differing_samples(&hw, &golden.samples);
        let all = BitVec::repeat(true, hw.pixels.len());
        let psnr = psnr_rgb(&pixels8(&hw.pixels), &pixels8(&golden.pixels), &all);
        let identical = differing == 0 && hw.pixels == golden.pixels;
        if let Some(float) = float {
            let luma = |p: &[[f32; 3]]| -> Vec<f64> { pixels8(p).into_iter().map(luma).collect() };
            vs_float_luma_db.push(psnr_plane(&luma(&hw.pixels), &luma(&float), &all));
        }
        // The golden frame is compared: its planes go before scoring and
        // writing allocate theirs (the process's peak memory).
        drop(golden);
        // Scoring beside writing the frame's files.
        let write = |out: &Path| -> anyhow::Result<()> {
            let (png, exr) = rayon::join(
                || write_png(&out.join(format!("frame-{k:04}.png")), w, h, &hw.pixels),
                || write_frame_exr(&out.join(format!("frame-{k:04}.exr")), &hw.frame),
            );
            png?;
            exr
        };
        let (vs_truth, written) = rayon::join(
            || {
                let truth = trace.load_truth(k)?;
                super::score::score_frame(truth.as_ref(), k, (w, h), &hw.pixels, &hw.covered, flip, out)
            },
            || out.map(write).transpose(),
        );
        let vs_truth = vs_truth?;
        written?;
        if let Some(out) = out {
            if let (Some(resolution), Some(t)) = (timeline, &hw.timeline) {
                let manifest = trace.manifest.display().to_string();
                let meta = TimelineMeta { trace: &manifest, frame: k, clock_hz: cfg.clock_hz, resolution };
                let path = out.join(format!("timeline-{k:04}.json"));
                crate::io_util::write_bytes_atomically(&path, &chrome_trace(t, &meta))
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
        let counters = HwCounters::of(&hw.stats, cfg.dram_burst_bytes);
        frames.push(HwFrame {
            index: k,
            rates: HwRates::of(&counters.as_f64(), &cfg),
            counters,
            vs_golden: VsGolden { identical, differing_samples: differing, psnr_db: psnr.is_finite().then_some(psnr) },
            vs_truth: vs_truth.as_ref().map(Truth::of),
            host_ms,
            golden_host_ms: golden_ms,
        });
        bar.inc(1);
    }
    let mut report = SimulateReport::new(trace.manifest.display().to_string(), flip, &cfg, from_trace, frames);
    report.ignored_layers = trace.layer_kinds().into_iter().map(String::from).collect();
    report.budget = crate::report::budget::to_json(&budget_of(&cfg, trace));
    let mut summary = summary(&report, &cfg, trace);
    if !vs_float_luma_db.is_empty() {
        let finite: Vec<f64> = vs_float_luma_db.iter().copied().filter(|x| x.is_finite()).collect();
        let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
        summary += &format!(
            "fixed-point datapath against the FP64 golden model of the same configuration: {} of {} frames identical{}\n",
            vs_float_luma_db.len() - finite.len(),
            vs_float_luma_db.len(),
            if finite.is_empty() { String::new() } else { format!(", mean luma PSNR of the others {mean:.2} dB") },
        );
    }
    if let Some(out) = out {
        crate::report::write(&report, out)?;
    }
    Ok(SimulateRun { report, summary, vs_float_luma_db })
}

/// A reference packed for the hardware model, with the packer's counters,
/// until its records are expanded (`HwReference::from_packed`).
type Packed = (PackedReference, AbufferCounters);

/// The budget of `cfg` for the frame and reference sizes of `trace`.
fn budget_of(cfg: &EngineConfig, trace: &Trace) -> Budget {
    Budget::sized(cfg, crate::report::budget::trace_sizes(trace, cfg.supersample))
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
            let d = &f.samples[i];
            d.colour != g.colour[i]
                || f.real[i] != g.real[i]
                || f.hole[i] != g.hole[i]
                || (f.real[i] && (d.inv_z != g.inv_z[i] || d.source != g.source[i]))
        })
        .count() as u64
}

/// The printed summary: a line naming the configuration, clock, target
/// rate and views; one row per frame and the mean (the numbers of
/// `report.json`); then DRAM bandwidth per client and utilisation.
fn summary(r: &SimulateReport, cfg: &EngineConfig, trace: &Trace) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let d = trace.display;
    let _ = writeln!(
        s,
        "configuration: {}; clock {} MHz, target {} Hz x {} view{}, DRAM {} B/cycle peak ({:.2} GB/s), {} x {} pixels at {}x{} \
         samples",
        config_name(cfg),
        cfg.clock_hz as f64 / 1e6,
        cfg.target_frame_rate_hz,
        cfg.views,
        if cfg.views == 1 { "" } else { "s" },
        cfg.dram_peak_bytes_per_cycle,
        cfg.dram_peak_bytes_per_cycle as f64 * cfg.clock_hz as f64 / 1e9,
        d.width,
        d.height,
        d.supersample,
        d.supersample,
    );
    let _ = writeln!(
        s,
        "{:>6} {:>10} {:>9} {:>9} {:>9} {:>8} {:>7} {:>8} {:>7} {:>7} {:>9} {:>9}",
        "frame",
        "cycles",
        "fps@clk",
        "rd_MB",
        "wr_MB",
        "GB/s@tgt",
        "dram%",
        "B/px",
        "dc_cmp",
        "dc_cap",
        "=golden",
        "psnr_luma"
    );
    let opt = |x: Option<f64>, scale: f64| x.map_or(f64::NAN, |v| v * scale);
    for f in &r.frames {
        let c = &f.counters;
        let _ = writeln!(
            s,
            "{:>6} {:>10} {:>9.1} {:>9.3} {:>9.3} {:>8.3} {:>7.2} {:>8.2} {:>7} {:>7} {:>9} {:>9.2}",
            f.index,
            c.cycles,
            opt(f.rates.frame_rate_at_clock_hz, 1.0),
            c.dram_read_bytes as f64 / 1e6,
            c.dram_write_bytes as f64 / 1e6,
            f.rates.dram_gbps_at_target_rate,
            opt(utilisation(&f.rates), 100.0),
            bytes_per_pixel(&f.rates),
            c.dest_cache.misses_compulsory,
            c.dest_cache.misses_capacity,
            if f.vs_golden.identical { "yes".to_string() } else { format!("no ({})", f.vs_golden.differing_samples) },
            opt(f.vs_truth.as_ref().and_then(|t| t.scores.psnr_luma_db), 1.0),
        );
    }
    let m = &r.mean;
    let _ = writeln!(
        s,
        "{:>6} {:>10.0} {:>9.1} {:>9.3} {:>9.3} {:>8.3} {:>7.2} {:>8.2} {:>7.1} {:>7.1} {:>9} {:>9.2}",
        "mean",
        m.counters.cycles,
        opt(m.rates.frame_rate_at_clock_hz, 1.0),
        m.counters.dram_read_bytes / 1e6,
        m.counters.dram_write_bytes / 1e6,
        m.rates.dram_gbps_at_target_rate,
        opt(utilisation(&m.rates), 100.0),
        bytes_per_pixel(&m.rates),
        m.counters.dest_cache.misses_compulsory,
        m.counters.dest_cache.misses_capacity,
        format!("{}/{}", r.total.identical_frames, r.total.frames),
        opt(m.vs_truth.as_ref().and_then(|t| t.scores.psnr_luma_db), 1.0),
    );
    let _ = write!(s, "DRAM at the target rate (mean): {:.3} GB/s =", m.rates.dram_gbps_at_target_rate);
    for (i, (name, gbps)) in m.rates.dram_gbps_by_client.iter().into_iter().enumerate() {
        let _ = write!(s, "{} {name} {gbps:.3}", if i == 0 { "" } else { " +" });
    }
    // With DRAMsim3 the part's own peak, not the ideal channel's knob.
    match m.rates.dram.dram_backend_utilisation {
        Some(u) => writeln!(s, "; utilisation {:.2} % of the DRAM part's peak over the frame's cycles", 100.0 * u),
        None => {
            writeln!(
                s,
                "; utilisation {:.2} % of the peak over the frame's cycles",
                opt(m.rates.dram_utilisation, 100.0)
            )
        }
    }
    .ok();
    if let (Some(b), Some(fl)) = (&m.rates.bytes_per_display_pixel, &m.rates.floor_bytes_per_display_pixel) {
        let _ = write!(s, "bytes per display pixel (mean), each with its floor:");
        for (i, ((name, v), (_, f))) in b.iter().into_iter().zip(fl.iter()).enumerate() {
            let _ = write!(s, "{} {name} {v:.1} ({f:.1})", if i == 0 { "" } else { " +" });
        }
        let total = |c: &ByClient<f64>| c.iter().into_iter().map(|(_, v)| v).sum::<f64>();
        let _ = writeln!(s, " = {:.1} ({:.1})", total(b), total(fl));
    }
    let peak = r.frames.iter().flat_map(|f| f.counters.peak_tiles.iter().copied()).max().unwrap_or(0);
    let tile_bytes = (cfg.tile_size as u64).pow(2) * postwarp_rtl::config::CACHE_BYTES_PER_SAMPLE;
    let model = r.frames.iter().flat_map(|f| f.counters.ws_model_tiles.iter().copied()).max().unwrap_or(0);
    let ratio = r.frames.iter().filter_map(|f| f.rates.peak_over_ws_model).fold(f64::NAN, f64::max);
    let d = &r.total.counters.dest_cache;
    let _ = writeln!(
        s,
        "destination cache: peak {peak} tiles held ({:.0} KiB) of {} ({} KiB); working-set model up to {model} tiles, \
         peak / model up to {ratio:.2}; over the frames {} tiles prefetched, {} demand, {} late and {} capacity \
         misses; {} tiles held to a warp's end",
        (peak * tile_bytes) as f64 / 1024.0,
        cfg.dest_cache_bytes / tile_bytes,
        cfg.dest_cache_bytes / 1024,
        d.prefetches,
        d.misses_demand,
        d.misses_late,
        d.misses_capacity,
        r.total.counters.tiles_held_to_warp_end.iter().sum::<u64>(),
    );
    if let Some(sat) = &r.total.counters.saturations {
        let _ = writeln!(
            s,
            "fixed point (arith = \"fixed\", docs/fixed-point.md): saturations over the frames: fetch {}, transform {}, \
             kernel_setup {}, raster {}, hole_fill {}",
            sat.fetch, sat.transform, sat.kernel_setup, sat.raster, sat.hole_fill
        );
    }
    let b = budget_of(cfg, trace);
    let t = &b.totals;
    let dest: u64 = b
        .stores
        .iter()
        .filter(|s| s.unit == "dest_cache" && s.kind == postwarp_rtl::budget::StoreKind::Sram)
        .map(|s| s.bytes)
        .sum();
    let _ = writeln!(
        s,
        "on-chip stores (budget in report.json, docs/budget.md): {:.1} KiB = {:.1} KiB SRAM ({:.1} KiB of it the \
         destination cache's per-sample planes at their widths, for {} KiB of dest_cache_bytes) + {:.1} KiB registers; area estimate \
         {:.2} mm² at {} ({:.2} SRAM + {:.2} registers + {:.2} operators: {} mul, {} add, {} recip, {} sqrt, {} cmp)",
        t.store_bytes as f64 / 1024.0,
        t.sram_bytes as f64 / 1024.0,
        dest as f64 / 1024.0,
        cfg.dest_cache_bytes / 1024,
        t.register_bytes as f64 / 1024.0,
        t.area_mm2,
        b.process_node,
        t.sram_area_mm2,
        t.register_area_mm2,
        t.logic_area_mm2,
        t.instances.mul,
        t.instances.add,
        t.instances.recip,
        t.instances.sqrt,
        t.instances.cmp,
    );
    s
}

/// The summary's DRAM utilisation: of the DRAM part's peak with DRAMsim3
/// (`dram_backend_utilisation`), else of the ideal channel's
/// (`dram_utilisation`).
fn utilisation(r: &HwRates) -> Option<f64> {
    r.dram.dram_backend_utilisation.or(r.dram_utilisation)
}

/// Total DRAM bytes per display pixel of `r`, NaN without pixels.
fn bytes_per_pixel(r: &HwRates) -> f64 {
    r.bytes_per_display_pixel.as_ref().map_or(f64::NAN, |b| b.iter().into_iter().map(|(_, v)| v).sum())
}

/// The configuration's name: the preset it equals, or "custom" with the
/// knobs that differ from the nearest preset.
fn config_name(cfg: &EngineConfig) -> String {
    let mut best: Option<(usize, &str, Vec<&str>)> = None;
    for p in postwarp_rtl::config::PRESETS {
        let base = EngineConfig::preset(p).expect("presets exist");
        let differ: Vec<&str> = postwarp_rtl::config::KNOBS
            .iter()
            .filter(|k| k.name != "supersample" && (k.get)(cfg) != (k.get)(&base))
            .map(|k| k.name)
            .collect();
        if best.as_ref().is_none_or(|b| differ.len() < b.0) {
            best = Some((differ.len(), p, differ));
        }
    }
    match best {
        Some((0, p, _)) => format!("preset {p}"),
        Some((_, p, d)) => format!("preset {p} with {} changed", d.join(", ")),
        None => "custom".into(),
    }
}
