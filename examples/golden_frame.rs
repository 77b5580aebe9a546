//! Profiling driver for the golden model: the standard bench frame
//! (`postwarp::bench`, the frame of `cargo bench --bench golden`) through
//! `Warper::warp_frame` on one thread N times (argument, default 1), after
//! preparing its references once and one untimed warm-up run, printing host
//! seconds per run. For `perf record` or callgrind (`measured` is a symbol
//! of its own): `cargo run --release --example golden_frame -- 3`. With
//! `--phases` after N, it also prints the mean seconds per frame of each
//! phase (`postwarp::golden::phase_times`).

use postwarp::bench::{BenchFrame, standard_spec};
use postwarp::golden::config::GoldenConfig;
use postwarp::golden::frame::{PreparedReference, Warper, prepare_reference};
use postwarp::golden::phase_times;
use std::time::Instant;

/// Huge pages for the frame planes (`postwarp::huge_pages`).
#[global_allocator]
static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1);
    let phases = std::env::args().nth(2).is_some_and(|a| a == "--phases");
    let f = BenchFrame::new(standard_spec()).expect("bench frame");
    let cfg = GoldenConfig::default();
    let refs: Vec<PreparedReference> =
        f.refs.iter().map(|img| prepare_reference(img, f.spec.supersample, &cfg)).collect();
    let refs: Vec<&PreparedReference> = refs.iter().collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one-thread pool");
    let mut warper = Warper::new();
    pool.install(|| {
        measured(&mut warper, &f.cmd, &refs, &cfg);
        phase_times::enable(phases);
        phase_times::take();
        let mut total = 0.0;
        for _ in 0..n {
            let t = Instant::now();
            measured(&mut warper, &f.cmd, &refs, &cfg);
            let s = t.elapsed().as_secs_f64();
            total += s;
            println!("{s:.4} s");
        }
        if phases {
            println!("mean seconds per frame by phase ({n} frames):");
            let split = phase_times::take();
            for (p, s) in split {
                println!("  {:<16} {:.4}", p.name(), s / n as f64);
            }
            let other = total - split.iter().map(|p| p.1).sum::<f64>();
            println!("  {:<16} {:.4}", phase_times::OTHER, other.max(0.0) / n as f64);
        }
    });
}

/// One timed frame (a symbol of its own for callgrind's toggle).
#[inline(never)]
fn measured(w: &mut Warper, cmd: &postwarp_rtl::FrameCommands, refs: &[&PreparedReference], cfg: &GoldenConfig) {
    std::hint::black_box(w.warp_frame(cmd, refs, cfg));
}
