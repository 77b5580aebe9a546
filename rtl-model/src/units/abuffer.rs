//! A-buffer packer and unpacker: frames in DRAM are held as at most
//! `abuffer_fragments` fragments per pixel (TR98 §10, after Carpenter) and
//! expanded back to super-samples on chip.
//!
//! Job: the packer compresses one pixel's `ss²` super-samples into
//! fragments when a frame (a reference being converted, or a destination
//! tile leaving the cache) is written to memory; the unpacker expands a
//! pixel's fragments back into samples when it is read. The functional
//! values are those of the golden model's A-buffer, bit for bit (same f32
//! and f64 operations in the same order); the memory format below only
//! fixes how many bytes a packed pixel occupies, for DRAM accounting.
//!
//! Ports:
//! - packer in: one pixel's `ss²` samples in raster order within the pixel
//!   (sample `k = j·ss + i`), each either empty or a [`SampleIn`] (colour,
//!   1/Z, slopes, kind real / hole fill, key, hole-fill weight), plus
//!   [`AbufferParams`]; out: a [`PackedPixel`] (fragment count and up to
//!   `abuffer_fragments` [`Fragment`]s) and its byte count
//!   ([`PackedPixel::bytes`]); counters in [`AbufferCounters`].
//! - unpacker in: one pixel's fragments; out: per sample the covering
//!   fragment (or none) and the 1/Z its plane gives at the sample
//!   ([`Fragment::inv_z_at`]).
//! - Frame level: [`pack_reference`] / [`PackedReference::unpack`] for
//!   reference frames (a [`SampleImage`] in, a [`PackedReference`] in
//!   memory, a [`SampleImage`] back out), [`round_trip_dest_pixels`] for a
//!   rectangle of destination pixels written back and read again
//!   ([`DestFrame`] memory planes rewritten in place).
//!
//! Throughput/latency (assumption): one pixel per clock in each direction,
//! packer and unpacker fully pipelined; the grouping is a chain of `ss²`
//! compare stages and each forced merge a pairwise-minimum tree, unrolled
//! for the worst case (`ss² − abuffer_fragments` merges). This file computes
//! values and byte counts only; it counts no cycles.
//!
//! Rules (the golden model's, restated):
//! 1. Grouping. The packer visits the covered samples of a pixel in raster
//!    order. A sample joins the first fragment built so far that has the
//!    same kind and key (the source number for a derived frame, the object
//!    id for a reference frame) and, for a real sample, whose plane
//!    predicts the sample's 1/Z within the Z tolerance
//!    `slope_tol·(|∂x| + |∂y|)` (the fragment's slopes) `+ rel_tol·1/Z`
//!    (the sample's 1/Z), compared in f64. All hole-fill samples of one
//!    key join one fragment. A sample that joins none opens a new fragment
//!    whose plane passes through it: 1/Z at the pixel centre
//!    `1/Z − ∂x·ox − ∂y·oy` (f32, sample offset `(ox, oy)` from the pixel
//!    centre in sample steps), its slopes; a hole-fill fragment has a zero
//!    plane. Empty samples belong to no fragment.
//! 2. A fragment's colour is the mean of its samples' colours, its
//!    hole-fill weight the mean of theirs (sums in f64, one division at the
//!    end, rounded to f32).
//! 3. Over the limit (more than `abuffer_fragments` fragments, and more than
//!    one): merge the closest pair, closeness ordered by (kinds differ,
//!    keys differ, |Δ 1/Z at the centre| in f64), ties to the lowest pair
//!    of indices; the merged fragment sits at the lower index and the
//!    others close up. It takes the union of the masks, the summed colours,
//!    weights and sample counts, and the plane, kind and key of the part
//!    with more samples (ties: the one with the larger centre 1/Z, i.e. the
//!    nearer). Repeat; each merge is counted in `forced_merges`.
//! 4. Expansion: every covered sample gets its fragment's colour, slopes,
//!    key, kind and weight, and the plane's 1/Z at the sample
//!    (`1/Z_c + ∂x·ox + ∂y·oy` in f32); a derived hole-fill sample gets
//!    1/Z = 0; uncovered samples are empty.
//! 5. Reference depth (this unit's rule for the golden model's fix-up, see
//!    below): a reference sample whose expanded depth `Z = 1/(1/Z)` is not
//!    finite and positive (the plane extrapolated to the sample reaches
//!    1/Z <= 0, or so close to 0 that the reciprocal overflows) is placed
//!    at the far limit, `Z = f32::MAX` ([`FAR_Z`]): the plane has run past
//!    the horizon, so the sample lies beyond every other surface.
//!    Derived frames keep 1/Z as stored (the compositor compares 1/Z
//!    directly, where 1/Z <= 0 already means "beyond everything").
//!
//! With `abuffer_fragments == 0` there is no A-buffer: samples are stored raw
//! ([`RAW_SAMPLE_BYTES`] each) and come back unchanged; no counter moves.
//!
//! The golden model's fix-up: golden `round_trip_reference` gives such a
//! sample the depth of the *original* sample, which a hardware unpacker
//! cannot see (the original samples are not in memory). Rule 5 replaces it.
//! The case needs no merge: a sample joins a grazing plane anchored at
//! another sample whenever it is within the Z tolerance, even where the
//! plane has crossed 1/Z = 0. On the bundled traces (room, slants,
//! hairball, occluders, motorcycle; ss = 2, limits 1, 2 and 3) no reference
//! sample reaches it, so the two agree bit for bit there
//! (`tests/hw_abuffer.rs` checks both, and the hand-made case).
//!
//! The golden model's one-fragment fast path for derived pixels is a
//! software speed-up with the same arithmetic; the packer has only the
//! general grouping, which gives the same fragment for every non-NaN 1/Z
//! (the fast path's test `|Δ| > tol` lets a NaN sample join where the
//! grouping's `|Δ| <= tol` does not; no warp produces one).
//!
//! # Memory format
//!
//! A packed pixel is a header followed by its fragments; pixels are
//! addressed through the headers (count per pixel), so a pixel costs
//! `PIXEL_HEADER_BYTES + count · FRAGMENT_BYTES`.
//!
//! | item | bytes | contents |
//! |---|---|---|
//! | pixel header ([`PIXEL_HEADER_BYTES`]) | 1 | fragment count (5 bits, 0–16) and 3 spare bits |
//! | fragment ([`FRAGMENT_BYTES`]) | 16 | see below |
//! | raw sample ([`RAW_SAMPLE_BYTES`], `abuffer_fragments == 0`) | 16 | one super-sample as in the on-chip caches |
//!
//! Fragment layout (128 bits):
//!
//! | bits | field |
//! |---|---|
//! | 30 | colour RGB, 3 × 10 bit |
//! | 1 | kind: real surface / hole fill |
//! | 1 | spare |
//! | 32 | 1/Z at the pixel centre (FP32) |
//! | 32 | slopes ∂(1/Z)/∂x, ∂(1/Z)/∂y, 2 × 16 bit (FP16) |
//! | 16 | coverage mask, bit `j·ss + i` (up to 4x4 samples) |
//! | 8 | key: source number (derived) or object tag (reference) |
//! | 8 | hole-fill weight |
//!
//! Not modelled: the quantisation of that format (the values stay f32
//! exactly as in the golden model; the layout only sets the byte counts);
//! Carpenter's opacity/area and zmin/zmax; the mesh/splat bit (not stored);
//! object ids wider than the 8-bit key field (kept whole here); cycles,
//! pipeline latency and the DRAM requests themselves (the caller turns the
//! returned byte counts into requests); partial pixels at a frame border
//! whose size is not a multiple of `ss` (never packed, like the golden
//! model, which leaves them untouched in a derived frame and empty in a
//! reference frame).

