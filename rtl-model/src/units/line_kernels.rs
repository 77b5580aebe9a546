//! Kernel setup's line computation and where the host runs it: the
//! kernels of a traversal line's valid samples in visiting order (rules
//! 1–5 of `units::kernel_setup`, whose datapath functions it calls).
//!
//! Job: turn a schedule line into its emissions (a kernel, or a culled
//! slot, per valid sample), reading the reference records and the line
//! buffer; each kernel carries its stamp (`units::raster::stamp_of`,
//! raster rule 5). No timing: the values are pure functions of the reference and
//! the warp, so the host may compute a line whenever it likes before kernel
//! setup emits it. Kernel setup's control (`KernelSetupStage`) decides when
//! each kernel leaves; this file decides nothing about time.
//!
//! Ports: in, the reference (its records through the block copy
//! `crate::ref_blocks::RefBlocks`, which this computation owns and lends
//! the line buffer; its valid map) and the warp's transform unit, through
//! the line buffer; out, a [`LineWork`] per line: the emissions and the
//! runs of positions the line buffer warped for it.
//!
//! Throughput: not a timed unit (kernel setup's lanes time the emissions).
//!
//! Rules:
//! 1. Lines are computed in schedule order, skipping dead lines (no
//!    `need`), each exactly once per warp, so the line buffer's contents
//!    and the warped runs are the same whoever computes them.
//! 2. Two hosts of the same values: [`LineSource::Inline`] computes a line
//!    when kernel setup first reaches it; [`LineSource::Ahead`] computes
//!    the lines on another host thread ([`LinesAhead`]), handing them
//!    over in batches of about [`SLOTS_PER_BATCH`] samples, at most
//!    [`BATCHES_AHEAD`] batches ahead, and kernel setup takes them in
//!    order. Both give the same emissions bit for bit
//!    (`rtl-model/tests/unit_kernel_setup.rs`, `tests/hw_look_ahead.rs`).
//! 3. Kernel setup checks a line's warped runs against the transform
//!    unit's streamed samples when it takes the line, in either mode
//!    (`line_buffer` rule 4).
//! 4. A panic on the look-ahead thread reaches kernel setup when it next
//!    takes a line, with the thread's own message.
//!
//! Not modelled: nothing of the hardware; this is the host's schedule of
//! a pure computation.

use super::kernel_setup::{Kernel, backward_step, bounding_box, corners_counted, same_surface};
use super::line_buffer::{LineBuffer, Sources, WarpedRun, at};
use super::raster::{StampShape, stamp_of};
use super::transform::TransformUnit;
use crate::hw_reference::{HwReference, RefSample};
use crate::ref_blocks::RefBlocks;
use crate::traversal::{Line, Major};
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel, sync_channel};
use std::thread::{Scope, ScopedJoinHandle};

/// What kernel setup emits for one valid sample of a line.
#[derive(Clone, Copy, Debug)]
pub enum Emit {
    /// Behind the derived camera: takes a slot, no kernel.
    Culled,
    /// A kernel for the rasterizer.
    Kernel(Kernel),
}

/// One line's results.
#[derive(Debug, Default)]
pub struct LineWork {
    /// The line's number in the schedule.
    pub index: usize,
    /// The emissions of its valid samples, in visiting order.
    pub emits: Vec<Emit>,
    /// The runs of positions the line buffer warped for it (rule 3).
    pub warped: Vec<WarpedRun>,
}

/// Samples (line positions, whether valid or not: the room each line's
/// emissions reserve) the look-ahead thread gathers before it hands a batch
/// of whole lines over (rule 2): one hand-over, and one wake-up of a
/// waiting thread, per batch rather than per line, and host memory bounded
/// whatever the frame size (at most about 2 MB of emissions of 128 bytes
/// per batch, beyond its last line; 2^13 to 2^15 ran the bench frame
/// equally fast, 2^12 and 2^16 slower).
pub const SLOTS_PER_BATCH: usize = 1 << 14;

