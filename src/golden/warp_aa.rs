//! The anti-aliased path's warp of one reference (`frame.rs` rules 2, 4
//! and 5): transform, kernel setup, rasterization into per-sample candidate
//! slots (phase A, reference raster order), then compositing each derived
//! sample's candidates in warp order (phase B).

use super::composite::{Candidate, Kind, Outcome, composite_with};
use super::config::{GoldenConfig, WarpOrder};
use super::cull;
use super::frame::{GoldenStats, KERNEL_HIST_MAX, PreparedReference, count_outcomes, forward_edge_neighbour};
use super::kernel_setup::{GroupState, bounding_box, corners_counted};
use super::phase_times::{Phase, start, stop};
use super::planes::DestPlanes;
use super::raster::{CEIL_I32_RANGE, ceil_i32, rect, rect_of_ranges};
use super::transform::{BATCH, SampleBatch, Transformed, WarpContext};
use super::traversal::OrderKey;
use glam::DVec2;
use postwarp_rtl::SampleImage;

/// A kernel ready to draw, kept small (24 bytes: phase B reads it from
/// memory): the rest of its candidate is read from the reference, its
/// warp-order key recomputed when a bucket needs sorting.
struct Kernel {
    /// Reference sample.
    x: u32,
    y: u32,
    /// Derived 1/Z.
    inv_z: f32,
    /// Derived slopes of 1/Z.
    slopes: [f32; 2],
    /// Better-reference mask once computed ([`UNKNOWN`] before).
    better: std::cell::Cell<u16>,
    /// Offset to the reference sample whose colour goes to the hole-fill
    /// plane (rule 4): (0, 0) or the forward-edge neighbour.
    fill: [i8; 2],
}

/// Marks a better-reference mask not yet computed (masks use bits 0–7).
const UNKNOWN: u16 = u16::MAX;

/// Working buffers of one reference warp, kept across warps and frames so
/// that a run does not page-fault fresh memory for every warp.
#[derive(Default)]
pub(super) struct Scratch {
    rows: Rows,
    kernels: Vec<Kernel>,
    /// Per derived sample: its only candidate kernel so far, [`EMPTY`] or
    /// [`MULTI`].
    slots: Vec<u32>,
    /// `(derived sample << 32) | kernel` for the derived samples with
    /// several candidates ([`MULTI`]).
    overflow: Vec<u64>,
}

/// A derived sample no kernel covers (yet).
const EMPTY: u32 = u32::MAX;
/// A derived sample several kernels cover: its candidates are in the
/// overflow list.
const MULTI: u32 = u32::MAX - 1;

/// The live region plus its one-sample ring, inclusive (reference samples).
#[derive(Clone, Copy, Debug)]
struct Region {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Region {
    /// Columns.
    fn width(&self) -> usize {
        (self.x1 - self.x0 + 1) as usize
    }
}

/// One row of warped samples over the region's columns, one array per
/// term (`ok`: a surface, warped in front of the derived camera).
#[derive(Default)]
struct WarpedRow {
    px: Vec<f64>,
    py: Vec<f64>,
    inv_z: Vec<f64>,
    e: Vec<f64>,
    ok: Vec<bool>,
    /// Fixed mode: the warp's saturations (0 in float mode).
    sat: Vec<u32>,
    /// The reference's 1/Z ([`PreparedReference::inv_z`]), kept for the
    /// row's kernel slopes.
    ref_inv_z: Vec<f64>,
}

impl WarpedRow {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.px, &mut self.py, &mut self.inv_z, &mut self.e, &mut self.ref_inv_z] {
            v.resize(n, 0.0);
        }
        self.ok.resize(n, false);
        self.sat.resize(n, 0);
    }

    /// Column `k`'s warp, `None` if not `ok`.
    #[inline(always)]
    fn at(&self, k: usize) -> Option<Transformed> {
        self.ok[k].then(|| Transformed {
            pos: DVec2::new(self.px[k], self.py[k]),
            inv_z: self.inv_z[k],
            e: self.e[k],
            sat: self.sat[k],
        })
    }
}

