//! Kernel setup's control (`units::kernel_setup`, [`KernelSetupStage`])
//! against its neighbours: a transform pipeline the test fills at chosen
//! cycles, the fetch unit's interval cursor the test sets, a kernel FIFO
//! the test drains (or not), and the tile manager.
//!
//! Doc rules checked (rule 6): it absorbs finished transforms, then emits
//! up to `transform_throughput` kernels along the schedule's lines; a
//! line's kernels start once the fetch interval of the next line of its
//! sheet has left the transform pipeline (`Schedule::need`), until then it
//! stalls on `upstream`; a full kernel FIFO stalls it on `fifo_full`;
//! samples without a surface cost nothing; a culled sample takes an
//! emission slot but yields no kernel; busy in a cycle it absorbed or
//! emitted anything. Each kernel counts against its line in the tile
//! manager.

use crate::common::{TickLog, Warp, activity, config, grid_len, image, plane, stall, streamed};
use glam::DVec3;
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::fifo::Fifo;
use postwarp_rtl::units::kernel_setup::{Kernel, KernelSetupPorts, KernelSetupStage};
use postwarp_rtl::units::line_buffer::LineBuffer;
use postwarp_rtl::units::line_kernels::{LineKernels, LineSource, LinesAhead};
use postwarp_rtl::units::tile_manager::TileManager;
use postwarp_rtl::units::transform::{InFlightSample, TransformStage};
use postwarp_rtl::units::{StallReason, Tick, UnitState};

const W: u32 = 12;
const H: u32 = 10;

/// A plane seen by a camera moved sideways: one column-major sheet, every
/// line live.
fn sideways(img: &postwarp_rtl::SampleImage) -> Warp {
    let w = Warp::new(img, DVec3::new(0.1, 0.0, 0.0), 0.0, config());
    assert!(w.sched.live.iter().all(|&l| l), "every line of the plane is live");
    w
}

/// A transform pipeline of `latency` that has taken every sample of the
/// plan at cycle 0 and delivered them (the test took them out): kernel
/// setup finds them transformed and the pipeline empty.
fn all_transformed(samples: &[InFlightSample]) -> TransformStage {
    let mut t = TransformStage::new(samples.len() as u32, 0, grid_len(W, H), activity(Cycle(0)));
    for &s in samples {
        t.accept(Cycle(0), s).unwrap();
    }
    while t.take(Cycle(0)).is_some() {}
    t
}

struct Io<'a> {
    transform: &'a mut TransformStage,
    out: &'a mut Fifo<Kernel>,
    tiles: &'a mut TileManager,
}

/// Kernel setup over `w`'s schedule with `lanes` lanes, computing its
/// lines inline into `buffer`, from cycle 0.
fn stage<'a>(w: &'a Warp, buffer: &'a mut LineBuffer, lanes: u32) -> KernelSetupStage<'a> {
    let s = &w.sched;
    KernelSetupStage::new(&s.lines, &s.need, &w.r, &w.tu, buffer, w.cfg.threshold, w.shape(), lanes, activity(Cycle(0)))
}

fn tick(k: &mut KernelSetupStage<'_>, now: Cycle, fetch_interval: usize, io: &mut Io<'_>) -> Tick {
    k.tick(now, &mut KernelSetupPorts { transform: io.transform, fetch_interval, out: io.out, tiles: io.tiles })
}

