//! The hole-fill unit's datapath: the epipolar post-pass after each
//! reference warp (TR98 §9, §9.1, App. B; `docs/warper-reference.md` §4 and
//! §7 items 9 and 15).
//!
//! Job: visit every derived sample once, in the forward sheet order around
//! the derived-image epipole `ê` (the line descriptors of
//! [`crate::traversal::forward_lines`]), and give each hole a fill colour
//! propagated from the samples one line behind it.
//!
//! Ports (functional): in — one sample address `(x, y)` with the [`Line`]
//! descriptor it belongs to, per call of [`HoleFillUnit::fill_sample`];
//! read/write — the destination planes 1, 5–9 of that sample and reads of
//! planes 6–8 at up to five tap positions ([`HoleFillUnit::tap_positions`]),
//! all in the destination store [`DestFrame`] (in the engine, the
//! destination tile cache); out — a [`FillOutcome`] per sample and the
//! [`HoleFillCounters`].
//!
//! Throughput: one sample per clock. A sample reads its own planes and at
//! most five taps (three near, two far), all on the previous line of its
//! sheet; it writes only itself. The taps' tiles must be on chip when the
//! sample is processed (the engine's tile schedule uses
//! [`HoleFillUnit::tap_positions`]).
//!
//! Rules (bit-identical to the golden model's `hole_fill`):
//! 1. Samples arrive in exactly the forward order; the caller guarantees
//!    it. The pass is preceded by the per-warp reset of planes 6–8
//!    ([`DestFrame::begin_warp_sample`]), which the caller also does.
//! 2. A sample whose plane 7 (fill valid) is set — a true surface, the
//!    only way plane 7 can be set before the sample's own visit — is left
//!    alone ([`FillOutcome::Surface`]).
//! 3. A hole looks one line back (`line − line_step` of its descriptor) at
//!    offsets −1, 0, +1 along the line. A tap counts only if it is inside
//!    the image, was visited earlier in this pass and has plane 7 set.
//!    "Visited earlier" is decided by comparing [`OrderKey`]s (`rank(tap) <
//!    rank(sample)`), not by a visited bit-plane: since the samples arrive
//!    in forward order, the two are the same thing.
//! 4. No near tap counts: the sample stays unfilled
//!    ([`FillOutcome::Unreached`]).
//! 5. Otherwise the distance is `min(1 + smallest near-tap distance,
//!    max_distance)`. If it exceeds `far_distance`, the taps at
//!    ±`far_offset` on the same previous line join under the same
//!    conditions (the far taps are "used" if at least one counts). The fill
//!    colour is the plain mean of the counted taps' plane-6 colours, summed
//!    in `f64` in tap order (−1, 0, +1, −far, +far), divided by their
//!    number and rounded to `f32`. Planes 6, 7 and 8 of the sample take the
//!    colour, "valid" and the distance (stored as its low 8 bits).
//! 6. A filled sample without a real surface accumulates the fill into
//!    planes 1, 5 and 9 with weight 1/distance, in `f64`:
//!    `C ← (C·Wt + c/d)/(Wt + 1/d)` (C taken as 0 if plane 5 was clear),
//!    `Wt ← Wt + 1/d`, plane 5 set. Real surfaces always win.
//!
//! 7. Control ([`HoleFillStage`]): the fill cursor walks the pass's lines
//!    in order, up to `hole_fill_per_cycle` samples per cycle. It stops at
//!    the first sample whose tile is not yet retired by the warp (stall
//!    `upstream`), or not resident (stall `tile`: the destination cache
//!    starts its load), or — for a hole — when a tile holding one of its
//!    taps is not resident (stall `tile`; tap tiles still untouched or
//!    already released in this warp are not waited for). A destination
//!    cache look-up is counted once when the cursor enters a tile, and once
//!    per hole for each distinct tile holding its taps (a retry after a
//!    tap miss is not counted again). While a hole's tap tiles are looked
//!    up, its own tile and the tap tiles already looked up for it are
//!    pinned: a miss on one tap tile never spills another the same hole
//!    needs (with only the two at hand pinned, a small cache could trade
//!    them for ever). Every visit, hole or surface, costs a slot.
//!
//! 8. Fallback mode ([`HoleFillUnit::new_fallback`], control in
//!    `units::fallback_fill`): the same rules 2–6 over the reverse of the
//!    forward order, "visited earlier" meaning a higher forward rank.
//!
//! 9. Fixed mode (`arith = "fixed"`, `docs/fixed-point.md`): the mean
//!    rounds to `q_colour`; in rule 6, `1/d` and `Wt + 1/d` round to
//!    `q_hole_weight`, the quotient to `q_colour` (a zero weight sum takes
//!    the fill colour itself); saturations are counted
//!    ([`HoleFillCounters::saturations`]). The planes stay `f32`.
//!
//! Not modelled: in float mode the fixed-point widths of the planes (plane
//! 6 is `f32`, the accumulation `f64`, the distance 8 bits wide — the golden
//! model's arithmetic, so that the two agree bit for bit), the divider's latency
//! and pipelining (the unit is a one-sample-per-clock function here),
//! the boundary line buffer that holds the previous line's taps across a
//! tile edge, and cache misses (the engine's business).