/// One row of 2x2 groups (top-left sample in this row) over the region's
/// columns: state and shared corner (set only where `Shared`), and for the
/// fast path the corner's ceilings (`fast`: shared, and the corner within
/// [`CEIL_I32_RANGE`]; `ceil` is only meaningful there).
#[derive(Default)]
struct GroupRow {
    state: Vec<GroupState>,
    cx: Vec<f64>,
    cy: Vec<f64>,
    fast: Vec<bool>,
    ceil_x: Vec<i32>,
    ceil_y: Vec<i32>,
    /// Fixed mode: the shared corner saturated `q_corner`.
    csat: Vec<bool>,
}

impl GroupRow {
    fn resize(&mut self, n: usize) {
        self.csat.resize(n, false);
        self.state.resize(n, GroupState::Missing);
        self.cx.resize(n, 0.0);
        self.cy.resize(n, 0.0);
        self.fast.resize(n, false);
        self.ceil_x.resize(n, 0);
        self.ceil_y.resize(n, 0);
    }

    /// Column `k`'s state and corner, as [`group`] gives them.
    #[inline(always)]
    fn at(&self, k: usize) -> (GroupState, DVec2) {
        match self.state[k] {
            GroupState::Shared => (GroupState::Shared, DVec2::new(self.cx[k], self.cy[k])),
            s => (s, DVec2::ZERO),
        }
    }
}

/// The rows phases 1–3 work on: warped rows y − 1, y, y + 1 and group rows
/// y − 1, y, each at index `(row − region.y0) mod 3` (mod 2 for groups).
#[derive(Default)]
pub(super) struct Rows {
    warped: [WarpedRow; 3],
    groups: [GroupRow; 2],
}

