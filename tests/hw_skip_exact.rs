//! The engine's idle skipping is exact: stepping every cycle
//! (`Engine::skip_idle(false)`) gives the same counters, planes and pixels
//! as jumping over the cycles in which nothing moves, on every bundled
//! trace at the default, two small-cache and a long-latency configuration.
//!
//! A unit that changes state with time alone, without an event the engine
//! knows of (a request queued in a stalled cycle, an item in transit
//! behind a blocked FIFO head), makes the skipping version differ here.

use crate::common::engine_runs::run_frames;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::FrameOutput;

/// The first `frames` frames of `trace` under `cfg`, skipping or stepping.
fn run(trace: &str, cfg: &EngineConfig, frames: usize, skip: bool) -> Vec<FrameOutput> {
    run_frames(trace, cfg, frames, |e| e.skip_idle(skip))
}

fn check(trace: &str, frames: usize) {
    let configs = [
        ("default", EngineConfig::default()),
        (
            "small-cache",
            EngineConfig { dest_cache_bytes: 16 * 1024, source_cache_bytes: 8 * 1024, ..Default::default() },
        ),
        ("tiny-cache", EngineConfig { dest_cache_bytes: 8 * 1024, source_cache_bytes: 4 * 1024, ..Default::default() }),
        ("long-latency", EngineConfig { dram_latency_cycles: 400, dram_max_outstanding: 4, ..Default::default() }),
    ];
    for (name, cfg) in configs {
        let (skipped, stepped) = (run(trace, &cfg, frames, true), run(trace, &cfg, frames, false));
        for (k, (a, b)) in skipped.iter().zip(&stepped).enumerate() {
            let (fa, fb) = (a.stats.flat(), b.stats.flat());
            let diff: Vec<_> = fa.iter().zip(&fb).filter(|(x, y)| x != y).take(8).collect();
            assert!(diff.is_empty() && fa.len() == fb.len(), "{trace} {name} frame {k}: skipped vs stepped {diff:?}");
            assert_eq!(a.pixels, b.pixels, "{trace} {name} frame {k}: pixels");
            assert_eq!(
                a.frame.plane(|s| s.colour),
                b.frame.plane(|s| s.colour),
                "{trace} {name} frame {k}: colour plane"
            );
        }
    }
}

#[test]
fn skipping_is_exact_on_room() {
    check("room", 2);
}

#[test]
fn skipping_is_exact_on_occluders() {
    check("occluders", 2);
}

#[test]
fn skipping_is_exact_on_slants() {
    check("slants", 2);
}

#[test]
fn skipping_is_exact_on_hairball() {
    check("hairball", 1);
}

/// The one bundled trace with an unseen border: its fallback pass runs.
#[test]
fn skipping_is_exact_on_motorcycle() {
    check("motorcycle", 1);
}
