//! Kernel setup ("neighbourhood" unit): the reconstruction kernel of each
//! reference sample from its warped 3x3 neighbourhood (TR98 §6, §7.2;
//! `docs/warper-reference.md` §3).
//!
//! Job: run the discontinuity and fold-over tests on the 2x2 groups
//! around a sample, produce its four kernel corners and their bounding
//! box, and tag forward edges (TR98 App. B.1).
//!
//! Ports: in, warped samples from the transform unit into a line buffer of
//! three traversal lines (the previous, current and next row of a
//! row-major sheet, or columns of a column-major one), each one sample
//! wider than the current line at both ends; out, one kernel per sample to
//! the rasterizer.
//!
//! Throughput: one kernel per cycle per transform lane
//! (`transform_throughput`); a line's kernels start once the next line of
//! its sheet has been transformed (the engine enforces this).
//!
//! Rules:
//! 1. Two samples at offset `o` (|o| = 1 or √2) are the same surface iff their
//!    warped distance is at most `threshold · |o| · (E_a + E_b)/2`
//!    (compared squared).
//! 2. A corner is shared by the 2x2 group around it: if the four samples
//!    are warped surfaces, all six pairs pass rule 1 and the quadrilateral
//!    A, B, D, C keeps the reference winding (all four edge cross products
//!    strictly positive), the corner is the mean of the four positions.
//! 3. Otherwise the corner is the sample's exact edge corner, or its own
//!    position if that corner is behind the derived camera.
//! 4. The kernel is the axis-aligned box of the corners.
//! 5. Forward edge: the backward neighbour is the 8-neighbour nearest the
//!    direction `−D(p)` in the reference (`D` toward the reference-image
//!    epipole); if it is a deeper, warped surface failing rule 1, its
//!    colour goes to the hole-fill plane instead of the sample's own.
//!
//! 6. Control ([`KernelSetupStage`]): each cycle it first absorbs up to
//!    `transform_throughput` finished transforms into the line buffer, then
//!    emits up to as many kernels along the schedule's lines. A line's
//!    kernels start once the fetch interval of the next line of its sheet
//!    has left the transform pipeline (`Schedule::need`); until then the
//!    unit stalls on `upstream` (the line buffer). A full kernel FIFO
//!    stalls it on `fifo_full`. Samples without a surface cost nothing; a
//!    culled sample takes an emission slot but yields no kernel. It is
//!    *busy* in a cycle it absorbed or emitted anything.
//!
//! Not modelled: line-buffer capacity stalls (the buffer is sized for the
//! longest line of the reference).

use super::line_buffer::LineBuffer;
use super::line_kernels::{Emit, LineKernels, LineSource, LineWork};
use super::raster::{Rect, StampShape};
use super::tile_manager::TileManager;
use super::transform::{TransformStage, TransformUnit, Transformed};
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::camera::Epipole;
use crate::clock::Cycle;
use crate::fifo::Fifo;
use crate::hw_reference::HwReference;
use crate::qformat::QFormat;
use crate::traversal::Line;
use glam::DVec2;

/// Why a 2x2 group's corner is not shared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Group {
    /// Rule 2 holds: shared corner at the mean.
    Shared(DVec2),
    /// Fixed mode: rule 2 holds, and the mean saturated `q_corner` (the
    /// corner is the end of its range; counted by each kernel using it).
    SharedSaturated(DVec2),
    /// A sample is missing (no surface, culled, or off the image).
    Missing,
    /// Some pair fails rule 1.
    Discontinuous,
    /// The warped quadrilateral folds over.
    Folded,
}

/// Rule 1.
#[inline]
pub fn same_surface(a: &Transformed, b: &Transformed, offset_len: f64, threshold: f64) -> bool {
    let limit = threshold * offset_len * 0.5 * (a.e + b.e);
    (a.pos - b.pos).length_squared() <= limit * limit
}

