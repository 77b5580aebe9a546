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
//! 1. Two samples at offset `o` (|o| = 1 or √2) are one surface iff their
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

use super::line_buffer::{LineBuffer, Sources, at};
use super::tile_manager::TileManager;
use super::transform::{TransformStage, TransformUnit, Transformed};
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::camera::Epipole;
use crate::clock::Cycle;
use crate::fifo::Fifo;
use crate::hw_reference::{HwReference, RefSample};
use crate::qformat::QFormat;
use crate::traversal::{Line, Major};
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
    /// Its warped position (derived samples).
    pub pos: DVec2,
    /// Its derived 1/Z.
    pub inv_z: f64,
    /// Rule 4's box `(x0, x1, y0, y1)`.
    pub corners_box: (f64, f64, f64, f64),
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
    /// rasterizer if its stamp is not empty (counts).
    pub sat: [u32; 2],
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

/// What kernel setup emits for one valid sample of a line.
#[derive(Clone, Copy, Debug)]
enum Emit {
    /// Behind the derived camera: takes a slot, no kernel.
    Culled,
    /// A kernel for the rasterizer.
    Kernel(Kernel),
}

/// Kernel setup's control for one warp (rule 6).
pub struct KernelSetupStage<'s> {
    lines: &'s [Line],
    need: &'s [Option<usize>],
    reference: &'s HwReference,
    tu: &'s TransformUnit,
    buffer: &'s mut LineBuffer,
    threshold: f64,
    lanes: usize,
    line: usize,
    /// The current line's emissions (its valid samples in visiting order)
    /// once its kernels are computed, and how many have been emitted.
    emits: Vec<Emit>,
    computed: bool,
    next_emit: usize,
    /// Host scratch: the current line's reference records, gathered before
    /// its kernels are computed (a column sheet's records are a row apart;
    /// independent loads overlap their misses). No model state.
    recs_run: Vec<RefSample>,
    kernels: u64,
    culled: u64,
    activity: Activity,
}

impl<'s> KernelSetupStage<'s> {
    /// Kernel setup over the schedule's `lines` (and their `need`) of a warp
    /// of `reference` by `tu`, `lanes` kernels per cycle, accounted by
    /// `activity`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        lines: &'s [Line],
        need: &'s [Option<usize>],
        reference: &'s HwReference,
        tu: &'s TransformUnit,
        buffer: &'s mut LineBuffer,
        threshold: f64,
        lanes: u32,
        activity: Activity,
    ) -> Self {
        buffer.begin_warp(reference.width, reference.height);
        KernelSetupStage {
            lines,
            need,
            reference,
            tu,
            buffer,
            threshold,
            lanes: lanes as usize,
            line: 0,
            emits: Vec::new(),
            computed: false,
            next_emit: 0,
            recs_run: Vec::new(),
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
                self.compute_line(io.transform);
            }
            let Some(e) = self.emits.get(self.next_emit) else {
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

    /// The kernels of the current line's valid samples, in visiting order
    /// (rules 1–5): a pure function of the reference and the warp, so the
    /// host computes the whole line when kernel setup first reaches it.
    fn compute_line(&mut self, transform: &TransformStage) {
        let l = self.lines[self.line];
        let (r, tu, threshold) = (self.reference, self.tu, self.threshold);
        let src = Sources { tu, r, transform, threshold };
        let (major, c) = (l.major, l.line as i64);
        let (lo, hi) = (l.lo as i64, l.hi as i64);
        let buf = &mut *self.buffer;
        for line in [c - 1, c, c + 1] {
            buf.fill_warps(src, major, line, lo - 1, hi + 1);
        }
        for line in [c - 1, c] {
            buf.fill_groups(src, major, line, lo - 1, hi);
        }
        self.emits.clear();
        self.emits.reserve(l.len() as usize);
        let epipole = &tu.setup.epipole_reference;
        let len = match major {
            Major::Row => r.width as i64,
            Major::Column => r.height as i64,
        };
        let wcur = buf.warp_row(major, c).expect("the current line is on the image");
        let neighbours = [buf.warp_row(major, c - 1), Some(wcur), buf.warp_row(major, c + 1)];
        let (gprev, gcur) = (buf.group_row(major, c - 1), buf.group_row(major, c));
        let group = |row: Option<&[Option<Group>]>, a: i64| if a < 0 { None } else { row.and_then(|g| g[a as usize]) };
        let recs = r.line_recs(major, l.line);
        self.recs_run.clear();
        self.recs_run.extend((lo..=hi).map(|a| *recs.at(a as usize)));
        for k in 0..l.len() as i64 {
            let a = if l.step > 0 { lo + k } else { hi - k };
            let (x, y) = at(major, c, a);
            if !r.valid_at(r.grid.index(x, y)) {
                continue;
            }
            let Some(t) = wcur[a as usize] else {
                self.emits.push(Emit::Culled);
                continue;
            };
            // Corner order: (x-1, y-1), (x, y-1), (x-1, y), (x, y).
            let groups = match major {
                Major::Row => [group(gprev, a - 1), group(gprev, a), group(gcur, a - 1), group(gcur, a)],
                Major::Column => [group(gprev, a - 1), group(gcur, a - 1), group(gprev, a), group(gcur, a)],
            };
            let rec = self.recs_run[(a - lo) as usize];
            let src_inv_z = r.inv_z(&rec);
            let (corners, _, [ts, ks]) = corners_counted(tu, &t, x, y, src_inv_z, rec.slopes, groups);
            // Rule 5: a forward edge takes its backward neighbour's colour.
            let mut fill_colour = rec.colour;
            if let Some((dx, dy)) = backward_step(epipole, x, y) {
                let (dl, da) = match major {
                    Major::Row => (dy as i64, dx as i64),
                    Major::Column => (dx as i64, dy as i64),
                };
                let an = a + da;
                if let Some(row) = neighbours[(dl + 1) as usize]
                    && (0..len).contains(&an)
                    && let Some(tn) = row[an as usize]
                {
                    let (nx, ny) = at(major, c + dl, an);
                    let nk = r.rec(nx, ny);
                    // |(dx, dy)| of an 8-neighbour step (sqrt is exact here).
                    let offset = if dx != 0 && dy != 0 { std::f64::consts::SQRT_2 } else { 1.0 };
                    if nk.z > rec.z && !same_surface(&t, &tn, offset, threshold) {
                        fill_colour = nk.colour;
                    }
                }
            }
            self.emits.push(Emit::Kernel(Kernel {
                line: self.line as u32,
                sample: (x, y),
                pos: t.pos,
                inv_z: t.inv_z,
                corners_box: bounding_box(&corners),
                colour: rec.colour,
                fill_colour,
                src_inv_z,
                src_slopes: rec.slopes,
                sat: [t.sat + ts, ks],
            }));
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
