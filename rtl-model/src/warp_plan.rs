//! The software half of a warp: what the tile manager's driver computes
//! before the warp's first cycle (zero cycles in the model): the schedule
//! (`crate::schedule`), the hole fill's lines and release order, the tile
//! prefetch's first-touch lists and the §5 working-set model; and, at the
//! warp's end, the count of tiles held to it.
//!
//! Rules:
//! 1. A plan is a pure function of the configuration, the warp's inputs and
//!    the derived frame's size; the engine may make it on any host thread
//!    at any time before the warp (`Engine::look_ahead`).
//! 2. Its reference side (the schedule) and derived side (everything else)
//!    do not depend on each other, and may be made at once on two threads;
//!    the plan is the same either way.
//!
//! Not modelled: the driver's own computation time.

use crate::camera::Epipole;
use crate::config::EngineConfig;
use crate::engine::WarpInput;
use crate::schedule::{Schedule, fill_first_lines, release_order};
use crate::traversal::{line_ring, warp_lines};
use crate::units::dest_cache::DestCache;
use crate::units::hole_fill::{HoleFillParams, HoleFillUnit};
use crate::units::tile_cache::TileState;

/// The software half of a warp (tile manager, zero cycles): the schedule,
/// the hole fill's release order and the prefetch lists.
pub(crate) struct WarpPlan {
    /// The tile manager's schedule (fetch plan, lines, retirement).
    pub(crate) sched: Schedule,
    /// The hole fill's unit, with its lines.
    pub(crate) fill: HoleFillUnit,
    /// The packer's release order.
    pub(crate) releases: Vec<(u64, u32)>,
    /// Per tile, the first hole-fill line that reads or writes it.
    pub(crate) fill_first: Vec<Option<u32>>,
    /// The §5 model's working set for this warp.
    pub(crate) working_set: crate::working_set::WorkingSet,
    /// The reference's size and epipole, for the ring bands of its lines.
    ring_of: (u32, u32, crate::camera::Epipole),
}

impl WarpPlan {
    /// The plan of warp `w` into a `dw x dh` derived frame. With `split`,
    /// the reference side (the schedule) and the derived side (the hole
    /// fill's lines, release order and prefetch lists, and the working-set
    /// model), which do not depend on each other, are made on two host
    /// threads; the plan is the same either way.
    pub(crate) fn new(cfg: &EngineConfig, w: &WarpInput<'_>, (dw, dh): (u32, u32), split: bool) -> WarpPlan {
        let size = (w.r.width, w.r.height);
        let schedule = || {
            let lines = warp_lines(size.0, size.1, &w.tu.setup.epipole_reference);
            Schedule::new(size, &w.r.depth, &w.tu.setup, lines, (dw, dh), cfg.tile_size, w.tu.fixed())
        };
        let derived = || {
            let params = HoleFillParams {
                far_distance: cfg.hole_far_distance,
                far_offset: cfg.hole_far_offset,
                max_distance: cfg.hole_max_distance,
            };
            let epipole: Epipole = w.tu.setup.epipole_derived;
            let fill =
                HoleFillUnit::new(dw, dh, &epipole, params).with_fixed(w.tu.fixed().map(|f| (f.colour, f.hole_weight)));
            let taps = HoleFillUnit::tap_offsets(&params);
            let releases = release_order(fill.lines(), (dw, dh), cfg.tile_size, &taps);
            // The prefetch's list for the hole fill (none without a prefetch).
            let fill_first = if cfg.tile_prefetch_distance > 0 {
                fill_first_lines(fill.lines(), (dw, dh), cfg.tile_size, &taps)
            } else {
                Vec::new()
            };
            let working_set = crate::working_set::predict(
                &w.tu.setup,
                (&w.tu.reference_camera(), &w.dst),
                size,
                &w.r.depth,
                fill.lines(),
                cfg.kernel_limit,
                cfg.tile_size,
            );
            (fill, releases, fill_first, working_set)
        };
        let (sched, (fill, releases, fill_first, working_set)) = if split {
            std::thread::scope(|scope| {
                let other = scope.spawn(derived);
                let sched = schedule();
                (sched, other.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            })
        } else {
            (schedule(), derived())
        };
        let ring_of = (size.0, size.1, w.tu.setup.epipole_reference);
        WarpPlan { sched, fill, releases, fill_first, working_set, ring_of }
    }

    /// When kernel setup has set up the warp's last line: the tiles still
    /// held (loading, resident or spilled) whose last write came at least
    /// [`held_bands`] ring bands before the warp's last live line
    /// ([`crate::frame_stats::FrameStats::tiles_held_to_warp_end`]).
    pub(crate) fn held_to_end(&self, cache: &DestCache) -> u64 {
        let lines = &self.sched.lines;
        let live = &self.sched.live;
        let (Some(first), Some(last)) = (live.iter().position(|&v| v), live.iter().rposition(|&v| v)) else {
            return 0;
        };
        let (w, h, e) = self.ring_of;
        let ring = |l: usize| line_ring(w, h, &e, &lines[l]);
        let end = ring(last);
        let at_least = held_bands(ring(first).abs_diff(end) + 1);
        self.sched
            .retire
            .iter()
            .enumerate()
            .filter(|&(t, r)| {
                r.is_some_and(|l| ring(l as usize).abs_diff(end) >= at_least)
                    && matches!(cache.state(t as u32), TileState::Loading | TileState::Resident | TileState::Spilled)
            })
            .count() as u64
    }
}

/// How far behind the warp's end (in ring bands of the warp's order,
/// `traversal.rs` rule 6) a tile's last write must lie for a tile still
/// held at the end to count as held to the warp's end, for a warp whose
/// live lines span `span` ring bands: a sixteenth of the span, and at
/// least 8 bands. The end front (tiles rightly held at the end) reached
/// 4 of 187 bands on the 640x480 room and 9 of about 300 at 1000x1000:
/// a tile counts only when the fill could not follow the warp to it.
pub fn held_bands(span: u64) -> u64 {
    (span / 16).max(8)
}