use crate::bits;
use crate::{DestFrame, SampleImage};

/// Bytes of one fragment in memory (128 bits: colour 3×10 bit, kind bit,
/// 1/Z FP32, slopes 2×FP16, 16-bit coverage mask, 8-bit key, 8-bit
/// hole-fill weight; see the module doc).
pub const FRAGMENT_BYTES: u64 = 16;

/// Bytes of one pixel header in memory: the pixel's fragment count
/// (5 bits for 0–16, padded to a byte).
pub const PIXEL_HEADER_BYTES: u64 = 1;

/// Bytes of one super-sample stored raw (no A-buffer, `abuffer_fragments == 0`),
/// the on-chip cache format.
pub const RAW_SAMPLE_BYTES: u64 = crate::config::CACHE_BYTES_PER_SAMPLE;

/// Most super-samples per pixel (4x4 super-sampling): the width of the
/// coverage mask and the most fragments a pixel can need.
pub const MAX_SAMPLES_PER_PIXEL: usize = 16;

/// Depth given to a reference sample whose plane extrapolates past the
/// horizon (rule 5), scene units.
pub const FAR_Z: f32 = f32::MAX;

/// Compression parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AbufferParams {
    /// Super-samples per pixel per axis (1 to 4).
    pub ss: u32,
    /// Fragment limit per pixel (0 = no A-buffer: samples stored raw).
    pub abuffer_fragments: u32,
    /// Z tolerance, slope term (dimensionless, times |∂x| + |∂y|).
    pub slope_tol: f64,
    /// Z tolerance, relative term (fraction of 1/Z).
    pub rel_tol: f64,
}

