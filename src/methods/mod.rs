//! Comparison methods: ways to make a derived frame from the same
//! [`FrameCommands`] and reference samples as the golden model, selectable
//! by name, so that speed and quality can be set side by side on the same
//! traces (`docs/methods.md`).
//!
//! A method is a [`Reconstruction`] (how reference samples become derived
//! samples) combined with a [`HoleFill`] (what fills what no reference
//! sample reached). Both write the golden model's derived planes
//! ([`DestPlanes`]: colour, 1/Z, source, `real`, `hole`), and every method
//! resolves to pixels with the golden model's resolve, so the metrics see
//! the same kind of image from all of them.
//!
//! Timing rules, the same for every method (`run::method`):
//! 1. [`Reconstruction::prepare`] runs once per reference frame and is timed
//!    apart (`prepare_ms`): work a renderer would do once per reference
//!    (A-buffer packing, mip-maps, quadtrees).
//! 2. `host_ms` is the median over several runs of
//!    [`Reconstruction::reconstruct`] plus [`HoleFill::fill`] on one
//!    thread, into an output frame allocated before the clock starts.
//! 3. `primitives` counts what the method draws (splats, quads, triangles,
//!    rectangles) or the work it does per ray or pixel (quadtree cells
//!    visited, gradient steps); [`MethodInfo::primitive`] names the unit.
//! 4. A method that warps a v2 trace's layers receives them in
//!    [`Reconstruction::prepare_layers`]; the others see only the
//!    reference image (the composited colour).

pub mod baselines;
pub mod didyk;
pub mod hole_fills;
pub mod lochmann;
pub mod mark;
pub mod schollmeyer;
pub mod smit;
#[cfg(test)]
mod test_frames;

use crate::golden::config::GoldenConfig;
use crate::golden::planes::DestPlanes;
use crate::golden::resolve::resolve;
use crate::trace::layers::Layers;
use bitvec::vec::BitVec;
use postwarp_rtl::{Camera, FrameCommands, SampleImage};
use serde_json::{Map, Value};
use std::any::Any;

pub use baselines::forward_splat::{ForwardSplatFrame, ForwardSplatStats, forward_splat};

/// Name, description and source of a reconstruction or a hole fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MethodInfo {
    /// Name on the command line (`--method`, `--hole-fill`).
    pub name: &'static str,
    /// One line: what it does.
    pub description: &'static str,
    /// The paper it comes from (seed file and section).
    pub paper: &'static str,
    /// Unit of `primitives` (plural noun), empty for hole fills.
    pub primitive: &'static str,
    /// The hole fill the paper pairs it with (reconstructions only).
    pub default_hole_fill: &'static str,
}

/// Per-reference data a reconstruction builds once ([`Reconstruction::prepare`]).
pub type Prepared = Box<dyn Any + Send + Sync>;

/// One frame's inputs: the commands and the reference samples
/// (`refs[j]` for `cmd.warps[j]`, each on its camera's sample grid), with
/// what [`Reconstruction::prepare`] made of each.
pub struct Input<'a> {
    /// The frame's commands (derived camera, warps in order).
    pub cmd: &'a FrameCommands,
    /// Reference samples in warp order.
    pub refs: &'a [&'a SampleImage],
    /// Prepared data of each reference, in warp order.
    pub prepared: &'a [&'a Prepared],
}

impl Input<'_> {
    /// Derived sample-grid size `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        let k = self.cmd.derived_camera.sample_grid(self.cmd.supersample).intrinsics;
        (k.width, k.height)
    }

    /// An empty derived frame of the sample-grid size.
    pub fn empty_frame(&self) -> DestPlanes {
        let (w, h) = self.size();
        DestPlanes::new(w, h)
    }
}

/// Counters a reconstruction or hole fill reports for one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Counters {
    /// Primitives drawn (in [`MethodInfo::primitive`] units).
    pub primitives: u64,
    /// Method-specific counters, each a number (unit in the key's docs).
    pub extra: Map<String, Value>,
}

/// How reference samples become derived samples.
pub trait Reconstruction: Send + Sync {
    /// Name, description, paper.
    fn info(&self) -> MethodInfo;

    /// Per-reference work done once (`ss`: super-samples per pixel axis).
    fn prepare(&self, _img: &SampleImage, _ss: u32) -> Prepared {
        Box::new(())
    }

    /// [`Reconstruction::prepare`] with the reference's v2 layers
    /// (transparent fragments, ray tree; both `None` for a v1 trace) and its
    /// camera (in pixels, as the trace gives it; `camera.sample_grid(ss)`
    /// is the image's). The default ignores both: a method that warps only
    /// the reference image sees a v2 trace's composited colour, as the
    /// hardware model does.
    fn prepare_layers(&self, img: &SampleImage, _layers: &Layers, _camera: &Camera, ss: u32) -> Prepared {
        self.prepare(img, ss)
    }

    /// Write the derived samples of `input` into `out` (empty, the
    /// sample-grid size): set `real`, `colour`, `inv_z` and `source` of
    /// every sample a surface covers.
    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters;

    /// This method configured with the golden model's knobs
    /// (`docs/golden.md`; `reconstruction` and `hole_fill` are set by the
    /// method and the hole fill, not by `cfg`), or `None` if the golden
    /// knobs do not apply to it (the default). `postwarp sweep` multiplies
    /// only the methods that return `Some` by its `[golden]` axes.
    fn with_golden_config(&self, _cfg: &GoldenConfig) -> Option<Box<dyn Reconstruction>> {
        None
    }

