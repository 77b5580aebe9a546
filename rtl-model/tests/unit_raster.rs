//! The rasterizer's control (`units::raster`, [`RasterStage`]) against its
//! neighbours: a kernel FIFO the test fills at chosen cycles, a stamp FIFO
//! the test drains (or not), and the tile manager.
//!
//! Doc rules checked (rule 4): up to `rects_per_cycle` kernels per cycle,
//! taken only while the stamp FIFO offers room (no output register), else
//! a stall on `fifo_full`; an empty stamp takes a slot, produces nothing
//! and is done (in the tile manager); a non-empty one carries the flat
//! candidate (colour, 1/Z, fill colour, derived slopes, reference
//! number); the stamp is [`rect`] of the kernel (rules 1–3). The kernel
//! and stamp FIFOs' latency of 1 puts a kernel pushed at P in the stamp
//! FIFO at P + 1 and in front of the compositor at P + 2.

use crate::common::{TickLog, Warp, activity, config, plane, stall};
use glam::DVec3;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::fifo::Fifo;
use postwarp_rtl::units::kernel_setup::Kernel;
use postwarp_rtl::units::raster::{RasterPorts, RasterStage, StampShape, Stamped, rect, stamp_of};
use postwarp_rtl::units::tile_manager::TileManager;
use postwarp_rtl::units::{StallReason, Tick, UnitState};

const SIZE: (u32, u32) = (8, 8);

fn warp() -> Warp {
    Warp::new(&plane(8, 8, 5.0), DVec3::new(0.1, 0.0, 0.0), 0.0, config())
}

/// The stamp shape of these tests: 4x4 stamps in an 8x8 image.
const SHAPE: StampShape = StampShape { limit: 4, size: SIZE };

/// A kernel of `line` with box `corners_box` around the warped sample at
/// `pos`, carrying its stamp ([`stamp_of`], as the line computation makes
/// it).
fn kernel_box(line: u32, pos: (f64, f64), corners_box: (f64, f64, f64, f64)) -> Kernel {
    Kernel {
        line,
        sample: (3, 4),
        inv_z: 0.2,
        stamp: stamp_of(SHAPE, corners_box, pos),
        colour: [0.1, 0.2, 0.3],
        fill_colour: [0.4, 0.5, 0.6],
        src_inv_z: 0.2,
        src_slopes: [0.01, -0.02],
        sat: [0, 0],
    }
}

/// A kernel of `line` at `pos` whose box reaches `half` samples either side.
fn kernel(line: u32, pos: (f64, f64), half: f64) -> Kernel {
    kernel_box(line, pos, (pos.0 - half, pos.0 + half, pos.1 - half, pos.1 + half))
}

fn tick(
    r: &mut RasterStage<'_>,
    now: Cycle,
    input: &mut Fifo<Kernel>,
    out: &mut Fifo<Stamped>,
    tiles: &mut TileManager,
) -> Tick {
    r.tick(now, &mut RasterPorts { input, out, tiles })
}

