//! Property tests of the A-buffer: the hardware packer/unpacker
//! (`postwarp_rtl::units::abuffer`) and the golden model's A-buffer
//! (`postwarp::golden::abuffer`), on random pixels at 1, 2, 3 and 4
//! super-samples per axis (traces allow 1 to 4).
//!
//! What a *surface* is here (rule 1 of both files, the grouping): the
//! samples one fragment takes before any forced merge. A hole-fill sample
//! joins the first fragment of hole fill with the same key (source), so all
//! hole-fill samples of one source in a pixel are one surface. A real sample
//! joins the first real fragment with the same key whose plane (anchored at
//! that fragment's first sample: its 1/Z carried back to the pixel centre
//! along its slopes) predicts the sample's 1/Z within
//! `slope_tol·(|∂x| + |∂y|) + rel_tol·1/Z`. So a real surface is a set of
//! samples of one key lying on one 1/Z plane (with that plane's slopes) and
//! far enough in 1/Z from any other surface of that key. Grouping is in the
//! pixel's raster order (sample `k = j·ss + i`); the code promises no
//! independence from that order (the first sample anchors the plane, and
//! merges break ties to the lowest indices), so the order-related property
//! tested is the one it does promise: fragments come out sorted by their
//! first sample, and the result depends on nothing but the pixel's samples.

use crate::common;

use postwarp::golden::abuffer as golden;
use postwarp::golden::planes::DestPlanes;
use postwarp_rtl::units::abuffer::{
    AbufferCounters, AbufferParams, FAR_Z, FRAGMENT_BYTES, Fragment, PIXEL_HEADER_BYTES, Packer, RAW_SAMPLE_BYTES,
    SampleIn, pack_reference, round_trip_dest_pixels, sample_offset,
};
use postwarp_rtl::{DestFrame, SampleImage};
use proptest::prelude::*;

const SLOPE_TOL: f64 = 2.0;
const REL_TOL: f64 = 0.01;

fn params(ss: u32, abuffer_fragments: u32) -> AbufferParams {
    AbufferParams { ss, abuffer_fragments, slope_tol: SLOPE_TOL, rel_tol: REL_TOL }
}

fn golden_params(p: &AbufferParams) -> golden::AbufferParams {
    golden::AbufferParams {
        ss: p.ss,
        abuffer_fragments: p.abuffer_fragments,
        slope_tol: p.slope_tol,
        rel_tol: p.rel_tol,
    }
}

fn ss() -> impl Strategy<Value = u32> {
    prop_oneof![2 => Just(1u32), 3 => Just(2), 1 => Just(3), 2 => Just(4)]
}

// ---------------------------------------------------------------------------
// Arbitrary samples: planes shared by several samples, some samples off their
// plane by a little or a lot, hole fill from several sources, empty samples,
// ties in 1/Z, occasional 1/Z <= 0 (derived frames: beyond everything).

/// A plane a sample may lie on: 1/Z at the pixel centre, slopes, key.
#[derive(Clone, Copy, Debug)]
struct Plane {
    inv_z: f32,
    slopes: [f32; 2],
    key: u32,
}

fn plane() -> impl Strategy<Value = Plane> {
    let inv_z = prop_oneof![1 => Just(0.25f32), 6 => 0.02f32..1.5, 1 => -0.05f32..0.0];
    let slopes = prop_oneof![1 => Just([0.0f32; 2]), 2 => prop::array::uniform2(-0.02f32..0.02), 1 => prop::array::uniform2(-0.3f32..0.3)];
    (inv_z, slopes, 0u32..3).prop_map(|(inv_z, slopes, key)| Plane { inv_z, slopes, key })
}

/// One sample before it is placed: which plane (index modulo the planes),
/// how far off it, colour, weight; or hole fill; or empty.
#[derive(Clone, Copy, Debug)]
enum Spec {
    Empty,
    Real { plane: usize, off: f32, colour: [f32; 3], weight: f32 },
    Hole { key: u32, colour: [f32; 3], weight: f32, inv_z: f32 },
}