/// Warp one reference into `d` (rules 2, 4 and 5). Inlined, with its
/// loops, into each [`super::vector_level::VectorLevel`]'s copy of the warp.
#[inline(always)]
pub(super) fn warp_reference(
    ctx: &WarpContext,
    prepared: &PreparedReference,
    source: u8,
    cfg: &GoldenConfig,
    d: &mut DestPlanes,
    st: &mut GoldenStats,
    scratch: &mut Scratch,
) {
    let Scratch { rows, kernels, slots, overflow } = scratch;
    let img = &prepared.samples;
    let (w, h) = (img.width, img.height);
    st.reference_samples += img.valid.count_ones() as u64;
    let live = cull::live_blocks(ctx, &prepared.blocks, d.width, d.height);
    let Some((rx0, ry0, rx1, ry1)) = live.bounds(w, h) else { return };
    // The live region plus its one-sample ring (neighbours of live samples).
    // Samples outside it are in culled blocks, where W > 0 (cull.rs).
    let q = Region {
        x0: rx0.saturating_sub(1),
        y0: ry0.saturating_sub(1),
        x1: (rx1 + 1).min(w - 1),
        y1: (ry1 + 1).min(h - 1),
    };
    let keys = OrderKey::new(w, h, &ctx.setup.epipole_reference);
    let reverse = cfg.warp_order == WarpOrder::Reverse;

    // Phases 1–3 a row at a time: the transform of row y + 1, the groups of
    // row y (warped rows y and y + 1), then phase A on row y (group rows
    // y − 1 and y, warped rows y − 1 to y + 1). Each is a loop of its own
    // over a row (the transform's vectorises), and the rows stay in cache.
    for r in rows.warped.iter_mut() {
        r.resize(q.width());
    }
    for g in rows.groups.iter_mut() {
        g.resize(q.width());
    }
    kernels.clear();
    slots.clear();
    slots.resize(d.len(), EMPTY);
    overflow.clear();
    let mut hist = [[0u64; KERNEL_HIST_MAX + 1]; KERNEL_HIST_MAX + 1];
    let t = start();
    transform_row(ctx, prepared, &q, q.y0, &mut rows.warped[0], st);
    if q.y0 < q.y1 {
        transform_row(ctx, prepared, &q, q.y0 + 1, &mut rows.warped[1], st);
    }
    stop(Phase::Transform, t);
    // Derived slopes, and the better-reference masks when earlier warps
    // have stored samples the kernels may meet (compositing rule 3;
    // otherwise on demand), are computed per row after phase A (`KernelSlopes`).
    let mut slopes = KernelSlopes { masks_now: source > 0, batch: Box::default() };
    let phase_a = PhaseA { ctx, img, prepared, cfg, q, live: &live, size: (d.width, d.height) };
    for y in q.y0..=q.y1 {
        let r = (y - q.y0) as usize;
        let t = start();
        if y < q.y1 {
            let [a, b] = [&rows.warped[r % 3], &rows.warped[(r + 1) % 3]];
            group_row(a, b, cfg.threshold, &mut rows.groups[r % 2]);
            if let Some(f) = ctx.fixed() {
                fix_group_row(f.corner, &mut rows.groups[r % 2]);
            }
        } else {
            rows.groups[r % 2].state.fill(GroupState::Missing);
            rows.groups[r % 2].fast.fill(false);
        }
        stop(Phase::Groups, t);
        if (ry0..=ry1).contains(&y) {
            let first = kernels.len();
            let t = start();
            phase_a.row(y, rows, kernels, slots, overflow, &mut hist, st);
            stop(Phase::PhaseA, t);
            let t = start();
            slopes.row(ctx, img, &rows.warped[r % 3], q.x0, &mut kernels[first..], st);
            stop(Phase::Slopes, t);
        }
        if y + 2 <= q.y1 {
            let t = start();
            transform_row(ctx, prepared, &q, y + 2, &mut rows.warped[(r + 2) % 3], st);
            stop(Phase::Transform, t);
        }
    }
    for (a, b) in st.kernel_sizes.iter_mut().zip(&hist) {
        for (a, b) in a.iter_mut().zip(b) {
            *a += b;
        }
    }

    // Phase B: per derived sample, composite its candidates in warp order.
    // Compositing touches only its own sample, so this equals drawing the
    // kernels one by one in warp order (rule 2). The overflow list sorted
    // holds each shared sample's candidates together.
    let t = start();
    overflow.sort_unstable();
    stop(Phase::Sort, t);
    let t = start();
    let b = PhaseB { ctx, prepared, source, slope_tol: cfg.slope_tol, rel_tol: cfg.rel_tol };
    let mut counts = [0u64; OUTCOMES];
    let mut next = 0;
    for (s, &slot) in slots.iter().enumerate() {
        match slot {
            EMPTY => {}
            MULTI => {
                let begin = next;
                while next < overflow.len() && (overflow[next] >> 32) as usize == s {
                    next += 1;
                }
                let shared = &mut overflow[begin..next];
                // Keys are distinct (one per reference sample): any sort
                // gives the warp order.
                shared.sort_unstable_by_key(|&e| {
                    let kern = &kernels[e as u32 as usize];
                    if reverse { keys.warp_key(kern.x, kern.y) } else { keys.key(kern.x, kern.y) }
                });
                for &e in shared.iter() {
                    b.draw(d, s, &kernels[e as u32 as usize], &mut counts);
                }
            }
            k => b.draw(d, s, &kernels[k as usize], &mut counts),
        }
    }
    stop(Phase::PhaseB, t);
    for (k, &n) in counts.iter().enumerate() {
        count_outcomes(st, OUTCOME_ORDER[k], n);
    }
}

