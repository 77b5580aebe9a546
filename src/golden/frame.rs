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

use super::abuffer::{
    AbufferParams, AbufferStats, round_trip_dest, round_trip_dest_where, round_trip_reference_in_place,
};
use super::composite::Outcome;
use super::config::{GoldenConfig, Reconstruction};
use super::cull;
use super::fallback_fill::fallback_fill;
use super::general;
use super::hole_fill::{HoleFillParams, HoleFillStats, hole_fill};
use super::kernel_setup::same_surface;
use super::phase_times::{Phase, start, stop};
use super::planes::DestPlanes;
use super::resolve::resolve;
use super::transform::{Transformed, WarpContext, backward_neighbour};
use super::vector_level::{VectorLevel, Work};
use super::warp_aa;
use bitvec::vec::BitVec;
use glam::DVec2;
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::qformat::QFormat;
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
    /// Fixed mode only (`None` in float mode): values that saturated their
    /// Q format, per stage, over the same sets as the hardware model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saturations: Option<SaturationCounts>,
}

/// The fixed mode's saturations per stage (`docs/fixed-point.md`; counts of
/// values): the golden model's count of what the hardware's
/// `saturations.*` count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SaturationCounts {
    /// Reference colour channels, 1/Z, slopes (every valid sample of each
    /// warped reference) and samples dropped for their coordinates.
    pub fetch: u64,
    /// Positions, derived 1/Z, `E` and edge corners of the drawn kernels.
    pub transform: u64,
    /// Saturated shared corners used by the drawn kernels.
    pub kernel_setup: u64,
    /// Derived slopes of the drawn kernels.
    pub raster: u64,
    /// Hole-fill colours and weights, fallback pass included.
    pub hole_fill: u64,
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
    /// Samples as expanded from the A-buffer, without their `object_id`
    /// plane (left empty): the A-buffer's merge key, which no warp reads
    /// once the reference is converted (4 bytes per sample of a run's
    /// peak memory, `docs/performance.md`).
    pub samples: SampleImage,
    /// A-buffer counters of the conversion.
    pub abuffer: AbufferStats,
    /// Per-block depth ranges for off-screen culling.
    pub blocks: cull::BlockDepth,
    /// Fixed mode: the format `1/Z` is read in (`q_ref_inv_z`); `None` in
    /// float mode. `1/Z` is computed where it is read
    /// ([`PreparedReference::inv_z`]) rather than kept as a plane: 8 bytes
    /// per sample of a run's peak memory (`docs/performance.md`).
    pub ref_inv_z: Option<QFormat>,
    /// Fixed mode: values the reference's expansion saturated (counts; 0 in
    /// float mode).
    pub fetch_saturations: u64,
}

impl PreparedReference {
    /// `1/Z` of sample `i` (0 where there is no surface; rounded to
    /// `q_ref_inv_z` in fixed mode, its saturations counted once, in
    /// `fetch_saturations`).
    #[inline(always)]
    pub fn inv_z(&self, i: usize) -> f64 {
        if !self.samples.valid[i] {
            return 0.0;
        }
        let v = 1.0 / self.samples.z[i] as f64;
        match self.ref_inv_z {
            None => v,
            Some(f) => f.q(v, &mut 0),
        }
    }

    /// [`PreparedReference::inv_z`] of samples `i..i + out.len()`.
    #[inline(always)]
    pub fn inv_z_into(&self, i: usize, out: &mut [f64]) {
        let (z, valid) = (&self.samples.z[i..i + out.len()], &self.samples.valid[i..i + out.len()]);
        for ((o, z), v) in out.iter_mut().zip(z).zip(valid.iter().by_vals()) {
            *o = if v { 1.0 / *z as f64 } else { 0.0 };
        }
        if let Some(f) = self.ref_inv_z {
            for o in out.iter_mut().filter(|o| **o != 0.0) {
                *o = f.q(*o, &mut 0);
            }
        }
    }
}

