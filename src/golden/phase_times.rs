//! Host seconds per phase of the golden model's frame, for profiling:
//! where a frame's time goes when `perf` cannot tell (every phase is
//! inlined into one function per vector level).
//!
//! Off by default: a phase then costs one relaxed atomic load per row or
//! pass, and nothing is timed. [`enable`] turns it on for the whole
//! process; each thread sums its own phases, read and reset by [`take`].
//! `cargo run --release --example golden_frame -- 10 --phases` prints the
//! standard frame's split (`docs/performance.md`, "Where a golden frame's
//! time goes"). Timing never changes a value the model computes.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// A phase of one derived frame, in the order a frame runs them (the
/// first nine once per warp, the last two once per frame). What no phase
/// times (the frame's planes allocated, a warp's set-up, the counters
/// summed) is the frame's time less theirs: [`OTHER`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Cache-only hole-fill planes reset before each warp (`DestPlanes::begin_warp`).
    BeginWarp,
    /// Phase 1: the 3D warp of every sample of the live region and its
    /// one-sample ring.
    Transform,
    /// Phase 2: the 2x2 groups' discontinuity and fold tests, shared corners.
    Groups,
    /// Phase A: kernels' rectangles rasterized into candidate slots.
    PhaseA,
    /// Kernels' derived slopes and better-reference masks.
    Slopes,
    /// Phase B: the shared samples' candidate list sorted.
    Sort,
    /// Phase B: every derived sample's candidates composited in warp order.
    PhaseB,
    /// The general reconstruction's whole warp (mesh and splats; not split).
    General,
    /// Hole fill after each warp.
    HoleFill,
    /// The frame's trip through the A-buffer after each warp.
    Abuffer,
    /// The fallback pass after the last warp, with the A-buffer trip of
    /// the pixels it changed.
    FallbackFill,
    /// Samples resolved to display pixels.
    Resolve,
}

impl Phase {
    /// Every phase, in [`Phase`]'s order.
    pub const ALL: [Phase; 12] = [
        Phase::BeginWarp,
        Phase::Transform,
        Phase::Groups,
        Phase::PhaseA,
        Phase::Slopes,
        Phase::Sort,
        Phase::PhaseB,
        Phase::General,
        Phase::HoleFill,
        Phase::Abuffer,
        Phase::FallbackFill,
        Phase::Resolve,
    ];

    /// Name as printed.
    pub fn name(self) -> &'static str {
        match self {
            Phase::BeginWarp => "begin warp",
            Phase::Transform => "transform",
            Phase::Groups => "groups",
            Phase::PhaseA => "phase A",
            Phase::Slopes => "slopes and masks",
            Phase::Sort => "phase B sort",
            Phase::PhaseB => "phase B",
            Phase::General => "general warp",
            Phase::HoleFill => "hole fill",
            Phase::Abuffer => "A-buffer",
            Phase::FallbackFill => "fallback fill",
            Phase::Resolve => "resolve",
        }
    }
}

/// Name printed for the rest of a frame's time, outside every phase.
pub const OTHER: &str = "other";

static ON: AtomicBool = AtomicBool::new(false);

thread_local! {
    static SECONDS: RefCell<[f64; Phase::ALL.len()]> = const { RefCell::new([0.0; Phase::ALL.len()]) };
}

/// Time phases from now on (`true`) or stop (`false`), process-wide.
pub fn enable(on: bool) {
    ON.store(on, Ordering::Relaxed);
}

/// The calling thread's seconds per phase since the last call, in
/// [`Phase::ALL`]'s order; resets them.
pub fn take() -> [(Phase, f64); Phase::ALL.len()] {
    let s = SECONDS.with(|s| std::mem::take(&mut *s.borrow_mut()));
    std::array::from_fn(|k| (Phase::ALL[k], s[k]))
}

/// A phase's start: the time if timing is on.
#[inline(always)]
pub(super) fn start() -> Option<Instant> {
    ON.load(Ordering::Relaxed).then(Instant::now)
}

/// A phase's end: adds the time since `t` (from [`start`]) to `phase`.
#[inline(always)]
pub(super) fn stop(phase: Phase, t: Option<Instant>) {
    if let Some(t) = t {
        let dt = t.elapsed().as_secs_f64();
        SECONDS.with(|s| s.borrow_mut()[phase as usize] += dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_is_declaration_order() {
        for (k, p) in Phase::ALL.iter().enumerate() {
            assert_eq!(*p as usize, k, "{p:?}");
        }
    }
}