#[test]
fn a_kernel_pushed_at_p_is_rasterized_at_p_plus_1_and_reaches_the_compositor_at_p_plus_2() {
    let w = warp();
    let mut r = RasterStage::new(&w.tu, 3, 1, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(2, 1), Fifo::new(2, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    let p = Cycle(10);
    let k = kernel(0, (3.2, 4.1), 1.0);
    tiles.kernel_issued(0);
    input.push(p, k).unwrap();
    // In the kernel FIFO's transit at P: nothing to take yet.
    assert_eq!(tick(&mut r, p, &mut input, &mut out, &mut tiles).state, UnitState::Stall(StallReason::Upstream));
    assert_eq!((input.len(), out.len()), (1, 0));
    let t = tick(&mut r, p + 1, &mut input, &mut out, &mut tiles);
    assert_eq!((t.state, t.moved, input.len(), out.len()), (UnitState::Busy, true, 0, 1));
    assert!(out.pop(p + 1).is_none(), "the stamp FIFO's latency");
    let s = out.pop(p + 2).expect("in front of the compositor at P + 2");
    assert_eq!(s.rect, rect(2.2, 4.2, 3.1, 5.1, (3.2, 4.1), 4, SIZE));
    assert_eq!((s.rect.x, s.rect.y), ((3, 4), (4, 5)));
    assert_eq!((s.line, s.sample, s.better, s.counted), (0, (3, 4), None, false));
    let c = &s.cand;
    assert_eq!((c.colour, c.fill_colour, c.inv_z, c.source), ([0.1, 0.2, 0.3], [0.4, 0.5, 0.6], 0.2f32, 3));
    let d = w.tu.dest_slopes(3.0, 4.0, 0.2, [0.01, -0.02]);
    assert_eq!(c.slopes, [d[0] as f32, d[1] as f32], "the derived slopes, from the transform unit");
    assert!(c.slopes != [0.0; 2]);
    // A non-empty stamp is done only once composited.
    assert!(!tiles.tick(1) && !tiles.is_retired(0));
}

#[test]
fn a_full_stamp_fifo_stalls_it_on_fifo_full_and_the_kernel_stays() {
    let w = warp();
    let mut r = RasterStage::new(&w.tu, 0, 2, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(4, 1), Fifo::new(1, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    let mut log = TickLog::new(Cycle(0));
    for x in [1.0, 5.0] {
        tiles.kernel_issued(0);
        input.push(Cycle(0), kernel(0, (x, 2.0), 0.9)).unwrap();
    }
    // Two lanes, one slot: one kernel taken, the other waits.
    let t = log.note(Cycle(1), tick(&mut r, Cycle(1), &mut input, &mut out, &mut tiles));
    assert_eq!((t.state, input.len(), out.len()), (UnitState::Busy, 1, 1));
    for c in [2, 3] {
        let t = log.note(Cycle(c), tick(&mut r, Cycle(c), &mut input, &mut out, &mut tiles));
        assert_eq!(t.state, stall(StallReason::FifoFull), "cycle {c}");
        assert!(!t.moved);
        assert_eq!(input.len(), 1, "cycle {c}: no kernel taken without room for its stamp");
    }
    // Skipped 4..=8; the compositor (ticked first) pops at 9.
    assert!(out.pop(Cycle(9)).is_some());
    let t = log.note(Cycle(9), tick(&mut r, Cycle(9), &mut input, &mut out, &mut tiles));
    assert_eq!((t.state, input.len(), out.len()), (UnitState::Busy, 0, 1));
    assert_eq!(out.counters().refused_pushes, 3, "the refused offers of cycles 1, 2 and 3");
    log.check(Cycle(15), r.close(Cycle(15)));
}

#[test]
fn lanes_bound_the_kernels_per_cycle() {
    let w = warp();
    let mut r = RasterStage::new(&w.tu, 0, 2, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(8, 1), Fifo::new(8, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    for k in 0..5 {
        tiles.kernel_issued(0);
        input.push(Cycle(0), kernel(0, (k as f64, 1.0), 0.6)).unwrap();
    }
    let mut per_cycle = Vec::new();
    for c in 1..=4 {
        let before = input.len();
        let t = tick(&mut r, Cycle(c), &mut input, &mut out, &mut tiles);
        per_cycle.push((before - input.len(), t.state));
    }
    assert_eq!(per_cycle, [(2, UnitState::Busy), (2, UnitState::Busy), (1, UnitState::Busy), (0, UnitState::Idle)]);
    assert_eq!(out.len(), 5);
}

#[test]
fn an_empty_stamp_takes_a_slot_produces_nothing_and_is_done() {
    let w = warp();
    let mut r = RasterStage::new(&w.tu, 0, 1, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(2, 1), Fifo::new(2, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    tiles.kernel_issued(0);
    // A box between sample centres covers none.
    input.push(Cycle(0), kernel(0, (2.5, 2.5), 0.3)).unwrap();
    assert!(!tiles.tick(1), "in flight");
    let t = tick(&mut r, Cycle(1), &mut input, &mut out, &mut tiles);
    assert_eq!((t.state, input.len(), out.len()), (UnitState::Busy, 0, 0));
    assert!(tiles.tick(1) && tiles.is_retired(0), "the empty stamp's kernel is done: its line completes");
    assert_eq!(out.counters().pushes, 0);
}

#[test]
fn a_box_over_the_stamp_is_clipped_around_the_sample_and_counted() {
    let w = warp();
    let mut r = RasterStage::new(&w.tu, 0, 1, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(2, 1), Fifo::new(2, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    tiles.kernel_issued(0);
    // 7 centres wide (0..=6), 2 tall.
    let k = kernel_box(0, (4.0, 3.5), (-0.5, 6.5, 2.9, 4.9));
    input.push(Cycle(0), k).unwrap();
    tick(&mut r, Cycle(1), &mut input, &mut out, &mut tiles);
    let s = out.pop(Cycle(2)).unwrap();
    assert_eq!((s.rect.x, s.rect.y, s.rect.size, s.rect.over_limit), ((3, 6), (3, 4), (7, 2), true));
    let (over, rects) = r.counts();
    assert_eq!(over, 1);
    assert_eq!(rects[4][2], 1, "counted by drawn size");
    assert_eq!(rects.iter().flatten().sum::<u64>(), 1);
}

#[test]
fn the_stamp_a_kernel_carries_is_the_rectangle_of_its_box_clipped_to_the_image() {
    assert_eq!(stamp_of(SHAPE, (2.2, 4.2, 3.1, 5.1), (3.2, 4.1)), rect(2.2, 4.2, 3.1, 5.1, (3.2, 4.1), 4, SIZE));
    // A box between centres: empty.
    assert!(stamp_of(SHAPE, (2.2, 2.8, 2.2, 2.8), (2.5, 2.5)).is_empty());
    // Clipped to the image.
    let c = stamp_of(SHAPE, (5.5, 9.5, -2.0, 0.5), (7.4, -0.6));
    assert_eq!((c.x, c.y), ((6, 7), (0, 0)));
    // Far outside: empty whatever the corners' range.
    assert!(stamp_of(SHAPE, (1e12, 2e12, 0.0, 1.0), (1.5e12, 0.5)).is_empty());
    assert!(stamp_of(SHAPE, (-2e12, -1e12, 0.0, 1.0), (-1.5e12, 0.5)).is_empty());
}

#[test]
fn in_fixed_mode_the_derived_slopes_round_to_q_slope_and_count_saturations() {
    let cfg = postwarp_rtl::config::EngineConfig::preset("fixed-minimal").unwrap();
    let fixed = cfg.fixed_formats().unwrap().expect("a fixed preset");
    let w = warp();
    let tu = w.tu.clone().with_fixed(Some(fixed.clone()));
    let mut r = RasterStage::new(&tu, 0, 1, activity(Cycle(0)));
    let (mut input, mut out) = (Fifo::new(2, 1), Fifo::new(2, 1));
    let mut tiles = TileManager::new(1, &[Some(0)]);
    tiles.kernel_issued(0);
    let mut k = kernel(0, (3.2, 4.1), 1.0);
    k.sat = [2, 1];
    input.push(Cycle(0), k).unwrap();
    tick(&mut r, Cycle(1), &mut input, &mut out, &mut tiles);
    let s = out.pop(Cycle(2)).expect("a stamp");
    let exact = tu.dest_slopes(3.0, 4.0, 0.2, [0.01, -0.02]);
    let mut n = 0;
    let q = exact.map(|v| fixed.slope.q(v, &mut n));
    assert_eq!(s.cand.slopes, [q[0] as f32, q[1] as f32]);
    assert_ne!(s.cand.slopes, [exact[0] as f32, exact[1] as f32], "the rounding shows at 12 fraction bits");
    assert_eq!(r.saturations(), [2, 1, n as u64], "the drawn kernel's own counts, then its slopes'");
}
