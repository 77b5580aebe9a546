//! Property suite: the rasterizer (`docs/invariants.md`, "Rasterizer").
//!
//! The golden rasterizer (`postwarp::golden::raster::rect`) and the
//! hardware stamp (`postwarp_rtl::units::raster::rect`) are checked
//! against a brute-force count of the sample centres inside the half-open
//! box, and against each other, on random boxes: continuous, on the
//! sample grid (where half-openness decides), empty, inverted and huge.

use postwarp::golden::config::OverLimit;
use postwarp::golden::raster;
use postwarp_rtl::DestFrame;
use postwarp_rtl::units::composite::{Candidate, Verdict, composite};
use postwarp_rtl::units::raster::rect;
use proptest::prelude::*;
use std::collections::BTreeSet;

use crate::common;

/// A box edge: anywhere, on a sample centre, or half-way between centres.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![-12.0f64..44.0, (-12i32..44).prop_map(f64::from), (-24i32..88).prop_map(|k| k as f64 / 2.0)]
}

/// A box `(x0, x1, y0, y1)`, the warped sample position, the stamp side and
/// the image size. Boxes are up to 9 samples wide, sometimes empty or
/// inverted (`x1 < x0`).
/// `(x0, x1, y0, y1)`.
type Box4 = (f64, f64, f64, f64);

fn case() -> impl Strategy<Value = (Box4, (f64, f64), u32, (u32, u32))> {
    let side = prop_oneof![0.0f64..9.0, (0i32..9).prop_map(f64::from), Just(-1.0)];
    (coord(), side.clone(), coord(), side, 0.0f64..1.0, 0.0f64..1.0, 1u32..7, 1u32..40, 1u32..40).prop_map(
        |(x0, wx, y0, wy, fx, fy, limit, w, h)| {
            let b = (x0, x0 + wx, y0, y0 + wy);
            (b, (x0 + fx * wx, y0 + fy * wy), limit, (w, h))
        },
    )
}

/// Brute force: centres `(i, j)` of a `size` image with `x0 <= i < x1`,
/// `y0 <= j < y1`.
fn inside(b: Box4, size: (u32, u32)) -> BTreeSet<(u32, u32)> {
    let mut s = BTreeSet::new();
    for j in 0..size.1 {
        for i in 0..size.0 {
            let (x, y) = (i as f64, j as f64);
            if b.0 <= x && x < b.1 && b.2 <= y && y < b.3 {
                s.insert((i, j));
            }
        }
    }
    s
}

/// Centres on one axis inside `[lo, hi)`, with no image (for the kernel size).
fn count_axis(lo: f64, hi: f64) -> u32 {
    let first = lo.ceil() as i64;
    let mut n = 0;
    let mut c = first;
    while (c as f64) < hi {
        n += 1;
        c += 1;
    }
    n
}

