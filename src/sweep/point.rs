//! One point of a sweep: a trace, a method (with its hole fill and golden
//! knobs) or the hardware model (with its configuration), run over every
//! derived frame of the trace and reduced to [`Metrics`].
//!
//! A point runs through the same code as the single runs:
//! [`measure_method`] (`postwarp golden --method`) for CPU methods and
//! [`measure_hardware`] (`postwarp simulate`) for `hardware`; its metrics
//! are read from the `mean` and `total` of the report those build.

use crate::golden::config::GoldenConfig;
use crate::methods;
use crate::report::{MethodReport, SimulateReport};
use crate::run::hw_config_toml::to_json;
use crate::run::method::measure_method;
use crate::run::simulate::measure_hardware;
use crate::trace::Trace;
use anyhow::Context;
use postwarp_rtl::config::EngineConfig;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};
use std::path::Path;

/// What runs at a point.
#[derive(Clone, Debug, PartialEq)]
pub enum PointRun {
    /// A CPU method from the registry.
    Method {
        /// Reconstruction name.
        reconstruction: String,
        /// Hole-fill name.
        hole_fill: String,
        /// Golden knobs, for methods that take them.
        golden: Option<GoldenConfig>,
        /// Timed runs per frame (host time = median).
        runs: u32,
        /// Score FLIP.
        flip: bool,
    },
    /// The cycle-level hardware model.
    Hardware {
        /// The preset the configuration started from.
        preset: String,
        /// The configuration (`supersample` = the trace's).
        config: EngineConfig,
        /// Score FLIP.
        flip: bool,
    },
}

impl PointRun {
    /// The `method` column.
    pub fn method(&self) -> &str {
        match self {
            PointRun::Method { reconstruction, .. } => reconstruction,
            PointRun::Hardware { .. } => "hardware",
        }
    }

    /// The `hole_fill` column (empty for `hardware`, whose hole fill is
    /// built in).
    pub fn hole_fill(&self) -> &str {
        match self {
            PointRun::Method { hole_fill, .. } => hole_fill,
            PointRun::Hardware { .. } => "",
        }
    }

    /// The canonical description of the point, hashed for its file name:
    /// the trace's content identity and frames used, the method, hole
    /// fill, runs, whether FLIP is scored, and the complete golden or hardware configuration (so
    /// a knob given at its default value is the same point).
    pub fn key(&self, trace_identity: &str, frames: usize) -> String {
        let (golden, hardware, runs) = match self {
            PointRun::Method { golden, runs, .. } => (
                golden.as_ref().map_or(Value::Null, |g| serde_json::to_value(g).expect("config serializes")),
                Value::Null,
                json!(runs),
            ),
            PointRun::Hardware { config, .. } => (Value::Null, to_json(config), Value::Null),
        };
        let flip = match self {
            PointRun::Method { flip, .. } | PointRun::Hardware { flip, .. } => *flip,
        };
        let k = json!({
            "format": 2,
            "trace": trace_identity,
            "frames": frames,
            "method": self.method(),
            "hole_fill": self.hole_fill(),
            "runs": runs,
            "golden": golden,
            "hardware": hardware,
            "flip": flip,
        });
        serde_json::to_string(&k).expect("key serializes")
    }
}

