//! Mark's methods (seed 003, TR98-011) as comparison methods: the golden
//! model's two reconstructions and its epipolar hole fill, behind the same
//! interface as the other papers' methods.
//!
//! - `mark-aa`: anti-aliased flat axis-aligned rectangles (TR98 §7.2), the
//!   hardware's path; primitives = rectangles (kernels) drawn.
//! - `mark-general`: triangle mesh inside surfaces plus edge splats
//!   (TR98 §7.1); primitives = triangles + splats.
//! - hole fill `epipolar`: TR98 §9's pass. Paired with a Mark
//!   reconstruction it runs after *each* reference warp, as in the paper
//!   (the golden model's own loop); after another method's reconstruction
//!   it runs once per reference epipole, in warp order, on the finished
//!   frame. Either way the fallback pass (`golden::fallback_fill`) follows
//!   it after the last warp, as the golden model's `fallback_fill` knob
//!   (default on) says.
//!
//! Rules: the golden configuration is the default (`docs/golden.md`), or
//! the one given to [`Reconstruction::with_golden_config`] (`postwarp
//! sweep`'s `[golden]` knobs), with only the reconstruction and the hole
//! fill switched; the A-buffer trip of
//! each reference is [`Reconstruction::prepare`] (timed apart, as the
//! golden run's `prepare_ms`); the derived frame's A-buffer trips between
//! warps are part of the method and of its time.

use super::{Counters, HoleFill, Input, MethodInfo, Prepared, Reconstruction};
use crate::golden::config::{GoldenConfig, Reconstruction as Path};
use crate::golden::fallback_fill::{FallbackStats, fallback_fill};
use crate::golden::frame::{GoldenStats, PreparedReference, Warper, prepare_reference};
use crate::golden::hole_fill::{HoleFillParams, hole_fill};
use crate::golden::planes::DestPlanes;
use postwarp_rtl::SampleImage;
use serde_json::{Map, Value, json};
use std::sync::Mutex;

/// The golden model's anti-aliased path.
#[derive(Default)]
pub struct MarkAa {
    warper: Mutex<Warper>,
    /// Knobs (`reconstruction` and `hole_fill` are overridden per run).
    cfg: GoldenConfig,
}

/// The golden model's general path.
#[derive(Default)]
pub struct MarkGeneral {
    warper: Mutex<Warper>,
    /// Knobs (`reconstruction` and `hole_fill` are overridden per run).
    cfg: GoldenConfig,
}

fn config(base: &GoldenConfig, path: Path, hole_fill: bool) -> GoldenConfig {
    GoldenConfig { reconstruction: path, hole_fill, fallback_fill: hole_fill && base.fallback_fill, ..base.clone() }
}

fn prepared<'a>(input: &'a Input) -> Vec<&'a PreparedReference> {
    input
        .prepared
        .iter()
        .map(|p| p.downcast_ref::<PreparedReference>().expect("prepared by a Mark reconstruction"))
        .collect()
}

/// Run the golden model; with `fill` = the epipolar fill, inside its loop.
fn run(
    warper: &Mutex<Warper>,
    base: &GoldenConfig,
    path: Path,
    input: &Input,
    fill: Option<&dyn HoleFill>,
    out: &mut DestPlanes,
) -> (Counters, Counters) {
    let inside = fill.is_some_and(|f| f.info().name == Epipolar.info().name);
    let cfg = config(base, path, inside);
    let refs = prepared(input);
    let frame = warper.lock().expect("warper lock").warp_frame(input.cmd, &refs, &cfg);
    *out = frame.samples;
    let rec = counters(path, &frame.stats);
    let filled = match fill {
        Some(_) if inside => Counters {
            primitives: 0,
            extra: [
                ("filled".to_string(), json!(frame.stats.hole_fill_filled)),
                ("unreached".to_string(), json!(frame.stats.hole_fill_unreached)),
                ("fallback_filled".to_string(), json!(frame.stats.fallback_filled)),
                ("fallback_unreached".to_string(), json!(frame.stats.fallback_unreached)),
            ]
            .into_iter()
            .collect(),
        },
        Some(f) => f.fill(input, out),
        None => Counters::default(),
    };
    (rec, filled)
}

