//! The hardware sheet sequencer (`postwarp_rtl::traversal`) and hole-fill
//! unit (`postwarp_rtl::units::hole_fill`) against the golden model: the
//! same sample order for every kind of epipole, and the same hole-fill
//! planes bit for bit, in both of the unit's modes (the epipolar pass and
//! the fallback pass, `units::fallback_fill`).

use glam::DVec3;
use postwarp::golden::config::GoldenConfig;
use postwarp::golden::fallback_fill::{FallbackStats, fallback_fill};
use postwarp::golden::frame::{PreparedReference, prepare_reference, warp_frame};
use postwarp::golden::hole_fill::{HoleFillParams as GoldenParams, HoleFillStats, hole_fill};
use postwarp::golden::planes::DestPlanes;
use postwarp::golden::traversal as golden;
use postwarp::trace::Trace;
use postwarp_rtl::DestFrame;
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::traversal::{Line, Major, OrderKey, forward_lines, reverse_lines, warp_key, warp_lines};
use postwarp_rtl::units::fallback_fill::prepare_sample;
use postwarp_rtl::units::hole_fill::{HoleFillCounters, HoleFillParams, HoleFillUnit};
use proptest::prelude::*;

use crate::common;
use crate::common::props::{epipole_strategy, finite};

// ---------------------------------------------------------------- traversal

fn flat(lines: &[Line]) -> Vec<(u32, u32)> {
    lines.iter().flat_map(|l| l.samples()).collect()
}

fn same_major(a: Major, b: golden::Major) -> bool {
    matches!((a, b), (Major::Row, golden::Major::Row) | (Major::Column, golden::Major::Column))
}

/// Everything the sequencer promises, against the golden traversal.
fn check_order(w: u32, h: u32, e: &Epipole) {
    let ctx = format!("{w}x{h}, epipole {:?} ({:?})", e.h, e.kind());
    let want = golden::order(w, h, e);
    let lines = forward_lines(w, h, e);
    for l in &lines {
        let (lines_n, len) = match l.major {
            Major::Row => (h, w),
            Major::Column => (w, h),
        };
        assert!(l.lo <= l.hi && l.hi < len && l.line < lines_n, "{ctx}: bad line {l:?}");
        assert!(l.step.abs() == 1 && l.line_step.abs() == 1, "{ctx}: bad steps {l:?}");
        assert_eq!(l.len() as usize, l.samples().count(), "{ctx}: {l:?}");
        assert!(!l.is_empty());
    }
    assert_eq!(flat(&lines), want, "{ctx}: forward order");

    // Each sheet's lines, taken out of the interleaved sweeps, are the
    // golden sheet with the same scan pattern, in order.
    let sheets = golden::sheets(w, h, e);
    let mut groups: Vec<Vec<Line>> = Vec::new();
    for n in 0..8u8 {
        let g: Vec<Line> = lines.iter().copied().filter(|l| l.sheet == n).collect();
        if !g.is_empty() {
            groups.push(g);
        }
    }
    assert_eq!(groups.len(), sheets.len(), "{ctx}: sheet count");
    for (g, s) in groups.iter().zip(&sheets) {
        assert_eq!(flat(g), s.samples, "{ctx}: sheet {}", g[0].sheet);
        for l in g {
            assert!(same_major(l.major, s.major), "{ctx}: {l:?} vs {:?}", s.major);
            assert_eq!((l.line_step, l.step), (s.line_step, s.step), "{ctx}: {l:?}");
        }
    }

    // Reverse order: exactly backwards, line by line.
    let back = reverse_lines(w, h, e);
    let mut rev = want.clone();
    rev.reverse();
    assert_eq!(flat(&back), rev, "{ctx}: reverse order");
    assert_eq!(back.len(), lines.len());
    for (b, f) in back.iter().zip(lines.iter().rev()) {
        assert_eq!(*b, f.reversed(), "{ctx}");
        assert_eq!(b.reversed(), *f, "{ctx}");
    }

    // Ranks: strictly increasing along the order, so sorting gives it.
    let r = OrderKey::new(w, h, e);
    assert!(want.windows(2).all(|p| r.key(p[0].0, p[0].1) < r.key(p[1].0, p[1].1)), "{ctx}: ranks not increasing");
    let mut all: Vec<(u32, u32)> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect();
    all.sort_by_key(|&(x, y)| r.key(x, y));
    assert_eq!(all, want, "{ctx}: rank sort");
    // The warp's order: ring bands reversed, each band's sweeps in
    // increasing order, each read backwards; the same in both engines and
    // sorted by the warp key.
    let warp = flat(&warp_lines(w, h, e));
    assert_eq!(warp, golden::warp_order(w, h, e), "{ctx}: warp order");
    assert!(
        warp.windows(2).all(|p| warp_key(r.key(p[0].0, p[0].1), &r) < warp_key(r.key(p[1].0, p[1].1), &r)),
        "{ctx}: warp keys"
    );
}