/// One A-buffer fragment (the functional contents of [`FRAGMENT_BYTES`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Linear RGB (coverage-weighted mean of the samples).
    pub colour: [f32; 3],
    /// 1/Z at the pixel centre (1/scene unit); 0 for hole fill.
    pub inv_z: f32,
    /// Slopes of 1/Z per sample step (1/scene unit per sample); 0 for hole fill.
    pub slopes: [f32; 2],
    /// Coverage mask over the pixel's samples (bit `j·ss + i`).
    pub mask: u16,
    /// True for a real surface, false for hole fill.
    pub real: bool,
    /// Source number (derived frames) or object id (reference frames).
    pub key: u32,
    /// Hole-fill weight (derived frames; mean over the samples), 0 for references.
    pub weight: f32,
}

const EMPTY_FRAGMENT: Fragment =
    Fragment { colour: [0.0; 3], inv_z: 0.0, slopes: [0.0; 2], mask: 0, real: false, key: 0, weight: 0.0 };

impl Fragment {
    /// The plane's 1/Z at sample `k` of the pixel (rule 4, f32).
    pub fn inv_z_at(&self, ss: u32, k: u32) -> f32 {
        let (ox, oy) = sample_offset(ss, k);
        self.inv_z + self.slopes[0] * ox + self.slopes[1] * oy
    }

    /// True if the fragment covers sample `k`.
    pub fn covers(&self, k: u32) -> bool {
        self.mask & (1 << k) != 0
    }
}

/// Offset of sample `k` (raster order in the pixel) from the pixel centre,
/// in sample steps: `i − (ss − 1)/2` per axis.
#[inline]
pub fn sample_offset(ss: u32, k: u32) -> (f32, f32) {
    let c = (ss as f32 - 1.0) / 2.0;
    let (i, j) = sample_xy(ss, k);
    (i as f32 - c, j as f32 - c)
}

/// Column and row `(k % ss, k / ss)` of sample `k` in its pixel. Host speed
/// only: read from a table for the pixel sizes the packer takes (no integer
/// division per sample, which was most of the cost of expanding a pixel).
#[inline]
pub fn sample_xy(ss: u32, k: u32) -> (u32, u32) {
    const SIDES: usize = 5;
    const TABLE: [[(u8, u8); MAX_SAMPLES_PER_PIXEL]; SIDES] = {
        let mut t = [[(0u8, 0u8); MAX_SAMPLES_PER_PIXEL]; SIDES];
        let mut ss = 1;
        while ss < SIDES {
            let mut k = 0;
            while k < MAX_SAMPLES_PER_PIXEL {
                t[ss][k] = ((k % ss) as u8, (k / ss) as u8);
                k += 1;
            }
            ss += 1;
        }
        t
    };
    match TABLE.get(ss as usize).and_then(|row| row.get(k as usize)) {
        Some(&(i, j)) if ss > 0 => (i as u32, j as u32),
        _ => (k % ss, k / ss),
    }
}

/// One covered super-sample as it enters the packer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleIn {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// 1/Z at the sample (1/scene unit).
    pub inv_z: f32,
    /// Slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// Real surface (true) or hole fill (false).
    pub real: bool,
    /// Source number (derived frames) or object id (reference frames).
    pub key: u32,
    /// Hole-fill weight (0 for references).
    pub weight: f32,
}

/// Counters of the packer (units: counts).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AbufferCounters {
    /// Pixels by number of fragments needed before merging (index = count,
    /// pixels), as the golden model's `AbufferStats::fragments_per_pixel`.
    pub fragments_per_pixel: Vec<u64>,
    /// Merges forced by the fragment limit (merges).
    pub forced_merges: u64,
    /// Pixels packed (pixels; raw stores not counted).
    pub pixels_packed: u64,
    /// Fragments written to memory after merging (fragments).
    pub fragments_written: u64,
}

impl AbufferCounters {
    fn record(&mut self, n: usize) {
        if self.fragments_per_pixel.len() <= n {
            self.fragments_per_pixel.resize(n + 1, 0);
        }
        self.fragments_per_pixel[n] += 1;
    }

    /// Add another set of counters.
    pub fn add(&mut self, o: &AbufferCounters) {
        if self.fragments_per_pixel.len() < o.fragments_per_pixel.len() {
            self.fragments_per_pixel.resize(o.fragments_per_pixel.len(), 0);
        }
        for (a, b) in self.fragments_per_pixel.iter_mut().zip(&o.fragments_per_pixel) {
            *a += b;
        }
        self.forced_merges += o.forced_merges;
        self.pixels_packed += o.pixels_packed;
        self.fragments_written += o.fragments_written;
    }
}

