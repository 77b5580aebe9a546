//! Kernel setup's lines computed on another host thread
//! (`Engine::look_ahead(true)`, the default on a multi-core host) give the
//! same planes, pixels and every counter as computing each line on the
//! clocked loop's thread when kernel setup reaches it
//! (`units::line_kernels`, rule 2), on every bundled trace, at the default
//! configuration, a small-cache one and the fixed-point datapath.

use crate::common::engine_runs::run_frames;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::FrameOutput;

/// The first `frames` frames of `trace` under `cfg`, with the look-ahead thread or without.
fn run(trace: &str, cfg: &EngineConfig, frames: usize, ahead: bool) -> Vec<FrameOutput> {
    run_frames(trace, cfg, frames, |e| e.look_ahead(ahead))
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