/// Epipole coordinates along an axis of `n` samples: outside on both sides,
/// on the image border, on every sample centre and half-way between.
fn coords(n: u32) -> Vec<f64> {
    let n = n as f64;
    let mut v = vec![-1e7, -3.0, -2.5, -1.0, -0.5, -0.3];
    let mut k = 0.0;
    while k <= n - 1.0 {
        v.push(k);
        v.push(k + 0.5);
        v.push(k + 0.2);
        k += 1.0;
    }
    v.extend([n - 0.5, n, n + 1.5, n + 3.0, 2e9]);
    v
}

const SIZES: [(u32, u32); 10] = [(1, 1), (1, 6), (6, 1), (2, 2), (2, 3), (5, 4), (4, 4), (7, 7), (8, 5), (3, 9)];

#[test]
fn sequencer_matches_golden_for_finite_epipoles_on_and_off_the_grid() {
    for (w, h) in SIZES {
        for px in coords(w) {
            for py in coords(h) {
                // Powers of two keep the point exact; 3 and −0.1 perturb it.
                for ew in [1.0, -1.0, 0.5, -2.0, 3.0, -0.1] {
                    check_order(w, h, &finite(px, py, ew));
                }
            }
        }
    }
}

#[test]
fn sequencer_matches_golden_on_diagonals_through_the_image() {
    // Points on the diagonals of sample centres, inside and outside, where
    // |dx| = |dy| ties decide the sheet.
    for (w, h) in [(9u32, 9u32), (7, 4), (4, 7)] {
        for t in -6..15 {
            let t = t as f64;
            for (px, py) in [(t, t), (t, h as f64 - 1.0 - t), (t + 0.5, t + 0.5), (t, t + 2.0)] {
                for ew in [1.0, -1.0, 0.25] {
                    check_order(w, h, &finite(px, py, ew));
                }
            }
        }
    }
}

#[test]
fn sequencer_matches_golden_at_infinity_and_for_coincident_centres() {
    let mut dirs: Vec<DVec3> = (0..48)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 48.0;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    for (x, y) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
    {
        dirs.push(DVec3::new(x, y, 0.0));
    }
    // Signed zeros, and |ew| under the infinity tolerance.
    dirs.extend([
        DVec3::new(-0.0, 1.0, 0.0),
        DVec3::new(-0.0, -1.0, -0.0),
        DVec3::new(1.0, -0.0, 0.0),
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(3.0, -2.0, 1e-13),
        DVec3::new(-2.0, -2.0, -1e-13),
        DVec3::new(5.0, 5.0, 0.0),
    ]);
    // Coincident centres.
    dirs.extend([DVec3::ZERO, DVec3::new(-0.0, -0.0, -0.0)]);
    for (w, h) in SIZES {
        for &d in &dirs {
            check_order(w, h, &Epipole { h: d });
        }
    }
}

#[test]
fn sequencer_matches_golden_for_far_and_near_infinite_epipoles() {
    // Finite but enormous (ew just above the tolerance) and tiny images.
    for (w, h) in [(5u32, 3u32), (1, 4), (6, 6)] {
        for h3 in [
            DVec3::new(1.0, 0.3, 2e-12),
            DVec3::new(-1.0, 1.0, -2e-12),
            DVec3::new(1e6, -1e6, 1.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1e-300, 1e-300, 1e-300),
        ] {
            check_order(w, h, &Epipole { h: h3 });
        }
    }
}

