//! Kernel setup's lines computed on a second host thread
//! (`Engine::look_ahead(true)`, the default on a multi-core host) give the
//! same planes, pixels and every counter as computing each line on the
//! clocked loop's thread when kernel setup reaches it
//! (`units::line_kernels`, rule 2), on every bundled trace, at the default
//! configuration, a small-cache one and the fixed-point datapath.

use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use std::path::PathBuf;

/// The first `frames` frames of `trace` under `cfg`, with the look-ahead
/// thread or without.
fn run(trace: &str, cfg: &EngineConfig, frames: usize, ahead: bool) -> Vec<FrameOutput> {
    let t = Trace::open(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap();
    let cfg = EngineConfig { supersample: t.display.supersample, ..cfg.clone() };
    let mut engine = Engine::new(cfg.clone()).unwrap();
    engine.look_ahead(ahead);
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

fn check(trace: &str, frames: usize) {
    let configs = [
        ("default", EngineConfig::default()),
        (
            "small-cache",
            EngineConfig { dest_cache_bytes: 16 * 1024, source_cache_bytes: 8 * 1024, ..Default::default() },
        ),
        ("fixed", EngineConfig { arith: "fixed".into(), ..Default::default() }),
    ];
    for (name, cfg) in configs {
        let (ahead, inline) = (run(trace, &cfg, frames, true), run(trace, &cfg, frames, false));
        assert_eq!(ahead.len(), inline.len());
        for (k, (a, b)) in ahead.iter().zip(&inline).enumerate() {
            let (fa, fb) = (a.stats.flat(), b.stats.flat());
            let diff: Vec<_> = fa.iter().zip(&fb).filter(|(x, y)| x != y).take(8).collect();
            assert!(diff.is_empty() && fa.len() == fb.len(), "{trace} {name} frame {k}: ahead vs inline {diff:?}");
            assert!(a.frame == b.frame, "{trace} {name} frame {k}: planes");
            assert_eq!(a.pixels, b.pixels, "{trace} {name} frame {k}: pixels");
            assert_eq!(a.unseen, b.unseen, "{trace} {name} frame {k}: unseen");
        }
    }
}

#[test]
fn look_ahead_is_exact_on_room() {
    check("room", 2);
}

#[test]
fn look_ahead_is_exact_on_occluders() {
    check("occluders", 2);
}

#[test]
fn look_ahead_is_exact_on_slants() {
    check("slants", 2);
}

#[test]
fn look_ahead_is_exact_on_hairball() {
    check("hairball", 1);
}

/// The one bundled trace with an unseen border: its fallback pass runs.
#[test]
fn look_ahead_is_exact_on_motorcycle() {
    check("motorcycle", 1);
}