/// The derived slopes and better-reference masks of a row's kernels, in
/// loops of their own over batches of kernels: they vectorise, and the
/// divisions of successive kernels overlap where inside phase A each
/// stalled it. The reference's 1/Z is read from the row just warped (not
/// divided again), its slopes from that row of the image.
struct KernelSlopes {
    /// Masks now (earlier warps have stored samples), not on demand.
    masks_now: bool,
    batch: Box<SampleBatch>,
}

impl KernelSlopes {
    /// Slopes (and masks) of `kernels`, all of reference row `row`'s
    /// samples, whose columns start at `x0`.
    #[inline(always)]
    fn row(
        &mut self,
        ctx: &WarpContext,
        img: &SampleImage,
        row: &WarpedRow,
        x0: u32,
        kernels: &mut [Kernel],
        st: &mut GoldenStats,
    ) {
        let batch = &mut *self.batch;
        let (mut slopes, mut masks) = ([[0.0; 2]; BATCH], [0u32; BATCH]);
        for chunk in kernels.chunks_mut(BATCH) {
            let n = chunk.len();
            for (k, kern) in chunk.iter().enumerate() {
                let i = img.index(kern.x, kern.y);
                batch.x[k] = kern.x as f64;
                batch.y[k] = kern.y as f64;
                batch.inv_z[k] = row.ref_inv_z[(kern.x - x0) as usize];
                batch.sx[k] = img.inv_z_slopes[i][0] as f64;
                batch.sy[k] = img.inv_z_slopes[i][1] as f64;
            }
            ctx.dest_slopes_batch(batch, &mut slopes[..n]);
            if let Some(f) = ctx.fixed() {
                // Fixed mode: the derived slopes in `q_slope` (the raster's).
                let mut sat = 0;
                for s in &mut slopes[..n] {
                    *s = s.map(|v| f.slope.q(v, &mut sat));
                }
                if let Some(s) = &mut st.saturations {
                    s.raster += sat as u64;
                }
            }
            for (kern, s) in chunk.iter_mut().zip(&slopes) {
                kern.slopes = [s[0] as f32, s[1] as f32];
            }
            if self.masks_now {
                ctx.better_mask_batch(batch, &mut masks[..n]);
                for (kern, &m) in chunk.iter_mut().zip(&masks) {
                    kern.better.set(m as u16);
                }
            }
        }
    }
}

/// Every [`Outcome`], in declaration order (`OUTCOME_ORDER[o as usize] == o`).
const OUTCOME_ORDER: [Outcome; OUTCOMES] = [
    Outcome::Filled,
    Outcome::NearerWins,
    Outcome::BetterWins,
    Outcome::Lost,
    Outcome::MeshOverSplat,
    Outcome::SplatRejected,
];
const OUTCOMES: usize = 6;

/// Phase B's fixed inputs for one reference.
struct PhaseB<'a> {
    ctx: &'a WarpContext,
    prepared: &'a PreparedReference,
    source: u8,
    slope_tol: f64,
    rel_tol: f64,
}

impl PhaseB<'_> {
    /// Composite kernel `kern`'s candidate into derived sample `s`; count
    /// the outcome in `counts` (at `outcome as usize`).
    #[inline(always)]
    fn draw(&self, d: &mut DestPlanes, s: usize, kern: &Kernel, counts: &mut [u64; OUTCOMES]) {
        let img = &self.prepared.samples;
        let i = img.index(kern.x, kern.y);
        let colour = img.colour[i];
        let fill_colour = if kern.fill == [0, 0] {
            colour
        } else {
            let (fx, fy) =
                (kern.x.wrapping_add_signed(kern.fill[0] as i32), kern.y.wrapping_add_signed(kern.fill[1] as i32));
            img.colour[img.index(fx, fy)]
        };
        let cand = Candidate {
            colour,
            inv_z: kern.inv_z,
            slopes: kern.slopes,
            source: self.source,
            better: 0, // read below
            fill_colour,
            kind: Kind::Mesh,
        };
        let better = || match kern.better.get() {
            UNKNOWN => {
                let m = self.ctx.better_mask(kern.x as f64, kern.y as f64, self.prepared.inv_z(i), img.inv_z_slopes[i]);
                kern.better.set(m as u16);
                m
            }
            m => m as u32,
        };
        let o = composite_with(d, s, &cand, better, self.slope_tol, self.rel_tol);
        counts[o as usize] += 1;
    }
}

