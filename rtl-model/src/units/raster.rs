//! Rasterizer: flat-shaded axis-aligned rectangles of at most
//! `kernel_limit` x `kernel_limit` samples (TR98 §7.2, §10: a 4x4 stamp).
//!
//! Job: turn a kernel's bounding box into the derived sample centres it
//! covers, clipped to the stamp around the warped sample and to the image.
//!
//! Ports: in, a kernel (its stamp, rule 5, and candidate) from kernel setup;
//! out, up to `kernel_limit²` covered sample addresses with the flat
//! candidate, to the compositor.
//!
//! Throughput: `rects_per_cycle` rectangles per cycle (knob); the stamp
//! compares all its centres in parallel, so a rectangle costs one cycle
//! whatever its size.
//!
//! Rules:
//! 1. Coverage is half-open: centre `c` is inside `[lo, hi)` iff
//!    `lo <= c < hi`, so abutting boxes never double-cover.
//! 2. A box wider or taller than the stamp is clipped per axis to the
//!    `kernel_limit` centres nearest the warped sample (the window start is
//!    `round(centre − (limit − 1)/2)`, clamped into the box), and counted.
//! 3. Then clipped to the derived image.
//!
//! 4. Control ([`RasterStage`]): each cycle it takes up to
//!    `rects_per_cycle` kernels from the kernel FIFO, but only while the
//!    stamp FIFO to the compositor offers room (it has no output register,
//!    so it accepts a kernel only when its output is ready): otherwise it
//!    stalls on `fifo_full`; with a kernel still in the kernel FIFO's
//!    transit it stalls on `upstream` (as the compositor does). A kernel whose stamp is empty after clipping
//!    takes a slot, produces nothing and is done. A non-empty stamp gets
//!    the flat candidate: the kernel's colour, 1/Z and fill colour, the
//!    derived slopes (from the transform unit, on request) and the
//!    reference number.
//!
//! 5. Host: the stamp (rules 1–3, [`stamp_of`]) is a pure function of
//!    the kernel's box and the warp, so the host computes it with the
//!    kernel, in kernel setup's line computation (`units::line_kernels`,
//!    on the look-ahead thread when there is one): the kernel carries its
//!    stamp (28 bytes) instead of its box and warped centre (48 bytes), and
//!    the control takes it with the kernel. Where and when the host
//!    computes it changes no cycle and no value.
//!
//! Fixed mode (`docs/fixed-point.md`): the derived slopes round to
//! `q_slope`; a non-empty stamp counts its kernel's saturations
//! (`saturations.transform`, `saturations.kernel_setup`) and its slopes'
//! (`saturations.raster`): drawn kernels are the set both engines agree on.
//!
//! Not modelled: the general path's triangle mesh (TR98 §7.1); boxes drawn
//! larger than the stamp (the hardware cannot).

use super::composite::Candidate;
use super::kernel_setup::Kernel;
use super::tile_manager::TileManager;
use super::transform::TransformUnit;
use super::{Activity, Run, StallReason, Tick, UnitCycles};
use crate::clock::Cycle;
use crate::fifo::Fifo;
use crate::frame_stats::RECT_HIST_MAX;

/// A rasterized rectangle. Its corners are clipped to the image, so they
/// fit 32 bits (an empty rectangle's, clamped to 32 bits, stay empty):
/// kernels carry their stamps across host threads, and its size is host
/// time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// Covered columns, inclusive (empty if `x.0 > x.1`).
    pub x: (i32, i32),
    /// Covered rows, inclusive.
    pub y: (i32, i32),
    /// Size of the box before clipping (sample centres per axis).
    pub size: (u32, u32),
    /// The box exceeded the stamp (rule 2).
    pub over_limit: bool,
}

/// Smallest integer `>= v` (`v` finite or not; NaN gives 0).
#[inline]
fn ceil_to_int(v: f64) -> i64 {
    v.ceil() as i64
}

#[inline]
fn centres_in(lo: f64, hi: f64) -> (i64, i64) {
    (ceil_to_int(lo), ceil_to_int(hi) - 1)
}

#[inline]
fn window(range: (i64, i64), centre: f64, limit: u32) -> (i64, i64) {
    let (a, b) = range;
    let l = limit as i64;
    if b - a < l {
        return range;
    }
    let start = ((centre - (l as f64 - 1.0) / 2.0).round() as i64).clamp(a, b - l + 1);
    (start, start + l - 1)
}