/// Batches the look-ahead thread may have ready beyond the one kernel setup
/// is taking from (rule 2).
pub const BATCHES_AHEAD: usize = 2;

/// The line computation of one warp (rule 1).
pub struct LineKernels<'s> {
    reference: &'s HwReference,
    tu: &'s TransformUnit,
    buffer: &'s mut LineBuffer,
    threshold: f64,
    /// The warp's stamp shape (raster rule 5).
    shape: StampShape,
    /// Host scratch: the current line's reference records, gathered before
    /// its kernels are computed (a column sheet's records are a row apart;
    /// independent loads overlap their misses). No model state.
    recs_run: Vec<RefSample>,
    /// The reference's records, a block at a time (`crate::ref_blocks`).
    blocks: RefBlocks,
}

impl<'s> LineKernels<'s> {
    /// The computation for a warp of `reference` by `tu`, with `buffer`
    /// (readied for the warp here), discontinuity `threshold` and stamps of
    /// `shape`.
    pub fn new(
        reference: &'s HwReference,
        tu: &'s TransformUnit,
        buffer: &'s mut LineBuffer,
        threshold: f64,
        shape: StampShape,
    ) -> Self {
        buffer.begin_warp(reference.width, reference.height);
        let blocks = RefBlocks::new(reference);
        LineKernels { reference, tu, buffer, threshold, shape, recs_run: Vec::new(), blocks }
    }

    /// Line `l` (number `index` in the schedule) into `out` (cleared
    /// first).
    pub fn compute(&mut self, index: usize, l: Line, out: &mut LineWork) {
        let (r, tu, threshold, shape) = (self.reference, self.tu, self.threshold, self.shape);
        let src = Sources { tu, r, threshold };
        let (major, c) = (l.major, l.line as i64);
        let (lo, hi) = (l.lo as i64, l.hi as i64);
        let buf = &mut *self.buffer;
        for line in [c - 1, c, c + 1] {
            buf.fill_warps(src, &mut self.blocks, major, line, lo - 1, hi + 1);
        }
        for line in [c - 1, c] {
            buf.fill_groups(src, major, line, lo - 1, hi);
        }
        buf.take_warped(&mut out.warped);
        out.index = index;
        let emits = &mut out.emits;
        emits.clear();
        emits.reserve(l.len() as usize);
        let epipole = &tu.setup.epipole_reference;
        let len = match major {
            Major::Row => r.width as i64,
            Major::Column => r.height as i64,
        };
        let wcur = buf.warp_row(major, c).expect("the current line is on the image");
        let neighbours = [buf.warp_row(major, c - 1), Some(wcur), buf.warp_row(major, c + 1)];
        let (gprev, gcur) = (buf.group_row(major, c - 1), buf.group_row(major, c));
        let group = |row: Option<&[Option<_>]>, a: i64| if a < 0 { None } else { row.and_then(|g| g[a as usize]) };
        self.recs_run.clear();
        self.blocks.line(r, major, l.line, lo as u32, hi as u32, &mut self.recs_run);
        for k in 0..l.len() as i64 {
            let a = if l.step > 0 { lo + k } else { hi - k };
            let (x, y) = at(major, c, a);
            if !r.valid_at(r.grid.index(x, y)) {
                continue;
            }
            let Some(t) = wcur[a as usize] else {
                emits.push(Emit::Culled);
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
                    let nk = self.blocks.rec(r, nx, ny);
                    // |(dx, dy)| of an 8-neighbour step (sqrt is exact here).
                    let offset = if dx != 0 && dy != 0 { std::f64::consts::SQRT_2 } else { 1.0 };
                    if nk.z > rec.z && !same_surface(&t, &tn, offset, threshold) {
                        fill_colour = nk.colour;
                    }
                }
            }
            emits.push(Emit::Kernel(Kernel {
                line: index as u32,
                sample: (x, y),
                inv_z: t.inv_z as f32,
                stamp: stamp_of(shape, bounding_box(&corners), (t.pos.x, t.pos.y)),
                colour: rec.colour,
                fill_colour,
                src_inv_z,
                src_slopes: rec.slopes,
                sat: [t.sat + ts, ks].map(|n| u8::try_from(n).expect("at most 12 saturations per kernel")),
            }));
        }
    }
}