fn abuffer_params(ss: u32, cfg: &GoldenConfig) -> AbufferParams {
    AbufferParams { ss, abuffer_fragments: cfg.abuffer_fragments, slope_tol: cfg.slope_tol, rel_tol: cfg.rel_tol }
}

/// Rule 1.
pub fn prepare_reference(img: &SampleImage, ss: u32, cfg: &GoldenConfig) -> PreparedReference {
    prepare_reference_owned(img.clone(), ss, cfg)
}

/// [`prepare_reference`] of a loaded reference the caller no longer needs:
/// its planes become the prepared samples (the A-buffer's round trip in
/// place), without a second image.
pub fn prepare_reference_owned(mut samples: SampleImage, ss: u32, cfg: &GoldenConfig) -> PreparedReference {
    let mut abuffer = AbufferStats::default();
    round_trip_reference_in_place(&mut samples, &abuffer_params(ss, cfg), &mut abuffer);
    samples.object_id = Vec::new();
    let Some(f) = cfg.fixed_formats().ok().flatten() else {
        let blocks = cull::block_depth(&samples);
        return PreparedReference { samples, abuffer, blocks, ref_inv_z: None, fetch_saturations: 0 };
    };
    // Fixed mode (`docs/fixed-point.md`, fetch): colours to `q_colour`,
    // slopes to `q_slope`, 1/Z to `q_ref_inv_z`; a sample whose
    // (x + ½, y + ½) exceeds `q_ref_coord` is dropped.
    let w = samples.width as usize;
    let mut sat = 0u32;
    let valid: Vec<usize> = samples.valid.iter_ones().collect();
    for i in valid {
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        if x + 0.5 > f.ref_coord.max() || y + 0.5 > f.ref_coord.max() {
            sat += 1;
            samples.valid.set(i, false);
            continue;
        }
        for c in &mut samples.colour[i] {
            *c = f.colour.q(*c as f64, &mut sat) as f32;
        }
        for g in &mut samples.inv_z_slopes[i] {
            *g = f.slope.q(*g as f64, &mut sat) as f32;
        }
    }
    for i in samples.valid.iter_ones() {
        f.ref_inv_z.q(1.0 / samples.z[i] as f64, &mut sat);
    }
    let blocks = cull::block_depth_of(&samples, |i| f.ref_inv_z.q(1.0 / samples.z[i] as f64, &mut 0));
    PreparedReference { samples, abuffer, blocks, ref_inv_z: Some(f.ref_inv_z), fetch_saturations: sat as u64 }
}

