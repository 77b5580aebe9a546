//! `report.json` of `postwarp simulate`: per frame the hardware counters
//! ([`HwCounters`]) and their rates ([`HwRates`]), the comparison with the
//! golden model (`vs_golden`) and the quality against ground truth
//! (`vs_truth`); `total` and `mean` by the key rules.

use super::hardware::{HwCounters, HwRates, counter_keys, rate_keys};
use super::keys::{KeyDoc, Reduce, Shape, nested, scalar};
use super::quality::{Pixels, Truth};
use super::{REPORT_VERSION, ReportKind};
use postwarp_rtl::config::{EngineConfig, KNOBS};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The hardware image against the golden model's, one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VsGolden {
    /// No differing sample and the same resolved pixels.
    pub identical: bool,
    /// Derived samples whose memory planes differ (samples).
    pub differing_samples: u64,
    /// RGB PSNR of the hardware image against the golden image (dB;
    /// `null` when identical).
    pub psnr_db: Option<f64>,
}

/// `vs_golden` in `total`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VsGoldenTotal {
    /// Differing samples over all frames (samples).
    pub differing_samples: u64,
}

/// `vs_golden` in `mean`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VsGoldenMean {
    /// Differing samples per frame (samples).
    pub differing_samples: f64,
    /// Mean PSNR over the frames that differ (dB).
    pub psnr_db: Option<f64>,
}

/// One derived frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HwFrame {
    /// Derived frame index in the trace.
    pub index: usize,
    /// The hardware model's counters.
    #[serde(flatten)]
    pub counters: HwCounters<u64>,
    /// Their rates.
    #[serde(flatten)]
    pub rates: HwRates,
    /// Against the golden model.
    pub vs_golden: VsGolden,
    /// Against ground truth (`null` without it).
    pub vs_truth: Option<Truth<u64>>,
    /// Host time of the hardware model (ms).
    pub host_ms: f64,
    /// Host time of the golden model on the same frame (ms).
    pub golden_host_ms: f64,
}

/// `total` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HwTotal {
    /// Derived frames (frames).
    pub frames: u64,
    /// Frames bit-identical to the golden model (frames).
    pub identical_frames: u64,
    /// Counters.
    #[serde(flatten)]
    pub counters: HwCounters<u64>,
    /// Against the golden model.
    pub vs_golden: VsGoldenTotal,
    /// Pixel counts against ground truth.
    pub vs_truth: Option<Pixels<u64>>,
    /// Host time of the hardware model (ms).
    pub host_ms: f64,
    /// Host time of the golden model (ms).
    pub golden_host_ms: f64,
}

/// `mean` over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HwMean {
    /// Counters per frame.
    #[serde(flatten)]
    pub counters: HwCounters<f64>,
    /// Rates of the mean counters.
    #[serde(flatten)]
    pub rates: HwRates,
    /// Against the golden model.
    pub vs_golden: VsGoldenMean,
    /// Against ground truth.
    pub vs_truth: Option<Truth<f64>>,
    /// Host time per frame (ms).
    pub host_ms: f64,
    /// Golden host time per frame (ms).
    pub golden_host_ms: f64,
}

/// `report.json` of `postwarp simulate`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimulateReport {
    /// [`super::REPORT_VERSION`].
    pub report_version: u32,
    /// [`ReportKind::Simulate`].
    pub kind: ReportKind,
    /// Path of the trace manifest.
    pub trace: String,
    /// FLIP scored (`--flip`); false: the FLIP keys are null.
    pub flip: bool,
    /// `mark-hw`.
    pub method: String,
    /// Every hardware knob: value, in `KNOBS` order.
    pub config: Map<String, Value>,
    /// The trace's super-sampling replaced the configuration's.
    pub supersample_from_trace: bool,
    /// The v2 layer kinds the trace holds, which the (diffuse) hardware
    /// model ignored (`[]` for a v1 trace).
    #[serde(default)]
    pub ignored_layers: Vec<String>,
    /// Per derived frame.
    pub frames: Vec<HwFrame>,
    /// Sums over frames.
    pub total: HwTotal,
    /// Means over frames.
    pub mean: HwMean,
    /// The SRAM and arithmetic budget of the configuration
    /// (`super::budget`; `null` in files written before it).
    #[serde(default)]
    pub budget: Value,
}