proptest! {
    #![proptest_config(common::prop_config(400))]

    #[test]
    fn sequencer_matches_golden_for_random_epipoles(w in 1u32..70, h in 1u32..70, e in epipole_strategy()) {
        check_order(w, h, &e);
    }
}

// ---------------------------------------------------------------- hole fill

fn bits3(v: &[[f32; 3]]) -> Vec<[u32; 3]> {
    v.iter().map(|c| c.map(f32::to_bits)).collect()
}

/// Every plane equal, floats bit for bit.
fn assert_same(d: &DestPlanes, f: &DestFrame, ctx: &str) {
    assert_eq!((d.width, d.height), (f.width, f.height), "{ctx}");
    let first = |a: &[[u32; 3]], b: &[[u32; 3]]| a.iter().zip(b).position(|(x, y)| x != y);
    if let Some(i) = first(&bits3(&d.colour), &bits3(&f.plane(|s| s.colour))) {
        panic!("{ctx}: colour of sample {i}: golden {:?}, hardware {:?}", d.colour[i], f.samples[i].colour);
    }
    if let Some(i) = first(&bits3(&d.fill_colour), &bits3(&f.plane(|s| s.fill_colour))) {
        panic!(
            "{ctx}: fill colour of sample {i}: golden {:?}, hardware {:?}",
            d.fill_colour[i], f.samples[i].fill_colour
        );
    }
    let w = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(w(&d.fill_weight), w(&f.plane(|s| s.fill_weight)), "{ctx}: fill weight");
    assert_eq!(w(&d.inv_z), w(&f.plane(|s| s.inv_z)), "{ctx}: inv_z");
    let s = |v: &[[f32; 2]]| v.iter().map(|c| c.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(s(&d.slopes), s(&f.plane(|s| s.slopes)), "{ctx}: slopes");
    assert_eq!(d.source, f.plane(|s| s.source), "{ctx}: source");
    assert_eq!(d.hole, f.hole, "{ctx}: hole");
    assert_eq!(d.real, f.real, "{ctx}: real");
    assert_eq!(d.fill_valid, f.fill_valid, "{ctx}: fill valid");
    assert_eq!(d.fill_distance, f.plane(|s| s.fill_distance), "{ctx}: fill distance");
}

/// One pass on each side (after each side's per-warp reset); the planes
/// and counters must agree. Returns the golden counters.
fn compare_pass(d: &mut DestPlanes, f: &mut DestFrame, e: &Epipole, p: HoleFillParams, ctx: &str) -> HoleFillStats {
    d.begin_warp();
    for i in 0..f.len() {
        f.begin_warp_sample(i);
    }
    assert_same(d, f, &format!("{ctx}, after the reset"));
    let st = hole_fill(
        d,
        e,
        &GoldenParams {
            far_distance: p.far_distance,
            far_offset: p.far_offset,
            max_distance: p.max_distance,
            fixed: None,
        },
    );
    let mut unit = HoleFillUnit::new(f.width, f.height, e, p);
    unit.fill_frame(f);
    assert_same(d, f, ctx);
    let c = unit.counters();
    assert_eq!(
        *c,
        HoleFillCounters {
            visited: f.len() as u64,
            filled: st.filled,
            unreached: st.unreached,
            far_taps_used: st.far_taps_used,
            saturations: 0
        },
        "{ctx}: counters"
    );
    st
}

/// A sample of a random frame: 0 real, 1 hole fill from earlier warps, 2 empty.
type SampleSpec = (u8, [f32; 3], f32);

fn frame_strategy() -> impl Strategy<Value = (u32, u32, Vec<SampleSpec>)> {
    (1u32..11, 1u32..11).prop_flat_map(|(w, h)| {
        let sample = (0u8..3, prop::array::uniform3(0.0f32..1.0), 0.01f32..3.0);
        (Just(w), Just(h), prop::collection::vec(sample, (w * h) as usize))
    })
}

fn params_strategy() -> impl Strategy<Value = HoleFillParams> {
    prop_oneof![
        Just(HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 }),
        (0u32..8, 0u32..6, 1u32..12).prop_map(|(a, b, c)| HoleFillParams {
            far_distance: a,
            far_offset: b,
            max_distance: c
        }),
        // Outside the golden configuration's range: distance 0 (1/0) and
        // distances past the 8-bit plane.
        (0u32..4, 0u32..3, prop::sample::select(vec![0u32, 255, 256, 300])).prop_map(|(a, b, c)| HoleFillParams {
            far_distance: a,
            far_offset: b,
            max_distance: c
        }),
    ]
}