fn spec() -> impl Strategy<Value = Spec> {
    let colour = prop::array::uniform3(0.0f32..1.0);
    let off = prop_oneof![6 => Just(0.0f32), 1 => 0.0f32..1e-3, 1 => -0.3f32..0.3];
    prop_oneof![
        1 => Just(Spec::Empty),
        6 => (0usize..8, off, colour.clone(), prop_oneof![Just(0.0f32), 0.0f32..2.0])
            .prop_map(|(plane, off, colour, weight)| Spec::Real { plane, off, colour, weight }),
        2 => (0u32..3, colour, 0.0f32..2.0, 0.0f32..1.0)
            .prop_map(|(key, colour, weight, inv_z)| Spec::Hole { key, colour, weight, inv_z }),
    ]
}

/// The sample `spec` becomes at offset `(ox, oy)` from its pixel centre.
fn sample_in(spec: Spec, planes: &[Plane], (ox, oy): (f32, f32)) -> Option<SampleIn> {
    match spec {
        Spec::Empty => None,
        Spec::Real { plane, off, colour, weight } => {
            let p = planes[plane % planes.len()];
            let inv_z = p.inv_z + p.slopes[0] * ox + p.slopes[1] * oy + off;
            Some(SampleIn { colour, inv_z, slopes: p.slopes, real: true, key: p.key, weight })
        }
        Spec::Hole { key, colour, weight, inv_z } => {
            Some(SampleIn { colour, inv_z, slopes: [0.0; 2], real: false, key, weight })
        }
    }
}

/// One pixel of arbitrary samples and a fragment limit (1 to 4, or 16).
fn pixel() -> impl Strategy<Value = (u32, u32, Vec<Option<SampleIn>>)> {
    (ss(), prop_oneof![4 => 1u32..=4, 1 => Just(16u32)]).prop_flat_map(|(ss, max)| {
        let n = (ss * ss) as usize;
        (prop::collection::vec(plane(), 1..6), prop::collection::vec(spec(), n)).prop_map(move |(planes, specs)| {
            let samples =
                specs.iter().enumerate().map(|(k, &s)| sample_in(s, &planes, sample_offset(ss, k as u32))).collect();
            (ss, max, samples)
        })
    })
}

/// A frame of `pw x ph` pixels of arbitrary samples, as golden planes.
fn dest_frame() -> impl Strategy<Value = (AbufferParams, DestPlanes)> {
    (ss(), 1u32..=4, 1u32..=3, prop_oneof![1 => Just(0u32), 6 => 1u32..=4, 1 => Just(16u32)]).prop_flat_map(
        |(ss, pw, ph, max)| {
            let n = (pw * ph * ss * ss) as usize;
            (prop::collection::vec(plane(), 1..6), prop::collection::vec(spec(), n)).prop_map(move |(planes, specs)| {
                let (w, h) = (pw * ss, ph * ss);
                let mut d = DestPlanes::new(w, h);
                for (i, &s) in specs.iter().enumerate() {
                    let (x, y) = (i as u32 % w, i as u32 / w);
                    let c = (ss as f32 - 1.0) / 2.0;
                    let o = ((x % ss) as f32 - c, (y % ss) as f32 - c);
                    // Cache-only planes: the A-buffer must leave them alone.
                    d.fill_colour[i] = [i as f32 / 7.0; 3];
                    d.fill_valid.set(i, i % 3 == 0);
                    d.fill_distance[i] = (i % 9) as u8;
                    let Some(s) = sample_in(s, &planes, o) else { continue };
                    d.colour[i] = s.colour;
                    d.inv_z[i] = s.inv_z;
                    d.slopes[i] = s.slopes;
                    d.source[i] = s.key as u8;
                    d.real.set(i, s.real);
                    d.hole.set(i, !s.real);
                    d.fill_weight[i] = s.weight;
                }
                (params(ss, max), d)
            })
        },
    )
}