impl SimulateReport {
    /// The report of `frames` run with `cfg`: `total` and `mean` by the key
    /// rules, the mean's rates from the mean counters.
    pub fn new(
        trace: String,
        flip: bool,
        cfg: &EngineConfig,
        supersample_from_trace: bool,
        frames: Vec<HwFrame>,
    ) -> Self {
        let identical = frames.iter().filter(|f| f.vs_golden.identical).count();
        let (total, mut mean): (HwTotal, HwMean) = super::reduce(&frames, &frame_keys(), |t| {
            t.insert("frames".into(), frames.len().into());
            t.insert("identical_frames".into(), identical.into());
        });
        mean.rates = HwRates::of(&mean.counters, cfg);
        SimulateReport {
            report_version: REPORT_VERSION,
            kind: ReportKind::Simulate,
            trace,
            flip,
            method: "mark-hw".into(),
            config: crate::run::hw_config_toml::to_json_map(cfg),
            supersample_from_trace,
            ignored_layers: Vec::new(),
            frames,
            total,
            mean,
            budget: super::budget::to_json(&postwarp_rtl::budget::Budget::of(cfg)),
        }
    }
}

fn vs_golden_keys() -> Vec<KeyDoc> {
    vec![
        scalar("identical", "bool", Reduce::Once, "no differing sample and the same resolved pixels"),
        scalar(
            "differing_samples",
            "samples",
            Reduce::Sum,
            "derived samples whose memory planes differ from the golden model's (colour, real and hole flags; 1/Z \
             and source where real)",
        ),
        scalar(
            "psnr_db",
            "dB",
            Reduce::Mean,
            "RGB PSNR of the hardware image against the golden image on 8-bit sRGB codes over all pixels; `null` when \
             identical (+∞)",
        ),
    ]
}

/// Keys of a frame.
pub fn frame_keys() -> Vec<KeyDoc> {
    let mut k = vec![scalar("index", "—", Reduce::Once, "derived frame index in the trace")];
    k.extend(counter_keys());
    k.extend(rate_keys());
    k.extend([
        nested("vs_golden", Reduce::Sum, vs_golden_keys, "comparison with the golden model on the same frame"),
        nested(
            "vs_truth",
            Reduce::Sum,
            super::quality::keys,
            "the hardware image scored against ground truth, with the golden report's metric keys; a pixel is \
             covered when all its samples hold real surfaces; `null` for a frame without ground truth",
        ),
        scalar(
            "host_ms",
            "ms",
            Reduce::Sum,
            "host time of the hardware model for this frame, one core (not deterministic)",
        ),
        scalar(
            "golden_host_ms",
            "ms",
            Reduce::Sum,
            "host time of the golden model for the same frame, one core (not deterministic)",
        ),
    ]);
    k
}

fn total_keys() -> Vec<KeyDoc> {
    let mut k = super::total_keys(frame_keys());
    k.insert(1, scalar("identical_frames", "frames", Reduce::Once, "frames bit-identical to the golden model"));
    k
}

fn mean_keys() -> Vec<KeyDoc> {
    super::mean_keys(frame_keys())
}

fn config_keys() -> Vec<KeyDoc> {
    KNOBS.iter().map(|k| scalar(k.name, k.unit, Reduce::Once, k.description)).collect()
}

/// Top-level keys.
pub fn report_keys() -> Vec<KeyDoc> {
    let mut k = super::header_keys();
    k.extend([
        scalar("method", "—", Reduce::Once, "`mark-hw`"),
        nested(
            "config",
            Reduce::Once,
            config_keys,
            "every hardware knob (`docs/units.md`) after the trace's `supersample` was applied",
        ),
        scalar(
            "supersample_from_trace",
            "bool",
            Reduce::Once,
            "true if the trace's super-sampling replaced the configuration's `supersample`",
        ),
        KeyDoc {
            key: "ignored_layers",
            unit: "—",
            reduce: Reduce::Once,
            shape: Shape::List,
            meaning: "the v2 layer kinds the trace holds (`fragments`, `raytree`; `[]` for a v1 trace): the hardware \
                      model is diffuse, as TR98 proposes, and warps only the reference images' composited colour; these \
                      layers were not used (`docs/non-diffuse.md`)",
        },
        nested("frames", Reduce::Once, frame_keys, "one object per derived frame"),
        nested("total", Reduce::Once, total_keys, "sums over frames (key rules)"),
        nested("mean", Reduce::Once, mean_keys, "means over frames (key rules); rates from the mean counters"),
        nested(
            "budget",
            Reduce::Once,
            super::budget::keys,
            "SRAM bytes of every on-chip store, operators per item of every datapath and a 45 nm area estimate for \
             this configuration, with the frame and reference sizes of the trace (`docs/budget.md`)",
        ),
    ]);
    k
}
