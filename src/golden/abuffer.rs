//! A-buffer: frames between warps held as at most `N` fragments per pixel
//! (TR98 §10, after Carpenter), expanded to samples for the warp.
//!
//! A fragment holds a colour, a 1/Z plane (value at the pixel centre and
//! slopes per sample step), a coverage mask over the pixel's `ss²` samples,
//! and for derived frames the source number, the hole-fill flag and the
//! hole-fill weight.
//!
//! Rules:
//! 1. Grouping: samples of a pixel are visited in raster order; a sample
//!    joins the first fragment of the same kind (real / hole fill) and key
//!    (source for derived frames, object id for reference frames) whose
//!    plane predicts its 1/Z within the Z tolerance
//!    `slope_tol·|slopes|₁ + rel_tol·1/Z`; hole-fill samples of a pixel form
//!    one fragment. Otherwise it starts a new fragment whose plane passes
//!    through it. Empty samples belong to no fragment.
//! 2. A fragment's colour is the mean of its samples' colours (coverage
//!    weighted); its hole-fill weight the mean of theirs.
//! 3. More than `N` fragments: repeatedly merge the pair that is closest by
//!    (different kind, different key, |Δ 1/Z at the centre|), ties to the
//!    lowest indices; the merged fragment takes the union of the masks, the
//!    coverage-weighted colour, and the plane, kind and key of the fragment
//!    with more coverage (ties: the nearer). Each merge is counted.
//! 4. Expansion gives every covered sample the fragment's colour and the
//!    plane's 1/Z at the sample. Hence expand(compress(x)) == x whenever
//!    every pixel of x holds at most `N` flat-coloured planar fragments
//!    (x itself an expansion); resolved pixel colours are kept by rule 2.
//!
//! Not modelled: Carpenter's opacity/area and zmin/zmax; a fixed-point
//! memory format (the byte counts live in the hardware model).

use super::planes::DestPlanes;
use bitvec::vec::BitVec;
use postwarp_rtl::SampleImage;
use rayon::prelude::*;

/// One A-buffer fragment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// 1/Z at the pixel centre.
    pub inv_z: f32,
    /// Slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// Coverage mask over the pixel's samples (bit `j·ss + i`).
    pub mask: u16,
    /// True for a real surface, false for hole fill.
    pub real: bool,
    /// Source number (derived frames) or object id (reference frames).
    pub key: u32,
    /// Hole-fill weight (derived frames).
    pub weight: f32,
}

/// Counters of one compression.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AbufferStats {
    /// Pixels by number of fragments needed before merging (index = count).
    pub fragments_per_pixel: Vec<u64>,
    /// Merges forced by the fragment limit.
    pub forced_merges: u64,
}

impl AbufferStats {
    fn record(&mut self, n: usize) {
        if self.fragments_per_pixel.len() <= n {
            self.fragments_per_pixel.resize(n + 1, 0);
        }
        self.fragments_per_pixel[n] += 1;
    }

    /// Add another set of counters.
    pub fn add(&mut self, o: &AbufferStats) {
        for (n, &c) in o.fragments_per_pixel.iter().enumerate() {
            if c > 0 {
                if self.fragments_per_pixel.len() <= n {
                    self.fragments_per_pixel.resize(n + 1, 0);
                }
                self.fragments_per_pixel[n] += c;
            }
        }
        self.forced_merges += o.forced_merges;
    }
}

/// One sample as the A-buffer sees it.
#[derive(Clone, Copy, Debug)]
struct SampleView {
    colour: [f32; 3],
    inv_z: f32,
    slopes: [f32; 2],
    real: bool,
    key: u32,
    weight: f32,
}

/// Reference sample `i` as the A-buffer sees it (`None`: no surface).
fn reference_view(img: &SampleImage, i: usize) -> Option<SampleView> {
    sample_view(img.valid[i], img.colour[i], img.z[i], img.inv_z_slopes[i], img.object_id[i])
}

