//! The fetch unit's control (`units::fetch`, [`FetchStage`]) against its
//! neighbours: the source cache's blocks arriving when the test says (the
//! engine's phase 1 delivers a DRAM completion before the fetch unit's
//! tick), a memory port the test inspects, and the transform pipeline the
//! test drains (or not).
//!
//! Doc rules checked: rule 3 (prefetch of the blocks of the current and
//! next interval, each once), rule 4 (a sample streams only when its block
//! is on chip, the cycle it arrives; samples without a surface cost no
//! cycle), rule 5 (up to `transform_throughput` samples per cycle; busy,
//! else stalled on `dram` or `fifo_full`, else idle; `wait_cycles` counts
//! every cycle from the first tick that meets an absent block to the first
//! that does not, skipped cycles included).

use crate::common::{TickLog, Warp, activity, config, grid_len, image, plane, stall};
use glam::DVec3;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::mem::{Dram, DramConfig, MemPort, Tag};
use postwarp_rtl::schedule::FetchInterval;
use postwarp_rtl::traversal::Major;
use postwarp_rtl::units::fetch::{BlockState, FetchPorts, FetchStage};
use postwarp_rtl::units::transform::TransformStage;
use postwarp_rtl::units::{StallReason, UnitState};

/// A 24x8-sample reference in 8-sample blocks (3 blocks in a row).
fn warp(img: &postwarp_rtl::SampleImage) -> Warp {
    Warp::new(img, DVec3::new(0.1, 0.0, 0.0), 0.0, postwarp_rtl::config::EngineConfig { tile_size: 8, ..config() })
}

fn row(line: u32, lo: u32, hi: u32) -> FetchInterval {
    FetchInterval { major: Major::Row, line, lo, hi, step: 1 }
}

/// Row 0 in block 0, row 1 in block 1, row 2 in block 2.
fn three_blocks() -> Vec<FetchInterval> {
    vec![row(0, 0, 7), row(1, 8, 15), row(2, 16, 23)]
}

fn transform(lanes: u32, latency: u32) -> TransformStage {
    TransformStage::new(lanes, latency, grid_len(24, 8), activity(Cycle(0)))
}

#[test]
fn a_block_arriving_at_n_streams_at_n_and_its_sample_leaves_the_transform_at_n_plus_latency() {
    let w = warp(&plane(24, 8, 5.0));
    let plan = three_blocks();
    let mut t = transform(1, 3);
    let mut port = MemPort::default();
    let mut f = FetchStage::new(&plan, &w.r, w.source_cache(1 << 20), 1, activity(Cycle(0)));
    let n = Cycle(20);
    for c in 0..n.get() {
        let k = f.tick(Cycle(c), &mut FetchPorts { transform: &mut t, port: &mut port });
        assert_eq!(k.state, stall(StallReason::Dram), "cycle {c}: block 0 not on chip");
        assert!(!k.moved);
        assert_eq!(t.samples(), 0, "cycle {c}: a sample streamed before its block arrived");
    }
    // Phase 1 of cycle N delivers block 0; the fetch unit streams at N.
    f.cache.arrived(0, n);
    let k = f.tick(n, &mut FetchPorts { transform: &mut t, port: &mut port });
    assert_eq!((k.state, k.moved, t.samples()), (UnitState::Busy, true, 1));
    assert_eq!(t.take(n + 2), None, "out of a latency-3 transform at N + 2");
    let s = t.take(n + 3).expect("out of a latency-3 transform at N + 3");
    assert_eq!(s.interval, 0);
    // It waited for the block from cycle 0 to N.
    assert_eq!(f.close(n).0.stall_by_reason[StallReason::Dram.index()], n.get());
    assert_eq!(f.cache.counters.wait_cycles, n.get());
}

#[test]
fn prefetch_queues_the_blocks_of_the_current_and_the_next_interval_once() {
    let w = warp(&plane(24, 8, 5.0));
    let mut plan = three_blocks();
    plan.push(row(3, 0, 7)); // block 0 again
    let mut t = transform(64, 0);
    let mut port = MemPort::default();
    let mut f = FetchStage::new(&plan, &w.r, w.source_cache(1 << 20), 1, activity(Cycle(0)));
    f.tick(Cycle(0), &mut FetchPorts { transform: &mut t, port: &mut port });
    assert_eq!(port.queued(), 2, "blocks of intervals 0 and 1");
    assert_eq!((f.cache.state(0), f.cache.state(1), f.cache.state(2)), {
        (BlockState::Requested, BlockState::Requested, BlockState::Absent)
    });
    f.cache.arrived(0, Cycle(1));
    f.cache.arrived(1, Cycle(1));
    let mut c = 1;
    while f.interval() == 0 {
        assert_eq!(port.queued(), 2, "cycle {c}: block 2 queued before interval 1 started");
        f.tick(Cycle(c), &mut FetchPorts { transform: &mut t, port: &mut port });
        c += 1;
    }
    assert_eq!(port.queued(), 3, "interval 1 started: the blocks of interval 2 are queued");
    assert_eq!(f.cache.state(2), BlockState::Requested);
    f.cache.arrived(2, Cycle(c));
    while !f.is_done() {
        f.tick(Cycle(c), &mut FetchPorts { transform: &mut t, port: &mut port });
        c += 1;
        assert!(c < 100);
    }
    // Block 0 was on chip for interval 3: three reads in all.
    assert_eq!((port.queued(), f.cache.counters.block_reads), (3, 3));
    assert_eq!(t.samples(), 32);
    // The reads carry their block numbers, in prefetch order.
    let mut dram: Dram<Tag> =
        Dram::new(DramConfig { peak_bytes_per_cycle: 1 << 16, latency_cycles: 0, burst_bytes: 32, max_outstanding: 8 });
    let mut tags = Vec::new();
    for k in 0..10 {
        dram.tick(Cycle(k));
        while let Some((tag, _)) = dram.completed(Cycle(k)) {
            tags.push(tag);
        }
        port.issue(&mut dram, Cycle(k));
    }
    assert_eq!(tags, [0, 1, 2].map(|block| Tag::Block { block, warp: 0 }));
}