/// The look-ahead thread's ends held by kernel setup (rule 2).
pub struct LinesAhead<'scope> {
    /// Batches of computed lines, in schedule order (live lines only).
    lines: Receiver<Vec<LineWork>>,
    /// The batch being taken from, and the next line in it; taken lines
    /// are swapped for spent ones, so the batch goes back whole.
    batch: Vec<LineWork>,
    next: usize,
    /// Spent batches back to the thread, to be refilled.
    spent: Sender<Vec<LineWork>>,
    /// The thread, joined if it stops early (rule 4).
    thread: Option<ScopedJoinHandle<'scope, ()>>,
}

impl<'scope> LinesAhead<'scope> {
    /// Start computing the live lines of `lines` (those with a `need`) with
    /// `kernels` on a thread of `scope`. The thread stops after the last
    /// line, or at its next hand-over once the returned ends are dropped.
    pub fn spawn<'env>(
        scope: &'scope Scope<'scope, 'env>,
        lines: &'env [Line],
        need: &'env [Option<usize>],
        mut kernels: LineKernels<'env>,
    ) -> LinesAhead<'scope> {
        let (tx, rx): (SyncSender<Vec<LineWork>>, _) = sync_channel(BATCHES_AHEAD);
        let (spent, spent_rx) = channel::<Vec<LineWork>>();
        let thread = scope.spawn(move || {
            let mut live = lines.iter().enumerate().filter(|&(i, _)| need[i].is_some());
            loop {
                let mut batch = spent_rx.try_recv().unwrap_or_default();
                let (mut n, mut slots) = (0, 0);
                while slots < SLOTS_PER_BATCH
                    && let Some((i, l)) = live.next()
                {
                    if n == batch.len() {
                        batch.push(LineWork::default());
                    }
                    kernels.compute(i, *l, &mut batch[n]);
                    slots += l.len() as usize;
                    n += 1;
                }
                batch.truncate(n);
                if n == 0 || tx.send(batch).is_err() {
                    return;
                }
            }
        });
        LinesAhead { lines: rx, batch: Vec::new(), next: 0, spent, thread: Some(thread) }
    }

    /// The next computed line into `work` (its old contents go back).
    fn take(&mut self, work: &mut LineWork) {
        if self.next == self.batch.len() {
            let spent = std::mem::take(&mut self.batch);
            if !spent.is_empty() {
                // The thread may have finished: then the batch is dropped.
                let _ = self.spent.send(spent);
            }
            self.batch = match self.lines.recv() {
                Ok(batch) => batch,
                Err(_) => match self.thread.take().map(ScopedJoinHandle::join) {
                    Some(Err(panic)) => std::panic::resume_unwind(panic),
                    _ => panic!("the kernel look-ahead thread stopped before the last line"),
                },
            };
            self.next = 0;
        }
        std::mem::swap(work, &mut self.batch[self.next]);
        self.next += 1;
    }
}

/// Where kernel setup's lines come from (rule 2).
pub enum LineSource<'s> {
    /// Computed on kernel setup's own thread when reached.
    Inline(LineKernels<'s>),
    /// Computed ahead on another thread.
    Ahead(LinesAhead<'s>),
}

impl LineSource<'_> {
    /// Line `l` (number `index`, live) into `work`, replacing its contents.
    ///
    /// # Panics
    /// With the look-ahead thread's panic if it panicked (rule 4).
    pub fn take(&mut self, index: usize, l: Line, work: &mut LineWork) {
        match self {
            LineSource::Inline(k) => k.compute(index, l, work),
            LineSource::Ahead(a) => a.take(work),
        }
        debug_assert_eq!(work.index, index, "lines are taken in the order they were computed");
    }
}