/// The 1/Z plane of a reference: `1/Z` where valid, 0 elsewhere (made
/// once per reference: every derived frame it serves reads it).
pub fn inv_z_plane(img: &SampleImage) -> Vec<f64> {
    (0..img.len()).map(|i| if img.valid[i] { 1.0 / img.z[i] as f64 } else { 0.0 }).collect()
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
        let Ok(frame) = self.warp_frame_streamed(cmd, cfg, |j| Ok::<_, std::convert::Infallible>(refs[j]));
        frame
    }

    /// [`Warper::warp_frame`] with each warp's prepared reference asked of
    /// `reference(j)` just before warp `j` and dropped just after it, so a
    /// caller that makes references on demand holds one at a time (the
    /// peak memory of `simulate`, `docs/performance.md`). The first error
    /// of `reference` stops the frame.
    pub fn warp_frame_streamed<R: std::ops::Deref<Target = PreparedReference>, E>(
        &mut self,
        cmd: &FrameCommands,
        cfg: &GoldenConfig,
        mut reference: impl FnMut(usize) -> Result<R, E>,
    ) -> Result<GoldenFrame, E> {
        let ss = cmd.supersample;
        let dst = cmd.derived_camera.sample_grid(ss);
        let mut d = DestPlanes::new(dst.intrinsics.width, dst.intrinsics.height);
        let mut st =
            GoldenStats { kernel_sizes: vec![vec![0; KERNEL_HIST_MAX + 1]; KERNEL_HIST_MAX + 1], ..Default::default() };
        let mut ab = AbufferStats::default();
        let fixed = cfg.fixed_formats().ok().flatten();
        st.saturations = fixed.as_ref().map(|_| SaturationCounts::default());
        let centres: Vec<_> = cmd.warps.iter().map(|w| w.reference_camera.pose.position).collect();
        for (j, warp) in cmd.warps.iter().enumerate() {
            let prepared = reference(j)?;
            let prepared = &*prepared;
            let ctx = WarpContext::new(warp.setup, warp.reference_camera, dst, centres.clone(), j, cfg.better_margin)
                .with_fixed(fixed.clone());
            if let Some(s) = &mut st.saturations {
                s.fetch += prepared.fetch_saturations;
            }
            self.level.run(WarpStep {
                ctx: &ctx,
                prepared,
                source: j as u8,
                cfg,
                epipole: &warp.setup.epipole_derived,
                ss,
                d: &mut d,
                st: &mut st,
                ab: &mut ab,
                scratch: &mut self.scratch,
            });
            if ss > 1 && cfg.abuffer_fragments > 0 {
                // The A-buffer holds no mesh/splat bit (general path); at ss = 1
                // each pixel is one fragment and the trip changes nothing.
                d.forget_splats();
            }
            if !self.keep {
                // Before the next warp's reference is asked for (and maybe
                // loaded beside them).
                self.scratch = warp_aa::Scratch::default();
            }
        }
        let mut unseen = BitVec::repeat(false, ((d.width / ss) * (d.height / ss)) as usize);
        let t = start();
        if cfg.hole_fill
            && cfg.fallback_fill
            && let Some(last) = cmd.warps.last()
            && let Some(changed) = fallback(&mut d, &last.setup.epipole_derived, ss, cfg, &mut st, &mut ab)
        {
            unseen = changed;
        }
        stop(Phase::FallbackFill, t);
        st.fragments_per_pixel = ab.fragments_per_pixel;
        st.forced_merges = ab.forced_merges;
        st.hole_samples = d.hole.count_ones() as u64;
        st.empty_samples = d.empty_count() as u64;
        if self.trim {
            d.drop_cache_planes();
        }
        let t = start();
        let (pixels, covered) = resolve(&d, ss);
        stop(Phase::Resolve, t);
        Ok(GoldenFrame { samples: d, pixels, covered, unseen, stats: st })
    }
}

/// One reference's warp into the derived frame (rules 3–5), as a
/// [`Work`] to run at the warper's [`VectorLevel`].
struct WarpStep<'a> {
    ctx: &'a WarpContext,
    prepared: &'a PreparedReference,
    /// Warp index (the samples' source).
    source: u8,
    cfg: &'a GoldenConfig,
    /// The derived image's epipole (hole-fill order).
    epipole: &'a Epipole,
    /// Samples per pixel side.
    ss: u32,
    d: &'a mut DestPlanes,
    st: &'a mut GoldenStats,
    ab: &'a mut AbufferStats,
    scratch: &'a mut warp_aa::Scratch,
}

impl Work for WarpStep<'_> {
    type Output = ();

    /// Warp, hole-fill and take the frame through the A-buffer.
    #[inline(always)]
    fn run(self) {
        let WarpStep { ctx, prepared, source, cfg, epipole, ss, d, st, ab, scratch } = self;
        let t = start();
        d.begin_warp();
        stop(Phase::BeginWarp, t);
        match cfg.reconstruction {
            Reconstruction::AaRect => warp_aa::warp_reference(ctx, prepared, source, cfg, d, st, scratch),
            Reconstruction::General => {
                let t = start();
                general::warp_reference_general(ctx, &prepared.samples, source, cfg, d, st);
                stop(Phase::General, t);
            }
        }
        let t = start();
        if cfg.hole_fill {
            let hf = hole_fill(d, epipole, &hole_fill_params(cfg));
            add_hole_stats(st, &hf);
        }
        stop(Phase::HoleFill, t);
        let t = start();
        round_trip_dest(d, &abuffer_params(ss, cfg), ab);
        stop(Phase::Abuffer, t);
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
    if d.empty_count() == 0 {
        return None;
    }
    let (fb, filled) = fallback_fill(d, e, &hole_fill_params(cfg));
    st.fallback_filled += fb.filled;
    st.fallback_unreached += fb.unreached;
    if let Some(s) = &mut st.saturations {
        s.hole_fill += fb.saturations;
    }
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
        fixed: cfg.fixed_formats().ok().flatten().map(|f| (f.colour, f.hole_weight)),
    }
}

