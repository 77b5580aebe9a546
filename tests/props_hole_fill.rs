//! Property suite: the epipolar hole fill (`docs/invariants.md`, "Hole
//! fill", and "Compositing" for "hole fill never overwrites a real
//! sample").
//!
//! Random derived frames (real samples at a random density, hole fill left
//! by earlier warps, empty samples), random epipoles of every kind and
//! random tap knobs; the golden pass (`golden::hole_fill`) and the hardware
//! unit (`units::hole_fill`) against a reference model written here that
//! walks the forward order (`golden::traversal::visit`) and keeps a
//! *visited* bit-plane, so a fill can read only samples already visited:
//! - both give the model's planes exactly: a fill reads only visited taps;
//! - a sample ends with a valid fill colour iff it is real or reachable
//!   from a real sample through near taps on earlier lines;
//! - real samples are never changed (colour, 1/Z, slopes, source, hole bit);
//! - work: every sample is visited once (hardware), and filled + unreached
//!   equals the samples that had no valid fill colour, at most the frame.

use postwarp::golden::hole_fill::{HoleFillParams as GoldenParams, hole_fill};
use postwarp::golden::planes::DestPlanes;
use postwarp::golden::traversal::{Major, OrderKey, SheetInfo, order};
use postwarp_rtl::DestFrame;
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::units::hole_fill::{HoleFillParams, HoleFillUnit};
use proptest::prelude::*;

use crate::common;
use crate::common::props::epipole_strategy;

/// Sample kinds: 0 real, 1 hole fill from an earlier warp, 2 empty.
fn frame() -> impl Strategy<Value = DestPlanes> {
    (1u32..16, 1u32..16, 0.0f64..1.0).prop_flat_map(|(w, h, density)| {
        let n = (w * h) as usize;
        let sample = (0.0f64..1.0, 0.0f64..1.0, prop::array::uniform3(0.0f32..1.0), 0.05f32..3.0);
        prop::collection::vec(sample, n).prop_map(move |v| {
            let mut d = DestPlanes::new(w, h);
            for (i, (r, k, colour, weight)) in v.into_iter().enumerate() {
                d.colour[i] = colour;
                d.inv_z[i] = colour[1] + 0.1;
                d.slopes[i] = [colour[2], -colour[0]];
                d.source[i] = (i % 3) as u8;
                if r < density {
                    d.real.set(i, true);
                } else if k < 0.5 {
                    d.hole.set(i, true);
                    d.fill_weight[i] = weight;
                } else {
                    d.colour[i] = [0.0; 3];
                }
            }
            d.begin_warp();
            d
        })
    })
}

fn params() -> impl Strategy<Value = HoleFillParams> {
    prop_oneof![
        Just(HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 }),
        (0u32..8, 0u32..6, 1u32..70).prop_map(|(a, b, c)| HoleFillParams {
            far_distance: a,
            far_offset: b,
            max_distance: c
        }),
    ]
}

/// Every sample in the hole fill's order (the golden model's
/// `traversal::order`, sweeps interleaved), with its sheet's scan pattern.
fn visit(width: u32, height: u32, e: &Epipole, mut f: impl FnMut(&SheetInfo, u32, u32)) {
    let keys = OrderKey::new(width, height, e);
    for (x, y) in order(width, height, e) {
        f(&keys.scan_at(x, y), x, y);
    }
}

/// The reference model: the pass as `golden::hole_fill` documents it, with
/// a visited bit-plane in place of ranks. Returns (filled, unreached).
fn model(d: &mut DestPlanes, e: &Epipole, p: &HoleFillParams) -> (u64, u64) {
    let (w, h) = (d.width as i64, d.height as i64);
    let mut visited = vec![false; d.len()];
    let (mut filled, mut unreached) = (0, 0);
    visit(d.width, d.height, e, |s, x, y| {
        let i = (y * d.width + x) as usize;
        let seen = |k: i64, visited: &[bool], d: &DestPlanes| -> Option<usize> {
            let (tx, ty) = match s.major {
                Major::Row => (x as i64 + k, y as i64 - s.line_step as i64),
                Major::Column => (x as i64 - s.line_step as i64, y as i64 + k),
            };
            if tx < 0 || ty < 0 || tx >= w || ty >= h {
                return None;
            }
            let j = (ty * w + tx) as usize;
            (visited[j] && d.fill_valid[j]).then_some(j)
        };
        if !d.fill_valid[i] {
            let mut taps: Vec<usize> = [-1, 0, 1].into_iter().filter_map(|k| seen(k, &visited, d)).collect();
            if taps.is_empty() {
                unreached += 1;
            } else {
                let near = taps.iter().map(|&j| d.fill_distance[j] as u32).min().expect("a tap");
                let dist = (1 + near).min(p.max_distance);
                if dist > p.far_distance {
                    let off = p.far_offset as i64;
                    taps.extend([-off, off].into_iter().filter_map(|k| seen(k, &visited, d)));
                }
                let mut c = [0.0f64; 3];
                for &j in &taps {
                    for (acc, v) in c.iter_mut().zip(d.fill_colour[j]) {
                        *acc += v as f64;
                    }
                }
                let c = c.map(|v| (v / taps.len() as f64) as f32);
                d.fill_colour[i] = c;
                d.fill_valid.set(i, true);
                d.fill_distance[i] = dist as u8;
                filled += 1;
                if !d.real[i] {
                    let (wt, inv_d) = (d.fill_weight[i] as f64, 1.0 / dist as f64);
                    let old = if d.hole[i] { d.colour[i] } else { [0.0; 3] };
                    for k in 0..3 {
                        d.colour[i][k] = ((old[k] as f64 * wt + c[k] as f64 * inv_d) / (wt + inv_d)) as f32;
                    }
                    d.fill_weight[i] = (wt + inv_d) as f32;
                    d.hole.set(i, true);
                }
            }
        }
        visited[i] = true;
    });
    (filled, unreached)
}

