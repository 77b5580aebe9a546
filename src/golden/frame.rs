//! One derived frame, end to end: for each reference in warp order, warp,
//! reconstruct, rasterize and composite every sample, then hole-fill; hold
//! the frame in A-buffer format between warps; resolve to pixels.
//!
//! Rules:
//! 1. References pass through the A-buffer once ([`prepare_reference`]),
//!    as the hardware reads them from memory in that format.
//! 2. Samples are warped in the reference's eight-sheet order around its
//!    epipole, reversed by default ([`WarpOrder`]); compositing is
//!    Z-buffered, so the order matters only for exact ties.
//! 3. Before each warp, the cache-only hole-fill planes are reset
//!    (`DestPlanes::begin_warp`); after it, the hole fill runs in the
//!    derived-epipole order; then the frame goes through the A-buffer,
//!    which does not keep the mesh/splat bit (cleared after the trip when
//!    ss > 1; at ss = 1 a pixel is one sample and the trip is the identity).
//! 4. Forward edges (TR98 App. B.1): a sample whose backward neighbour
//!    (toward −D) is a deeper, separate surface writes that neighbour's
//!    colour into the hole-fill plane instead of its own.
//! 5. Reconstruction: [`Reconstruction::AaRect`] warps each reference with
//!    the anti-aliased flat rectangles here; [`Reconstruction::General`]
//!    with the triangle mesh and edge splats of
//!    [`general::warp_reference_general`]. Hole fill, A-buffer and resolve
//!    are the same for both.
//! 6. After the last warp, with `fallback_fill` (and `hole_fill`), the
//!    samples no epipolar pass reached are filled by the fallback pass
//!    ([`fallback_fill`]), and the pixels it changed take the A-buffer trip
//!    again, as the hardware writes them back.

use super::abuffer::{AbufferParams, AbufferStats, round_trip_dest, round_trip_dest_where, round_trip_reference};
use super::composite::{Candidate, Kind, Outcome, composite_with};
use super::config::{GoldenConfig, Reconstruction, WarpOrder};
use super::cull;
use super::fallback_fill::fallback_fill;
use super::general;
use super::hole_fill::{HoleFillParams, HoleFillStats, hole_fill};
use super::kernel_setup::{GroupState, bounding_box, corners, group, same_surface};
use super::planes::DestPlanes;
use super::raster::rect;
use super::resolve::resolve;
use super::transform::{BATCH, SampleBatch, Transformed, WarpContext, backward_neighbour};
use super::traversal::OrderKey;
use bitvec::vec::BitVec;
use glam::DVec2;
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::{FrameCommands, SampleImage};
use serde::Serialize;

/// Largest kernel side tracked individually in the histogram; larger sizes
/// land in the last bucket.
pub const KERNEL_HIST_MAX: usize = 8;

/// Counters of one derived frame (units: counts).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct GoldenStats {
    /// Reference samples with a surface, over all warps.
    pub reference_samples: u64,
    /// Samples behind the derived camera (W <= 0), culled.
    pub culled_samples: u64,
    /// Kernels by (width, height) in sample centres: `kernel_sizes[w][h]`,
    /// sizes above 8 in bucket 8. General path: the edge splats' bounding
    /// boxes (mesh triangles are not kernels).
    pub kernel_sizes: Vec<Vec<u64>>,
    /// Kernels wider or taller than the rasterizer limit (general path:
    /// edge splats).
    pub kernels_over_limit: u64,
    /// Kernel corners computed from the sample alone (edge, fold, border);
    /// general path: four per edge splat drawn.
    pub edge_corners: u64,
    /// 2x2 groups failing the discontinuity test.
    pub discontinuous_groups: u64,
    /// 2x2 groups passing it but folded over.
    pub folded_groups: u64,
    /// Samples tagged as forward edges.
    pub forward_edges: u64,
    /// Candidate samples written over empty or hole-fill samples.
    pub composite_filled: u64,
    /// Candidate samples that won the depth test.
    pub composite_nearer: u64,
    /// Candidate samples that won the same-surface arbitration (general
    /// path: including mesh over splat).
    pub composite_better: u64,
    /// Candidate samples that lost (general path: including splats
    /// rejected by the mesh/splat rule).
    pub composite_lost: u64,
    /// General path: mesh triangles rasterized (count; two per 2x2 group of
    /// reference samples that is one surface), over all warps.
    pub mesh_triangles: u64,
    /// General path: edge splats rasterized (count of reference samples
    /// with a discontinuity, missing neighbour or unmeshed 2x2 group next
    /// to them, not suppressed), over all warps.
    pub edge_splats: u64,
    /// General path: edge splats suppressed (count of edge samples on a
    /// poorly sampled surface, footprint > 2 derived samples, that another
    /// reference samples better), over all warps.
    pub suppressed_splats: u64,
    /// General path: splat candidate samples rejected because the stored
    /// sample at the same depth came from the mesh (count of derived-sample
    /// writes; a subset of `composite_lost`).
    pub splats_rejected_by_mesh: u64,
    /// General path: mesh candidate samples that replaced a stored splat at
    /// the same depth (count of derived-sample writes; a subset of
    /// `composite_better`).
    pub mesh_over_splat: u64,
    /// Hole samples filled, summed over passes.
    pub hole_fill_filled: u64,
    /// Hole samples no pass could reach, summed over passes.
    pub hole_fill_unreached: u64,
    /// Hole samples the fallback pass filled (after the last warp).
    pub fallback_filled: u64,
    /// Empty samples the fallback pass could not reach (left empty).
    pub fallback_unreached: u64,
    /// Display pixels holding a sample the fallback pass filled: what no
    /// reference saw along any epipolar line the passes follow (pixels).
    pub unseen_pixels: u64,
    /// Derived samples holding hole fill at the end.
    pub hole_samples: u64,
    /// Derived samples with neither surface nor fill at the end (black).
    pub empty_samples: u64,
    /// Derived pixels by A-buffer fragments needed (index = count), over
    /// every store of the frame.
    pub fragments_per_pixel: Vec<u64>,
    /// A-buffer merges forced by the fragment limit (derived frame stores).
    pub forced_merges: u64,
}