/// Rasterize the box `[x0, x1) x [y0, y1)` of a kernel whose warped sample
/// is at `centre`, with stamp side `limit`, in a `size` image.
#[inline]
pub fn rect(x0: f64, x1: f64, y0: f64, y1: f64, centre: (f64, f64), limit: u32, size: (u32, u32)) -> Rect {
    let (rx, ry) = (centres_in(x0, x1), centres_in(y0, y1));
    let n = |r: (i64, i64)| (r.1 - r.0 + 1).max(0) as u32;
    let kernel = (n(rx), n(ry));
    let over_limit = kernel.0 > limit || kernel.1 > limit;
    let (rx, ry) = (window(rx, centre.0, limit), window(ry, centre.1, limit));
    // Clipped to the image, then clamped into 32 bits (only an empty
    // range's ends can lie outside them; clamping keeps it empty).
    let clip = |r: (i64, i64), n: u32| {
        let (lo, hi) = (r.0.max(0), r.1.min(n as i64 - 1));
        let c = |v: i64| v.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        (c(lo), c(hi))
    };
    Rect { x: clip(rx, size.0), y: clip(ry, size.1), size: kernel, over_limit }
}

impl Rect {
    /// True if no centre is covered.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.x.0 > self.x.1 || self.y.0 > self.y.1
    }

    /// Covered centres (columns, rows) after clipping.
    #[inline]
    pub fn drawn(&self) -> (u32, u32) {
        if self.is_empty() { (0, 0) } else { ((self.x.1 - self.x.0 + 1) as u32, (self.y.1 - self.y.0 + 1) as u32) }
    }

    /// Visit the covered centres in raster order.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(u32, u32)) {
        // Half-open ranges: an inclusive range's iterator carries an
        // exhausted flag that the host checks on every step.
        for y in self.y.0..self.y.1 + 1 {
            for x in self.x.0..self.x.1 + 1 {
                f(x as u32, y as u32);
            }
        }
    }
}

/// The stamp shape of a warp: the stamp side (`kernel_limit`) and the
/// derived image size the rectangles are clipped to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StampShape {
    /// Stamp side, samples (`kernel_limit`).
    pub limit: u32,
    /// Derived image size, samples.
    pub size: (u32, u32),
}

/// The stamp of a kernel box `corners_box` `(x0, x1, y0, y1)` around the
/// warped sample at `pos` (rules 1–3; the datapath of rule 5).
#[inline]
pub fn stamp_of(shape: StampShape, corners_box: (f64, f64, f64, f64), pos: (f64, f64)) -> Rect {
    let (x0, x1, y0, y1) = corners_box;
    rect(x0, x1, y0, y1, pos, shape.limit, shape.size)
}

/// One clock's stamp travelling from the rasterizer to the compositor: the
/// kernel's clipped rectangle of covered samples (the golden model's
/// [`Rect`] too) and its flat candidate. "Stamp" is the hardware's 4x4
/// footprint per clock (`docs/warper-reference.md`), the one word the
/// golden model has no twin for.
#[derive(Clone, Copy, Debug)]
pub struct Stamped {
    /// The schedule line of its kernel.
    pub line: u32,
    /// Covered derived samples.
    pub rect: Rect,
    /// The flat candidate.
    pub cand: Candidate,
    /// The reference sample.
    pub sample: (u32, u32),
    /// The reference sample's 1/Z and slopes (for the better mask).
    pub src_inv_z: f64,
    /// The reference sample's 1/Z slopes.
    pub src_slopes: [f32; 2],
    /// The better-reference mask, once computed.
    pub better: Option<u32>,
    /// The compositor has counted this stamp's tile look-ups (a retry is
    /// not counted again).
    pub counted: bool,
}

/// The rasterizer's ports for one cycle.
pub struct RasterPorts<'a> {
    /// The kernel FIFO from kernel setup.
    pub input: &'a mut Fifo<Kernel>,
    /// The stamp FIFO to the compositor.
    pub out: &'a mut Fifo<Stamped>,
    /// The tile manager (a kernel with an empty stamp is done).
    pub tiles: &'a mut TileManager,
}