/// A reference sample's planes as the A-buffer sees them (`None`: no
/// surface).
fn sample_view(valid: bool, colour: [f32; 3], z: f32, slopes: [f32; 2], key: u32) -> Option<SampleView> {
    valid.then(|| SampleView { colour, inv_z: 1.0 / z, slopes, real: true, key, weight: 0.0 })
}

/// Compression parameters.
#[derive(Clone, Copy, Debug)]
pub struct AbufferParams {
    /// Super-samples per pixel per axis.
    pub ss: u32,
    /// Fragment limit per pixel.
    pub abuffer_fragments: u32,
    /// Z tolerance slope term.
    pub slope_tol: f64,
    /// Z tolerance relative term.
    pub rel_tol: f64,
}

fn offset(ss: u32, i: u32) -> f32 {
    i as f32 - (ss as f32 - 1.0) / 2.0
}

fn plane_at(f: &Fragment, ox: f32, oy: f32) -> f32 {
    f.inv_z + f.slopes[0] * ox + f.slopes[1] * oy
}

/// Most samples per pixel (4x4 super-sampling).
const MAX_SS2: usize = 16;

/// A fragment being built: fragment, colour sum, weight sum, sample count.
type Building = (Fragment, [f64; 3], f64, u32);

/// Working buffers of [`compress_pixel`], reused from pixel to pixel.
#[derive(Default)]
struct PixelScratch {
    building: Vec<Building>,
    out: Vec<Fragment>,
}

/// Group one pixel's samples into fragments (rules 1–3), into `sc.out`.
fn compress_pixel(samples: &[Option<SampleView>], p: &AbufferParams, stats: &mut AbufferStats, sc: &mut PixelScratch) {
    let ss = p.ss;
    let frags = &mut sc.building;
    frags.clear();
    let mut n = 0usize;
    for (k, s) in samples.iter().enumerate() {
        let Some(s) = s else { continue };
        let (ox, oy) = (offset(ss, k as u32 % ss), offset(ss, k as u32 / ss));
        let found = frags[..n].iter().position(|(f, ..)| {
            f.real == s.real && f.key == s.key && {
                if !s.real {
                    true
                } else {
                    let pred = plane_at(f, ox, oy) as f64;
                    let tol = p.slope_tol * (f.slopes[0].abs() + f.slopes[1].abs()) as f64 + p.rel_tol * s.inv_z as f64;
                    (pred - s.inv_z as f64).abs() <= tol
                }
            }
        });
        let idx = match found {
            Some(i) => i,
            None => {
                let inv_z_c = if s.real { s.inv_z - s.slopes[0] * ox - s.slopes[1] * oy } else { 0.0 };
                frags.push((
                    Fragment {
                        colour: [0.0; 3],
                        inv_z: inv_z_c,
                        slopes: if s.real { s.slopes } else { [0.0; 2] },
                        mask: 0,
                        real: s.real,
                        key: s.key,
                        weight: 0.0,
                    },
                    [0.0; 3],
                    0.0,
                    0,
                ));
                n += 1;
                n - 1
            }
        };
        let e = &mut frags[idx];
        e.0.mask |= 1 << k;
        for c in 0..3 {
            e.1[c] += s.colour[c] as f64;
        }
        e.2 += s.weight as f64;
        e.3 += 1;
    }
    stats.record(n);
    while n > p.abuffer_fragments as usize && n > 1 {
        let mut best = (u8::MAX, u8::MAX, f64::INFINITY, 0usize, 0usize);
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (&frags[i].0, &frags[j].0);
                let key = ((a.real != b.real) as u8, (a.key != b.key) as u8, (a.inv_z as f64 - b.inv_z as f64).abs());
                if (key.0, key.1) < (best.0, best.1) || ((key.0, key.1) == (best.0, best.1) && key.2 < best.2) {
                    best = (key.0, key.1, key.2, i, j);
                }
            }
        }
        let (i, j) = (best.3, best.4);
        let b = frags.remove(j);
        n -= 1;
        let a = &mut frags[i];
        let dominant_b = b.3 > a.3 || (b.3 == a.3 && b.0.inv_z > a.0.inv_z);
        if dominant_b {
            a.0.inv_z = b.0.inv_z;
            a.0.slopes = b.0.slopes;
            a.0.real = b.0.real;
            a.0.key = b.0.key;
        }
        a.0.mask |= b.0.mask;
        for c in 0..3 {
            a.1[c] += b.1[c];
        }
        a.2 += b.2;
        a.3 += b.3;
        stats.forced_merges += 1;
    }
    sc.out.clear();
    for (f, sum, wsum, cnt) in &frags[..n] {
        let cnt = *cnt as f64;
        sc.out.push(Fragment { colour: sum.map(|c| (c / cnt) as f32), weight: (wsum / cnt) as f32, ..*f });
    }
}