use super::dest_cache::DestCache;
use super::tile_cache::TileState;
use super::tile_manager::TileManager;
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::bits;
use crate::camera::Epipole;
use crate::clock::Cycle;
use crate::dest_frame::DestFrame;
use crate::mem::MemPort;
use crate::qformat::QFormat;
use crate::traversal::{Line, Major, OrderKey, forward_lines, reverse_lines};

/// Knobs of the pass (the golden configuration's `hole_far_distance`,
/// `hole_far_offset`, `hole_max_distance`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HoleFillParams {
    /// Distance (samples) past which the two far taps join.
    pub far_distance: u32,
    /// Offset (samples, along the previous line) of the far taps.
    pub far_offset: u32,
    /// Saturation of the distance (samples).
    pub max_distance: u32,
}

/// What the unit did with one sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FillOutcome {
    /// Plane 7 was already valid (a true surface): left alone.
    Surface,
    /// Filled from the previous line.
    Filled {
        /// The far taps joined the average (at least one counted).
        far_taps: bool,
    },
    /// A hole with no counted near tap: left unfilled by this pass.
    Unreached,
}

/// Counters of one pass (counts of samples).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HoleFillCounters {
    /// Samples processed.
    pub visited: u64,
    /// Holes filled.
    pub filled: u64,
    /// Holes with no counted near tap (left unfilled).
    pub unreached: u64,
    /// Fills that used the far taps.
    pub far_taps_used: u64,
    /// Fixed mode: values that saturated (fill colours, weights).
    pub saturations: u64,
}

/// The hole-fill unit for one pass (one reference warp): its traversal,
/// its rank comparator and its counters.
#[derive(Clone, Debug)]
pub struct HoleFillUnit {
    width: u32,
    height: u32,
    params: HoleFillParams,
    lines: Vec<Line>,
    order: OrderKey,
    /// The fallback mode (`units::fallback_fill`): the lines in reverse
    /// forward order, "visited earlier" = higher forward rank.
    reverse: bool,
    counters: HoleFillCounters,
    /// Fixed mode: the colour and weight formats (`None`: float).
    fixed: Option<(QFormat, QFormat)>,
}

impl HoleFillUnit {
    /// A unit for one pass over a `width x height` derived frame whose
    /// epipole (of the warp just done) is `epipole_derived`.
    pub fn new(width: u32, height: u32, epipole_derived: &Epipole, p: HoleFillParams) -> HoleFillUnit {
        HoleFillUnit {
            width,
            height,
            params: p,
            lines: forward_lines(width, height, epipole_derived),
            order: OrderKey::new(width, height, epipole_derived),
            reverse: false,
            counters: HoleFillCounters::default(),
            fixed: None,
        }
    }

    /// The unit in the fixed mode with colour format `colour` and weight
    /// format `weight` (rule 9; `None`: float).
    pub fn with_fixed(mut self, fixed: Option<(QFormat, QFormat)>) -> HoleFillUnit {
        self.fixed = fixed;
        self
    }

    /// The unit in its fallback mode (`units::fallback_fill`): the same
    /// datapath over the reverse of the forward order
    /// ([`crate::traversal::reverse_lines`]: each line's previous line is
    /// the forward order's next one), a tap counting only if its forward
    /// rank is *higher* than the sample's.
    pub fn new_fallback(width: u32, height: u32, epipole_derived: &Epipole, p: HoleFillParams) -> HoleFillUnit {
        HoleFillUnit {
            lines: reverse_lines(width, height, epipole_derived),
            reverse: true,
            ..HoleFillUnit::new(width, height, epipole_derived, p)
        }
    }

