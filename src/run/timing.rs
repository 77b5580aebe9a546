//! Host-time measurement shared by every timed run (`postwarp golden
//! --method`, `postwarp compare`, `postwarp sweep`).
//!
//! Rules:
//! 1. At most one timed section runs at a time in the process: [`timed`]
//!    holds a global lock around it, so that parallel sweeps do not time
//!    two methods against each other. Untimed work (loading, metrics,
//!    the hardware model) keeps running on the other threads.
//! 2. Called from a rayon worker (a sweep's thread pool), the section runs
//!    on a fresh plain thread while the worker blocks: a method that uses
//!    rayon inside its timed section then cannot make the worker steal
//!    another point's task, which would wait for the lock it holds.
//! 3. The clock starts and stops on the thread that runs the section;
//!    thread start-up is outside it.

use std::sync::{Mutex, PoisonError};
use std::time::Instant;

/// The lock every timed section holds.
static GATE: Mutex<()> = Mutex::new(());

/// Run `f` alone (module rules) and return its result and its host time in
/// milliseconds.
pub fn timed<R: Send>(f: impl FnOnce() -> R + Send) -> (R, f64) {
    let _alone = GATE.lock().unwrap_or_else(PoisonError::into_inner);
    let run = move || {
        let t = Instant::now();
        let r = f();
        (r, t.elapsed().as_secs_f64() * 1e3)
    };
    if rayon::current_thread_index().is_some() {
        std::thread::scope(|s| s.spawn(run).join()).unwrap_or_else(|p| std::panic::resume_unwind(p))
    } else {
        run()
    }
}

#[cfg(test)]
mod tests {
    use super::timed;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn timed_sections_never_overlap_even_from_a_pool() {
        let inside = AtomicUsize::new(0);
        let most = AtomicUsize::new(0);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        pool.scope(|s| {
            for _ in 0..8 {
                s.spawn(|_| {
                    let (_, ms) = timed(|| {
                        let now = inside.fetch_add(1, Ordering::SeqCst) + 1;
                        most.fetch_max(now, Ordering::SeqCst);
                        std::thread::sleep(std::time::Duration::from_millis(2));
                        inside.fetch_sub(1, Ordering::SeqCst);
                    });
                    assert!(ms >= 1.0, "{ms}");
                });
            }
        });
        assert_eq!(most.load(Ordering::SeqCst), 1);
    }

    #[test]
    fn rayon_inside_a_timed_section_does_not_deadlock() {
        use rayon::prelude::*;
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let sums: Vec<u64> = pool.install(|| {
            (0..6u64)
                .into_par_iter()
                .map(|i| timed(|| (0..1000u64).into_par_iter().map(|x| x * i).sum::<u64>()).0)
                .collect()
        });
        assert_eq!(sums[2], 2 * 499_500);
    }
}