fn for_each_pixel(width: u32, height: u32, ss: u32, mut f: impl FnMut(u32, u32, &[usize])) {
    let mut idx = Vec::with_capacity((ss * ss) as usize);
    for py in 0..height / ss {
        for px in 0..width / ss {
            idx.clear();
            for j in 0..ss {
                for i in 0..ss {
                    idx.push(((py * ss + j) * width + px * ss + i) as usize);
                }
            }
            f(px, py, &idx);
        }
    }
}

/// Depth of an expanded reference sample whose plane has run past the
/// horizon (1/Z <= 0 or a reciprocal that overflows), scene units.
pub const FAR_Z: f32 = f32::MAX;

/// Compress a reference frame's samples to fragments and expand them back
/// (the round trip through memory). With `abuffer_fragments == 0` the samples
/// pass unchanged.
pub fn round_trip_reference(img: &SampleImage, p: &AbufferParams, stats: &mut AbufferStats) -> SampleImage {
    let mut out = img.clone();
    round_trip_reference_in_place(&mut out, p, stats);
    out
}

/// [`round_trip_reference`] on the image itself: each pixel's samples are
/// read before they are rewritten, and samples outside whole pixels are
/// emptied, so the values are the same without a second image (a loaded
/// reference becomes its prepared form). Bands of [`BAND_PIXEL_ROWS`]
/// pixel rows go through in parallel; pixels are independent and the
/// counters add, so values and counters are the same on any number of
/// threads.
pub fn round_trip_reference_in_place(img: &mut SampleImage, p: &AbufferParams, stats: &mut AbufferStats) {
    if p.abuffer_fragments == 0 {
        return;
    }
    let (w, h, ss) = (img.width as usize, img.height as usize, p.ss as usize);
    for y in 0..h {
        for x in 0..w {
            if x >= w / ss * ss || y >= h / ss * ss {
                let i = y * w + x;
                (img.colour[i], img.z[i], img.inv_z_slopes[i], img.object_id[i]) = ([0.0; 3], 0.0, [0.0; 2], 0);
                img.valid.set(i, false);
            }
        }
    }
    let whole = h / ss * ss * w;
    let band = (BAND_PIXEL_ROWS * ss * w).max(1);
    let SampleImage { colour, z, inv_z_slopes, object_id, valid, .. } = img;
    let valid_in: &BitVec = valid;
    let bands: Vec<(BitVec, AbufferStats)> = colour[..whole]
        .par_chunks_mut(band)
        .zip(z[..whole].par_chunks_mut(band))
        .zip(inv_z_slopes[..whole].par_chunks_mut(band))
        .zip(object_id[..whole].par_chunks_mut(band))
        .enumerate()
        .map(|(k, (((colour, z), slopes), object_id))| {
            let valid = valid_in[k * band..k * band + colour.len()].to_bitvec();
            let mut b = Band { colour, z, slopes, object_id, valid };
            let mut st = AbufferStats::default();
            round_trip_band(&mut b, w, p, &mut st);
            (b.valid, st)
        })
        .collect();
    for (k, (v, st)) in bands.into_iter().enumerate() {
        valid[k * band..k * band + v.len()].copy_from_bitslice(&v);
        stats.add(&st);
    }
}

/// Pixel rows per band of [`round_trip_reference_in_place`].
const BAND_PIXEL_ROWS: usize = 16;