/// Samples reachable from a real sample: real, or with a near tap (offset
/// −1, 0, +1 on the previous line of its sheet, visited earlier) that is.
fn reachable(d: &DestPlanes, e: &Epipole) -> Vec<bool> {
    let (w, h) = (d.width as i64, d.height as i64);
    let mut visited = vec![false; d.len()];
    let mut r = vec![false; d.len()];
    visit(d.width, d.height, e, |s, x, y| {
        let i = (y * d.width + x) as usize;
        r[i] = d.real[i]
            || [-1i64, 0, 1].into_iter().any(|k| {
                let (tx, ty) = match s.major {
                    Major::Row => (x as i64 + k, y as i64 - s.line_step as i64),
                    Major::Column => (x as i64 - s.line_step as i64, y as i64 + k),
                };
                let j = (ty * w + tx) as usize;
                tx >= 0 && ty >= 0 && tx < w && ty < h && visited[j] && r[j]
            });
        visited[i] = true;
    });
    r
}

fn bits(d: &DestPlanes) -> Vec<u32> {
    let mut v = Vec::new();
    for i in 0..d.len() {
        v.extend(d.colour[i].map(f32::to_bits));
        v.extend(d.fill_colour[i].map(f32::to_bits));
        v.extend([d.fill_valid[i] as u32, d.fill_distance[i] as u32, d.hole[i] as u32, d.fill_weight[i].to_bits()]);
    }
    v
}

fn frame_bits(f: &DestFrame) -> Vec<u32> {
    let mut v = Vec::new();
    for i in 0..f.len() {
        v.extend(f.samples[i].colour.map(f32::to_bits));
        v.extend(f.samples[i].fill_colour.map(f32::to_bits));
        v.extend([
            f.fill_valid[i] as u32,
            f.samples[i].fill_distance as u32,
            f.hole[i] as u32,
            f.samples[i].fill_weight.to_bits(),
        ]);
    }
    v
}

proptest! {
    #![proptest_config(common::prop_config(1000))]

    #[test]
    fn hole_fill_reads_only_visited_samples_and_fills_every_reachable_hole(
        d in frame(),
        e in epipole_strategy(),
        p in params(),
    ) {
        let ctx = format!("{}x{} epipole {:?} {p:?}", d.width, d.height, e.h);
        let before = d.clone();
        let holes = before.fill_valid.count_zeros() as u64;
        let reach = reachable(&before, &e);

        let mut m = before.clone();
        let (m_filled, m_unreached) = model(&mut m, &e, &p);

        let mut g = before.clone();
        let gp = GoldenParams { far_distance: p.far_distance, far_offset: p.far_offset, max_distance: p.max_distance, fixed: None };
        let st = hole_fill(&mut g, &e, &gp);
        prop_assert_eq!(bits(&g), bits(&m), "golden differs from the visited-only model: {}", ctx);
        prop_assert_eq!((st.filled, st.unreached), (m_filled, m_unreached), "{}", ctx);

        let mut f = common::dest_frame(&before);
        let mut unit = HoleFillUnit::new(d.width, d.height, &e, p);
        unit.fill_frame(&mut f);
        prop_assert_eq!(frame_bits(&f), bits(&m), "hardware differs from the visited-only model: {}", ctx);
        let c = *unit.counters();
        prop_assert_eq!(c.visited, (d.width * d.height) as u64, "each sample visited once: {}", ctx);
        prop_assert_eq!((c.filled, c.unreached), (m_filled, m_unreached), "{}", ctx);

        // Work bounded by the frame: each hole handled exactly once.
        prop_assert_eq!(st.filled + st.unreached, holes, "{}", ctx);
        prop_assert!(holes <= (d.width * d.height) as u64);

        for (i, &r) in reach.iter().enumerate() {
            prop_assert_eq!(g.fill_valid[i], r, "sample {} reachable {} but fill valid {}: {}", i, r, g.fill_valid[i], ctx);
            if before.real[i] {
                prop_assert!(!g.hole[i] && !f.hole[i], "a real sample became a hole: {}", ctx);
                prop_assert_eq!(g.colour[i], before.colour[i]);
                prop_assert_eq!(f.samples[i].colour, before.colour[i]);
                prop_assert_eq!((g.inv_z[i], g.slopes[i], g.source[i]), (before.inv_z[i], before.slopes[i], before.source[i]));
                prop_assert_eq!((f.samples[i].inv_z, f.samples[i].slopes, f.samples[i].source), (before.inv_z[i], before.slopes[i], before.source[i]));
            }
        }
    }
}
