//! Runs of the hardware model over a bundled trace, for the tests that
//! compare two ways of running it (`hw_skip_exact.rs`, `hw_look_ahead.rs`).

use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use std::path::PathBuf;

/// The first `frames` frames of bundled trace `trace` under `cfg` (its
/// supersampling taken from the trace), on an engine `set` adjusts first.
pub fn run_frames(trace: &str, cfg: &EngineConfig, frames: usize, set: impl Fn(&mut Engine)) -> Vec<FrameOutput> {
    let t = Trace::open(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap();
    let cfg = EngineConfig { supersample: t.display.supersample, ..cfg.clone() };
    let mut engine = Engine::new(cfg.clone()).unwrap();
    set(&mut engine);
    (0..frames.min(t.derived.len()))
        .map(|k| {
            let refs: Vec<HwReference> = t.derived[k]
                .references
                .iter()
                .map(|&r| HwReference::new(&t.load_reference(r).unwrap().samples, &cfg))
                .collect();
            engine.run_frame(&t.frame_commands(k), &refs.iter().collect::<Vec<_>>())
        })
        .collect()
}