/// Whole pixel rows of a reference, as slices of its planes (`valid`
/// copied out, and back when the band is done).
struct Band<'a> {
    colour: &'a mut [[f32; 3]],
    z: &'a mut [f32],
    slopes: &'a mut [[f32; 2]],
    object_id: &'a mut [u32],
    valid: BitVec,
}

/// The round trip of one band of `w`-sample rows.
fn round_trip_band(b: &mut Band, w: usize, p: &AbufferParams, stats: &mut AbufferStats) {
    let ss = p.ss;
    let rows = (b.colour.len() / w) as u32;
    let mut views = Vec::with_capacity((ss * ss) as usize);
    let mut sc = PixelScratch::default();
    for_each_pixel(w as u32, rows, ss, |_, _, idx| {
        views.clear();
        views.extend(idx.iter().map(|&i| sample_view(b.valid[i], b.colour[i], b.z[i], b.slopes[i], b.object_id[i])));
        compress_pixel(&views, p, stats, &mut sc);
        for &i in idx {
            (b.colour[i], b.z[i], b.slopes[i], b.object_id[i]) = ([0.0; 3], 0.0, [0.0; 2], 0);
            b.valid.set(i, false);
        }
        for f in &sc.out {
            for (k, &i) in idx.iter().enumerate() {
                if f.mask & (1 << k) != 0 {
                    let (ox, oy) = (offset(ss, k as u32 % ss), offset(ss, k as u32 / ss));
                    b.colour[i] = f.colour;
                    b.z[i] = 1.0 / plane_at(f, ox, oy);
                    b.slopes[i] = f.slopes;
                    b.object_id[i] = f.key;
                    b.valid.set(i, true);
                }
            }
        }
    });
    // A plane extrapolated to a sample can reach 1/Z <= 0 on a grazing
    // surface (only after a merge: the anchor sample is on its plane), or
    // so close to 0 that the reciprocal overflows. Memory holds the plane,
    // not the sample's own depth, so the sample goes past the horizon, at
    // the far limit, as the hardware's unpack does.
    for i in b.valid.iter_ones() {
        if !(b.z[i].is_finite() && b.z[i] > 0.0) {
            b.z[i] = FAR_Z;
        }
    }
}

/// Compress the derived frame's memory planes to fragments and expand them
/// back. Cache-only planes are untouched (they are reset per warp).
#[inline(always)]
pub fn round_trip_dest(d: &mut DestPlanes, p: &AbufferParams, stats: &mut AbufferStats) {
    if p.abuffer_fragments == 0 {
        return;
    }
    // One copy per common super-sampling factor, where the sample offsets
    // and loop bounds are constants.
    match p.ss {
        1 => round_trip_dest_ss(d, p, stats, 1, None),
        2 => round_trip_dest_ss(d, p, stats, 2, None),
        4 => round_trip_dest_ss(d, p, stats, 4, None),
        ss => round_trip_dest_ss(d, p, stats, ss, None),
    }
}

/// [`round_trip_dest`] of the pixels set in `only` (one bit per display
/// pixel, row-major) and no other: what the hardware does when it writes
/// back the pixels one pass changed (the fallback fill, `fallback_fill.rs`).
pub fn round_trip_dest_where(d: &mut DestPlanes, p: &AbufferParams, stats: &mut AbufferStats, only: &BitVec) {
    if p.abuffer_fragments == 0 {
        return;
    }
    round_trip_dest_ss(d, p, stats, p.ss, Some(only));
}

