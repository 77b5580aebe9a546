//! The anti-aliased path's warp of one reference (`frame.rs` rules 2, 4
//! and 5): transform, kernel setup, rasterization into per-sample candidate
//! slots (phase A, reference raster order), then compositing each derived
//! sample's candidates in warp order (phase B).

use super::composite::{Candidate, Kind, composite_with};
use super::config::{GoldenConfig, WarpOrder};
use super::cull;
use super::frame::{GoldenStats, KERNEL_HIST_MAX, PreparedReference, count_outcome, forward_edge_neighbour};
use super::kernel_setup::{GroupState, bounding_box, corners, group};
use super::planes::DestPlanes;
use super::raster::rect;
use super::transform::{BATCH, SampleBatch, Transformed, WarpContext};
use super::traversal::OrderKey;
use glam::DVec2;

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

/// Warp one reference into `d` (rules 2, 4 and 5).
pub(super) fn warp_reference(
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