/// Sample indices where a hardware frame and golden planes differ in any bit.
fn dest_diffs(a: &DestFrame, b: &DestPlanes) -> Vec<usize> {
    (0..a.len())
        .filter(|&i| {
            a.samples[i].colour.map(f32::to_bits) != b.colour[i].map(f32::to_bits)
                || a.samples[i].inv_z.to_bits() != b.inv_z[i].to_bits()
                || a.samples[i].slopes.map(f32::to_bits) != b.slopes[i].map(f32::to_bits)
                || a.samples[i].source != b.source[i]
                || a.hole[i] != b.hole[i]
                || a.real[i] != b.real[i]
                || a.samples[i].fill_colour.map(f32::to_bits) != b.fill_colour[i].map(f32::to_bits)
                || a.fill_valid[i] != b.fill_valid[i]
                || a.samples[i].fill_distance != b.fill_distance[i]
                || a.samples[i].fill_weight.to_bits() != b.fill_weight[i].to_bits()
        })
        .collect()
}

/// Every bit of a fragment.
fn bits(f: &Fragment) -> ([u32; 3], u32, [u32; 2], u16, bool, u32, u32) {
    (
        f.colour.map(f32::to_bits),
        f.inv_z.to_bits(),
        f.slopes.map(f32::to_bits),
        f.mask,
        f.real,
        f.key,
        f.weight.to_bits(),
    )
}

fn pack(samples: &[Option<SampleIn>], p: &AbufferParams) -> (Vec<Fragment>, AbufferCounters, u64) {
    let mut c = AbufferCounters::default();
    let px = Packer::new().pack_pixel(samples, p, &mut c);
    (px.fragments().to_vec(), c, px.bytes())
}

// ---------------------------------------------------------------------------
// Distinct surfaces with exact arithmetic: 1/Z, slopes, colours and weights
// are multiples of 1/1024 or 1/256 with few bits, so every plane evaluation
// and every mean of equal values is exact in f32, and a surface's expansion
// gives back its samples bit for bit.

/// A surface: real on a plane of its own band of 1/Z, or hole fill of a key.
#[derive(Clone, Copy, Debug)]
struct Surface {
    real: bool,
    key: u32,
    /// 1/Z at the pixel centre within the band (1/1024 units).
    band_offset: i32,
    /// Slopes (1/1024 units).
    slopes: [i32; 2],
    colour: [u8; 3],
    weight: u8,
}

fn surface() -> impl Strategy<Value = Surface> {
    (prop::bool::weighted(0.75), 0u32..3, 0i32..64, prop::array::uniform2(-4i32..=4), any::<[u8; 3]>(), any::<u8>())
        .prop_map(|(real, key, band_offset, slopes, colour, weight)| Surface {
            real,
            key,
            band_offset,
            slopes,
            colour,
            weight,
        })
}