#[test]
fn a_full_transform_pipeline_stalls_it_on_fifo_full_and_loses_no_sample() {
    let w = warp(&plane(24, 8, 5.0));
    let plan = three_blocks();
    // 1 lane, latency 1: 2 slots.
    let mut t = transform(1, 1);
    let mut port = MemPort::default();
    let mut cache = w.source_cache(1 << 20);
    for b in 0..3 {
        cache.arrived(b, Cycle(0));
    }
    let mut f = FetchStage::new(&plan, &w.r, cache, 1, activity(Cycle(0)));
    let mut log = TickLog::new(Cycle(0));
    let mut taken = Vec::new();
    let mut c = 0u64;
    while !f.is_done() || !t.is_empty() {
        let now = Cycle(c);
        // Kernel setup (ticked first) takes nothing in cycles 2..6.
        if !(2..6).contains(&c)
            && let Some(s) = t.take(now)
        {
            taken.push(s);
        }
        let k = log.note(now, f.tick(now, &mut FetchPorts { transform: &mut t, port: &mut port }));
        let tt = t.tick(now);
        if (3..6).contains(&c) {
            assert_eq!(k.state, stall(StallReason::FifoFull), "cycle {c}: the pipeline is full");
            assert_eq!(tt.state, stall(StallReason::FifoFull), "cycle {c}: the transform refused a sample");
        }
        c += 1;
        assert!(c < 200);
    }
    assert_eq!(taken.len(), 24, "every sample of the plan, none lost to a refusal");
    let mut seen: Vec<u32> = taken.iter().map(|s| s.grid_index).collect();
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), 24, "each sample once");
    assert!(taken.windows(2).all(|p| p[0].interval <= p[1].interval));
    assert_eq!(log.count(stall(StallReason::FifoFull)), 3, "cycles 3..6 (cycle 2 filled the second slot)");
    log.check(Cycle(c), f.close(Cycle(c)));
}

#[test]
fn samples_without_a_surface_cost_no_cycle_and_lanes_bound_each_cycle() {
    // Row 0: surfaces at odd x only.
    let img = image(24, 8, |x, y| (y > 0 || x % 2 == 1).then_some((5.0, [0.5; 3])));
    let w = warp(&img);
    let plan = vec![row(0, 0, 23)];
    let mut t = transform(64, 0);
    let mut port = MemPort::default();
    let mut cache = w.source_cache(1 << 20);
    for b in 0..3 {
        cache.arrived(b, Cycle(0));
    }
    let mut f = FetchStage::new(&plan, &w.r, cache, 2, activity(Cycle(0)));
    for c in 0..6u64 {
        assert!(!f.is_done(), "cycle {c}: 12 samples at 2 a cycle take 6 cycles");
        let k = f.tick(Cycle(c), &mut FetchPorts { transform: &mut t, port: &mut port });
        assert_eq!(k.state, UnitState::Busy);
        assert_eq!(t.samples(), 2 * (c + 1), "cycle {c}: 2 lanes");
    }
    assert!(f.is_done(), "the 12 empty samples cost no cycle");
}

#[test]
fn wait_cycles_run_from_the_first_tick_meeting_an_absent_block_including_busy_ones_and_skips() {
    let w = warp(&plane(24, 8, 5.0));
    let plan = vec![row(0, 0, 15)]; // blocks 0 and 1
    let mut t = transform(64, 0);
    let mut port = MemPort::default();
    let mut cache = w.source_cache(1 << 20);
    cache.arrived(0, Cycle(0));
    let mut f = FetchStage::new(&plan, &w.r, cache, 3, activity(Cycle(0)));
    let mut log = TickLog::new(Cycle(0));
    let mut tick = |f: &mut FetchStage<'_>, c: u64| {
        log.note(Cycle(c), f.tick(Cycle(c), &mut FetchPorts { transform: &mut t, port: &mut port })).state
    };
    assert_eq!(tick(&mut f, 0), UnitState::Busy); // x 0..=2
    assert_eq!(tick(&mut f, 1), UnitState::Busy); // x 3..=5
    assert_eq!(tick(&mut f, 2), UnitState::Busy, "x 6, 7, then block 1 absent"); // wait starts
    assert_eq!(tick(&mut f, 3), stall(StallReason::Dram));
    // The engine skips 4..=8 while the unit waits.
    f.cache.arrived(1, Cycle(9));
    assert_eq!(tick(&mut f, 9), UnitState::Busy);
    assert_eq!(f.cache.counters.wait_cycles, 7, "cycles 2..9, the busy cycle 2 and the skipped ones included");
    for c in 10..12 {
        tick(&mut f, c);
    }
    assert!(f.is_done());
    assert_eq!(tick(&mut f, 20), UnitState::Idle);
    log.check(Cycle(30), f.close(Cycle(30)));
    assert_eq!(f.cache.counters.wait_cycles, 7);
}