/// Results of one point: means over its derived frames. `None` where a
/// metric does not apply (hardware columns of CPU methods and the
/// reverse) or nothing was scored (no ground truth).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Derived frames run (frames).
    pub frames: u64,
    /// Mean luma PSNR against ground truth (dB); frames with identical
    /// images (+inf) are left out of the mean, as in `report.json`.
    pub psnr_luma_db: Option<f64>,
    /// Mean luma SSIM (1).
    pub ssim_luma: Option<f64>,
    /// Mean of each frame's mean LDR-FLIP (1; lower is better).
    pub flip_mean: Option<f64>,
    /// Mean share of known pixels not covered by a real sample (fraction).
    pub hole_fraction: Option<f64>,
    /// Mean primitives drawn per frame, CPU methods (primitives).
    pub primitives_per_frame: Option<f64>,
    /// Mean rectangles per frame whose kernel exceeded `kernel_limit`
    /// (clipped or split), for methods that count them (`mark-aa`,
    /// `mark-general`) (rectangles).
    #[serde(default)]
    pub kernels_over_limit_per_frame: Option<f64>,
    /// Samples composited per destination sample filled, all frames
    /// together, for `mark-aa` and `mark-general` (writes/sample): about
    /// one per reference where rectangles tile without overlap; rectangle
    /// overlap (roll, minification) raises it.
    #[serde(default)]
    pub composite_writes_per_sample: Option<f64>,
    /// Mean over frames of the median host time of `runs` runs, CPU
    /// methods (ms; not deterministic).
    pub host_ms_per_frame: Option<f64>,
    /// Mean engine cycles per frame, hardware (cycles).
    pub cycles_per_frame: Option<f64>,
    /// Mean DRAM bytes read per frame, hardware (bytes).
    pub dram_read_bytes_per_frame: Option<f64>,
    /// Mean DRAM bytes written per frame, hardware (bytes).
    pub dram_write_bytes_per_frame: Option<f64>,
    /// DRAM bandwidth at the configuration's target frame rate, hardware
    /// (GB/s): mean bytes per frame · views · target rate.
    pub dram_gbps_at_target_rate: Option<f64>,
    /// Frames per second the engine sustains at its clock, hardware (Hz):
    /// clock / (mean cycles · views).
    pub frame_rate_at_clock_hz: Option<f64>,
    /// Destination-cache hits over accesses, all frames together,
    /// hardware (fraction).
    pub dest_cache_hit_rate: Option<f64>,
    /// Frames whose hardware image equals the golden model's bit for bit,
    /// hardware (frames).
    pub golden_identical_frames: Option<u64>,
    /// Mean RGB PSNR on the common mask of the point's run (dB;
    /// `docs/metrics.md`: known ∧ seen ∧ covered by this point).
    #[serde(default)]
    pub psnr_rgb_common_db: Option<f64>,
    /// Mean luma SSIM on the same mask (1).
    #[serde(default)]
    pub ssim_luma_common: Option<f64>,
    /// Mean LDR-FLIP on the same mask (1).
    #[serde(default)]
    pub flip_mean_common: Option<f64>,
    /// Mean pixels of that mask per frame (pixels).
    #[serde(default)]
    pub common_pixels_per_frame: Option<f64>,
    /// DRAM bytes over the frames' time at the clock, hardware (GB/s):
    /// the bandwidth the memory delivered (`dram_achieved_gbps`).
    #[serde(default)]
    pub dram_achieved_gbps: Option<f64>,
    /// Row hits over DRAMsim3 transactions, hardware with `dram_backend =
    /// "dramsim3"` (fraction; empty for `ideal`).
    #[serde(default)]
    pub dram_row_hit_rate: Option<f64>,
    /// Mean luma PSNR of the hardware image against the FP64 golden image
    /// of the same configuration with `arith = "float"`, hardware with
    /// `arith = "fixed"` (dB; frames identical to float left out).
    #[serde(default)]
    pub psnr_luma_vs_float_db: Option<f64>,
    /// Frames whose hardware image equals the float golden image bit for
    /// bit, hardware with `arith = "fixed"` (frames).
    #[serde(default)]
    pub vs_float_identical_frames: Option<u64>,
    /// Bits of the destination tile cache's per-sample planes at the
    /// configuration's widths, over 8, hardware (bytes/sample).
    #[serde(default)]
    pub dest_bytes_per_sample: Option<f64>,
}