/// One pixel as the packer writes it: fragment count and fragments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedPixel {
    count: u8,
    frags: [Fragment; MAX_SAMPLES_PER_PIXEL],
}

impl PackedPixel {
    /// The pixel's fragments, in packer order (masks are disjoint).
    pub fn fragments(&self) -> &[Fragment] {
        &self.frags[..self.count as usize]
    }

    /// Bytes the pixel occupies in memory: header plus fragments.
    pub fn bytes(&self) -> u64 {
        PIXEL_HEADER_BYTES + self.count as u64 * FRAGMENT_BYTES
    }

    /// The fragment covering sample `k`, if any (the unpacker's lookup).
    pub fn covering(&self, k: u32) -> Option<&Fragment> {
        self.fragments().iter().find(|f| f.covers(k))
    }
}

/// A fragment register of the packer while a pixel is being grouped:
/// fragment, colour sums, weight sum, sample count (wide accumulators,
/// f64 as in the golden model).
#[derive(Clone, Copy)]
struct Building {
    frag: Fragment,
    sum: [f64; 3],
    wsum: f64,
    count: u32,
}

const EMPTY_BUILDING: Building = Building { frag: EMPTY_FRAGMENT, sum: [0.0; 3], wsum: 0.0, count: 0 };

/// The packer: fragment registers reused from pixel to pixel.
#[derive(Clone)]
pub struct Packer {
    regs: [Building; MAX_SAMPLES_PER_PIXEL],
    /// The output register: the last pixel packed (fragments past its
    /// count are stale).
    out: PackedPixel,
}

impl Default for Packer {
    fn default() -> Self {
        Packer::new()
    }
}

impl Packer {
    /// A packer with cleared registers.
    pub fn new() -> Packer {
        Packer {
            regs: [EMPTY_BUILDING; MAX_SAMPLES_PER_PIXEL],
            out: PackedPixel { count: 0, frags: [EMPTY_FRAGMENT; MAX_SAMPLES_PER_PIXEL] },
        }
    }

    /// Pack one pixel (rules 1–3). `samples[k]` is sample `k` of the pixel
    /// (`ss²` entries, `None` = empty); `p.abuffer_fragments` must be at least 1.
    pub fn pack_pixel(
        &mut self,
        samples: &[Option<SampleIn>],
        p: &AbufferParams,
        c: &mut AbufferCounters,
    ) -> PackedPixel {
        let n = self.pack_in_place(samples, p, c).count as usize;
        let mut out = PackedPixel { count: n as u8, frags: [EMPTY_FRAGMENT; MAX_SAMPLES_PER_PIXEL] };
        out.frags[..n].copy_from_slice(&self.out.frags[..n]);
        out
    }

    /// [`Packer::pack_pixel`] into the packer's output register (the same
    /// fragments; no copy of the whole pixel).
    pub fn pack_in_place(
        &mut self,
        samples: &[Option<SampleIn>],
        p: &AbufferParams,
        c: &mut AbufferCounters,
    ) -> &PackedPixel {
        let ss = p.ss;
        assert!(p.abuffer_fragments >= 1, "the packer needs at least one fragment per pixel");
        assert!(samples.len() == (ss * ss) as usize && samples.len() <= MAX_SAMPLES_PER_PIXEL, "ss = {ss}");
        let regs = &mut self.regs;
        let mut n = 0usize;
        // Rule 1: one compare stage per sample.
        for (k, s) in samples.iter().enumerate() {
            let Some(s) = s else { continue };
            let (ox, oy) = sample_offset(ss, k as u32);
            let joins = |b: &Building| {
                let f = &b.frag;
                if f.real != s.real || f.key != s.key {
                    return false;
                }
                if !s.real {
                    return true;
                }
                let pred = f.inv_z_at(ss, k as u32) as f64;
                let tol = p.slope_tol * (f.slopes[0].abs() + f.slopes[1].abs()) as f64 + p.rel_tol * s.inv_z as f64;
                (pred - s.inv_z as f64).abs() <= tol
            };
            let idx = match regs[..n].iter().position(joins) {
                Some(i) => i,
                None => {
                    let (inv_z, slopes) = if s.real {
                        (s.inv_z - s.slopes[0] * ox - s.slopes[1] * oy, s.slopes)
                    } else {
                        (0.0, [0.0; 2])
                    };
                    regs[n] = Building {
                        frag: Fragment { inv_z, slopes, real: s.real, key: s.key, ..EMPTY_FRAGMENT },
                        ..EMPTY_BUILDING
                    };
                    n += 1;
                    n - 1
                }
            };
            let b = &mut regs[idx];
            b.frag.mask |= 1 << k;
            for (acc, v) in b.sum.iter_mut().zip(s.colour) {
                *acc += v as f64;
            }
            b.wsum += s.weight as f64;
            b.count += 1;
        }
        c.record(n);
        // Rule 3: forced merges.
        while n > p.abuffer_fragments as usize && n > 1 {
            let (i, j) = closest_pair(&regs[..n]);
            let b = regs[j];
            regs.copy_within(j + 1..n, j);
            n -= 1;
            let a = &mut regs[i];
            if b.count > a.count || (b.count == a.count && b.frag.inv_z > a.frag.inv_z) {
                a.frag.inv_z = b.frag.inv_z;
                a.frag.slopes = b.frag.slopes;
                a.frag.real = b.frag.real;
                a.frag.key = b.frag.key;
            }
            a.frag.mask |= b.frag.mask;
            for (acc, v) in a.sum.iter_mut().zip(b.sum) {
                *acc += v;
            }
            a.wsum += b.wsum;
            a.count += b.count;
            c.forced_merges += 1;
        }
        // Rule 2: the means, as written to memory.
        let out = &mut self.out;
        out.count = n as u8;
        for (o, b) in out.frags.iter_mut().zip(&regs[..n]) {
            let cnt = b.count as f64;
            *o = Fragment { colour: b.sum.map(|s| (s / cnt) as f32), weight: (b.wsum / cnt) as f32, ..b.frag };
        }
        c.pixels_packed += 1;
        c.fragments_written += n as u64;
        out
    }
}