fn add_hole_stats(st: &mut GoldenStats, hf: &HoleFillStats) {
    st.hole_fill_filled += hf.filled;
    st.hole_fill_unreached += hf.unreached;
    if let Some(s) = &mut st.saturations {
        s.hole_fill += hf.saturations;
    }
}

/// The golden model with its working buffers: create one and reuse it for
/// every frame of a run.
pub struct Warper {
    scratch: warp_aa::Scratch,
    /// Keep the working buffers from warp to warp (for the next warp or
    /// frame), or free them after each warp.
    keep: bool,
    /// Hand frames back with their memory planes only.
    trim: bool,
    /// Instructions the warps run with (values never depend on it).
    level: VectorLevel,
}

impl Default for Warper {
    fn default() -> Warper {
        Warper { scratch: warp_aa::Scratch::default(), keep: true, trim: false, level: VectorLevel::detect() }
    }
}

impl Warper {
    /// A warper with empty buffers, kept from frame to frame.
    pub fn new() -> Warper {
        Warper::default()
    }

    /// Keep the working buffers (a kernel per reference sample) from warp
    /// to warp and frame to frame, so later warps reuse their pages (the
    /// default); or, for a run's last frame, free them as soon as each
    /// warp is done, before the next warp's reference is asked for (and,
    /// with [`Warper::warp_frame_streamed`], maybe loaded) and before the
    /// frame is resolved and handed back. Values never depend on it.
    pub fn keep_buffers(&mut self, keep: bool) {
        self.keep = keep;
    }

    /// Hand every frame back with its memory planes only: the cache-only
    /// planes 6–8 are freed before the resolve
    /// (`DestPlanes::drop_cache_planes`), for runs that only score and
    /// write the frame (`postwarp golden`, `simulate`). Off by default: an
    /// untrimmed frame can take further warps. Values never depend on it.
    pub fn trim_frames(&mut self, on: bool) {
        self.trim = on;
    }

    /// Run the warps with the build's baseline instructions only, or (off,
    /// the default) with the widest the host has ([`VectorLevel`]). Values
    /// never depend on it; tests compare the two.
    pub fn baseline_instructions(&mut self, on: bool) {
        self.level = if on { VectorLevel::BASELINE } else { VectorLevel::detect() };
    }

    /// The instructions this warper's warps run with.
    pub fn vector_level(&self) -> VectorLevel {
        self.level
    }
}

/// Add one composite outcome to the counters.
pub(super) fn count_outcome(st: &mut GoldenStats, o: Outcome) {
    count_outcomes(st, o, 1);
}

/// Add `n` composites with outcome `o` to the counters.
pub(super) fn count_outcomes(st: &mut GoldenStats, o: Outcome, n: u64) {
    match o {
        Outcome::Filled => st.composite_filled += n,
        Outcome::NearerWins => st.composite_nearer += n,
        Outcome::BetterWins => st.composite_better += n,
        Outcome::Lost => st.composite_lost += n,
        Outcome::MeshOverSplat => {
            st.composite_better += n;
            st.mesh_over_splat += n;
        }
        Outcome::SplatRejected => {
            st.composite_lost += n;
            st.splats_rejected_by_mesh += n;
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
