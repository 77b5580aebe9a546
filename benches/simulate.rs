//! Speed of the hardware model: simulated cycles per host second and host
//! seconds per derived frame, as the engine runs by default (kernel setup's
//! lines computed on a second host thread when the host has a second core,
//! `units::line_kernels`) and, as `mark1998-one-thread`, all on one core.
//!
//! Input: the golden benchmark's frame (`postwarp::bench`, as
//! `benches/golden.rs` and `postwarp bench` use it): `room` at 640x480 with
//! 2x2 samples, derived frame 3 from references 0 and 1 (2140x1496 samples
//! each), built in memory; the references are packed to A-buffer
//! format once (`HwReference::new`), outside the measurement. The
//! configuration is the `mark1998` preset, and beside it `one-lane`: the
//! preset as it was before issue 14's sizing (one sample, rectangle and
//! hole-fill sample per clock, 576 KiB of destination cache, no tile
//! prefetch, no miss queue), on one thread, so that host speed can be
//! compared on the same simulated machine across versions.
//!
//! Run: `cargo bench --bench simulate`. Criterion prints the time per
//! frame and, as its throughput, reference samples per host second: the
//! valid samples of both references after the A-buffer, as
//! `benches/golden.rs` and `postwarp bench` count them (the honest figure:
//! the engine skips idle cycles, so cycles per host second flatter it).
//! The cycles per frame are printed once before measuring, so cycles per
//! host second = cycles / time.

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use postwarp::bench::{BenchFrame, standard_spec};
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, HwReference};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Huge pages for the frame planes (`postwarp::huge_pages`).
#[global_allocator]
static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;

/// `mark1998` before issue 14's sizing (module doc).
fn one_lane() -> EngineConfig {
    EngineConfig {
        transform_throughput: 1,
        rects_per_cycle: 1,
        hole_fill_per_cycle: 1,
        dest_cache_bytes: 576 * 1024,
        tile_prefetch_distance: 0,
        composite_miss_queue: 0,
        ..EngineConfig::default()
    }
}

fn bench(c: &mut Criterion) {
    let BenchFrame { cmd, refs: imgs, .. } = BenchFrame::new(standard_spec()).expect("bench frame");
    let mut g = c.benchmark_group("simulate_room_640x480_ss2_frame3");
    g.sample_size(10);
    g.sampling_mode(SamplingMode::Flat);
    g.measurement_time(Duration::from_secs(20));
    // `None`: the engine's default.
    for (name, cfg, look_ahead) in [
        ("mark1998", EngineConfig::default(), None),
        ("mark1998-one-thread", EngineConfig::default(), Some(false)),
        ("one-lane", one_lane(), Some(false)),
    ] {
        let refs: Vec<HwReference> = imgs.iter().map(|i| HwReference::new(i, &cfg)).collect();
        let refs: Vec<&HwReference> = refs.iter().collect();
        let valid: u64 = refs.iter().map(|r| r.expanded().valid.count_ones() as u64).sum();
        let mut engine = Engine::new(cfg).expect("the configuration validates");
        if let Some(on) = look_ahead {
            engine.look_ahead(on);
        }
        let t = Instant::now();
        let out = engine.run_frame(&cmd, &refs);
        let s = t.elapsed().as_secs_f64();
        let cycles = out.stats.cycles;
        println!(
            "simulate room 640x480 ss2 frame 3, {name}: {cycles} cycles and {valid} reference samples per frame; \
             first run {s:.3} s = {:.2} M cycles, {:.2} M reference samples per host second",
            cycles as f64 / s / 1e6,
            valid as f64 / s / 1e6
        );
        g.throughput(Throughput::Elements(valid));
        g.bench_function(name, |b| b.iter(|| black_box(engine.run_frame(&cmd, &refs).stats.cycles)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