/// The golden model's output for one derived frame.
#[derive(Clone, Debug)]
pub struct GoldenFrame {
    /// Final per-sample planes.
    pub samples: DestPlanes,
    /// Resolved display pixels (linear RGB).
    pub pixels: Vec<[f32; 3]>,
    /// Pixels whose samples all hold real surfaces.
    pub covered: BitVec,
    /// Pixels holding a sample the fallback pass filled (rule 6): no
    /// epipolar pass reached them.
    pub unseen: BitVec,
    /// Counters.
    pub stats: GoldenStats,
}

/// A reference frame after its trip through the A-buffer.
#[derive(Clone, Debug)]
pub struct PreparedReference {
    /// Samples as expanded from the A-buffer.
    pub samples: SampleImage,
    /// A-buffer counters of the conversion.
    pub abuffer: AbufferStats,
    /// Per-block depth ranges for off-screen culling.
    pub blocks: cull::BlockDepth,
    /// `1/Z` of every sample (0 where there is no surface), computed once.
    pub inv_z: Vec<f64>,
}

fn abuffer_params(ss: u32, cfg: &GoldenConfig) -> AbufferParams {
    AbufferParams { ss, max_fragments: cfg.abuffer_fragments, slope_tol: cfg.slope_tol, rel_tol: cfg.rel_tol }
}

/// Rule 1.
pub fn prepare_reference(img: &SampleImage, ss: u32, cfg: &GoldenConfig) -> PreparedReference {
    let mut abuffer = AbufferStats::default();
    let samples = round_trip_reference(img, &abuffer_params(ss, cfg), &mut abuffer);
    let blocks = cull::block_depth(&samples);
    let inv_z = (0..samples.len()).map(|i| if samples.valid[i] { 1.0 / samples.z[i] as f64 } else { 0.0 }).collect();
    PreparedReference { samples, abuffer, blocks, inv_z }
}

/// Produce derived frame `cmd` from its prepared references (`refs[j]` for
/// `cmd.warps[j]`). Allocates its buffers: use [`Warper::warp_frame`] in a loop.
pub fn warp_frame(cmd: &FrameCommands, refs: &[&PreparedReference], cfg: &GoldenConfig) -> GoldenFrame {
    Warper::new().warp_frame(cmd, refs, cfg)
}