/// A pixel made of distinct surfaces: `(ss, limit, samples, surface of each
/// sample)`. Hole-fill surfaces of one key are one surface (rule 1), so a
/// hole surface takes the values of the first hole surface with its key.
/// Real surface `r` (in order of appearance among the real ones) lies in the
/// band 1/Z ∈ [0.25 + 0.25·r, 0.25 + 0.25·r + 1/16) at the centre: bands are
/// further apart than the tolerance (at most 2·8/1024 + 0.01·1.3) plus the
/// planes' swing from the centre over a 4x4 pixel (at most 1.5·(4 + 4)/1024
/// each), so no real sample
/// joins another surface's fragment, whatever the keys.
fn surfaces_pixel() -> impl Strategy<Value = (u32, u32, Vec<Option<SampleIn>>, Vec<Option<usize>>)> {
    (ss(), 1u32..=4, prop::collection::vec(surface(), 1..=5)).prop_flat_map(|(ss, max, surfaces)| {
        let n = (ss * ss) as usize;
        let slot = prop_oneof![1 => Just(None), 5 => (0..surfaces.len()).prop_map(Some)];
        prop::collection::vec(slot, n).prop_map(move |slots| {
            // Canonical surface of each generated one.
            let canon: Vec<usize> = (0..surfaces.len())
                .map(|s| {
                    if surfaces[s].real {
                        s
                    } else {
                        (0..=s).find(|&t| !surfaces[t].real && surfaces[t].key == surfaces[s].key).unwrap()
                    }
                })
                .collect();
            let band = |s: usize| surfaces[..s].iter().filter(|t| t.real).count() as i32;
            let mut samples = Vec::with_capacity(n);
            let mut which = Vec::with_capacity(n);
            for (k, slot) in slots.iter().enumerate() {
                let Some(s) = slot.map(|s| canon[s]) else {
                    samples.push(None);
                    which.push(None);
                    continue;
                };
                let sf = surfaces[s];
                let colour = sf.colour.map(|c| c as f32 / 256.0);
                let weight = sf.weight as f32 / 256.0;
                let sample = if sf.real {
                    let centre = (256 + 256 * band(s) + sf.band_offset) as f32 / 1024.0;
                    let slopes = sf.slopes.map(|v| v as f32 / 1024.0);
                    let (ox, oy) = sample_offset(ss, k as u32);
                    let inv_z = centre + slopes[0] * ox + slopes[1] * oy;
                    SampleIn { colour, inv_z, slopes, real: true, key: sf.key, weight }
                } else {
                    SampleIn { colour, inv_z: 0.0, slopes: [0.0; 2], real: false, key: sf.key, weight }
                };
                samples.push(Some(sample));
                which.push(Some(s));
            }
            (ss, max, samples, which)
        })
    })
}

/// The packer's expansion of pixel `frags` at sample `k` (rule 4), as the
/// destination round trip writes it: hole fill at 1/Z = 0.
fn expand(frags: &[Fragment], ss: u32, k: u32) -> Option<SampleIn> {
    let f = frags.iter().find(|f| f.covers(k))?;
    let inv_z = if f.real { f.inv_z_at(ss, k) } else { 0.0 };
    Some(SampleIn { colour: f.colour, inv_z, slopes: f.slopes, real: f.real, key: f.key, weight: f.weight })
}

/// Every bit of a sample: colour, 1/Z, slopes, kind, key, weight.
type SampleBits = ([u32; 3], u32, [u32; 2], bool, u32, u32);

fn sample_bits(s: &Option<SampleIn>) -> Option<SampleBits> {
    s.map(|s| {
        (s.colour.map(f32::to_bits), s.inv_z.to_bits(), s.slopes.map(f32::to_bits), s.real, s.key, s.weight.to_bits())
    })
}

/// A one-pixel golden frame holding `samples`.
fn planes_of(ss: u32, samples: &[Option<SampleIn>]) -> DestPlanes {
    let mut d = DestPlanes::new(ss, ss);
    for (i, s) in samples.iter().enumerate() {
        let Some(s) = s else { continue };
        d.colour[i] = s.colour;
        d.inv_z[i] = s.inv_z;
        d.slopes[i] = s.slopes;
        d.source[i] = s.key as u8;
        d.real.set(i, s.real);
        d.hole.set(i, !s.real);
        d.fill_weight[i] = s.weight;
    }
    d
}

// ---------------------------------------------------------------------------

/// A reference frame of `pw x ph` pixels (arbitrary real samples, object ids
/// as keys), as a sample image.
fn reference_frame() -> impl Strategy<Value = (AbufferParams, SampleImage)> {
    dest_frame().prop_map(|(p, d)| {
        let mut img = SampleImage::empty(d.width, d.height);
        for i in 0..d.inv_z.len() {
            if d.real[i] && d.inv_z[i] > 0.0 {
                img.z[i] = 1.0 / d.inv_z[i];
                img.colour[i] = d.colour[i];
                img.inv_z_slopes[i] = d.slopes[i];
                img.object_id[i] = d.source[i] as u32 + 1;
                img.valid.set(i, true);
            }
        }
        (p, img)
    })
}