fn planes_from(w: u32, h: u32, spec: &[SampleSpec]) -> DestPlanes {
    let mut d = DestPlanes::new(w, h);
    for (i, &(kind, colour, weight)) in spec.iter().enumerate() {
        d.colour[i] = colour;
        d.inv_z[i] = colour[0] + 0.5;
        d.source[i] = kind;
        match kind {
            0 => d.real.set(i, true),
            1 => {
                d.hole.set(i, true);
                d.fill_weight[i] = weight;
            }
            _ => d.colour[i] = [0.0; 3],
        }
    }
    d
}

proptest! {
    #![proptest_config(common::prop_config(300))]

    #[test]
    fn hole_fill_unit_matches_golden_bit_for_bit(
        (w, h, spec) in frame_strategy(),
        passes in prop::collection::vec((epipole_strategy(), params_strategy()), 1..4),
    ) {
        let mut d = planes_from(w, h, &spec);
        let mut f = common::dest_frame(&d);
        for (k, (e, p)) in passes.iter().enumerate() {
            compare_pass(&mut d, &mut f, e, *p, &format!("{w}x{h} pass {k}, epipole {:?}, {p:?}", e.h));
        }
    }
}

#[test]
fn hole_fill_unit_matches_golden_on_edge_epipoles() {
    // Every frame kind of a fixed 9x7 frame against a stripe of real samples,
    // for epipoles on sample centres, diagonals, borders and at infinity.
    let (w, h) = (9u32, 7u32);
    let spec: Vec<SampleSpec> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let kind = if (x + 2 * y) % 5 == 0 {
                0
            } else if x % 4 == 1 {
                1
            } else {
                2
            };
            (kind, [x as f32 / 9.0, y as f32 / 7.0, 0.5], 0.5 + (i % 3) as f32)
        })
        .collect();
    let mut cases: Vec<Epipole> = Vec::new();
    for (px, py) in
        [(4.0, 3.0), (4.5, 3.5), (0.0, 0.0), (-0.5, -0.5), (8.0, 6.0), (-3.0, 3.0), (12.0, -2.0), (2.0, 9.0)]
    {
        cases.push(finite(px, py, 1.0));
        cases.push(finite(px, py, -1.0));
    }
    for (x, y) in [(1.0, 0.0), (0.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (0.3, -0.9)] {
        cases.push(Epipole { h: DVec3::new(x, y, 0.0) });
    }
    cases.push(Epipole { h: DVec3::ZERO });
    let p = HoleFillParams { far_distance: 1, far_offset: 2, max_distance: 63 };
    for e in &cases {
        let mut d = planes_from(w, h, &spec);
        let mut f = common::dest_frame(&d);
        compare_pass(&mut d, &mut f, e, p, &format!("epipole {:?}", e.h));
    }
}