impl Warper {
    /// Produce derived frame `cmd` from its prepared references (`refs[j]`
    /// for `cmd.warps[j]`).
    pub fn warp_frame(&mut self, cmd: &FrameCommands, refs: &[&PreparedReference], cfg: &GoldenConfig) -> GoldenFrame {
        let ss = cmd.supersample;
        let dst = cmd.derived_camera.sample_grid(ss);
        let mut d = DestPlanes::new(dst.intrinsics.width, dst.intrinsics.height);
        let mut st =
            GoldenStats { kernel_sizes: vec![vec![0; KERNEL_HIST_MAX + 1]; KERNEL_HIST_MAX + 1], ..Default::default() };
        let mut ab = AbufferStats::default();
        let centres: Vec<_> = cmd.warps.iter().map(|w| w.reference_camera.pose.position).collect();
        for (j, (warp, prepared)) in cmd.warps.iter().zip(refs).enumerate() {
            let img = &prepared.samples;
            let ctx = WarpContext::new(warp.setup, warp.reference_camera, dst, centres.clone(), j, cfg.better_margin);
            d.begin_warp();
            match cfg.reconstruction {
                Reconstruction::AaRect => {
                    warp_reference(&ctx, prepared, j as u8, cfg, &mut d, &mut st, &mut self.scratch)
                }
                Reconstruction::General => general::warp_reference_general(&ctx, img, j as u8, cfg, &mut d, &mut st),
            }
            if cfg.hole_fill {
                let hf = hole_fill(&mut d, &warp.setup.epipole_derived, &hole_fill_params(cfg));
                add_hole_stats(&mut st, &hf);
            }
            round_trip_dest(&mut d, &abuffer_params(ss, cfg), &mut ab);
            if ss > 1 && cfg.abuffer_fragments > 0 {
                // The A-buffer holds no mesh/splat bit (general path); at ss = 1
                // each pixel is one fragment and the trip changes nothing.
                d.forget_splats();
            }
        }
        let mut unseen = BitVec::repeat(false, ((d.width / ss) * (d.height / ss)) as usize);
        if cfg.hole_fill
            && cfg.fallback_fill
            && let Some(last) = cmd.warps.last()
            && let Some(changed) = fallback(&mut d, &last.setup.epipole_derived, ss, cfg, &mut st, &mut ab)
        {
            unseen = changed;
        }
        st.fragments_per_pixel = ab.fragments_per_pixel;
        st.forced_merges = ab.forced_merges;
        st.hole_samples = d.hole.count_ones() as u64;
        st.empty_samples = (0..d.len()).filter(|&i| !d.real[i] && !d.hole[i]).count() as u64;
        let (pixels, covered) = resolve(&d, ss);
        GoldenFrame { samples: d, pixels, covered, unseen, stats: st }
    }
}

/// Rule 6: the fallback pass over the samples no epipolar pass reached,
/// then the A-buffer trip of the pixels it changed; those pixels, or
/// `None` if no sample was empty.
fn fallback(
    d: &mut DestPlanes,
    e: &Epipole,
    ss: u32,
    cfg: &GoldenConfig,
    st: &mut GoldenStats,
    ab: &mut AbufferStats,
) -> Option<BitVec> {
    if d.real.iter().zip(d.hole.iter()).all(|(r, h)| *r || *h) {
        return None;
    }
    let (fb, filled) = fallback_fill(d, e, &hole_fill_params(cfg));
    st.fallback_filled += fb.filled;
    st.fallback_unreached += fb.unreached;
    let pw = (d.width / ss) as usize;
    let mut pixels = BitVec::repeat(false, pw * (d.height / ss) as usize);
    for i in filled {
        let (x, y) = (i % d.width as usize, i / d.width as usize);
        pixels.set(y / ss as usize * pw + x / ss as usize, true);
    }
    st.unseen_pixels = pixels.count_ones() as u64;
    round_trip_dest_where(d, &abuffer_params(ss, cfg), ab, &pixels);
    Some(pixels)
}

fn hole_fill_params(cfg: &GoldenConfig) -> HoleFillParams {
    HoleFillParams {
        far_distance: cfg.hole_far_distance,
        far_offset: cfg.hole_far_offset,
        max_distance: cfg.hole_max_distance,
    }
}