/// Phase 1 on row `y` of the region: warp its samples into `out`, counting
/// the culled ones (a surface behind the derived camera or not finite).
#[inline(always)]
fn transform_row(
    ctx: &WarpContext,
    prepared: &PreparedReference,
    q: &Region,
    y: u32,
    out: &mut WarpedRow,
    st: &mut GoldenStats,
) {
    let img = &prepared.samples;
    let i0 = img.index(q.x0, y);
    let n = q.width();
    let mut batch = [[0.0; 4]; BATCH];
    let mut ok = [false; BATCH];
    for c in (0..n).step_by(BATCH) {
        let m = (n - c).min(BATCH);
        let i = i0 + c;
        // The reference's 1/Z, kept in the row for its kernel slopes.
        let inv_z = &mut out.ref_inv_z[c..c + m];
        prepared.inv_z_into(i, inv_z);
        // A batch at a time (the transform's loop vectorises).
        if ctx.fixed().is_some() {
            ctx.transform_batch_fixed(
                (q.x0 as usize + c) as f64,
                y as f64,
                inv_z,
                &mut batch[..m],
                &mut ok[..m],
                &mut out.sat[c..c + m],
            );
        } else {
            ctx.transform_batch((q.x0 as usize + c) as f64, y as f64, inv_z, &mut batch[..m], &mut ok[..m]);
        }
        let valid = &img.valid[i..i + m];
        for k in 0..m {
            let [px, py, inv_z, e] = batch[k];
            let v = valid[k];
            out.px[c + k] = px;
            out.py[c + k] = py;
            out.inv_z[c + k] = inv_z;
            out.e[c + k] = e;
            out.ok[c + k] = v & ok[k];
            st.culled_samples += (v & !ok[k]) as u64;
        }
    }
}

