//! Profiling driver for the hardware model: runs the standard bench frame
//! (`postwarp::bench`, the frame of `cargo bench --bench simulate`) through
//! `Engine::run_frame` with the `mark1998` preset N times (argument, default
//! 1), after building and packing it once and one untimed warm-up run
//! (which builds each reference's lazily made line-buffer records), and
//! prints cycles and host seconds per run. For `perf record`, or for
//! `valgrind --tool=callgrind --collect-atstart=no
//! --toggle-collect='*hw_frame*measured*'` to count the steady-state runs
//! only: `cargo run --release --example hw_frame -- 3`.

use postwarp::bench::{BenchFrame, standard_spec};
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, HwReference};
use std::time::Instant;

/// Huge pages for the frame planes (`postwarp::huge_pages`).
#[global_allocator]
static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1);
    let BenchFrame { cmd, refs: imgs, .. } = BenchFrame::new(standard_spec()).expect("bench frame");
    let cfg = EngineConfig::default();
    let refs: Vec<HwReference> = imgs.iter().map(|i| HwReference::new(i, &cfg)).collect();
    let refs: Vec<&HwReference> = refs.iter().collect();
    let mut engine = Engine::new(cfg).expect("the configuration validates");
    engine.run_frame(&cmd, &refs);
    for _ in 0..n {
        let t = Instant::now();
        let cycles = measured(&mut engine, &cmd, &refs);
        println!("{cycles} cycles, {:.3} s", t.elapsed().as_secs_f64());
    }
}

/// One timed frame (a symbol of its own for callgrind's toggle).
#[inline(never)]
fn measured(engine: &mut Engine, cmd: &postwarp_rtl::cmd::FrameCommands, refs: &[&HwReference]) -> u64 {
    engine.run_frame(cmd, refs).stats.cycles
}