proptest! {
    #![proptest_config(common::prop_config(512))]

    /// At most `abuffer_fragments` fragments per pixel, exactly
    /// `min(needed, max)`; one forced merge per fragment over the limit; the
    /// masks partition the covered samples (disjoint, non-empty, union =
    /// the non-empty samples); fragments sorted by their first sample;
    /// bytes = header + fragments; every fragment carries the kind and key
    /// of a sample it covers (of all of them without a merge); colours
    /// are coverage-weighted means (the pixel's colour sum is kept).
    #[test]
    fn fragments_are_bounded_and_partition_the_covered_samples((ss, max, samples) in pixel()) {
        let p = params(ss, max);
        let (frags, c, bytes) = pack(&samples, &p);
        let needed = c.fragments_per_pixel.len() - 1;
        prop_assert_eq!(c.fragments_per_pixel[needed], 1);
        prop_assert_eq!(c.fragments_per_pixel.iter().sum::<u64>(), 1);
        prop_assert!(frags.len() <= max as usize);
        prop_assert_eq!(frags.len(), needed.min(max as usize));
        prop_assert_eq!(c.forced_merges as usize, needed - frags.len());
        prop_assert_eq!((c.pixels_packed, c.fragments_written), (1, frags.len() as u64));
        prop_assert_eq!(bytes, PIXEL_HEADER_BYTES + frags.len() as u64 * FRAGMENT_BYTES);

        let covered = samples.iter().enumerate().fold(0u16, |m, (k, s)| m | (s.is_some() as u16) << k);
        let mut union = 0u16;
        for f in &frags {
            prop_assert!(f.mask != 0, "empty fragment");
            prop_assert_eq!(union & f.mask, 0, "masks overlap");
            union |= f.mask;
        }
        prop_assert_eq!(union, covered);
        prop_assert!(frags.windows(2).all(|w| w[0].mask.trailing_zeros() < w[1].mask.trailing_zeros()), "order");

        let mut sum = [0f64; 3];
        let mut kept = [0f64; 3];
        for (k, s) in samples.iter().enumerate() {
            if let Some(s) = s {
                for (acc, v) in sum.iter_mut().zip(s.colour) {
                    *acc += v as f64;
                }
            }
            let e = expand(&frags, ss, k as u32);
            prop_assert_eq!(e.is_some(), s.is_some(), "sample {} coverage", k);
            if let Some(e) = e {
                for (acc, v) in kept.iter_mut().zip(e.colour) {
                    *acc += v as f64;
                }
            }
        }
        for ch in 0..3 {
            prop_assert!((sum[ch] - kept[ch]).abs() <= 1e-6 * (1.0 + sum[ch]), "colour sum {} vs {}", sum[ch], kept[ch]);
        }
        for f in &frags {
            let mine = |k: usize| samples[k].is_some_and(|s| s.real == f.real && s.key == f.key);
            let ks: Vec<usize> = (0..samples.len()).filter(|&k| f.covers(k as u32)).collect();
            prop_assert!(ks.iter().any(|&k| mine(k)), "fragment kind/key from none of its samples");
            if needed <= max as usize {
                prop_assert!(ks.iter().all(|&k| mine(k)), "a sample grouped with another kind or key");
            }
        }
    }

    /// expand(compress(x)) == x bit for bit, in the packer, in the hardware
    /// destination round trip and in the golden one, exactly when the pixel
    /// holds at most `abuffer_fragments` distinct surfaces (module doc); the
    /// fragments are then the surfaces, in order of their first sample,
    /// with no merge. With more surfaces than the limit, merges happen and
    /// the round trip changes the pixel.
    #[test]
    fn at_most_the_limit_of_distinct_surfaces_round_trips_exactly((ss, max, samples, which) in surfaces_pixel()) {
        let p = params(ss, max);
        let mut surfaces: Vec<usize> = Vec::new();
        for s in which.iter().flatten() {
            if !surfaces.contains(s) {
                surfaces.push(*s);
            }
        }
        let (frags, c, _) = pack(&samples, &p);
        prop_assert_eq!(c.fragments_per_pixel.len() - 1, surfaces.len(), "one fragment per surface before merging");
        let n = samples.len() as u32;
        let expanded: Vec<_> = (0..n).map(|k| expand(&frags, ss, k)).collect();
        let exact = expanded.iter().map(sample_bits).eq(samples.iter().map(sample_bits));
        let fits = surfaces.len() <= max as usize;
        prop_assert_eq!(exact, fits, "{} surfaces, limit {}", surfaces.len(), max);
        if fits {
            prop_assert_eq!(c.forced_merges, 0);
            for (f, s) in frags.iter().zip(&surfaces) {
                let mask = which.iter().enumerate().fold(0u16, |m, (k, w)| m | ((*w == Some(*s)) as u16) << k);
                prop_assert_eq!(f.mask, mask);
            }
        }
        // The same through the frame-level round trips, hardware and golden.
        let d = planes_of(ss, &samples);
        let mut hw = common::dest_frame(&d);
        round_trip_dest_pixels(&mut hw, 0, 0, 1, 1, &p, &mut AbufferCounters::default());
        let mut gd = d.clone();
        golden::round_trip_dest(&mut gd, &golden_params(&p), &mut golden::AbufferStats::default());
        prop_assert_eq!(dest_diffs(&hw, &gd), Vec::<usize>::new(), "hardware vs golden");
        prop_assert_eq!(dest_diffs(&hw, &d).is_empty(), fits, "hardware round trip exact iff it fits");
    }

    /// Same input, same bytes: a fresh packer and one reused after other
    /// pixels give the same fragments bit for bit (the registers carry
    /// nothing over), and so do two calls in a row.
    #[test]
    fn packing_is_deterministic((ss, max, samples) in pixel(), (_, _, other) in pixel()) {
        let p = params(ss, max);
        let (a, ca, _) = pack(&samples, &p);
        let mut reused = Packer::new();
        let mut c = AbufferCounters::default();
        if other.len() == samples.len() {
            reused.pack_pixel(&other, &p, &mut c);
        }
        let full = SampleIn { colour: [9.0; 3], inv_z: 3.0, slopes: [1.0; 2], real: true, key: 7, weight: 5.0 };
        reused.pack_pixel(&vec![Some(full); samples.len()], &p, &mut c);
        let mut cb = AbufferCounters::default();
        let b = reused.pack_pixel(&samples, &p, &mut cb);
        prop_assert_eq!(a.iter().map(bits).collect::<Vec<_>>(), b.fragments().iter().map(bits).collect::<Vec<_>>());
        prop_assert_eq!(ca, cb);
        let (again, _, _) = pack(&samples, &p);
        prop_assert_eq!(a.iter().map(bits).collect::<Vec<_>>(), again.iter().map(bits).collect::<Vec<_>>());
    }

    /// The hardware destination round trip equals the golden one bit for
    /// bit on every plane (cache-only planes untouched), with the same
    /// counters, over the whole frame and tile by tile (2x2-pixel
    /// rectangles, overhanging the border); bytes are headers plus
    /// fragments (or raw samples without an A-buffer).
    #[test]
    fn hardware_destination_round_trip_equals_golden((p, d) in dest_frame()) {
        let mut want = d.clone();
        let mut gs = golden::AbufferStats::default();
        golden::round_trip_dest(&mut want, &golden_params(&p), &mut gs);
        let (pw, ph) = (d.width / p.ss, d.height / p.ss);

        let mut whole = common::dest_frame(&d);
        let mut c = AbufferCounters::default();
        let bytes = round_trip_dest_pixels(&mut whole, 0, 0, pw, ph, &p, &mut c);
        prop_assert_eq!(dest_diffs(&whole, &want), Vec::<usize>::new());
        prop_assert_eq!(&c.fragments_per_pixel, &gs.fragments_per_pixel);
        prop_assert_eq!(c.forced_merges, gs.forced_merges);
        if p.abuffer_fragments == 0 {
            prop_assert_eq!(bytes, (pw * ph * p.ss * p.ss) as u64 * RAW_SAMPLE_BYTES);
            prop_assert_eq!(dest_diffs(&whole, &d), Vec::<usize>::new(), "no A-buffer: nothing changes");
        } else {
            prop_assert_eq!(bytes, (pw * ph) as u64 * PIXEL_HEADER_BYTES + c.fragments_written * FRAGMENT_BYTES);
        }

        let mut tiled = common::dest_frame(&d);
        let mut ct = AbufferCounters::default();
        let mut tile_bytes = 0;
        for ty in (0..ph).step_by(2) {
            for tx in (0..pw).step_by(2) {
                tile_bytes += round_trip_dest_pixels(&mut tiled, tx, ty, tx + 2, ty + 2, &p, &mut ct);
            }
        }
        prop_assert_eq!(dest_diffs(&tiled, &want), Vec::<usize>::new());
        prop_assert_eq!((ct, tile_bytes), (c, bytes));
    }

    /// Reference frames: unpack(pack) equals golden `round_trip_reference`
    /// bit for bit, with the same counters, including the samples of rule 5
    /// (the plane reaches 1/Z <= 0 or a reciprocal that overflows at the
    /// sample), which both put at FAR_Z. Invalid samples stay invalid,
    /// valid ones valid.
    #[test]
    fn hardware_reference_round_trip_equals_golden((p, img) in reference_frame()) {
        let mut gs = golden::AbufferStats::default();
        let want = golden::round_trip_reference(&img, &golden_params(&p), &mut gs);
        let mut c = AbufferCounters::default();
        let packed = pack_reference(&img, &p, &mut c);
        let got = packed.unpack();
        prop_assert_eq!(&c.fragments_per_pixel, &gs.fragments_per_pixel);
        prop_assert_eq!(c.forced_merges, gs.forced_merges);
        prop_assert_eq!(&got.valid, &img.valid);
        prop_assert_eq!(&want.valid, &img.valid);
        let ss = p.ss;
        for py in 0..img.height / ss {
            for px in 0..img.width / ss {
                let frags = packed.pixel_fragments(px, py);
                let g = golden::compress_reference_pixel(&img, px, py, &golden_params(&p));
                if p.abuffer_fragments > 0 {
                    prop_assert!(golden::masks_partition(&g, golden::valid_mask(&img.valid, img.width, px, py, ss)));
                    prop_assert_eq!(frags.len(), g.len());
                }
                for k in 0..ss * ss {
                    let i = img.index(px * ss + k % ss, py * ss + k / ss);
                    let same = got.colour[i].map(f32::to_bits) == want.colour[i].map(f32::to_bits)
                        && got.inv_z_slopes[i].map(f32::to_bits) == want.inv_z_slopes[i].map(f32::to_bits)
                        && got.object_id[i] == want.object_id[i]
                        && got.z[i].to_bits() == want.z[i].to_bits();
                    prop_assert!(same, "sample {} differs", i);
                    // Rule 5: a plane past the horizon puts the sample at the far limit.
                    if let Some(f) = frags.iter().find(|f| f.covers(k)) {
                        let z = 1.0 / f.inv_z_at(ss, k);
                        prop_assert!(z.is_finite() && z > 0.0 || got.z[i] == FAR_Z, "sample {}: rule 5", i);
                    }
                }
            }
        }
    }
}