/// The pair to merge (rule 3): smallest (kinds differ, keys differ,
/// |Δ 1/Z|), first pair in (i, j) order on ties.
fn closest_pair(regs: &[Building]) -> (usize, usize) {
    let mut best = (u8::MAX, u8::MAX, f64::INFINITY, 0usize, 0usize);
    for i in 0..regs.len() {
        for j in i + 1..regs.len() {
            let (a, b) = (&regs[i].frag, &regs[j].frag);
            let class = ((a.real != b.real) as u8, (a.key != b.key) as u8);
            let dz = (a.inv_z as f64 - b.inv_z as f64).abs();
            if class < (best.0, best.1) || (class == (best.0, best.1) && dz < best.2) {
                best = (class.0, class.1, dz, i, j);
            }
        }
    }
    (best.3, best.4)
}

/// Sample indices of pixel `(px, py)` in a row-major frame `width` samples
/// wide, in the pixel's raster order.
fn pixel_samples(width: u32, ss: u32, px: u32, py: u32) -> impl Iterator<Item = usize> {
    (0..ss * ss).map(move |k| {
        let (i, j) = sample_xy(ss, k);
        ((py * ss + j) as usize) * width as usize + (px * ss + i) as usize
    })
}

/// A reference frame in memory: fragments per pixel (or raw samples when
/// `abuffer_fragments == 0`).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedReference {
    /// Width of the frame (samples).
    width: u32,
    /// Height of the frame (samples).
    height: u32,
    /// Super-samples per pixel per axis.
    ss: u32,
    /// Fragment count per pixel (the headers), row-major over whole pixels.
    counts: Vec<u8>,
    /// Index in `frags` of each pixel's first fragment.
    first: Vec<u32>,
    /// All fragments, pixel after pixel.
    frags: Vec<Fragment>,
    /// The samples themselves when stored raw (`abuffer_fragments == 0`).
    raw: Option<SampleImage>,
}

/// Pack a reference frame (the conversion of renderer output to A-buffer
/// format): every whole pixel through the packer. With
/// `p.abuffer_fragments == 0` the samples are stored raw.
pub fn pack_reference(img: &SampleImage, p: &AbufferParams, c: &mut AbufferCounters) -> PackedReference {
    let (pw, ph) = (img.width / p.ss, img.height / p.ss);
    let mut out = PackedReference {
        width: img.width,
        height: img.height,
        ss: p.ss,
        counts: Vec::new(),
        first: Vec::new(),
        frags: Vec::new(),
        raw: None,
    };
    if p.abuffer_fragments == 0 {
        out.raw = Some(img.clone());
        return out;
    }
    out.counts.reserve((pw * ph) as usize);
    out.first.reserve((pw * ph) as usize);
    let mut packer = Packer::new();
    let mut samples = [None; MAX_SAMPLES_PER_PIXEL];
    let n = (p.ss * p.ss) as usize;
    for py in 0..ph {
        for px in 0..pw {
            for (s, i) in samples.iter_mut().zip(pixel_samples(img.width, p.ss, px, py)) {
                *s = img.valid[i].then(|| SampleIn {
                    colour: img.colour[i],
                    inv_z: 1.0 / img.z[i],
                    slopes: img.inv_z_slopes[i],
                    real: true,
                    key: img.object_id[i],
                    weight: 0.0,
                });
            }
            let packed = packer.pack_in_place(&samples[..n], p, c);
            out.first.push(out.frags.len() as u32);
            out.counts.push(packed.count);
            out.frags.extend_from_slice(packed.fragments());
        }
    }
    out
}