/// (column, unit, description, deterministic) of every metric in
/// `results.csv`, in column order; each is a [`Metrics`] field.
pub const METRIC_COLUMNS: &[(&str, &str, &str, bool)] = &[
    ("psnr_luma_db", "dB", "mean luma PSNR against ground truth (+inf frames left out)", true),
    ("ssim_luma", "1", "mean luma SSIM", true),
    ("flip_mean", "1", "mean LDR-FLIP (lower is better)", true),
    ("hole_fraction", "fraction", "mean share of known pixels not covered by a real sample", true),
    ("primitives_per_frame", "primitives", "mean primitives drawn per frame (CPU methods)", true),
    (
        "kernels_over_limit_per_frame",
        "rectangles",
        "mean rectangles per frame whose kernel exceeded kernel_limit (mark-aa, mark-general)",
        true,
    ),
    (
        "composite_writes_per_sample",
        "writes/sample",
        "samples composited per destination sample filled (mark-aa, mark-general): about 1 per reference \
         without overlap, more where rectangles overlap",
        true,
    ),
    ("host_ms_per_frame", "ms", "mean over frames of the median host time of `runs` runs (CPU methods)", false),
    ("cycles_per_frame", "cycles", "mean engine cycles per frame (hardware)", true),
    ("dram_read_bytes_per_frame", "bytes", "mean DRAM bytes read per frame (hardware)", true),
    ("dram_write_bytes_per_frame", "bytes", "mean DRAM bytes written per frame (hardware)", true),
    ("dram_gbps_at_target_rate", "GB/s", "DRAM bandwidth at target_frame_rate_hz for every view (hardware)", true),
    ("frame_rate_at_clock_hz", "Hz", "frames per second at clock_hz, every view (hardware)", true),
    ("dest_cache_hit_rate", "fraction", "destination-cache hits / accesses over all frames (hardware)", true),
    ("golden_identical_frames", "frames", "frames whose image equals the golden model's bit for bit (hardware)", true),
    (
        "psnr_rgb_common_db",
        "dB",
        "mean RGB PSNR on the point's common mask: known pixels a reference sees that the point covers",
        true,
    ),
    ("ssim_luma_common", "1", "mean luma SSIM on the point's common mask", true),
    ("flip_mean_common", "1", "mean LDR-FLIP on the point's common mask (lower is better)", true),
    (
        "common_pixels_per_frame",
        "pixels",
        "mean pixels per frame of the point's common mask (compare points over equal counts)",
        true,
    ),
    (
        "dram_achieved_gbps",
        "GB/s",
        "DRAM bytes over the frames' time at clock_hz: the bandwidth the memory delivered (hardware)",
        true,
    ),
    ("dram_row_hit_rate", "fraction", "row hits / DRAMsim3 transactions (hardware, dram_backend = dramsim3)", true),
    (
        "psnr_luma_vs_float_db",
        "dB",
        "mean luma PSNR against the FP64 golden image of the same configuration (hardware, arith = fixed; identical \
         frames left out)",
        true,
    ),
    (
        "vs_float_identical_frames",
        "frames",
        "frames equal bit for bit to the FP64 golden image (hardware, arith = fixed)",
        true,
    ),
    (
        "dest_bytes_per_sample",
        "bytes/sample",
        "destination tile cache bytes per sample, all planes at the configuration's widths (hardware)",
        true,
    ),
];

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

impl Metrics {
    /// From a `postwarp golden --method` report (its `mean`, and its
    /// frames' reconstruction counters).
    pub fn from_method_report(r: &MethodReport) -> Metrics {
        let m = &r.mean;
        Metrics {
            frames: r.frames.len() as u64,
            psnr_luma_db: m.scores.psnr_luma_db,
            ssim_luma: m.scores.ssim_luma,
            flip_mean: m.scores.flip_mean,
            hole_fraction: m.scores.hole_fraction,
            primitives_per_frame: finite(m.primitives),
            host_ms_per_frame: finite(m.host_ms),
            kernels_over_limit_per_frame: r.mean_reconstruction_counter("kernels_over_limit"),
            composite_writes_per_sample: r.reconstruction_ratio("composite_writes", "composite_filled"),
            psnr_rgb_common_db: m.scores.psnr_rgb_common_db,
            ssim_luma_common: m.scores.ssim_luma_common,
            flip_mean_common: m.scores.flip_mean_common,
            common_pixels_per_frame: m.pixels.common_pixels,
            ..Metrics::default()
        }
    }

    /// From a `postwarp simulate` report (its `mean` and `total`).
    pub fn from_hardware_report(r: &SimulateReport) -> Metrics {
        let (m, t) = (&r.mean, &r.total);
        let q = m.vs_truth.as_ref().map(|t| &t.scores);
        Metrics {
            frames: r.frames.len() as u64,
            psnr_luma_db: q.and_then(|q| q.psnr_luma_db),
            ssim_luma: q.and_then(|q| q.ssim_luma),
            flip_mean: q.and_then(|q| q.flip_mean),
            hole_fraction: q.and_then(|q| q.hole_fraction),
            cycles_per_frame: finite(m.counters.cycles),
            dram_read_bytes_per_frame: finite(m.counters.dram_read_bytes),
            dram_write_bytes_per_frame: finite(m.counters.dram_write_bytes),
            dram_gbps_at_target_rate: finite(m.rates.dram_gbps_at_target_rate),
            frame_rate_at_clock_hz: m.rates.frame_rate_at_clock_hz,
            dest_cache_hit_rate: m.rates.dest_cache_hit_rate,
            golden_identical_frames: Some(t.identical_frames),
            psnr_rgb_common_db: q.and_then(|q| q.psnr_rgb_common_db),
            ssim_luma_common: q.and_then(|q| q.ssim_luma_common),
            flip_mean_common: q.and_then(|q| q.flip_mean_common),
            common_pixels_per_frame: m.vs_truth.as_ref().and_then(|t| t.pixels.common_pixels),
            dram_achieved_gbps: m.rates.dram.dram_achieved_gbps,
            dram_row_hit_rate: m.rates.dram.dram_row_hit_rate,
            dest_bytes_per_sample: crate::report::budget::dest_bytes_per_sample(&r.budget),
            ..Metrics::default()
        }
    }