    /// The line descriptors of the pass, in forward order.
    pub fn lines(&self) -> &[Line] {
        &self.lines
    }

    /// The knobs of the pass.
    pub fn params(&self) -> HoleFillParams {
        self.params
    }

    /// The counters so far.
    pub fn counters(&self) -> &HoleFillCounters {
        &self.counters
    }

    /// Tap `k` along the previous line of `line`, from sample `(x, y)`.
    fn tap(line: &Line, x: u32, y: u32, k: i64) -> (i64, i64) {
        let back = line.line_step as i64;
        match line.major {
            Major::Row => (x as i64 + k, y as i64 - back),
            Major::Column => (x as i64 - back, y as i64 + k),
        }
    }

    /// Every tap position sample `(x, y)` of `line` may read, in tap order:
    /// the near taps at −1, 0, +1 along the previous line, then the far
    /// taps at −`far_offset`, +`far_offset` (listed whether or not they
    /// will join). Positions may lie outside the image (never read) and
    /// may repeat (`far_offset` ≤ 1). The sample's own position, read and
    /// written, is not listed.
    pub fn tap_positions(line: &Line, x: u32, y: u32, p: &HoleFillParams) -> impl Iterator<Item = (i64, i64)> + use<> {
        let line = *line;
        Self::tap_offsets(p).into_iter().map(move |k| Self::tap(&line, x, y, k))
    }

    /// The taps' offsets along the previous line, in tap order: the near
    /// taps −1, 0, +1, then the far taps −`far_offset`, +`far_offset`.
    pub fn tap_offsets(p: &HoleFillParams) -> [i64; 5] {
        let f = p.far_offset as i64;
        [-1, 0, 1, -f, f]
    }

    /// Linear index of tap `k` if it counts (rule 3).
    fn counted(&self, f: &DestFrame, line: &Line, x: u32, y: u32, own_rank: u64, k: i64) -> Option<usize> {
        let (tx, ty) = Self::tap(line, x, y, k);
        if tx < 0 || ty < 0 || tx >= self.width as i64 || ty >= self.height as i64 {
            return None;
        }
        let (tx, ty) = (tx as u32, ty as u32);
        let j = f.index(tx, ty);
        let key = self.order.key(tx, ty);
        let earlier = if self.reverse { key > own_rank } else { key < own_rank };
        (earlier && bits::get(&f.fill_valid, j)).then_some(j)
    }

