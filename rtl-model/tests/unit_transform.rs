//! The transform unit's pipeline control (`units::transform`,
//! [`TransformStage`]) against its neighbours: the fetch unit's offers and
//! kernel setup's takes, made by the test at chosen cycles.
//!
//! Doc rules checked: the pipeline is a FIFO of `throughput · (latency + 1)`
//! slots and latency `latency` (a sample accepted at N is taken at N +
//! latency, not N + latency − 1); busy in a cycle that accepted a sample,
//! stalled on `fifo_full` in one that only refused, idle otherwise; with
//! kernel setup ticked first it sustains `throughput` samples per cycle.

use crate::common::{TickLog, activity, stall};
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::units::transform::{InFlightSample, TransformStage};
use postwarp_rtl::units::{StallReason, UnitState};

fn sample(i: u32) -> InFlightSample {
    InFlightSample { grid_index: i, interval: i / 4 }
}

#[test]
fn a_sample_accepted_at_n_is_taken_at_n_plus_latency_and_not_before() {
    for latency in [0u32, 1, 3, 12] {
        let n = Cycle(40);
        let mut t = TransformStage::new(1, latency, 64, activity(Cycle(0)));
        t.accept(n, sample(9)).unwrap();
        assert_eq!(t.next_visible(), Some(n + latency as u64), "latency {latency}");
        if latency > 0 {
            assert_eq!(t.take(n + (latency as u64 - 1)), None, "latency {latency}: out at N + latency - 1");
        }
        assert_eq!(t.take(n + latency as u64), Some(sample(9)), "latency {latency}: not out at N + latency");
        assert!(t.is_empty());
        assert!(t.has_transformed(9) && !t.has_transformed(8));
        assert_eq!(t.samples(), 1);
    }
}

#[test]
fn a_full_pipeline_refuses_and_stalls_on_fifo_full() {
    // 2 lanes, latency 3: 8 slots.
    let mut t = TransformStage::new(2, 3, 64, activity(Cycle(0)));
    let mut log = TickLog::new(Cycle(0));
    for i in 0..8 {
        t.accept(Cycle(0), sample(i)).unwrap();
    }
    assert_eq!(t.accept(Cycle(0), sample(8)), Err(sample(8)), "a 9th sample in 8 slots");
    assert!(!t.has_transformed(8), "a refused sample is not transformed");
    // Accepted and refused in one cycle: busy.
    assert_eq!(log.note(Cycle(0), t.tick(Cycle(0))).state, UnitState::Busy);
    // Only refused: stalled on a full FIFO, nothing moved.
    assert_eq!(t.accept(Cycle(1), sample(8)), Err(sample(8)));
    let k = log.note(Cycle(1), t.tick(Cycle(1)));
    assert_eq!(k.state, stall(StallReason::FifoFull));
    assert!(!k.moved);
    // Nothing offered: idle.
    assert_eq!(log.note(Cycle(2), t.tick(Cycle(2))).state, UnitState::Idle);
    // Samples accepted at cycle 0 leave at cycle 3; a freed slot takes the
    // refused sample in the same cycle.
    assert_eq!(t.take(Cycle(3)), Some(sample(0)));
    t.accept(Cycle(3), sample(8)).unwrap();
    assert_eq!(log.note(Cycle(3), t.tick(Cycle(3))).state, UnitState::Busy);
    assert_eq!((t.len(), t.samples()), (8, 9));
    log.check(Cycle(5), t.close(Cycle(5)));
}

#[test]
fn with_kernel_setup_ticked_first_it_sustains_its_throughput() {
    for (lanes, latency) in [(1u32, 0u32), (1, 12), (2, 3), (16, 12)] {
        let mut t = TransformStage::new(lanes, latency, 4096, activity(Cycle(0)));
        let mut next = 0u32;
        let mut taken = Vec::new();
        for c in 0..60u64 {
            let now = Cycle(c);
            // Downstream first: kernel setup takes up to `lanes`.
            for _ in 0..lanes {
                match t.take(now) {
                    Some(s) => taken.push((s.grid_index, c)),
                    None => break,
                }
            }
            for _ in 0..lanes {
                t.accept(now, sample(next)).unwrap_or_else(|_| panic!("{lanes}x{latency}: refused at {c}"));
                next += 1;
            }
            assert_eq!(t.tick(now).state, UnitState::Busy);
        }
        // Every sample left exactly `latency` cycles after it entered (a
        // latency-0 sample is visible after the push, so the consumer,
        // ticked first, takes it in the next cycle: `fifo.rs`).
        assert!(!taken.is_empty());
        let wait = latency.max(1) as u64;
        for &(i, c) in &taken {
            assert_eq!(c, (i / lanes) as u64 + wait, "{lanes}x{latency}: sample {i}");
        }
    }
}

#[test]
fn busy_stall_and_idle_add_up_to_the_cycles_ticked_with_skips() {
    let start = Cycle(100);
    let mut t = TransformStage::new(1, 2, 64, activity(start));
    let mut log = TickLog::new(start);
    // The engine ticks every cycle while things move and jumps over idle
    // stretches: the state of the last tick holds through the jump.
    let mut i = 0;
    for c in [100u64, 101, 102, 103, 110, 111, 130, 131, 132, 150] {
        let now = Cycle(c);
        while t.take(now).is_some() {}
        if c < 104 || c == 131 {
            // Offer 4: the 3 slots take at most 3 before any leaves.
            for _ in 0..4 {
                if t.accept(now, sample(i)).is_ok() {
                    i += 1;
                }
            }
        }
        log.note(now, t.tick(now));
    }
    assert!(log.count(stall(StallReason::FifoFull)) > 0, "the pattern must include a full pipeline");
    assert!(log.count(UnitState::Idle) > 0 && log.count(UnitState::Busy) > 0);
    log.check(Cycle(170), t.close(Cycle(170)));
}