/// Phase 2 on one row: the groups whose top-left samples are in warped row
/// `a` (bottom samples in `b`); the last column has none (Missing).
/// [`group`]'s rules and arithmetic, operation for operation, but
/// branch-free over arrays (every test evaluated, the state selected), so
/// that the loop vectorises.
#[inline(always)]
fn group_row(a: &WarpedRow, b: &WarpedRow, threshold: f64, out: &mut GroupRow) {
    let n = out.state.len();
    // `same_surface`'s limit is `threshold · |o| · 0.5 · (E_a + E_b)`, left to right.
    let (t1, t2) = (threshold * 1.0 * 0.5, threshold * std::f64::consts::SQRT_2 * 0.5);
    let m = n - 1;
    let (ax, ay, ae, aok) = (&a.px[..n], &a.py[..n], &a.e[..n], &a.ok[..n]);
    let (bx, by, be, bok) = (&b.px[..n], &b.py[..n], &b.e[..n], &b.ok[..n]);
    let (state, cx, cy) = (&mut out.state[..m], &mut out.cx[..m], &mut out.cy[..m]);
    let (fast, ceil_x, ceil_y) = (&mut out.fast[..m], &mut out.ceil_x[..m], &mut out.ceil_y[..m]);
    for k in 0..m {
        // a, b: top left and right; c, d: bottom left and right.
        let (pa, pb, pc, pd) = ((ax[k], ay[k]), (ax[k + 1], ay[k + 1]), (bx[k], by[k]), (bx[k + 1], by[k + 1]));
        let (ea, eb, ec, ed) = (ae[k], ae[k + 1], be[k], be[k + 1]);
        let ok = aok[k] & aok[k + 1] & bok[k] & bok[k + 1];
        let same = |p: (f64, f64), q: (f64, f64), ep: f64, eq: f64, t: f64| {
            let limit = t * (ep + eq);
            let (dx, dy) = (p.0 - q.0, p.1 - q.1);
            dx * dx + dy * dy <= limit * limit
        };
        let all = same(pa, pb, ea, eb, t1)
            & same(pc, pd, ec, ed, t1)
            & same(pa, pc, ea, ec, t1)
            & same(pb, pd, eb, ed, t1)
            & same(pa, pd, ea, ed, t2)
            & same(pb, pc, eb, ec, t2);
        // `folded`: quad a, b, d, c must turn left at every corner.
        let cross = |u: (f64, f64), v: (f64, f64), w: (f64, f64)| {
            let (e1, e2) = ((v.0 - u.0, v.1 - u.1), (w.0 - v.0, w.1 - v.1));
            e1.0 * e2.1 - e1.1 * e2.0 <= 0.0
        };
        let folded = cross(pa, pb, pd) | cross(pb, pd, pc) | cross(pd, pc, pa) | cross(pc, pa, pb);
        state[k] = if !ok {
            GroupState::Missing
        } else if !all {
            GroupState::Discontinuous
        } else if folded {
            GroupState::Folded
        } else {
            GroupState::Shared
        };
        let (x, y) = ((pa.0 + pb.0 + pc.0 + pd.0) * 0.25, (pa.1 + pb.1 + pc.1 + pd.1) * 0.25);
        (cx[k], cy[k]) = (x, y);
        fast[k] = ok & all & !folded & (x.abs() < CEIL_I32_RANGE) & (y.abs() < CEIL_I32_RANGE);
        (ceil_x[k], ceil_y[k]) = (ceil_i32(x), ceil_i32(y));
    }
    out.state[m] = GroupState::Missing;
    out.fast[m] = false;
}

/// The fixed mode's shared corners of a group row (`group_row` computed
/// them in FP64): each rounded to `corner`, saturating (`csat`), and the
/// fast path's ceilings of the rounded corner.
fn fix_group_row(corner: postwarp_rtl::qformat::QFormat, g: &mut GroupRow) {
    for k in 0..g.state.len() {
        g.csat[k] = false;
        if g.state[k] != GroupState::Shared {
            continue;
        }
        let ((x, sx), (y, sy)) = (corner.quantise(g.cx[k]), corner.quantise(g.cy[k]));
        (g.cx[k], g.cy[k], g.csat[k]) = (x, y, sx | sy);
        g.fast[k] = (x.abs() < CEIL_I32_RANGE) & (y.abs() < CEIL_I32_RANGE);
        (g.ceil_x[k], g.ceil_y[k]) = (ceil_i32(x), ceil_i32(y));
    }
}

/// Phase A's fixed inputs for one reference.
struct PhaseA<'a> {
    ctx: &'a WarpContext,
    img: &'a SampleImage,
    /// The reference (its 1/Z, rounded in fixed mode).
    prepared: &'a PreparedReference,
    cfg: &'a GoldenConfig,
    q: Region,
    live: &'a cull::LiveBlocks,
    /// Derived image size (samples).
    size: (u32, u32),
}