    /// Process sample `(x, y)` of `line` (rules 2–6). Samples must come in
    /// exactly the order of [`HoleFillUnit::lines`].
    pub fn fill_sample(&mut self, f: &mut DestFrame, line: &Line, x: u32, y: u32) -> FillOutcome {
        debug_assert!(f.width == self.width && f.height == self.height, "frame size differs from the unit's");
        self.counters.visited += 1;
        let i = f.index(x, y);
        if bits::get(&f.fill_valid, i) {
            return FillOutcome::Surface;
        }
        let own = self.order.key(x, y);
        let p = self.params;
        let mut taps = [0usize; 5];
        let mut n = 0;
        for k in [-1, 0, 1] {
            if let Some(j) = self.counted(f, line, x, y, own, k) {
                taps[n] = j;
                n += 1;
            }
        }
        if n == 0 {
            self.counters.unreached += 1;
            return FillOutcome::Unreached;
        }
        let nearest = taps[..n].iter().map(|&j| f.samples[j].fill_distance as u32).min().unwrap_or(0);
        let dist = (1 + nearest).min(p.max_distance);
        let mut far_taps = false;
        if dist > p.far_distance {
            let near = n;
            for k in [-(p.far_offset as i64), p.far_offset as i64] {
                if let Some(j) = self.counted(f, line, x, y, own, k) {
                    taps[n] = j;
                    n += 1;
                }
            }
            far_taps = n > near;
        }
        // Mean of the counted taps' fill colours: f64 sum in tap order.
        let mut sum = [0.0f64; 3];
        for &j in &taps[..n] {
            for (acc, v) in sum.iter_mut().zip(f.samples[j].fill_colour) {
                *acc += v as f64;
            }
        }
        let count = n as f64;
        let mut sat = 0;
        let c = match self.fixed {
            None => sum.map(|v| (v / count) as f32),
            Some((col, _)) => sum.map(|v| col.q(v / count, &mut sat) as f32),
        };
        let d = &mut f.samples[i];
        d.fill_colour = c;
        bits::put(&mut f.fill_valid, i, true);
        d.fill_distance = dist as u8;
        if !bits::get(&f.real, i) {
            // Rule 6: weighted accumulation over references.
            let wt = d.fill_weight as f64;
            let old = if bits::get(&f.hole, i) { d.colour } else { [0.0; 3] };
            match self.fixed {
                None => {
                    let inv_d = 1.0 / dist as f64;
                    for k in 0..3 {
                        d.colour[k] = ((old[k] as f64 * wt + c[k] as f64 * inv_d) / (wt + inv_d)) as f32;
                    }
                    d.fill_weight = (wt + inv_d) as f32;
                }
                Some((col, wf)) => {
                    // Rule 9: 1/d and the sum in `q_hole_weight`, the
                    // colour in `q_colour`; a zero sum takes the fill.
                    let inv_d = wf.q(1.0 / dist as f64, &mut sat);
                    let den = wf.q(wt + inv_d, &mut sat);
                    for k in 0..3 {
                        let v = if den > 0.0 { (old[k] as f64 * wt + c[k] as f64 * inv_d) / den } else { c[k] as f64 };
                        d.colour[k] = col.q(v, &mut sat) as f32;
                    }
                    d.fill_weight = den as f32;
                }
            }
            bits::put(&mut f.hole, i, true);
        }
        self.counters.saturations += sat as u64;
        self.counters.filled += 1;
        self.counters.far_taps_used += far_taps as u64;
        FillOutcome::Filled { far_taps }
    }

    /// Run the whole pass over `f`: every line in order, every sample of
    /// each line in order. The caller has reset planes 6–8 for the warp.
    pub fn fill_frame(&mut self, f: &mut DestFrame) {
        for k in 0..self.lines.len() {
            let line = self.lines[k];
            for (x, y) in line.samples() {
                self.fill_sample(f, &line, x, y);
            }
        }
    }
}

/// The hole fill's ports for one cycle.
pub struct HoleFillPorts<'a> {
    /// The derived frame's planes (the cache contents).
    pub frame: &'a mut DestFrame,
    /// The destination cache.
    pub cache: &'a mut DestCache,
    /// The memory port (loads and spills the cache starts).
    pub port: &'a mut MemPort,
    /// The tile manager (which tiles are retired).
    pub tiles: &'a TileManager,
}

/// The hole fill's control for one pass (rule 7).
pub struct HoleFillStage {
    unit: HoleFillUnit,
    lanes: u32,
    line: usize,
    pos: u32,
    visits: u64,
    /// The tile the cursor is in (its look-up counted on entry).
    fill_tile: Option<u32>,
    /// The current sample's tap look-ups were made and one missed: the
    /// retry is not counted again.
    tap_retry: bool,
    activity: Activity,
}

impl HoleFillStage {
    /// The pass of `unit`, `lanes` samples per cycle, accounted by
    /// `activity`.
    pub fn new(unit: HoleFillUnit, lanes: u32, activity: Activity) -> HoleFillStage {
        HoleFillStage { unit, lanes, line: 0, pos: 0, visits: 0, fill_tile: None, tap_retry: false, activity }
    }

    /// Samples visited so far.
    #[inline]
    pub fn visits(&self) -> u64 {
        self.visits
    }

    /// Every sample has been visited.
    #[inline]
    pub fn is_done(&self) -> bool {
        self.line >= self.unit.lines.len()
    }

    /// Lines of the pass finished so far.
    #[inline]
    pub fn lines_done(&self) -> usize {
        self.line
    }

    /// The datapath (its line list and counters).
    pub fn unit(&self) -> &HoleFillUnit {
        &self.unit
    }