impl PackedReference {
    /// Width of the frame (samples).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of the frame (samples).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Width in whole pixels.
    pub fn width_pixels(&self) -> u32 {
        self.width / self.ss
    }

    /// Height in whole pixels.
    pub fn height_pixels(&self) -> u32 {
        self.height / self.ss
    }

    /// Super-samples per pixel per axis.
    pub fn ss(&self) -> u32 {
        self.ss
    }

    /// True if the samples are stored raw (`abuffer_fragments == 0`).
    pub fn is_raw(&self) -> bool {
        self.raw.is_some()
    }

    /// The fragments of pixel `(px, py)` (empty when stored raw).
    pub fn pixel_fragments(&self, px: u32, py: u32) -> &[Fragment] {
        if self.raw.is_some() {
            return &[];
        }
        let p = (py * self.width_pixels() + px) as usize;
        let f = self.first[p] as usize;
        &self.frags[f..f + self.counts[p] as usize]
    }

    /// Bytes of the half-open pixel rectangle `[px0, px1) x [py0, py1)` in
    /// memory (headers plus fragments, or raw samples), clipped to the
    /// frame's whole pixels.
    pub fn bytes_in_pixels(&self, px0: u32, py0: u32, px1: u32, py1: u32) -> u64 {
        let (pw, ph) = (self.width_pixels(), self.height_pixels());
        let (px1, py1) = (px1.min(pw), py1.min(ph));
        if px0 >= px1 || py0 >= py1 {
            return 0;
        }
        if self.raw.is_some() {
            let pixels = (px1 - px0) as u64 * (py1 - py0) as u64;
            return pixels * (self.ss * self.ss) as u64 * RAW_SAMPLE_BYTES;
        }
        let mut bytes = 0;
        for py in py0..py1 {
            let row = (py * pw) as usize;
            for &n in &self.counts[row + px0 as usize..row + px1 as usize] {
                bytes += PIXEL_HEADER_BYTES + n as u64 * FRAGMENT_BYTES;
            }
        }
        bytes
    }

    /// Bytes of the whole frame in memory.
    pub fn bytes(&self) -> u64 {
        self.bytes_in_pixels(0, 0, self.width_pixels(), self.height_pixels())
    }

    /// Expand every pixel back to samples (rules 4 and 5): what the warper
    /// reads. Equals the golden model's `round_trip_reference` bit for bit
    /// wherever rule 5 does not apply.
    pub fn unpack(&self) -> SampleImage {
        if let Some(raw) = &self.raw {
            return raw.clone();
        }
        let mut out = SampleImage::empty(self.width, self.height);
        self.for_each_sample(|x, y, s| {
            let i = out.index(x, y);
            out.colour[i] = s.colour;
            out.z[i] = s.z;
            out.inv_z_slopes[i] = s.slopes;
            out.object_id[i] = s.key;
            out.valid.set(i, true);
        });
        out
    }

    /// Every sample holding a surface, as [`PackedReference::unpack`]
    /// expands it, with its sample column and row: pixel after pixel (or
    /// row after row when stored raw). What a consumer that keeps only part
    /// of each sample reads, without the whole expanded image.
    pub fn for_each_sample(&self, f: impl FnMut(u32, u32, ExpandedSample)) {
        self.for_each_sample_in(0, 0, self.width_pixels(), self.height_pixels(), f);
    }

    /// Ask the host CPU to fetch the headers and fragments of the whole
    /// pixels `[px0, px1) x [py0, py1)` (a hint: no value changes). Host
    /// speed only: a block's rows lie far apart in memory, so expanding it
    /// otherwise misses the host's caches row after row, one at a time.
    pub fn prefetch_pixels(&self, px0: u32, py0: u32, px1: u32, py1: u32) {
        use crate::host_hint::prefetch;
        let (pw, ph) = (self.width_pixels(), self.height_pixels());
        let (px1, py1) = (px1.min(pw), py1.min(ph));
        if self.raw.is_some() || px0 >= px1 {
            return;
        }
        for py in py0..py1 {
            let (a, b) = ((py * pw + px0) as usize, (py * pw + px1 - 1) as usize);
            prefetch(&self.counts[a]);
            prefetch(&self.counts[b]);
            prefetch(&self.first[a]);
            prefetch(&self.first[b]);
        }
        for py in py0..py1 {
            let (a, b) = ((py * pw + px0) as usize, (py * pw + px1 - 1) as usize);
            let (f0, f1) = (self.first[a] as usize, self.first[b] as usize + self.counts[b] as usize);
            if let Some(frags) = self.frags.get(f0..f1) {
                let bytes = frags.as_ptr_range();
                let (mut p, end) = (bytes.start.cast::<u8>(), bytes.end.cast::<u8>());
                while p < end {
                    prefetch(p);
                    p = p.wrapping_add(64);
                }
            }
        }
    }