#[inline]
fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The 2x2 group with samples `a` (top left), `b` (top right), `c` (bottom
/// left), `d` (bottom right), rule 2.
#[inline]
pub fn group(
    a: Option<Transformed>,
    b: Option<Transformed>,
    c: Option<Transformed>,
    d: Option<Transformed>,
    threshold: f64,
) -> Group {
    group_in(a, b, c, d, threshold, None)
}

/// [`group`], with the fixed mode's corner format `corner` (the mean
/// rounded to it, saturating: [`Group::SharedSaturated`]).
#[inline(always)]
pub fn group_in(
    a: Option<Transformed>,
    b: Option<Transformed>,
    c: Option<Transformed>,
    d: Option<Transformed>,
    threshold: f64,
    corner: Option<QFormat>,
) -> Group {
    let (Some(a), Some(b), Some(c), Some(d)) = (a, b, c, d) else { return Group::Missing };
    let r2 = std::f64::consts::SQRT_2;
    let pairs = [(&a, &b, 1.0), (&c, &d, 1.0), (&a, &c, 1.0), (&b, &d, 1.0), (&a, &d, r2), (&b, &c, r2)];
    if !pairs.iter().all(|(p, q, o)| same_surface(p, q, *o, threshold)) {
        return Group::Discontinuous;
    }
    let q = [a.pos, b.pos, d.pos, c.pos];
    if (0..4).any(|k| cross(q[(k + 1) % 4] - q[k], q[(k + 2) % 4] - q[(k + 1) % 4]) <= 0.0) {
        return Group::Folded;
    }
    let mean = (a.pos + b.pos + c.pos + d.pos) * 0.25;
    let Some(f) = corner else { return Group::Shared(mean) };
    let ((x, sx), (y, sy)) = (f.quantise(mean.x), f.quantise(mean.y));
    if sx | sy { Group::SharedSaturated(DVec2::new(x, y)) } else { Group::Shared(DVec2::new(x, y)) }
}

/// Corners of sample `(x, y)` (warped `t`, 1/Z `inv_z`, reference slopes
/// `slopes`) given the four groups around it, in the order top-left,
/// top-right, bottom-left, bottom-right (`None`: off the image). Returns the
/// corners and how many were edge corners (rules 2–3).
#[inline]
pub fn corners(
    tu: &TransformUnit,
    t: &Transformed,
    x: u32,
    y: u32,
    inv_z: f64,
    slopes: [f32; 2],
    groups: [Option<Group>; 4],
) -> ([DVec2; 4], u32) {
    let (out, edges, _) = corners_counted(tu, t, x, y, inv_z, slopes, groups);
    (out, edges)
}

/// [`corners`], with the fixed mode's saturations: those of the edge
/// corners' warps (the transform unit's) and the saturated shared
/// corners used (kernel setup's), `[transform, kernel_setup]`.
#[inline(always)]
pub fn corners_counted(
    tu: &TransformUnit,
    t: &Transformed,
    x: u32,
    y: u32,
    inv_z: f64,
    slopes: [f32; 2],
    groups: [Option<Group>; 4],
) -> ([DVec2; 4], u32, [u32; 2]) {
    let mut edges = 0;
    let mut sat = [0; 2];
    // Each corner built whole (not written into an array field by field:
    // the host's store forwarding stalled on reading such an array back).
    let mut corner = |k: usize, sx: f64, sy: f64| match groups[k] {
        Some(Group::Shared(c)) => c,
        Some(Group::SharedSaturated(c)) => {
            sat[1] += 1;
            c
        }
        _ => {
            edges += 1;
            let (c, n) = tu.edge_corner_counted(x as f64, y as f64, inv_z, slopes, sx, sy);
            sat[0] += n;
            c.unwrap_or(t.pos)
        }
    };
    let out = [corner(0, -1.0, -1.0), corner(1, 1.0, -1.0), corner(2, -1.0, 1.0), corner(3, 1.0, 1.0)];
    (out, edges, sat)
}

/// Rule 4: `(x0, x1, y0, y1)`. The corners are finite (a shared corner
/// is a mean of finite positions, an edge corner is finite or replaced by
/// the sample's finite position), so plain comparisons give what
/// `f64::min`/`max` give, in one instruction each.
#[inline]
pub fn bounding_box(c: &[DVec2; 4]) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (c[0].x, c[0].x, c[0].y, c[0].y);
    for p in &c[1..] {
        x0 = if p.x < x0 { p.x } else { x0 };
        x1 = if p.x > x1 { p.x } else { x1 };
        y0 = if p.y < y0 { p.y } else { y0 };
        y1 = if p.y > y1 { p.y } else { y1 };
    }
    debug_assert!([x0, x1, y0, y1].iter().all(|v| v.is_finite()), "corners are finite");
    (x0, x1, y0, y1)
}