/// [`round_trip_dest`] with `p.ss == pss`.
#[inline(always)]
fn round_trip_dest_ss(
    d: &mut DestPlanes,
    p: &AbufferParams,
    stats: &mut AbufferStats,
    pss: u32,
    only: Option<&BitVec>,
) {
    debug_assert_eq!(pss, p.ss);
    let ss = pss as usize;
    let w = d.width as usize;
    let mut views = [None; MAX_SS2];
    let mut idx = [0usize; MAX_SS2];
    let mut sc = PixelScratch::default();
    for py in 0..d.height as usize / ss {
        for px in 0..w / ss {
            if only.is_some_and(|m| !m[py * (w / ss) + px]) {
                continue;
            }
            for j in 0..ss {
                for i in 0..ss {
                    let k = j * ss + i;
                    let s = (py * ss + j) * w + px * ss + i;
                    idx[k] = s;
                    views[k] = (d.real[s] || d.hole[s]).then(|| SampleView {
                        colour: d.colour[s],
                        inv_z: d.inv_z[s],
                        slopes: d.slopes[s],
                        real: d.real[s],
                        key: d.source[s] as u32,
                        weight: d.fill_weight[s],
                    });
                }
            }
            if one_plane_fast_path(d, &views[..ss * ss], &idx[..ss * ss], p, pss, stats) {
                continue;
            }
            compress_pixel(&views[..ss * ss], p, stats, &mut sc);
            // Pixels do not overlap: write this one back at once.
            for (k, &i) in idx[..ss * ss].iter().enumerate() {
                let (ox, oy) = (offset(pss, k as u32 % pss), offset(pss, k as u32 / pss));
                match sc.out.iter().find(|f| f.mask & (1 << k) != 0) {
                    None => {
                        d.real.set(i, false);
                        d.hole.set(i, false);
                    }
                    Some(f) => {
                        d.colour[i] = f.colour;
                        d.inv_z[i] = if f.real { plane_at(f, ox, oy) } else { 0.0 };
                        d.slopes[i] = f.slopes;
                        d.source[i] = f.key as u8;
                        d.real.set(i, f.real);
                        d.hole.set(i, !f.real);
                        d.fill_weight[i] = f.weight;
                    }
                }
            }
        }
    }
}

/// The common pixel: every sample real, from one source, on the first
/// sample's plane (rule 1). It compresses to one fragment, computed here with
/// exactly the arithmetic of [`compress_pixel`] and written back without
/// touching the planes that cannot change (kind, source). Returns false,
/// changing nothing, for any other pixel. `pss == p.ss`.
#[inline(always)]
fn one_plane_fast_path(
    d: &mut DestPlanes,
    views: &[Option<SampleView>],
    idx: &[usize],
    p: &AbufferParams,
    pss: u32,
    stats: &mut AbufferStats,
) -> bool {
    let Some(Some(s0)) = views.first() else { return false };
    if !s0.real {
        return false;
    }
    let (ox0, oy0) = (offset(pss, 0), offset(pss, 0));
    let f = Fragment {
        colour: [0.0; 3],
        inv_z: s0.inv_z - s0.slopes[0] * ox0 - s0.slopes[1] * oy0,
        slopes: s0.slopes,
        mask: 0,
        real: true,
        key: s0.key,
        weight: 0.0,
    };
    let slope_term = p.slope_tol * (f.slopes[0].abs() + f.slopes[1].abs()) as f64;
    let mut sum = [0.0f64; 3];
    let mut wsum = 0.0f64;
    for (k, v) in views.iter().enumerate() {
        let Some(s) = v else { return false };
        if !s.real || s.key != f.key {
            return false;
        }
        if k > 0 {
            let (ox, oy) = (offset(pss, k as u32 % pss), offset(pss, k as u32 / pss));
            let pred = plane_at(&f, ox, oy) as f64;
            if (pred - s.inv_z as f64).abs() > slope_term + p.rel_tol * s.inv_z as f64 {
                return false;
            }
        }
        for (acc, v) in sum.iter_mut().zip(s.colour) {
            *acc += v as f64;
        }
        wsum += s.weight as f64;
    }
    stats.record(1);
    let n = views.len() as f64;
    let colour = sum.map(|c| (c / n) as f32);
    let weight = (wsum / n) as f32;
    for (k, &i) in idx.iter().enumerate() {
        let (ox, oy) = (offset(pss, k as u32 % pss), offset(pss, k as u32 / pss));
        d.colour[i] = colour;
        d.inv_z[i] = plane_at(&f, ox, oy);
        d.slopes[i] = f.slopes;
        d.fill_weight[i] = weight;
    }
    true
}

/// The coverage masks of a compressed pixel partition its covered samples.
pub fn masks_partition(frags: &[Fragment], covered: u16) -> bool {
    let mut acc = 0u16;
    for f in frags {
        if acc & f.mask != 0 {
            return false;
        }
        acc |= f.mask;
    }
    acc == covered
}