    /// [`PackedReference::for_each_sample`] over the whole pixels
    /// `[px0, px1) x [py0, py1)` only (clipped to the frame; when stored
    /// raw, the samples of those pixels, and of the partial pixels beyond
    /// the last whole one if the rectangle reaches it), pixel after pixel:
    /// a block of the reference expanded on its own.
    pub fn for_each_sample_in(
        &self,
        px0: u32,
        py0: u32,
        px1: u32,
        py1: u32,
        mut f: impl FnMut(u32, u32, ExpandedSample),
    ) {
        let ss = self.ss;
        let (px1, py1) = (px1.min(self.width_pixels()), py1.min(self.height_pixels()));
        if let Some(raw) = &self.raw {
            // Raw samples right of or below the last whole pixel belong to it.
            let end = |p1: u32, n: u32, pixels: u32| if p1 == pixels { n } else { p1 * ss };
            let (x1, y1) = (end(px1, self.width, self.width_pixels()), end(py1, self.height, self.height_pixels()));
            for y in py0 * ss..y1 {
                for x in px0 * ss..x1 {
                    let i = y as usize * self.width as usize + x as usize;
                    if raw.valid[i] {
                        let (colour, z, slopes, key) = (raw.colour[i], raw.z[i], raw.inv_z_slopes[i], raw.object_id[i]);
                        f(x, y, ExpandedSample { colour, z, slopes, key });
                    }
                }
            }
            return;
        }
        for py in py0..py1 {
            for px in px0..px1 {
                let frags = self.pixel_fragments(px, py);
                for k in 0..ss * ss {
                    let Some(fr) = frags.iter().find(|fr| fr.covers(k)) else { continue };
                    let z = reference_depth(fr.inv_z_at(ss, k));
                    let (i, j) = sample_xy(ss, k);
                    f(
                        px * ss + i,
                        py * ss + j,
                        ExpandedSample { colour: fr.colour, z, slopes: fr.slopes, key: fr.key },
                    );
                }
            }
        }
    }
}

/// One sample of a packed reference as the unpacker expands it
/// ([`PackedReference::for_each_sample`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExpandedSample {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Depth from the fragment's plane (rule 5).
    pub z: f32,
    /// Slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// The fragment's key (object id).
    pub key: u32,
}

/// Depth of an expanded reference sample from its plane's 1/Z (rule 5).
pub fn reference_depth(inv_z: f32) -> f32 {
    let z = 1.0 / inv_z;
    if z.is_finite() && z > 0.0 { z } else { FAR_Z }
}

/// Derived sample `i` of `frame` as the packer's input: `None` if it holds
/// neither a surface nor fill. The one conversion the A-buffer round trip
/// and the fallback pass's byte count share.
#[inline]
pub fn sample_in(frame: &DestFrame, i: usize) -> Option<SampleIn> {
    let real = bits::get(&frame.real, i);
    if !(real || bits::get(&frame.hole, i)) {
        return None;
    }
    let d = &frame.samples[i];
    Some(SampleIn {
        colour: d.colour,
        inv_z: d.inv_z,
        slopes: d.slopes,
        real,
        key: d.source as u32,
        weight: d.fill_weight,
    })
}