    /// Reconstruct and fill in one go. The default reconstructs, then
    /// calls `fill`; a method whose paper interleaves the two (Mark's
    /// per-warp hole fill) overrides it.
    fn reconstruct_and_fill(&self, input: &Input, fill: &dyn HoleFill, out: &mut DestPlanes) -> (Counters, Counters) {
        let r = self.reconstruct(input, out);
        let f = fill.fill(input, out);
        (r, f)
    }
}

/// What fills the derived samples no surface reached.
pub trait HoleFill: Send + Sync {
    /// Name, description, paper.
    fn info(&self) -> MethodInfo;

    /// Fill holes of `d` (samples with neither `real` nor `hole` set):
    /// write `colour` and set `hole`; never change a `real` sample.
    fn fill(&self, input: &Input, d: &mut DestPlanes) -> Counters;
}

/// Leave holes empty (they resolve to black).
pub struct NoFill;

impl HoleFill for NoFill {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "none",
            description: "no hole fill: samples no surface reached stay empty (black)",
            paper: "-",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, _input: &Input, _d: &mut DestPlanes) -> Counters {
        Counters::default()
    }
}

/// Every reconstruction, in listing order.
pub fn reconstructions() -> Vec<Box<dyn Reconstruction>> {
    vec![
        Box::new(mark::MarkAa::default()),
        Box::new(mark::MarkGeneral::default()),
        Box::new(baselines::forward_splat::ForwardSplat),
        Box::new(baselines::rubber_sheet::RubberSheet),
        Box::new(didyk::Didyk::single()),
        Box::new(didyk::Didyk::two_ref()),
        Box::new(schollmeyer::grid::Schollmeyer::new(schollmeyer::quadtree::Reduction::Cross)),
        Box::new(schollmeyer::grid::Schollmeyer::new(schollmeyer::quadtree::Reduction::Partial)),
        Box::new(schollmeyer::grid::Schollmeyer::new(schollmeyer::quadtree::Reduction::Irregular)),
        Box::new(schollmeyer::transparent::SchollmeyerTransparent::new(schollmeyer::transparent::Mode::RayCast)),
        Box::new(schollmeyer::transparent::SchollmeyerTransparent::new(schollmeyer::transparent::Mode::GlassDepth)),
        Box::new(smit::point::SmitPoint::default()),
        Box::new(smit::quad::SmitQuad::default()),
        Box::new(smit::mesh::SmitMesh::default()),
        Box::new(smit::mesh::SmitMesh::connected()),
        Box::new(lochmann::Lochmann::ray_tree()),
        Box::new(lochmann::Lochmann::naive()),
    ]
}

/// Every hole fill, in listing order.
pub fn hole_fills() -> Vec<Box<dyn HoleFill>> {
    vec![
        Box::new(NoFill),
        Box::new(mark::Epipolar),
        Box::new(hole_fills::stretch::Stretch),
        Box::new(hole_fills::pull_push::PullPush),
        Box::new(didyk::inpaint::DidykInpaint),
        Box::new(schollmeyer::low_pass_fill::LowPass),
    ]
}

/// The reconstruction called `name`, or an error listing the names.
pub fn reconstruction(name: &str) -> anyhow::Result<Box<dyn Reconstruction>> {
    let all = reconstructions();
    let names: Vec<&str> = all.iter().map(|m| m.info().name).collect::<Vec<_>>();
    let names = names.join(", ");
    all.into_iter()
        .find(|m| m.info().name == name)
        .ok_or_else(|| anyhow::anyhow!("unknown method `{name}` (known: {names}; `postwarp methods` lists them)"))
}

/// The hole fill called `name`, or an error listing the names.
pub fn hole_fill(name: &str) -> anyhow::Result<Box<dyn HoleFill>> {
    let all = hole_fills();
    let names: Vec<&str> = all.iter().map(|m| m.info().name).collect::<Vec<_>>();
    let names = names.join(", ");
    all.into_iter()
        .find(|m| m.info().name == name)
        .ok_or_else(|| anyhow::anyhow!("unknown hole fill `{name}` (known: {names}; `postwarp methods` lists them)"))
}

/// One derived frame made by a method.
#[derive(Clone, Debug)]
pub struct MethodFrame {
    /// Final derived samples.
    pub samples: DestPlanes,
    /// Resolved display pixels (linear RGB).
    pub pixels: Vec<[f32; 3]>,
    /// Pixels whose samples all hold real surfaces.
    pub covered: BitVec,
    /// Reconstruction counters.
    pub reconstruction: Counters,
    /// Hole-fill counters.
    pub hole_fill: Counters,
}

/// Run `rec` + `fill` on one frame into `out` (an empty frame from
/// [`Input::empty_frame`]) and resolve it.
pub fn render(rec: &dyn Reconstruction, fill: &dyn HoleFill, input: &Input, mut out: DestPlanes) -> MethodFrame {
    let (r, f) = rec.reconstruct_and_fill(input, fill, &mut out);
    let (pixels, covered) = resolve(&out, input.cmd.supersample);
    MethodFrame { samples: out, pixels, covered, reconstruction: r, hole_fill: f }
}
