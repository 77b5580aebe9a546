//! The standard benchmark frames, built once here for `cargo bench`
//! (`benches/golden.rs`, `benches/simulate.rs`) and `postwarp bench`, so
//! every figure is quoted on the same input.
//!
//! The frame: derived frame [`FRAME`] of the built-in scene `room` as
//! `postwarp make-trace --scene room --width 640 --height 480
//! --supersample 2` would write it (default spec otherwise: 88x68°
//! references, spline path, prediction 0.4 s, start 0.5 s), with its
//! references 0 and 1 (2140x1496 samples each), colour rounded to half as
//! the trace stores it ([`frame_in_memory`]).

use crate::scene::Scene;
use crate::tracegen::{TraceSpec, frame_in_memory, write_frame_trace};
use postwarp_rtl::{FrameCommands, SampleImage};
use std::path::{Path, PathBuf};

/// Derived frame benchmarked (its references are 0 and 1).
pub const FRAME: usize = 3;

/// Built-in scene of the benchmark frame.
pub const SCENE: &str = "room";

/// The standard frame's spec: 640x480 with 2x2 samples per pixel.
pub fn standard_spec() -> TraceSpec {
    TraceSpec { width: 640, height: 480, supersample: 2, ..TraceSpec::default() }
}

/// A frame of the `hmd2026` preset's display size (2000x2000 with 2x2
/// samples per pixel), for `postwarp bench --hmd`; with `quick`, 200x200
/// (for tests).
pub fn hmd_spec(quick: bool) -> TraceSpec {
    let side = if quick { 200 } else { 2000 };
    TraceSpec { width: side, height: side, supersample: 2, ..TraceSpec::default() }
}

/// A small frame of the same scene and path (160x120, 2x2 samples) for
/// quick checks (`postwarp bench --quick`).
pub fn quick_spec() -> TraceSpec {
    TraceSpec { width: 160, height: 120, supersample: 2, ..TraceSpec::default() }
}

/// One derived frame's commands and its two references' samples.
pub struct BenchFrame {
    /// The spec it was made with.
    pub spec: TraceSpec,
    /// The derived frame's commands (warps of references 0 and 1).
    pub cmd: FrameCommands,
    /// The references as the trace stores them (before the A-buffer).
    pub refs: Vec<SampleImage>,
}

impl BenchFrame {
    /// Render derived frame [`FRAME`] of [`SCENE`] under `spec`.
    pub fn new(spec: TraceSpec) -> anyhow::Result<BenchFrame> {
        let scene = Scene::builtin(SCENE)?;
        let (cmd, refs) = frame_in_memory(&scene, &spec, FRAME)?;
        Ok(BenchFrame { spec, cmd, refs })
    }

    /// Total reference samples (both references, valid or not).
    pub fn reference_samples(&self) -> u64 {
        self.refs.iter().map(|r| r.len() as u64).sum()
    }

    /// Write the frame as a one-frame trace (with ground truth) into `out`.
    pub fn write_trace(&self, out: &Path) -> anyhow::Result<PathBuf> {
        let scene = Scene::builtin(SCENE)?;
        write_frame_trace(&scene, &self.spec, FRAME, &self.refs, out)
    }
}