    /// The value of metric column `col` as CSV text (empty if `None`).
    pub fn cell(&self, col: &str) -> String {
        let v = serde_json::to_value(self).expect("metrics serialize");
        match &v[col] {
            Value::Null => String::new(),
            // This struct's own field, printed; not a report value read.
            Value::Number(n) if n.is_u64() || n.is_i64() => n.to_string(),
            Value::Number(n) => {
                let x = n.as_f64().unwrap_or(f64::NAN); // own field
                format!("{x}")
            }
            other => other.to_string(),
        }
    }
}

/// Run one point on `trace` (already limited to the frames used). With
/// `images`, the run's frames, heat-maps and `report.json` are written
/// there, as `postwarp golden --method` / `postwarp simulate` would.
pub fn run_point(run: &PointRun, trace: &Trace, images: Option<&Path>) -> anyhow::Result<Metrics> {
    let quiet = indicatif::ProgressBar::hidden();
    // The image folder is built under a temporary name and replaces an
    // older one whole (a point is recomputed when another build stored it).
    let staged = images.map(|d| crate::io_util::OutDir::create(d, true, &[&trace.manifest])).transpose()?;
    let images = staged.as_ref().map(|s| s.path());
    let m = match run {
        PointRun::Method { reconstruction, hole_fill, golden, runs, flip } => {
            let mut rec = methods::reconstruction(reconstruction)?;
            if let Some(cfg) = golden {
                rec = rec
                    .with_golden_config(cfg)
                    .with_context(|| format!("method {reconstruction} does not take golden knobs"))?;
            }
            let fill = methods::hole_fill(hole_fill)?;
            let r = measure_method(trace, rec.as_ref(), fill.as_ref(), *runs, *flip, images, &quiet)?;
            Metrics::from_method_report(&r.report)
        }
        PointRun::Hardware { config, flip, .. } => {
            let r = measure_hardware(trace, config, *flip, images, &quiet)?;
            let mut m = Metrics::from_hardware_report(&r.report);
            if !r.vs_float_luma_db.is_empty() {
                // Identical frames (+inf) are left out of the mean, as
                // report.json's means leave them out.
                let finite: Vec<f64> = r.vs_float_luma_db.iter().copied().filter(|x| x.is_finite()).collect();
                m.psnr_luma_vs_float_db =
                    (!finite.is_empty()).then(|| finite.iter().sum::<f64>() / finite.len() as f64);
                m.vs_float_identical_frames = Some((r.vs_float_luma_db.len() - finite.len()) as u64);
            }
            m
        }
    };
    if let Some(s) = staged {
        s.commit()?;
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_metric_column_is_a_field_and_cells_print_numbers_exactly() {
        let m = Metrics { psnr_luma_db: Some(0.1 + 0.2), golden_identical_frames: Some(2), ..Metrics::default() };
        let v = serde_json::to_value(&m).unwrap();
        let fields: Vec<&String> = v.as_object().unwrap().keys().filter(|k| *k != "frames").collect();
        let cols: Vec<&str> = METRIC_COLUMNS.iter().map(|c| c.0).collect();
        assert_eq!(fields, cols);
        assert_eq!(m.cell("psnr_luma_db"), "0.30000000000000004");
        assert_eq!(m.cell("golden_identical_frames"), "2");
        assert_eq!(m.cell("ssim_luma"), "");
        let back: Metrics = serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn keys_ignore_how_a_default_was_reached_but_not_the_trace() {
        let a = PointRun::Method {
            reconstruction: "m".into(),
            hole_fill: "f".into(),
            golden: Some(GoldenConfig::default()),
            runs: 1,
            flip: false,
        };
        assert_eq!(a.key("t", 2), a.clone().key("t", 2));
        assert_ne!(a.key("t", 2), a.key("u", 2));
        assert_ne!(a.key("t", 2), a.key("t", 1));
        let h = PointRun::Hardware { preset: "mark1998".into(), config: EngineConfig::default(), flip: false };
        assert!(h.key("t", 1).contains("\"dest_cache_bytes\":1048576"));
        // Scoring FLIP is another point.
        let hf = PointRun::Hardware { preset: "mark1998".into(), config: EngineConfig::default(), flip: true };
        assert_ne!(h.key("t", 1), hf.key("t", 1));
        assert_eq!(h.hole_fill(), "");
    }
}