/// Rule 5's direction: the 8-neighbour offset nearest `−D(x, y)` for the
/// reference-image epipole `e`; `None` where `D` vanishes.
#[inline]
pub fn backward_step(e: &Epipole, x: u32, y: u32) -> Option<(i32, i32)> {
    let d = -e.direction_at(DVec2::new(x as f64, y as f64));
    if d.length_squared() == 0.0 || !d.is_finite() {
        return None;
    }
    // 45° sectors split at tan(22.5°) = √2 − 1.
    const T: f64 = std::f64::consts::SQRT_2 - 1.0;
    let (ax, ay) = (d.x.abs(), d.y.abs());
    let sx = if d.x < 0.0 { -1 } else { 1 };
    let sy = if d.y < 0.0 { -1 } else { 1 };
    Some(if ay <= T * ax {
        (sx, 0)
    } else if ax <= T * ay {
        (0, sy)
    } else {
        (sx, sy)
    })
}

/// A kernel travelling from kernel setup to the rasterizer.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    /// The schedule line it belongs to.
    pub line: u32,
    /// The reference sample.
    pub sample: (u32, u32),
    /// Its derived 1/Z, as the candidate carries it (single precision).
    pub inv_z: f32,
    /// The stamp of rule 4's box around the warped sample (raster rules
    /// 1–3, [`crate::units::raster::stamp_of`]): computed with the kernel,
    /// taken by the rasterizer's control with it (raster rule 5).
    pub stamp: Rect,
    /// The sample's colour.
    pub colour: [f32; 3],
    /// Rule 5's hole-fill colour.
    pub fill_colour: [f32; 3],
    /// The reference sample's 1/Z and slopes (for the derived slopes and
    /// the better mask, computed on request).
    pub src_inv_z: f64,
    /// The reference sample's 1/Z slopes.
    pub src_slopes: [f32; 2],
    /// Fixed mode: saturations of its transform (own warp and edge
    /// corners) and of its kernel setup (shared corners), counted by the
    /// rasterizer if its stamp is not empty (counts, at most 12 and 4: up
    /// to 4 saturations in its own warp and 2 in each of its 4 edge
    /// corners; 4 shared corners).
    pub sat: [u8; 2],
}

/// Kernel setup's ports for one cycle.
pub struct KernelSetupPorts<'a> {
    /// The transform pipeline it absorbs from.
    pub transform: &'a mut TransformStage,
    /// The fetch unit's interval cursor (intervals fully pushed).
    pub fetch_interval: usize,
    /// The kernel FIFO to the rasterizer.
    pub out: &'a mut Fifo<Kernel>,
    /// The tile manager (kernels in flight per line).
    pub tiles: &'a mut TileManager,
}

/// Emissions ahead of the next one that kernel setup asks the host to
/// fetch (a host hint, no model effect).
const EMITS_AHEAD: usize = 6;

/// Kernel setup's control for one warp (rule 6).
pub struct KernelSetupStage<'s> {
    lines: &'s [Line],
    need: &'s [Option<usize>],
    reference: &'s HwReference,
    lanes: usize,
    line: usize,
    /// Where the lines' kernels are computed (`units::line_kernels`).
    source: LineSource<'s>,
    /// The current line's emissions (its valid samples in visiting order)
    /// once taken from `source`, and how many have been emitted.
    work: LineWork,
    computed: bool,
    next_emit: usize,
    kernels: u64,
    culled: u64,
    activity: Activity,
}