    /// One cycle (rule 7).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut HoleFillPorts<'_>) -> Tick {
        let mut did = 0;
        let mut stalled = StallReason::Upstream;
        let (dw, dh) = (self.unit.width, self.unit.height);
        while did < self.lanes && self.line < self.unit.lines.len() {
            let line = self.unit.lines[self.line];
            let (x, y) = line.at(if line.step > 0 { line.lo + self.pos } else { line.hi - self.pos });
            let t = io.cache.tile_of(x, y);
            if !io.tiles.is_retired(t) {
                stalled = StallReason::Upstream;
                break;
            }
            let entering = self.fill_tile != Some(t);
            self.fill_tile = Some(t);
            if !io.cache.want(now, t, entering, &[t], io.frame, io.port) {
                stalled = StallReason::Tile;
                break;
            }
            let i = io.frame.index(x, y);
            if !bits::get(&io.frame.fill_valid, i) {
                // Taps read tiles visited earlier: they must be on chip.
                let mut ready = true;
                // Each tap tile is looked up once per sample, however many
                // of the taps fall in it.
                // The sample's own tile first, then its tap tiles: all of
                // them pinned while any is looked up.
                let (mut seen, mut n_seen) = ([u32::MAX; 9], 1);
                seen[0] = t;
                for (tx, ty) in HoleFillUnit::tap_positions(&line, x, y, &self.unit.params) {
                    if tx < 0 || ty < 0 || tx >= dw as i64 || ty >= dh as i64 {
                        continue;
                    }
                    let tt = io.cache.tile_of(tx as u32, ty as u32);
                    if seen[..n_seen].contains(&tt)
                        || matches!(io.cache.state(tt), TileState::Untouched | TileState::Released)
                    {
                        continue;
                    }
                    if n_seen < seen.len() {
                        seen[n_seen] = tt;
                        n_seen += 1;
                    }
                    // A retry of the same sample's taps is not counted again.
                    if !io.cache.want(now, tt, !self.tap_retry, &seen[..n_seen], io.frame, io.port) {
                        ready = false;
                    }
                }
                if !ready {
                    self.tap_retry = true;
                    stalled = StallReason::Tile;
                    break;
                }
                self.tap_retry = false;
            }
            self.unit.fill_sample(io.frame, &line, x, y);
            self.visits += 1;
            did += 1;
            self.pos += 1;
            if self.pos == line.len() {
                self.line += 1;
                self.pos = 0;
            }
        }
        let t = if did > 0 {
            Tick::BUSY
        } else if self.line < self.unit.lines.len() {
            Tick::stall(stalled)
        } else {
            Tick::IDLE
        };
        self.activity.record(now, t)
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn params() -> HoleFillParams {
        HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 }
    }

    #[test]
    fn hole_fills_from_the_background_side_with_growing_distance() {
        // 8x3, real background in columns 0..2, fill direction +x.
        let mut f = DestFrame::new(8, 3);
        for y in 0..3 {
            for x in 0..2 {
                let i = f.index(x, y);
                f.real.set(i, true);
                f.samples[i].colour = [0.25; 3];
            }
        }
        for i in 0..f.len() {
            f.begin_warp_sample(i);
        }
        let mut u = HoleFillUnit::new(8, 3, &Epipole { h: DVec3::new(1.0, 0.0, 0.0) }, params());
        u.fill_frame(&mut f);
        assert_eq!(
            *u.counters(),
            HoleFillCounters { visited: 24, filled: 18, unreached: 0, far_taps_used: 0, saturations: 0 }
        );
        for x in 2..8 {
            let i = f.index(x, 1);
            assert!(f.hole[i] && f.fill_valid[i]);
            assert_eq!(f.samples[i].colour, [0.25; 3]);
            assert_eq!(f.samples[i].fill_distance as u32, x - 1);
        }
    }

    #[test]
    fn taps_lie_on_the_previous_line() {
        let row = Line { sheet: 0, major: Major::Row, line: 5, lo: 0, hi: 9, step: 1, line_step: 1 };
        let t: Vec<_> = HoleFillUnit::tap_positions(&row, 5, 5, &params()).collect();
        assert_eq!(t, [(4, 4), (5, 4), (6, 4), (1, 4), (9, 4)]);
        let col = Line { sheet: 4, major: Major::Column, line: 3, lo: 0, hi: 9, step: -1, line_step: -1 };
        let t: Vec<_> = HoleFillUnit::tap_positions(&col, 3, 2, &params()).collect();
        assert_eq!(t, [(4, 1), (4, 2), (4, 3), (4, -2), (4, 6)]);
    }
}