fn add_hole_stats(st: &mut GoldenStats, hf: &HoleFillStats) {
    st.hole_fill_filled += hf.filled;
    st.hole_fill_unreached += hf.unreached;
}

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
struct Scratch {
    warped: Vec<Option<Transformed>>,
    groups: Vec<(GroupState, DVec2)>,
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

/// The golden model with its working buffers: create one and reuse it for
/// every frame of a run.
#[derive(Default)]
pub struct Warper {
    scratch: Scratch,
}

impl Warper {
    /// A warper with empty buffers.
    pub fn new() -> Warper {
        Warper::default()
    }
}

/// Warp one reference into `d` (rules 2, 4 and 5).
fn warp_reference(
    ctx: &WarpContext,
    prepared: &PreparedReference,
    source: u8,
    cfg: &GoldenConfig,
    d: &mut DestPlanes,
    st: &mut GoldenStats,
    scratch: &mut Scratch,
) {
    let Scratch { warped, groups, kernels, slots, overflow } = scratch;
    let img = &prepared.samples;
    let (w, h) = (img.width, img.height);
    st.reference_samples += img.valid.count_ones() as u64;
    let live = cull::live_blocks(ctx, &prepared.blocks, d.width, d.height);
    let Some((rx0, ry0, rx1, ry1)) = live.bounds(w, h) else { return };
    // The live region plus its one-sample ring (neighbours of live samples).
    let (qx0, qy0) = (rx0.saturating_sub(1), ry0.saturating_sub(1));
    let (qx1, qy1) = ((rx1 + 1).min(w - 1), (ry1 + 1).min(h - 1));
    let qw = (qx1 - qx0 + 1) as usize;
    let qi = |x: u32, y: u32| (y - qy0) as usize * qw + (x - qx0) as usize;
    warped.clear();
    warped.reserve(qw * (qy1 - qy0 + 1) as usize);
    let mut out = [[0.0; 4]; BATCH];
    let mut ok = [false; BATCH];
    for y in qy0..=qy1 {
        // A batch of samples at a time (the transform's loop vectorises).
        for x in (qx0..=qx1).step_by(BATCH) {
            let n = ((qx1 - x + 1) as usize).min(BATCH);
            let i0 = img.index(x, y);
            ctx.transform_batch(x as f64, y as f64, &prepared.inv_z[i0..i0 + n], &mut out[..n], &mut ok[..n]);
            for k in 0..n {
                let valid = img.valid[i0 + k];
                let [px, py, inv_z, e] = out[k];
                let t = (valid && ok[k]).then_some(Transformed { pos: DVec2::new(px, py), inv_z, e });
                st.culled_samples += (valid && t.is_none()) as u64;
                warped.push(t);
            }
        }
    }
    // Samples outside the region are in culled blocks, where W > 0 (cull.rs).
    let at = |x: u32, y: u32| warped[qi(x, y)];
    groups.clear();
    groups.reserve(qw * (qy1 - qy0 + 1) as usize);
    for gy in qy0..=qy1 {
        for gx in qx0..=qx1 {
            groups.push(if gx < qx1 && gy < qy1 {
                group(at, gx, gy, cfg.threshold)
            } else {
                (GroupState::Missing, DVec2::ZERO)
            });
        }
    }
    let group_at = |gx: u32, gy: u32| groups[qi(gx, gy)];
    let keys = OrderKey::new(w, h, &ctx.setup.epipole_reference);
    let reverse = cfg.warp_order == WarpOrder::Reverse;
    let size = (d.width, d.height);

    // Phase A, raster order: every kernel that reaches the derived image.
    kernels.clear();
    slots.clear();
    slots.resize(d.len(), EMPTY);
    overflow.clear();
    for y in ry0..=ry1 {
        for x in rx0..=rx1 {
            if !live.sample_live(x, y) {
                continue;
            }
            let Some(t) = at(x, y) else { continue };
            let (c, edges) = corners(ctx, img, &t, group_at, x, y);
            let (x0, x1, y0, y1) = bounding_box(&c);
            let r = rect(x0, x1, y0, y1, (t.pos.x, t.pos.y), cfg.kernel_limit, cfg.over_limit, size);
            if r.x.0 > r.x.1 || r.y.0 > r.y.1 {
                continue;
            }
            let (kw, kh) = (r.size.0 as usize, r.size.1 as usize);
            st.kernel_sizes[kw.min(KERNEL_HIST_MAX)][kh.min(KERNEL_HIST_MAX)] += 1;
            st.kernels_over_limit += r.over_limit as u64;
            st.edge_corners += edges as u64;
            if x + 1 < w && y + 1 < h {
                match group_at(x, y).0 {
                    GroupState::Discontinuous => st.discontinuous_groups += 1,
                    GroupState::Folded => st.folded_groups += 1,
                    _ => {}
                }
            }
            let fill = match forward_edge_neighbour(ctx, img, at, &t, x, y, cfg.threshold) {
                Some(k) => {
                    st.forward_edges += 1;
                    let (nx, ny) = ((k % w as usize) as i64, (k / w as usize) as i64);
                    [(nx - x as i64) as i8, (ny - y as i64) as i8]
                }
                None => [0, 0],
            };
            let k = kernels.len() as u32;
            debug_assert!(k < MULTI);
            r.for_each(|sx, sy| {
                let s = (sy * d.width + sx) as usize;
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
                slopes: [0.0; 2],                      // set below, in a pass of their own
                better: std::cell::Cell::new(UNKNOWN), // below or on demand
                fill,
            });
        }
    }

    // Derived slopes, and the better-reference masks when earlier warps
    // have stored samples the kernels may meet (compositing rule 3;
    // otherwise on demand), in loops of their own over batches of kernels:
    // they vectorise, and the divisions of successive kernels overlap where
    // inside phase A each stalled it.
    let masks_now = source > 0;
    let mut batch = SampleBatch::default();
    let (mut slopes, mut masks) = ([[0.0; 2]; BATCH], [0u32; BATCH]);
    for chunk in kernels.chunks_mut(BATCH) {
        let n = chunk.len();
        for (k, kern) in chunk.iter().enumerate() {
            let i = img.index(kern.x, kern.y);
            batch.x[k] = kern.x as f64;
            batch.y[k] = kern.y as f64;
            batch.inv_z[k] = prepared.inv_z[i];
            batch.sx[k] = img.inv_z_slopes[i][0] as f64;
            batch.sy[k] = img.inv_z_slopes[i][1] as f64;
        }
        ctx.dest_slopes_batch(&batch, &mut slopes[..n]);
        for (kern, s) in chunk.iter_mut().zip(&slopes) {
            kern.slopes = [s[0] as f32, s[1] as f32];
        }
        if masks_now {
            ctx.better_mask_batch(&mut batch, &mut masks[..n]);
            for (kern, &m) in chunk.iter_mut().zip(&masks) {
                kern.better.set(m as u16);
            }
        }
    }
    // Phase B: per derived sample, composite its candidates in warp order.
    // Compositing touches only its own sample, so this equals drawing the
    // kernels one by one in warp order (rule 2). The overflow list sorted
    // holds each shared sample's candidates together.
    overflow.sort_unstable();
    let mut draw = |d: &mut DestPlanes, s: usize, kern: &Kernel| {
        let i = img.index(kern.x, kern.y);
        let fill =
            img.index(kern.x.wrapping_add_signed(kern.fill[0] as i32), kern.y.wrapping_add_signed(kern.fill[1] as i32));
        let cand = Candidate {
            colour: img.colour[i],
            inv_z: kern.inv_z,
            slopes: kern.slopes,
            source,
            better: 0, // read below
            fill_colour: img.colour[fill],
            kind: Kind::Mesh,
        };
        let better = || match kern.better.get() {
            UNKNOWN => {
                let m = ctx.better_mask(kern.x as f64, kern.y as f64, prepared.inv_z[i], img.inv_z_slopes[i]);
                kern.better.set(m as u16);
                m
            }
            m => m as u32,
        };
        count_outcome(st, composite_with(d, s, &cand, better, cfg.slope_tol, cfg.rel_tol));
    };
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
                    let key = keys.key(kern.x, kern.y);
                    if reverse { !key } else { key }
                });
                for &e in shared.iter() {
                    draw(d, s, &kernels[e as u32 as usize]);
                }
            }
            k => draw(d, s, &kernels[k as usize]),
        }
    }
}