/// The rasterizer's control for one warp (rule 4).
pub struct RasterStage<'s> {
    tu: &'s TransformUnit,
    source: u8,
    lanes: usize,
    over_limit: u64,
    rects: [[u64; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1],
    /// Fixed mode: saturations of the non-empty stamps' kernels,
    /// `[transform, kernel_setup, raster]` (counts).
    sat: [u64; 3],
    activity: Activity,
}

impl<'s> RasterStage<'s> {
    /// A rasterizer of `lanes` rectangles per cycle, for the warp of
    /// reference number `source` by `tu`, accounted by `activity`.
    pub fn new(tu: &'s TransformUnit, source: u8, lanes: u32, activity: Activity) -> Self {
        RasterStage {
            tu,
            source,
            lanes: lanes as usize,
            over_limit: 0,
            rects: [[0; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1],
            sat: [0; 3],
            activity,
        }
    }

    /// One cycle (rule 4).
    #[inline]
    pub fn tick(&mut self, now: Cycle, io: &mut RasterPorts<'_>) -> Tick {
        let mut did = 0;
        let mut blocked = false;
        while did < self.lanes && io.input.can_pop(now) {
            if !io.out.offer(now) {
                blocked = true;
                break;
            }
            let k = io.input.pop(now).expect("visible");
            did += 1;
            let s = k.stamp;
            self.over_limit += s.over_limit as u64;
            if s.is_empty() {
                io.tiles.kernel_done(k.line);
                continue;
            }
            let (cw, ch) = s.drawn();
            self.rects[(cw as usize).min(RECT_HIST_MAX)][(ch as usize).min(RECT_HIST_MAX)] += 1;
            let (x, y) = k.sample;
            let mut slopes = self.tu.dest_slopes(x as f64, y as f64, k.src_inv_z, k.src_slopes);
            if let Some(f) = self.tu.fixed() {
                // Fixed mode: the derived slopes in `q_slope`; the stamp's
                // kernel's saturations count now that it is drawn.
                let mut n = 0;
                slopes = slopes.map(|v| f.slope.q(v, &mut n));
                self.sat[0] += u64::from(k.sat[0]);
                self.sat[1] += u64::from(k.sat[1]);
                self.sat[2] += n as u64;
            }
            let cand = Candidate {
                colour: k.colour,
                inv_z: k.inv_z,
                slopes: [slopes[0] as f32, slopes[1] as f32],
                source: self.source,
                fill_colour: k.fill_colour,
            };
            let job = Stamped {
                line: k.line,
                rect: s,
                cand,
                sample: k.sample,
                src_inv_z: k.src_inv_z,
                src_slopes: k.src_slopes,
                better: None,
                counted: false,
            };
            io.out.push(now, job).unwrap_or_else(|_| unreachable!("offer() accepted the stamp"));
        }
        let t = if did > 0 {
            Tick::BUSY
        } else if blocked {
            Tick::stall(StallReason::FifoFull)
        } else if !io.input.is_empty() {
            // A kernel still in the kernel FIFO's transit.
            Tick::stall(StallReason::Upstream)
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

    /// Fixed mode: saturations of the drawn kernels in this warp,
    /// `[transform, kernel_setup, raster]`.
    pub fn saturations(&self) -> [u64; 3] {
        self.sat
    }

    /// Kernels over the stamp, and non-empty stamps by drawn size, in this
    /// warp.
    pub fn counts(&self) -> (u64, &[[u64; RECT_HIST_MAX + 1]; RECT_HIST_MAX + 1]) {
        (self.over_limit, &self.rects)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_is_half_open_and_clipped_around_the_sample() {
        let s = rect(-0.5, 0.5, 0.5, 1.5, (0.0, 1.0), 4, (10, 10));
        assert_eq!((s.x, s.y), ((0, 0), (1, 1)));
        let s = rect(0.2, 0.8, 0.0, 1.0, (0.5, 0.5), 4, (10, 10));
        assert!(s.is_empty());
        let s = rect(-0.5, 9.5, -0.5, 1.5, (5.2, 0.5), 4, (10, 10));
        assert_eq!((s.x, s.size, s.over_limit), ((4, 7), (10, 2), true));
        assert_eq!(s.drawn(), (4, 2));
    }
}