proptest! {
    #![proptest_config(common::prop_config(2000))]

    /// Unclipped (`OverLimit::Allow`), the golden rectangle covers exactly
    /// the centres inside the half-open box and inside the image.
    #[test]
    fn covers_exactly_the_centres_inside_the_half_open_box((b, c, limit, size) in case()) {
        let r = raster::rect(b.0, b.1, b.2, b.3, c, limit, OverLimit::Allow, size);
        let mut got = BTreeSet::new();
        r.for_each(|x, y| { got.insert((x, y)); });
        prop_assert_eq!(&got, &inside(b, size));
        prop_assert_eq!(r.size, (count_axis(b.0, b.1), count_axis(b.2, b.3)));
        prop_assert_eq!(r.over_limit, r.size.0 > limit || r.size.1 > limit);
    }

    /// Clipped (the hardware's stamp): at most `limit²` centres (16 for the
    /// 4x4 stamp), all inside the box; the whole box when it fits; else on
    /// each axis a window of exactly `limit` consecutive centres (before
    /// the image clips it) holding the centre nearest the warped sample.
    #[test]
    fn the_stamp_draws_at_most_limit_squared_centres_of_the_box((b, c, limit, size) in case()) {
        let s = rect(b.0, b.1, b.2, b.3, c, limit, size);
        let mut got = BTreeSet::new();
        s.for_each(|x, y| { got.insert((x, y)); });
        let all = inside(b, size);
        prop_assert!(got.len() as u32 <= limit * limit);
        prop_assert!(got.is_subset(&all), "drew centres outside the box: {:?}", got.difference(&all).collect::<Vec<_>>());
        if !s.over_limit {
            prop_assert_eq!(&got, &all);
        }
        // Without the image clip, the window per axis.
        let big = (u32::MAX / 4, u32::MAX / 4);
        let shift = 1000.0; // move the box into positive coordinates
        let u = rect(b.0 + shift, b.1 + shift, b.2 + shift, b.3 + shift, (c.0 + shift, c.1 + shift), limit, big);
        let (nx, ny) = u.drawn();
        prop_assert_eq!(nx, if u.is_empty() { 0 } else { s.size.0.min(limit) });
        prop_assert_eq!(ny, if u.is_empty() { 0 } else { s.size.1.min(limit) });
        if !u.is_empty() {
            for (axis, (lo, hi), centre) in [(0, u.x, c.0 + shift), (1, u.y, c.1 + shift)] {
                let box_lo = if axis == 0 { b.0 } else { b.2 } + shift;
                let box_hi = if axis == 0 { b.1 } else { b.3 } + shift;
                let nearest = centre.round().clamp(box_lo.ceil(), (box_hi - 1.0).ceil().max(box_lo.ceil())) as i64;
                prop_assert!(lo as i64 <= nearest && nearest <= hi as i64, "axis {axis}: window {lo}..={hi} misses centre {nearest}");
            }
        }
    }

    /// The golden rasterizer in clip mode and the hardware stamp agree on
    /// every rectangle: the same centres, size and over-limit flag.
    #[test]
    fn golden_and_hardware_rasterizers_agree((b, c, limit, size) in case()) {
        let g = raster::rect(b.0, b.1, b.2, b.3, c, limit, OverLimit::Clip, size);
        let h = rect(b.0, b.1, b.2, b.3, c, limit, size);
        prop_assert_eq!(g.size, h.size);
        prop_assert_eq!(g.over_limit, h.over_limit);
        let (mut a, mut z) = (Vec::new(), Vec::new());
        g.for_each(|x, y| a.push((x, y)));
        h.for_each(|x, y| z.push((x, y)));
        prop_assert_eq!(a, z);
    }

    /// Flat shading: every centre a stamp covers receives the same candidate
    /// (colour, 1/Z, slopes, source) through the compositor, and no other
    /// sample changes.
    #[test]
    fn a_stamp_is_flat_shaded(
        (b, c, limit, size) in case(),
        colour in prop::array::uniform3(0.0f32..1.0),
        inv_z in 0.01f32..10.0,
        slopes in prop::array::uniform2(-0.1f32..0.1),
    ) {
        let s = rect(b.0, b.1, b.2, b.3, c, limit, size);
        let mut f = DestFrame::new(size.0, size.1);
        let cand = Candidate { colour, inv_z, slopes, source: 0, fill_colour: colour };
        let mut covered = BTreeSet::new();
        s.for_each(|x, y| {
            let i = f.index(x, y);
            covered.insert(i);
            assert_eq!(composite(&mut f, i, &cand, || 0, 2.0, 0.01), Verdict::Filled);
        });
        for i in 0..f.len() {
            if covered.contains(&i) {
                prop_assert!(f.real[i]);
                prop_assert_eq!((f.samples[i].colour, f.samples[i].inv_z, f.samples[i].slopes, f.samples[i].source), (colour, inv_z, slopes, 0));
            } else {
                prop_assert!(!f.real[i] && f.samples[i].colour == [0.0; 3] && f.samples[i].inv_z == 0.0);
            }
        }
    }
}