/// Compress one pixel of a reference image (for tests and tools).
pub fn compress_reference_pixel(img: &SampleImage, px: u32, py: u32, p: &AbufferParams) -> Vec<Fragment> {
    let mut views = Vec::new();
    for j in 0..p.ss {
        for i in 0..p.ss {
            let k = img.index(px * p.ss + i, py * p.ss + j);
            views.push(reference_view(img, k));
        }
    }
    let mut sc = PixelScratch::default();
    compress_pixel(&views, p, &mut AbufferStats::default(), &mut sc);
    sc.out
}

/// Valid-sample mask of a reference pixel (bit `j·ss + i`).
pub fn valid_mask(valid: &BitVec, width: u32, px: u32, py: u32, ss: u32) -> u16 {
    let mut m = 0u16;
    for j in 0..ss {
        for i in 0..ss {
            if valid[((py * ss + j) * width + px * ss + i) as usize] {
                m |= 1 << (j * ss + i);
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(n: u32) -> AbufferParams {
        AbufferParams { ss: 2, abuffer_fragments: n, slope_tol: 2.0, rel_tol: 0.01 }
    }

    /// A 1x1-pixel reference whose 4 samples hold `surfaces` flat planar
    /// surfaces (sample k belongs to surface k % surfaces).
    fn pixel(surfaces: usize) -> SampleImage {
        let mut s = SampleImage::empty(2, 2);
        for k in 0..4 {
            let f = k % surfaces;
            let inv_z_c = 0.1 + 0.2 * f as f32;
            let slopes = [0.001 * f as f32, -0.002];
            let (ox, oy) = (offset(2, k as u32 % 2), offset(2, k as u32 / 2));
            s.z[k] = 1.0 / (inv_z_c + slopes[0] * ox + slopes[1] * oy);
            s.inv_z_slopes[k] = slopes;
            s.colour[k] = [f as f32 / 4.0, 0.5, 0.25];
            s.object_id[k] = 1;
            s.valid.set(k, true);
        }
        s
    }

    /// The round trip in place gives the planes a second image gets,
    /// samples outside whole pixels emptied (an odd-sized 2x2-sampled
    /// frame whose samples all hold a surface), in bands on one thread or
    /// several (37 whole pixel rows: three bands, the last one short).
    #[test]
    fn the_round_trip_in_place_is_the_round_trip() {
        let (w, h) = (7, 75);
        assert!(h as usize / 2 > 2 * BAND_PIXEL_ROWS);
        let mut img = SampleImage::empty(w, h);
        for i in 0..img.len() {
            let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
            img.z[i] = 1.0 / (0.1 + 0.01 * x + 0.02 * (y % 3.0));
            img.inv_z_slopes[i] = [0.01, 0.02];
            img.colour[i] = [x / 7.0, y / 5.0, 0.5];
            img.object_id[i] = 1 + (x as u32 / 4);
            img.valid.set(i, i % 11 != 3);
        }
        for n in [0, 1, 3] {
            let mut st2 = AbufferStats::default();
            let mut want = SampleImage::empty(w, h);
            // The round trip into a second image, written out here.
            for_each_pixel(w, h, 2, |_, _, idx| {
                let views: Vec<_> = idx.iter().map(|&i| reference_view(&img, i)).collect();
                let mut sc = PixelScratch::default();
                compress_pixel(&views, &params(n), &mut st2, &mut sc);
                for f in &sc.out {
                    for (k, &i) in idx.iter().enumerate().filter(|(k, _)| f.mask & (1 << k) != 0) {
                        let (ox, oy) = (offset(2, k as u32 % 2), offset(2, k as u32 / 2));
                        (want.colour[i], want.z[i], want.inv_z_slopes[i]) =
                            (f.colour, 1.0 / plane_at(f, ox, oy), f.slopes);
                        want.object_id[i] = f.key;
                        want.valid.set(i, true);
                    }
                }
            });
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
                let mut got = img.clone();
                let mut st = AbufferStats::default();
                pool.install(|| round_trip_reference_in_place(&mut got, &params(n), &mut st));
                if n == 0 {
                    assert_eq!(got, img, "no A-buffer: unchanged");
                    continue;
                }
                assert_eq!(got, want, "{n} fragments, {threads} threads");
                assert_eq!(st.fragments_per_pixel, st2.fragments_per_pixel);
                assert_eq!(st.forced_merges, st2.forced_merges);
                assert!(!got.valid[6] && !got.valid[(74 * w) as usize], "outside whole pixels: empty");
                assert!(got.valid.count_ones() > 0);
            }
        }
    }

    #[test]
    fn lossless_up_to_the_limit() {
        for n in 1..=3 {
            let img = pixel(n);
            let mut st = AbufferStats::default();
            // One round trip brings depths onto the fragments' planes; from
            // then on the A-buffer is exact.
            let once = round_trip_reference(&img, &params(3), &mut st);
            let twice = round_trip_reference(&once, &params(3), &mut st);
            assert_eq!(once, twice, "{n} surfaces");
            assert_eq!(st.forced_merges, 0);
            for k in 0..4 {
                assert!((once.z[k] - img.z[k]).abs() <= 1e-5 * img.z[k], "{n}: {} vs {}", once.z[k], img.z[k]);
                assert_eq!(once.colour[k], img.colour[k]);
            }
        }
    }

    #[test]
    fn four_surfaces_merge_once_and_keep_the_pixel_mean() {
        let img = pixel(4);
        let mut st = AbufferStats::default();
        let out = round_trip_reference(&img, &params(3), &mut st);
        assert_eq!(st.forced_merges, 1);
        assert_eq!(st.fragments_per_pixel, vec![0, 0, 0, 0, 1]);
        let mean = |s: &SampleImage| (0..4).map(|k| s.colour[k][0]).sum::<f32>() / 4.0;
        assert!((mean(&out) - mean(&img)).abs() < 1e-6);
        let frags = compress_reference_pixel(&img, 0, 0, &params(3));
        assert_eq!(frags.len(), 3);
        assert!(masks_partition(&frags, 0b1111));
    }

    #[test]
    fn a_planar_single_source_pixel_becomes_one_fragment() {
        // Four real samples of one source on the plane 1/Z = 0.5 + 0.01·x − 0.02·y
        // (sample offsets ±0.5): the fast path must give the coverage mean colour
        // and the plane's values, exactly as the general grouping would.
        let mut d = DestPlanes::new(2, 2);
        let inv_z = |k: usize| 0.5 + 0.01 * offset(2, k as u32 % 2) - 0.02 * offset(2, k as u32 / 2);
        for k in 0..4 {
            d.real.set(k, true);
            d.source[k] = 1;
            d.colour[k] = [k as f32 / 4.0, 0.5, 1.0];
            d.inv_z[k] = inv_z(k);
            d.slopes[k] = [0.01, -0.02];
        }
        let mut st = AbufferStats::default();
        round_trip_dest(&mut d, &params(3), &mut st);
        assert_eq!(st.fragments_per_pixel, vec![0, 1]);
        for k in 0..4 {
            assert_eq!(d.colour[k], [0.375, 0.5, 1.0]);
            assert!((d.inv_z[k] - inv_z(k)).abs() < 1e-7);
            assert!(d.real[k] && !d.hole[k] && d.source[k] == 1);
        }
        // One sample off the plane: two fragments (general path).
        d.inv_z[3] = 0.9;
        round_trip_dest(&mut d, &params(3), &mut st);
        assert_eq!(st.fragments_per_pixel, vec![0, 1, 1]);
    }

    #[test]
    fn invalid_samples_stay_invalid_and_masks_partition() {
        let mut img = pixel(2);
        img.valid.set(3, false);
        let out = round_trip_reference(&img, &params(3), &mut AbufferStats::default());
        assert!(!out.valid[3] && out.valid[0]);
        let frags = compress_reference_pixel(&img, 0, 0, &params(3));
        assert!(masks_partition(&frags, valid_mask(&img.valid, 2, 0, 0, 2)));
    }
}