impl PhaseA<'_> {
    /// Phase A on row `y`: every kernel of a live sample that reaches the
    /// derived image, in raster order, into `kernels` and the slots.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn row(
        &self,
        y: u32,
        rows: &Rows,
        kernels: &mut Vec<Kernel>,
        slots: &mut [u32],
        overflow: &mut Vec<u64>,
        hist: &mut [[u64; KERNEL_HIST_MAX + 1]; KERNEL_HIST_MAX + 1],
        st: &mut GoldenStats,
    ) {
        let (ctx, img, cfg, q) = (self.ctx, self.img, self.cfg, self.q);
        let (w, h) = (img.width, img.height);
        let r = (y - q.y0) as usize;
        let warped_row = |yy: u32| &rows.warped[(yy - q.y0) as usize % 3];
        let at = |x: u32, yy: u32| warped_row(yy).at((x - q.x0) as usize);
        let group_at = |gx: u32, gy: u32| rows.groups[(gy - q.y0) as usize % 2].at((gx - q.x0) as usize);
        let cur = &rows.warped[r % 3];
        // Groups of rows y − 1 and y (the fast path's; y ≥ 1 there).
        let (gp, gc) = (&rows.groups[(r + 1) % 2], &rows.groups[r % 2]);
        let inner_y = y >= 1 && y + 1 < h;
        let dw = self.size.0;
        let by = y / cull::BLOCK;
        for bx in 0..self.live.bw {
            if !self.live.live[(by * self.live.bw + bx) as usize] {
                continue;
            }
            let xs = bx * cull::BLOCK..((bx + 1) * cull::BLOCK).min(w);
            for x in xs {
                let kx = (x - q.x0) as usize;
                let Some(t) = cur.at(kx) else { continue };
                // Inside the image with all four groups around the sample one
                // surface: shared corners only (no edge corner), the sample's
                // own group counts nothing, and it is no forward edge (every
                // 8-neighbour passed `same_surface` with it in a shared group).
                // The box's covered centres are then the extreme ceilings of
                // the corners (ceil is monotone), computed once per group.
                let shared =
                    inner_y && x >= 1 && x + 1 < w && { gp.fast[kx - 1] & gp.fast[kx] & gc.fast[kx - 1] & gc.fast[kx] };
                let (rc, edges, sat) = if shared {
                    let span = |a: i32, b: i32, c: i32, d: i32| {
                        (a.min(b).min(c.min(d)) as i64, a.max(b).max(c.max(d)) as i64 - 1)
                    };
                    let rx = span(gp.ceil_x[kx - 1], gp.ceil_x[kx], gc.ceil_x[kx - 1], gc.ceil_x[kx]);
                    let ry = span(gp.ceil_y[kx - 1], gp.ceil_y[kx], gc.ceil_y[kx - 1], gc.ceil_y[kx]);
                    let ks = gp.csat[kx - 1] as u32 + gp.csat[kx] as u32 + gc.csat[kx - 1] as u32 + gc.csat[kx] as u32;
                    let rc = rect_of_ranges(rx, ry, (t.pos.x, t.pos.y), cfg.kernel_limit, cfg.over_limit, self.size);
                    (rc, 0, [t.sat, ks])
                } else {
                    let group_sat = |gx: u32, gy: u32| rows.groups[(gy - q.y0) as usize % 2].csat[(gx - q.x0) as usize];
                    let i = img.index(x, y);
                    let (c, edges, sat) =
                        corners_counted(ctx, img, self.prepared.inv_z(i), &t, group_at, group_sat, x, y);
                    let (x0, x1, y0, y1) = bounding_box(&c);
                    let rc = rect(x0, x1, y0, y1, (t.pos.x, t.pos.y), cfg.kernel_limit, cfg.over_limit, self.size);
                    (rc, edges, [t.sat + sat[0], sat[1]])
                };
                if rc.x.0 > rc.x.1 || rc.y.0 > rc.y.1 {
                    continue;
                }
                let (kw, kh) = (rc.size.0 as usize, rc.size.1 as usize);
                hist[kw.min(KERNEL_HIST_MAX)][kh.min(KERNEL_HIST_MAX)] += 1;
                st.kernels_over_limit += rc.over_limit as u64;
                st.edge_corners += edges as u64;
                if let Some(s) = &mut st.saturations {
                    s.transform += sat[0] as u64;
                    s.kernel_setup += sat[1] as u64;
                }
                let mut fill = [0, 0];
                if !shared {
                    if x + 1 < w && y + 1 < h {
                        match group_at(x, y).0 {
                            GroupState::Discontinuous => st.discontinuous_groups += 1,
                            GroupState::Folded => st.folded_groups += 1,
                            _ => {}
                        }
                    }
                    if let Some(k) = forward_edge_neighbour(ctx, img, at, &t, x, y, cfg.threshold) {
                        st.forward_edges += 1;
                        let (nx, ny) = ((k % w as usize) as i64, (k / w as usize) as i64);
                        fill = [(nx - x as i64) as i8, (ny - y as i64) as i8];
                    }
                }
                let k = kernels.len() as u32;
                debug_assert!(k < MULTI);
                rc.for_each(|sx, sy| {
                    let s = (sy * dw + sx) as usize;
                    match slots[s] {
                        EMPTY => slots[s] = k,
                        MULTI => overflow.push(((s as u64) << 32) | k as u64),
                        first => {
                            overflow.push(((s as u64) << 32) | first as u64);
                            overflow.push(((s as u64) << 32) | k as u64);
                            slots[s] = MULTI;
                        }
                    }
                });
                kernels.push(Kernel {
                    x,
                    y,
                    inv_z: t.inv_z as f32,
                    slopes: [0.0; 2],                      // set after the row (`KernelSlopes`)
                    better: std::cell::Cell::new(UNKNOWN), // after the row or on demand
                    fill,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::golden::kernel_setup::group;

    /// Two warped rows of pseudo-random samples: jittered grid positions
    /// (some far apart, some swapped, some missing) with random spacing.
    fn rows(n: usize, seed: u64) -> [WarpedRow; 2] {
        let mut s = seed;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut out: [WarpedRow; 2] = Default::default();
        for (y, r) in out.iter_mut().enumerate() {
            r.resize(n);
            for k in 0..n {
                // Some samples jump ahead (discontinuities), some back past
                // their left neighbour (folds).
                let jump = if next() < 0.04 {
                    3.0 * next()
                } else if next() < 0.04 {
                    -1.2
                } else {
                    0.0
                };
                r.px[k] = k as f64 * 1.1 + (next() - 0.5) * 0.3 + jump;
                r.py[k] = y as f64 * 1.1 + (next() - 0.5) * 0.3;
                r.e[k] = 0.9 + next() * 0.8;
                r.inv_z[k] = next();
                r.ok[k] = next() > 0.05;
            }
        }
        out
    }

    #[test]
    fn outcome_order_is_declaration_order() {
        for (k, &o) in OUTCOME_ORDER.iter().enumerate() {
            assert_eq!(o as usize, k, "{o:?}");
        }
    }

    #[test]
    fn branch_free_groups_give_the_group_functions_results() {
        let mut states = [0u32; 4];
        for seed in 1..20u64 {
            let [a, b] = rows(300, seed.wrapping_mul(0x9e3779b97f4a7c15));
            let mut g = GroupRow::default();
            g.resize(300);
            group_row(&a, &b, 1.4, &mut g);
            let at = |x: u32, y: u32| if y == 0 { a.at(x as usize) } else { b.at(x as usize) };
            for k in 0..300 {
                let want = if k + 1 < 300 { group(at, k as u32, 0, 1.4) } else { (GroupState::Missing, DVec2::ZERO) };
                let got = g.at(k);
                assert_eq!(got.0, want.0, "seed {seed} group {k}");
                assert_eq!(
                    got.1.to_array().map(f64::to_bits),
                    want.1.to_array().map(f64::to_bits),
                    "seed {seed} group {k}"
                );
                assert_eq!(g.fast[k], want.0 == GroupState::Shared, "in range here");
                if g.fast[k] {
                    assert_eq!((g.ceil_x[k] as f64, g.ceil_y[k] as f64), (want.1.x.ceil(), want.1.y.ceil()));
                }
                states[want.0 as usize] += 1;
            }
        }
        assert!(states.iter().all(|&n| n > 200), "every state met: {states:?}");
    }
}