/// Write the destination pixels `[px0, px1) x [py0, py1)` (clipped to the
/// frame's whole pixels) back to memory in A-buffer format and read them
/// again: the memory planes (colour, 1/Z, slopes, source, hole, real,
/// hole-fill weight) of those pixels are rewritten in place as the golden
/// model's `round_trip_dest` does; cache-only planes are untouched.
/// Returns the bytes the pixels occupy in memory. With
/// `p.abuffer_fragments == 0` nothing changes and the bytes are the raw samples'.
///
/// Precondition (an invariant of the compositor and the hole fill): no
/// sample is both `real` and `hole`.
pub fn round_trip_dest_pixels(
    frame: &mut DestFrame,
    px0: u32,
    py0: u32,
    px1: u32,
    py1: u32,
    p: &AbufferParams,
    c: &mut AbufferCounters,
) -> u64 {
    let ss = p.ss;
    let (px1, py1) = (px1.min(frame.width / ss), py1.min(frame.height / ss));
    if px0 >= px1 || py0 >= py1 {
        return 0;
    }
    if p.abuffer_fragments == 0 {
        return (px1 - px0) as u64 * (py1 - py0) as u64 * (ss * ss) as u64 * RAW_SAMPLE_BYTES;
    }
    let n = (ss * ss) as usize;
    let mut packer = Packer::new();
    let mut samples = [None; MAX_SAMPLES_PER_PIXEL];
    let mut idx = [0usize; MAX_SAMPLES_PER_PIXEL];
    let mut bytes = 0;
    for py in py0..py1 {
        // Host speed only: the next row of pixels' samples, ahead.
        for r in 0..ss {
            let i = frame.index(px0 * ss, (py + 1) * ss + r);
            frame.prefetch_run(i..i + ((px1 - px0) * ss) as usize);
        }
        for px in px0..px1 {
            for (k, i) in pixel_samples(frame.width, ss, px, py).enumerate() {
                idx[k] = i;
                samples[k] = sample_in(frame, i);
            }
            let packed = packer.pack_in_place(&samples[..n], p, c);
            bytes += packed.bytes();
            // Unpack at once: pixels do not overlap.
            for (k, &i) in idx[..n].iter().enumerate() {
                match packed.covering(k as u32) {
                    None => {
                        bits::put(&mut frame.real, i, false);
                        bits::put(&mut frame.hole, i, false);
                    }
                    Some(f) => {
                        let d = &mut frame.samples[i];
                        d.colour = f.colour;
                        d.inv_z = if f.real { f.inv_z_at(ss, k as u32) } else { 0.0 };
                        d.slopes = f.slopes;
                        d.source = f.key as u8;
                        d.fill_weight = f.weight;
                        bits::put(&mut frame.real, i, f.real);
                        bits::put(&mut frame.hole, i, !f.real);
                    }
                }
            }
        }
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(n: u32) -> AbufferParams {
        AbufferParams { ss: 2, abuffer_fragments: n, slope_tol: 2.0, rel_tol: 0.01 }
    }

    fn real(inv_z: f32, key: u32, colour: f32) -> Option<SampleIn> {
        Some(SampleIn { colour: [colour; 3], inv_z, slopes: [0.0; 2], real: true, key, weight: 0.0 })
    }

    #[test]
    fn four_flat_surfaces_merge_the_two_closest_into_the_larger() {
        let mut c = AbufferCounters::default();
        let px = Packer::new().pack_pixel(
            &[real(0.1, 1, 0.0), real(0.5, 1, 1.0), real(0.52, 1, 0.5), real(0.9, 1, 0.25)],
            &params(3),
            &mut c,
        );
        assert_eq!(c.fragments_per_pixel, vec![0, 0, 0, 0, 1]);
        assert_eq!((c.forced_merges, c.pixels_packed, c.fragments_written), (1, 1, 3));
        let f = px.fragments();
        assert_eq!(f.len(), 3);
        // Samples 1 and 2 merged (|Δ| = 0.02): equal counts, the nearer plane.
        assert_eq!(f[1].mask, 0b0110);
        assert_eq!(f[1].inv_z, 0.52);
        assert_eq!(f[1].colour, [0.75; 3]);
        assert_eq!(px.bytes(), PIXEL_HEADER_BYTES + 3 * FRAGMENT_BYTES);
        assert_eq!(px.covering(2).map(|f| f.mask), Some(0b0110));
    }

    #[test]
    fn hole_fill_samples_of_one_source_form_one_fragment() {
        let hole =
            |w: f32| Some(SampleIn { colour: [w; 3], inv_z: 7.0, slopes: [1.0; 2], real: false, key: 0, weight: w });
        let mut c = AbufferCounters::default();
        let px = Packer::new().pack_pixel(&[hole(1.0), None, hole(0.5), real(0.2, 0, 0.0)], &params(3), &mut c);
        let f = px.fragments();
        assert_eq!(f.len(), 2);
        assert_eq!((f[0].mask, f[0].real, f[0].inv_z, f[0].slopes, f[0].weight), (0b0101, false, 0.0, [0.0; 2], 0.75));
        assert_eq!(px.covering(1), None);
    }

    #[test]
    fn a_plane_past_the_horizon_is_far() {
        assert_eq!(reference_depth(0.5), 2.0);
        assert_eq!(reference_depth(-0.5), FAR_Z);
        assert_eq!(reference_depth(0.0), FAR_Z);
        assert_eq!(reference_depth(f32::MIN_POSITIVE / 4.0), FAR_Z);
        assert_eq!(reference_depth(f32::NAN), FAR_Z);
    }
}