#[test]
fn a_line_starts_in_the_cycle_its_need_interval_leaves_the_transform_and_not_before() {
    let w = sideways(&plane(W, H, 5.0));
    let s = &w.sched;
    let n0 = s.need[0].expect("line 0 is live");
    let all = streamed(&w.r, &w.cfg, &s.fetch);
    let upto: Vec<_> = all.iter().copied().filter(|x| x.interval as usize <= n0).collect();
    let (&last, first) = upto.split_last().unwrap();
    assert_eq!(last.interval as usize, n0);
    let latency = 3;
    let mut t = TransformStage::new(64, latency, grid_len(W, H), activity(Cycle(0)));
    let mut out: Fifo<Kernel> = Fifo::new(64, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut buffer = LineBuffer::default();
    let mut k = stage(&w, &mut buffer, 64);
    // The fetch unit pushes the last sample of interval n0 at cycle P: it
    // is visible at N = P + latency. Its cursor reads n0 until the end of
    // cycle P (kernel setup is ticked before the fetch unit).
    let p = 6u64;
    let n = p + latency as u64;
    for c in 0..=n {
        let now = Cycle(c);
        let fetch_interval = if c <= p { n0 } else { n0 + 1 };
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        let state = tick(&mut k, now, fetch_interval, io).state;
        if c < n {
            assert!(out.is_empty(), "cycle {c}: a kernel of line 0 before N = {n}");
            let want = if c == latency as u64 { UnitState::Busy } else { stall(StallReason::Upstream) };
            assert_eq!(state, want, "cycle {c}: waiting on interval {n0} (busy only absorbing)");
        } else {
            assert_eq!(state, UnitState::Busy);
            assert!(!out.is_empty(), "no kernel of line 0 at N = {n}");
        }
        // Phase 8: the fetch unit's pushes.
        if c == 0 {
            for &x in first {
                t.accept(now, x).unwrap();
            }
        }
        if c == p {
            t.accept(now, last).unwrap();
        }
    }
    // The kernel FIFO's latency: visible to the rasterizer at N + 1.
    assert!(out.pop(Cycle(n)).is_none());
    let kern = out.pop(Cycle(n + 1)).expect("a kernel at N + 1");
    assert_eq!(kern.line, 0);
    // All of line 0 in that cycle (64 lanes), then line 1 waits for its own
    // need interval.
    assert_eq!((k.lines_emitted(), k.counts().0), (1, s.lines[0].len() as u64));
    assert!(s.need[1].is_some_and(|n1| n1 > n0), "line 1 needs a later interval");
}

#[test]
fn a_full_kernel_fifo_stalls_it_on_fifo_full_until_the_rasterizer_pops() {
    let w = sideways(&plane(W, H, 5.0));
    let s = &w.sched;
    let mut t = all_transformed(&streamed(&w.r, &w.cfg, &s.fetch));
    let mut out: Fifo<Kernel> = Fifo::new(1, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut buffer = LineBuffer::default();
    let mut k = stage(&w, &mut buffer, 4);
    let fi = s.fetch.len();
    let mut log = TickLog::new(Cycle(0));
    let mut io = Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
    let k1 = log.note(Cycle(1), tick(&mut k, Cycle(1), fi, &mut io));
    assert_eq!((k1.state, k.counts().0), (UnitState::Busy, 1), "one slot: one kernel of the 4 lanes");
    for c in [2u64, 3] {
        let kc = log.note(Cycle(c), tick(&mut k, Cycle(c), fi, &mut io));
        assert_eq!(kc.state, stall(StallReason::FifoFull), "cycle {c}");
        assert!(!kc.moved);
    }
    // Skipped: 4..=7. The rasterizer (ticked first) pops at 8.
    assert!(io.out.pop(Cycle(8)).is_some());
    let k8 = log.note(Cycle(8), tick(&mut k, Cycle(8), fi, &mut io));
    assert_eq!((k8.state, k.counts().0), (UnitState::Busy, 2));
    assert_eq!(io.out.counters().refused_pushes, 4, "each full cycle's offer counts (cycles 1, 2, 3, 8)");
    log.check(Cycle(12), k.close(Cycle(12)));
}

#[test]
fn lanes_bound_each_cycle_samples_without_a_surface_cost_nothing_and_each_kernel_counts_on_its_line() {
    // Holes: every third sample has no surface.
    let img = image(W, H, |x, y| ((x + 2 * y) % 3 != 0).then_some((5.0, [0.3; 3])));
    let w = sideways(&img);
    let s = &w.sched;
    let valid = (0..W * H).filter(|&i| (i % W + 2 * (i / W)) % 3 != 0).count() as u64;
    let mut t = all_transformed(&streamed(&w.r, &w.cfg, &s.fetch));
    let mut out: Fifo<Kernel> = Fifo::new(64, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut buffer = LineBuffer::default();
    let lanes = 3;
    let mut k = stage(&w, &mut buffer, lanes);
    let fi = s.fetch.len();
    let mut kernels = Vec::new();
    let mut c = 1;
    while k.counts().0 < valid {
        let before = k.counts().0;
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        assert_eq!(tick(&mut k, Cycle(c), fi, io).state, UnitState::Busy);
        let emitted = k.counts().0 - before;
        assert_eq!(emitted, (lanes as u64).min(valid - before), "cycle {c}: lanes per cycle, holes free");
        while let Some(kern) = out.pop(Cycle(c)) {
            kernels.push(kern);
        }
        c += 1;
        assert!(c < 1000);
    }
    assert_eq!(k.counts(), (valid, 0));
    let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
    assert_eq!(tick(&mut k, Cycle(c), fi, io).state, UnitState::Idle);
    assert!(k.is_done());
    kernels.extend(std::iter::from_fn(|| out.pop(Cycle(c + 1))));
    assert_eq!(kernels.len() as u64, valid);
    // Kernels follow the lines in order, each from a sample with a surface
    // on its line.
    assert!(kernels.windows(2).all(|p| p[0].line <= p[1].line));
    for kern in &kernels {
        let l = s.lines[kern.line as usize];
        let (x, y) = kern.sample;
        assert_eq!(if l.major == postwarp_rtl::traversal::Major::Row { y } else { x }, l.line);
        assert!(img.valid[img.index(x, y)]);
    }
    // Each kernel counted against its line: no tile retires while any is
    // in flight, all do once the last is done.
    let touched: Vec<u32> = (0..s.retire.len() as u32).filter(|&t| s.retire[t as usize].is_some()).collect();
    assert!(!touched.is_empty());
    assert!(!tiles.tick(s.lines.len()), "kernels in flight hold their lines");
    assert!(touched.iter().all(|&t| !tiles.is_retired(t)), "kernels in flight hold their tiles");
    for kern in &kernels {
        tiles.kernel_done(kern.line);
    }
    tiles.tick(s.lines.len());
    assert!(touched.iter().all(|&t| tiles.is_retired(t)));
}

#[test]
fn a_culled_sample_takes_an_emission_slot_but_yields_no_kernel() {
    // The derived camera stands just past the plane, looking sideways
    // along it: part of the plane is in front of it, part behind, so the
    // chunks straddling its W = 0 plane are live and hold culled samples.
    let w = Warp::new(&plane(W, H, 5.0), DVec3::new(0.0, 0.0, 5.5), std::f64::consts::FRAC_PI_2, config());
    let s = &w.sched;
    let live_samples: u64 = s.lines.iter().zip(&s.live).filter(|p| *p.1).map(|p| p.0.len() as u64).sum();
    assert!(live_samples > 0, "unbounded chunks are live");
    let mut t = all_transformed(&streamed(&w.r, &w.cfg, &s.fetch));
    let mut out: Fifo<Kernel> = Fifo::new(1 << 20, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut buffer = LineBuffer::default();
    let mut k = stage(&w, &mut buffer, 2);
    let fi = s.fetch.len();
    let mut busy = 0;
    for c in 1..1000 {
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        match tick(&mut k, Cycle(c), fi, io).state {
            UnitState::Busy => busy += 1,
            UnitState::Idle => break,
            other => panic!("cycle {c}: {other:?}"),
        }
    }
    let (kernels, culled) = k.counts();
    assert!(culled > 0 && kernels > 0, "some samples culled, some not: {kernels} kernels, {culled} culled");
    assert_eq!(kernels + culled, live_samples, "every valid sample of a live line takes a slot");
    assert_eq!(busy, live_samples.div_ceil(2), "a culled sample takes a slot of the 2 lanes");
    assert_eq!(out.counters().pushes, kernels, "a culled sample yields no kernel");
}

/// The kernels (as printed: `Kernel` has no equality), cycle and state of
/// every tick of a stage run to the end, 3 lanes, a FIFO of 4 the test
/// drains every other cycle.
fn run_to_end(k: &mut KernelSetupStage<'_>, w: &Warp) -> Vec<(u64, UnitState, Vec<String>)> {
    let s = &w.sched;
    let mut t = all_transformed(&streamed(&w.r, &w.cfg, &s.fetch));
    let mut out: Fifo<Kernel> = Fifo::new(4, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut log = Vec::new();
    for c in 1..10_000u64 {
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        let state = tick(k, Cycle(c), s.fetch.len(), io).state;
        let popped: Vec<String> = if c % 2 == 0 {
            std::iter::from_fn(|| out.pop(Cycle(c))).map(|kern| format!("{kern:?}")).collect()
        } else {
            Vec::new()
        };
        log.push((c, state, popped));
        if k.is_done() && out.is_empty() {
            return log;
        }
    }
    panic!("kernel setup never finished");
}

#[test]
fn lines_computed_on_the_look_ahead_thread_leave_in_the_same_cycles_with_the_same_bits() {
    // Holes and a slanted depth: discontinuities, forward edges, culling.
    let img = image(W, H, |x, y| ((x * y) % 5 != 1).then_some((3.0 + 0.4 * x as f32, [0.1 * y as f32, 0.5, 0.2])));
    let w = Warp::new(&img, DVec3::new(0.3, -0.2, 0.4), 0.2, config());
    let s = &w.sched;
    let mut buffer = LineBuffer::default();
    let mut k = stage(&w, &mut buffer, 3);
    let inline = run_to_end(&mut k, &w);
    let mut buffer = LineBuffer::default();
    let ahead = std::thread::scope(|scope| {
        let kernels = LineKernels::new(&w.r, &w.tu, &mut buffer, w.cfg.threshold, w.shape());
        let source = LineSource::Ahead(LinesAhead::spawn(scope, &s.lines, &s.need, kernels));
        let mut k = KernelSetupStage::with_source(&s.lines, &s.need, &w.r, source, 3, activity(Cycle(0)));
        run_to_end(&mut k, &w)
    });
    let kernels: usize = inline.iter().map(|t| t.2.len()).sum();
    assert!(kernels > 20, "the warp sets up kernels ({kernels})");
    assert_eq!(inline, ahead);
}

/// A stage whose schedule claims every fetch interval done while the
/// transform unit has streamed nothing reads unstreamed samples.
fn read_before_streamed(ahead: bool) {
    let w = sideways(&plane(W, H, 5.0));
    let s = &w.sched;
    let mut t = TransformStage::new(4, 0, grid_len(W, H), activity(Cycle(0)));
    let mut out: Fifo<Kernel> = Fifo::new(4, 1);
    let mut tiles = TileManager::new(s.lines.len(), &s.retire);
    let mut buffer = LineBuffer::default();
    std::thread::scope(|scope| {
        let kernels = LineKernels::new(&w.r, &w.tu, &mut buffer, w.cfg.threshold, w.shape());
        let source = if ahead {
            LineSource::Ahead(LinesAhead::spawn(scope, &s.lines, &s.need, kernels))
        } else {
            LineSource::Inline(kernels)
        };
        let mut k = KernelSetupStage::with_source(&s.lines, &s.need, &w.r, source, 4, activity(Cycle(0)));
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        tick(&mut k, Cycle(1), s.fetch.len(), io);
    });
}

#[test]
#[should_panic(expected = "before it was transformed")]
fn reading_a_sample_not_streamed_panics_when_lines_are_computed_inline() {
    read_before_streamed(false);
}

#[test]
#[should_panic(expected = "before it was transformed")]
fn reading_a_sample_not_streamed_panics_when_lines_are_computed_ahead() {
    read_before_streamed(true);
}

/// A panic on the look-ahead thread (here: a line off the image, which
/// kernel setup's line computation refuses) reaches the stage with the
/// thread's own message, not a hang or a message about a closed channel.
#[test]
#[should_panic(expected = "the current line is on the image")]
fn a_panic_on_the_look_ahead_thread_reaches_kernel_setup_with_its_message() {
    let w = sideways(&plane(W, H, 5.0));
    let s = &w.sched;
    let off = postwarp_rtl::traversal::Line {
        sheet: 0,
        major: postwarp_rtl::traversal::Major::Row,
        line: H + 3,
        lo: 0,
        hi: 3,
        step: 1,
        line_step: 1,
    };
    let (lines, need) = ([off], [Some(0)]);
    let mut t = all_transformed(&streamed(&w.r, &w.cfg, &s.fetch));
    let mut out: Fifo<Kernel> = Fifo::new(4, 1);
    let mut tiles = TileManager::new(1, &s.retire);
    let mut buffer = LineBuffer::default();
    std::thread::scope(|scope| {
        let kernels = LineKernels::new(&w.r, &w.tu, &mut buffer, w.cfg.threshold, w.shape());
        let source = LineSource::Ahead(LinesAhead::spawn(scope, &lines, &need, kernels));
        let mut k = KernelSetupStage::with_source(&lines, &need, &w.r, source, 4, activity(Cycle(0)));
        let io = &mut Io { transform: &mut t, out: &mut out, tiles: &mut tiles };
        tick(&mut k, Cycle(1), 1, io);
    });
}