impl<'s> KernelSetupStage<'s> {
    /// Kernel setup over the schedule's `lines` (and their `need`) of a warp
    /// of `reference` by `tu`, `lanes` kernels per cycle, accounted by
    /// `activity`; it computes each line's kernels when it reaches it.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        lines: &'s [Line],
        need: &'s [Option<usize>],
        reference: &'s HwReference,
        tu: &'s TransformUnit,
        buffer: &'s mut LineBuffer,
        threshold: f64,
        shape: StampShape,
        lanes: u32,
        activity: Activity,
    ) -> Self {
        let source = LineSource::Inline(LineKernels::new(reference, tu, buffer, threshold, shape));
        Self::with_source(lines, need, reference, source, lanes, activity)
    }

    /// [`KernelSetupStage::new`], taking the lines' kernels from `source`
    /// (which must compute them for the same `lines` and `reference`).
    pub fn with_source(
        lines: &'s [Line],
        need: &'s [Option<usize>],
        reference: &'s HwReference,
        source: LineSource<'s>,
        lanes: u32,
        activity: Activity,
    ) -> Self {
        KernelSetupStage {
            lines,
            need,
            reference,
            lanes: lanes as usize,
            line: 0,
            source,
            work: LineWork::default(),
            computed: false,
            next_emit: 0,
            kernels: 0,
            culled: 0,
            activity,
        }
    }

    /// Lines whose kernels have all been emitted.
    #[inline]
    pub fn lines_emitted(&self) -> usize {
        self.line
    }

    /// Every line's kernels have been emitted.
    #[inline]
    pub fn is_done(&self) -> bool {
        self.line >= self.lines.len()
    }

    fn next_line(&mut self) {
        self.line += 1;
        self.computed = false;
        self.next_emit = 0;
    }

    /// One cycle (rule 6).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut KernelSetupPorts<'_>) -> Tick {
        let mut absorbed = 0;
        while absorbed < self.lanes && io.transform.take(now).is_some() {
            absorbed += 1;
        }
        let done_intervals = io.transform.oldest_interval().unwrap_or(io.fetch_interval);
        let mut emitted = 0;
        let mut stalled = None;
        while emitted < self.lanes && self.line < self.lines.len() {
            let Some(need) = self.need[self.line] else {
                // Dead line: no kernels.
                self.next_line();
                continue;
            };
            if need >= done_intervals {
                stalled = Some(StallReason::Upstream);
                break;
            }
            if !self.computed {
                self.take_line(io.transform);
            }
            // Host hint: fetch the emissions a few ahead of their use (with
            // the look-ahead they were written on another core).
            let ahead = self.work.emits.as_ptr().wrapping_add(self.next_emit + EMITS_AHEAD);
            crate::host_hint::prefetch(ahead);
            crate::host_hint::prefetch(ahead.cast::<u8>().wrapping_add(64));
            let Some(e) = self.work.emits.get(self.next_emit) else {
                self.next_line();
                continue;
            };
            if !io.out.offer(now) {
                stalled = Some(StallReason::FifoFull);
                break;
            }
            self.next_emit += 1;
            emitted += 1;
            match e {
                Emit::Culled => self.culled += 1,
                Emit::Kernel(k) => {
                    self.kernels += 1;
                    io.tiles.kernel_issued(self.line);
                    io.out.push(now, *k).unwrap_or_else(|_| unreachable!("offer() accepted the kernel"));
                }
            }
        }
        let t = if emitted > 0 || absorbed > 0 { Tick::BUSY } else { stalled.map_or(Tick::IDLE, Tick::stall) };
        self.activity.record(now, t)
    }

    /// The current line's kernels (rules 1–5, `units::line_kernels`), and
    /// the line buffer's check that every valid sample they read has been
    /// streamed by the transform unit (`line_buffer` rule 4).
    ///
    /// # Panics
    /// If the schedule lets kernel setup read a sample before the
    /// transform unit streamed it.
    fn take_line(&mut self, transform: &TransformStage) {
        self.source.take(self.line, self.lines[self.line], &mut self.work);
        let r = self.reference;
        for f in &self.work.warped {
            // Eight positions at a time: a run's bits in each 8x8 grid word.
            for (w, mask) in r.grid.run_words(f.major, f.line as u32, f.a0 as u32, f.a1 as u32) {
                let unstreamed = r.valid_word(w) & !transform.transformed_word(w) & mask;
                if unstreamed != 0 {
                    let (x, y) = r.grid.position(w, unstreamed.trailing_zeros());
                    panic!("line buffer read ({x}, {y}) before it was transformed");
                }
            }
        }
        self.computed = true;
    }

    /// End the warp at `now`; the unit's cycles and (when recording) its
    /// runs of states.
    pub fn close(&mut self, now: Cycle) -> (UnitCycles, Vec<Run>) {
        self.activity.close(now);
        (self.activity.cycles(), self.activity.take_runs())
    }

    /// Kernels set up and samples culled in this warp.
    pub fn counts(&self) -> (u64, u64) {
        (self.kernels, self.culled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(x: f64, y: f64) -> Option<Transformed> {
        Some(Transformed { pos: DVec2::new(x, y), inv_z: 1.0, e: 1.0, sat: 0 })
    }

    #[test]
    fn groups_share_the_mean_or_say_why_not() {
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(1.0, 1.0), 1.4), Group::Shared(DVec2::splat(0.5)));
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(3.0, 1.0), 1.4), Group::Discontinuous);
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), None, 1.4), Group::Missing);
        assert_eq!(group(w(0.0, 0.0), w(1.0, 0.0), w(0.0, 1.0), w(0.2, 0.2), 1.4), Group::Folded);
    }

    #[test]
    fn backward_step_points_away_from_a_front_epipole() {
        let e = Epipole { h: glam::DVec3::new(10.0, 10.0, 1.0) };
        assert_eq!(backward_step(&e, 20, 10), Some((1, 0)));
        assert_eq!(backward_step(&e, 0, 0), Some((-1, -1)));
        assert_eq!(backward_step(&e, 10, 10), None);
    }
}