#[test]
fn hole_fill_unit_matches_golden_on_a_warped_room_frame() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let trace = Trace::open(&root.join("traces").join("room")).unwrap();
    let cfg = GoldenConfig { hole_fill: false, ..GoldenConfig::default() };
    let full = trace.frame_commands(0);
    let prepared: Vec<PreparedReference> = trace.derived[0]
        .references
        .iter()
        .map(|&r| prepare_reference(&trace.load_reference(r).unwrap().samples, full.supersample, &cfg))
        .collect();
    let p = HoleFillParams {
        far_distance: cfg.hole_far_distance,
        far_offset: cfg.hole_far_offset,
        max_distance: cfg.hole_max_distance,
    };
    // Frame 0 from both its references leaves almost no holes (its camera
    // nearly sits on reference 0's), so also warp each reference alone:
    // reference 1 alone leaves real disocclusions.
    let mut filled = Vec::new();
    for subset in [vec![0usize, 1], vec![1], vec![0]] {
        let mut cmd = full.clone();
        cmd.warps = subset.iter().map(|&j| full.warps[j].clone()).collect();
        let refs: Vec<&PreparedReference> = subset.iter().map(|&j| &prepared[j]).collect();
        let mut d = warp_frame(&cmd, &refs, &cfg).samples;
        let mut f = common::dest_frame(&d);
        // One pass per warp of the command, each around that warp's derived
        // epipole, accumulating over the passes.
        for (k, warp) in cmd.warps.iter().enumerate() {
            let ctx = format!("room frame 0 from references {subset:?}, pass {k}");
            let st = compare_pass(&mut d, &mut f, &warp.setup.epipole_derived, p, &ctx);
            filled.push(st.filled);
        }
    }
    assert!(
        filled.iter().max().unwrap() > &1000,
        "the frame must have holes for this test to mean anything: {filled:?}"
    );
}

// ------------------------------------------------------------ fallback fill

/// The fallback pass on each side (golden `fallback_fill`; the unit in its
/// fallback mode over every sample after `units::fallback_fill`'s
/// preparation); the planes and counters must agree.
fn compare_fallback(d: &mut DestPlanes, f: &mut DestFrame, e: &Epipole, p: HoleFillParams, ctx: &str) -> FallbackStats {
    let gp = GoldenParams {
        far_distance: p.far_distance,
        far_offset: p.far_offset,
        max_distance: p.max_distance,
        fixed: None,
    };
    let (st, filled) = fallback_fill(d, e, &gp);
    for i in 0..f.len() {
        prepare_sample(f, i);
    }
    let mut unit = HoleFillUnit::new_fallback(f.width, f.height, e, p);
    unit.fill_frame(f);
    assert_same(d, f, ctx);
    let c = unit.counters();
    assert_eq!((c.filled, c.unreached), (st.filled, st.unreached), "{ctx}: counters");
    assert_eq!(filled.len() as u64, st.filled, "{ctx}: filled samples listed");
    st
}

proptest! {
    #![proptest_config(common::prop_config(300))]

    #[test]
    fn fallback_mode_matches_golden_bit_for_bit(
        (w, h, spec) in frame_strategy(),
        (e, p) in (epipole_strategy(), params_strategy()),
    ) {
        let mut d = planes_from(w, h, &spec);
        let mut f = common::dest_frame(&d);
        compare_fallback(&mut d, &mut f, &e, p, &format!("{w}x{h}, epipole {:?}, {p:?}", e.h));
    }
}

#[test]
fn fallback_mode_matches_golden_on_edge_epipoles_and_fills_the_unreached_border() {
    // A 9x7 frame, real samples in the right half only: Mark's pass toward
    // +x cannot reach the left columns, the fallback fills every one.
    let (w, h) = (9u32, 7u32);
    let spec: Vec<SampleSpec> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (if x >= 5 { 0 } else { 2 }, [x as f32 / 9.0, y as f32 / 7.0, 0.5], 1.0)
        })
        .collect();
    let p = HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63 };
    let along_x = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
    let mut d = planes_from(w, h, &spec);
    let mut f = common::dest_frame(&d);
    compare_pass(&mut d, &mut f, &along_x, p, "Mark's pass");
    assert!((0..d.len()).any(|i| !d.real[i] && !d.hole[i]), "Mark's pass leaves the left columns empty");
    let st = compare_fallback(&mut d, &mut f, &along_x, p, "fallback along +x");
    assert_eq!(st.unreached, 0);
    assert!((0..d.len()).all(|i| d.real[i] || d.hole[i]), "no empty sample left");
    for e in [finite(4.0, 3.0, 1.0), finite(-3.0, 3.0, -1.0), finite(12.0, -2.0, 1.0), Epipole { h: DVec3::ZERO }] {
        let mut d = planes_from(w, h, &spec);
        let mut f = common::dest_frame(&d);
        compare_fallback(&mut d, &mut f, &e, p, &format!("epipole {:?}", e.h));
    }
}