fn counters(path: Path, st: &GoldenStats) -> Counters {
    let kernels: u64 = st.kernel_sizes.iter().flatten().sum();
    let primitives = match path {
        Path::AaRect => kernels,
        Path::General => st.mesh_triangles + st.edge_splats,
    };
    let mut extra = Map::new();
    for (k, v) in [
        ("reference_samples", st.reference_samples),
        ("culled_samples", st.culled_samples),
        ("kernels_over_limit", st.kernels_over_limit),
        ("discontinuous_groups", st.discontinuous_groups),
        ("mesh_triangles", st.mesh_triangles),
        ("edge_splats", st.edge_splats),
        ("forced_merges", st.forced_merges),
        ("composite_filled", st.composite_filled),
        ("composite_writes", st.composite_filled + st.composite_nearer + st.composite_better + st.composite_lost),
    ] {
        extra.insert(k.to_string(), Value::from(v));
    }
    Counters { primitives, extra }
}

impl Reconstruction for MarkAa {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "mark-aa",
            description: "Mark's anti-aliased reconstruction: flat axis-aligned rectangles of at most 4x4 samples",
            paper: "003 Mark et al. TR98-011 §7.2",
            primitive: "rectangles",
            default_hole_fill: "epipolar",
        }
    }

    fn prepare(&self, img: &SampleImage, ss: u32) -> Prepared {
        Box::new(prepare_reference(img, ss, &self.cfg))
    }

    fn with_golden_config(&self, cfg: &GoldenConfig) -> Option<Box<dyn Reconstruction>> {
        Some(Box::new(MarkAa { warper: Mutex::default(), cfg: cfg.clone() }))
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        run(&self.warper, &self.cfg, Path::AaRect, input, None, out).0
    }

    fn reconstruct_and_fill(&self, input: &Input, fill: &dyn HoleFill, out: &mut DestPlanes) -> (Counters, Counters) {
        run(&self.warper, &self.cfg, Path::AaRect, input, Some(fill), out)
    }
}

impl Reconstruction for MarkGeneral {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "mark-general",
            description: "Mark's general reconstruction: triangle mesh inside surfaces, edge splats at discontinuities",
            paper: "003 Mark et al. TR98-011 §7.1",
            primitive: "triangles + splats",
            default_hole_fill: "epipolar",
        }
    }

    fn prepare(&self, img: &SampleImage, ss: u32) -> Prepared {
        Box::new(prepare_reference(img, ss, &self.cfg))
    }

    fn with_golden_config(&self, cfg: &GoldenConfig) -> Option<Box<dyn Reconstruction>> {
        Some(Box::new(MarkGeneral { warper: Mutex::default(), cfg: cfg.clone() }))
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        run(&self.warper, &self.cfg, Path::General, input, None, out).0
    }

    fn reconstruct_and_fill(&self, input: &Input, fill: &dyn HoleFill, out: &mut DestPlanes) -> (Counters, Counters) {
        run(&self.warper, &self.cfg, Path::General, input, Some(fill), out)
    }
}

/// Mark's epipolar hole fill (TR98 §9) as a stand-alone pass.
pub struct Epipolar;

impl HoleFill for Epipolar {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "epipolar",
            description: "Mark's epipolar hole fill: propagate background colour from the previous line in the inverse occlusion-compatible order, blurred by 3 (5 far) taps; after the last warp the same pass in reverse order fills what it could not reach",
            paper: "003 Mark et al. TR98-011 §9",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, input: &Input, d: &mut DestPlanes) -> Counters {
        let g = GoldenConfig::default();
        let p = HoleFillParams {
            far_distance: g.hole_far_distance,
            far_offset: g.hole_far_offset,
            max_distance: g.hole_max_distance,
            fixed: None,
        };
        let (mut filled, mut unreached) = (0u64, 0u64);
        for warp in &input.cmd.warps {
            d.begin_warp();
            let st = hole_fill(d, &warp.setup.epipole_derived, &p);
            filled += st.filled;
            unreached += st.unreached;
        }
        let mut fallback = FallbackStats::default();
        if g.fallback_fill
            && let Some(last) = input.cmd.warps.last()
        {
            fallback = fallback_fill(d, &last.setup.epipole_derived, &p).0;
        }
        let mut extra = Map::new();
        extra.insert("filled".into(), json!(filled));
        extra.insert("unreached".into(), json!(unreached));
        extra.insert("fallback_filled".into(), json!(fallback.filled));
        extra.insert("fallback_unreached".into(), json!(fallback.unreached));
        Counters { primitives: 0, extra }
    }
}