/// Add one composite outcome to the counters.
pub(super) fn count_outcome(st: &mut GoldenStats, o: Outcome) {
    match o {
        Outcome::Filled => st.composite_filled += 1,
        Outcome::NearerWins => st.composite_nearer += 1,
        Outcome::BetterWins => st.composite_better += 1,
        Outcome::Lost => st.composite_lost += 1,
        Outcome::MeshOverSplat => {
            st.composite_better += 1;
            st.mesh_over_splat += 1;
        }
        Outcome::SplatRejected => {
            st.composite_lost += 1;
            st.splats_rejected_by_mesh += 1;
        }
    }
}

/// Rule 4: the index of the deeper, separate backward neighbour, if any.
pub(super) fn forward_edge_neighbour(
    ctx: &WarpContext,
    img: &SampleImage,
    at: impl Fn(u32, u32) -> Option<Transformed>,
    t: &Transformed,
    x: u32,
    y: u32,
    threshold: f64,
) -> Option<usize> {
    let (dx, dy) = backward_neighbour(&ctx.setup.epipole_reference, x as f64, y as f64)?;
    let (nx, ny) = (x as i64 + dx as i64, y as i64 + dy as i64);
    if nx < 0 || ny < 0 || nx >= img.width as i64 || ny >= img.height as i64 {
        return None;
    }
    let k = img.index(nx as u32, ny as u32);
    let tn = at(nx as u32, ny as u32)?;
    let i = img.index(x, y);
    let offset = DVec2::new(dx as f64, dy as f64).length();
    (img.z[k] > img.z[i] && !same_surface(t, &tn, offset, threshold)).then_some(k)
}
