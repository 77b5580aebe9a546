//! Speed of the golden model against the plain forward splat, on one core,
//! the golden model at the host's widest vector level (`golden::vector_level`;
//! `postwarp bench` also times it at the baseline).
//!
//! Input: the standard frame of `postwarp::bench` (`room` at 640x480 with
//! 2x2 samples, derived frame 3 and its references 0 and 1, 2140x1496
//! samples each, built in memory), both references passed through the
//! A-buffer (`prepare_reference`). Both methods warp the same prepared
//! references. `postwarp bench` times the same frame the same way.
//!
//! Throughput is in reference samples per second: the valid samples of both
//! references per derived frame.
//!
//! Run: `cargo bench --bench golden`.

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use postwarp::bench::{BenchFrame, standard_spec};
use postwarp::golden::config::GoldenConfig;
use postwarp::golden::frame::{PreparedReference, Warper, inv_z_plane, prepare_reference};
use postwarp::methods::baselines::forward_splat::forward_splat_with;
use postwarp_rtl::{FrameCommands, SampleImage};
use std::hint::black_box;
use std::time::Duration;

/// Huge pages for the frame planes (`postwarp::huge_pages`).
#[global_allocator]
static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;

/// One derived frame's commands and its prepared references.
struct Input {
    cmd: FrameCommands,
    refs: Vec<PreparedReference>,
}

/// The standard frame, its references through the A-buffer.
fn input() -> Input {
    let f = BenchFrame::new(standard_spec()).expect("bench frame");
    let cfg = GoldenConfig::default();
    let refs = f.refs.iter().map(|img| prepare_reference(img, f.spec.supersample, &cfg)).collect();
    Input { cmd: f.cmd, refs }
}

fn bench(c: &mut Criterion) {
    let input = input();
    let prepared: Vec<&PreparedReference> = input.refs.iter().collect();
    // Both methods warp the same samples: the references after the A-buffer.
    let refs: Vec<&SampleImage> = input.refs.iter().map(|p| &p.samples).collect();
    // The splat's input: each reference's 1/Z plane, made outside the
    // timing (the golden model divides 1/Z from Z as it reads a sample;
    // the splat doing the same measured 6 % slower, docs/performance.md).
    let planes: Vec<Vec<f64>> = input.refs.iter().map(|p| inv_z_plane(&p.samples)).collect();
    let inv_z: Vec<&[f64]> = planes.iter().map(Vec::as_slice).collect();
    let valid: u64 = refs.iter().map(|r| r.valid.count_ones() as u64).sum();
    let cfg = GoldenConfig::default();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one-thread pool");

    let mut g = c.benchmark_group("room_640x480_ss2_frame3");
    g.throughput(Throughput::Elements(valid));
    g.sample_size(10);
    g.sampling_mode(SamplingMode::Flat);
    g.warm_up_time(Duration::from_secs(1));
    // Flat sampling with a target below 10 iterations' time: one iteration
    // per sample, so the whole bench stays near 40 s on a 2-core machine.
    g.measurement_time(Duration::from_secs(20));
    // One warper reused across frames, as `postwarp golden` does.
    let mut warper = Warper::new();
    g.bench_function("golden", |b| {
        pool.install(|| b.iter(|| black_box(warper.warp_frame(&input.cmd, &prepared, &cfg))))
    });
    g.measurement_time(Duration::from_secs(5));
    g.bench_function("forward_splat", |b| {
        pool.install(|| b.iter(|| black_box(forward_splat_with(&input.cmd, &refs, &inv_z))))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
