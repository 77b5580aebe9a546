//! The hardware model stays bit-exact with the golden model at the
//! smallest displays: 1 to 4 pixels a side, super-sampling 1 to 4 and
//! A-buffer fragments 0 to 4, on every built-in scene (a property suite:
//! random cases per scene, plus the corner that once diverged, 1x1 at 4x4
//! samples with 1 to 3 fragments, where a merged plane ran past the
//! horizon and the golden model kept a depth memory does not hold).

use postwarp::run::simulate::measure_hardware;
use postwarp::scene::Scene;
use postwarp::trace::Trace;
use postwarp::tracegen::{TraceSpec, make_trace};
use postwarp_rtl::config::EngineConfig;
use proptest::prelude::*;

use crate::common;

/// Render `scene` at `w`x`h`, `ss`x`ss` samples, two derived frames, and
/// return how many of them the hardware model reproduces bit for bit.
fn identical(scene: &str, (w, h, ss, fragments): (u32, u32, u32, u32)) -> (u64, u64) {
    let dir = tempfile::tempdir().unwrap();
    let spec = TraceSpec { width: w, height: h, supersample: ss, frames: 2, truth: false, ..TraceSpec::default() };
    let s = Scene::builtin(scene).unwrap();
    let manifest = make_trace(&s, &spec, &dir.path().join("t"), "hw_tiny_displays").unwrap();
    let trace = Trace::open(&manifest).unwrap();
    let d = EngineConfig::default();
    // Tiles hold whole pixels: 3x3 super-sampling needs a multiple of 3.
    let tile_size = if d.tile_size % ss == 0 { d.tile_size } else { 4 * ss };
    let cfg = EngineConfig { abuffer_fragments: fragments, tile_size, ..d };
    let r = measure_hardware(&trace, &cfg, false, None, &indicatif::ProgressBar::hidden()).unwrap();
    (r.report.total.identical_frames, r.report.total.frames)
}

fn case() -> impl Strategy<Value = (u32, u32, u32, u32)> {
    (1u32..=4, 1u32..=4, 1u32..=4, 0u32..=4)
}

#[test]
fn one_pixel_at_4x4_samples_with_lossy_fragments() {
    for f in 1..=3 {
        let (same, frames) = identical("occluders", (1, 1, 4, f));
        assert_eq!(same, frames, "occluders 1x1, 4x4 samples, {f} fragments");
    }
}

proptest! {
    #![proptest_config(common::prop_config(24))]

    #[test]
    fn tiny_displays_match_the_golden_model_on_every_scene(c in case()) {
        for &scene in Scene::builtin_names() {
            let (same, frames) = identical(scene, c);
            prop_assert_eq!(same, frames, "{} at {}x{} px, {}x{} samples, {} fragments", scene, c.0, c.1, c.2, c.2, c.3);
        }
    }
}
