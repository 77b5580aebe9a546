//! Property suite: compositing (`docs/invariants.md`, "Compositing").
//!
//! Golden (`golden::composite`) and hardware (`units::composite`)
//! compositors on one derived sample:
//! - candidates whose depths are pairwise farther apart than the Z
//!   tolerance give the same result in any order: the nearest wins;
//! - a real candidate always replaces a hole-fill or empty sample, whatever
//!   its depth, and a candidate never turns a real sample into a hole;
//! - both compositors agree on every sequence, including candidates within
//!   the tolerance (same-surface arbitration).
//!
//! That hole fill never overwrites a real sample is checked in
//! `props_hole_fill.rs`.

use postwarp::golden::composite as gc;
use postwarp::golden::planes::DestPlanes;
use postwarp_rtl::DestFrame;
use postwarp_rtl::units::composite as hc;
use proptest::prelude::*;

use crate::common;

const SLOPE_TOL: f64 = 2.0;
const REL_TOL: f64 = 0.01;

#[derive(Clone, Copy, Debug)]
struct Cand {
    colour: [f32; 3],
    inv_z: f32,
    slopes: [f32; 2],
    source: u8,
    better: u32,
}

fn golden(c: &Cand) -> gc::Candidate {
    gc::Candidate {
        colour: c.colour,
        inv_z: c.inv_z,
        slopes: c.slopes,
        source: c.source,
        better: c.better,
        fill_colour: c.colour,
        kind: gc::Kind::Mesh,
    }
}

fn hardware(c: &Cand) -> hc::Candidate {
    hc::Candidate { colour: c.colour, inv_z: c.inv_z, slopes: c.slopes, source: c.source, fill_colour: c.colour }
}

/// The sample a frame starts with: empty, hole fill from an earlier warp,
/// or nothing special (then only candidates write it).
#[derive(Clone, Copy, Debug)]
enum Start {
    Empty,
    Hole([f32; 3], f32),
}

/// Composite `cands` in order into a fresh 1x1 golden frame and hardware
/// frame; returns both frames.
fn run(start: Start, cands: &[Cand]) -> (DestPlanes, DestFrame) {
    let (mut d, mut f) = (DestPlanes::new(1, 1), DestFrame::new(1, 1));
    if let Start::Hole(colour, inv_z) = start {
        d.hole.set(0, true);
        f.hole.set(0, true);
        d.colour[0] = colour;
        f.samples[0].colour = colour;
        d.inv_z[0] = inv_z;
        f.samples[0].inv_z = inv_z;
        d.fill_weight[0] = 0.5;
        f.samples[0].fill_weight = 0.5;
    }
    for c in cands {
        gc::composite(&mut d, 0, &golden(c), SLOPE_TOL, REL_TOL);
        hc::composite(&mut f, 0, &hardware(c), || c.better, SLOPE_TOL, REL_TOL);
    }
    (d, f)
}

/// The stored sample of both frames, as comparable bits:
/// (colour, 1/Z, slopes, source, real, hole, fill weight).
type Stored = ([u32; 3], u32, [u32; 2], u8, bool, bool, u32);

fn stored_golden(d: &DestPlanes) -> Stored {
    (
        d.colour[0].map(f32::to_bits),
        d.inv_z[0].to_bits(),
        d.slopes[0].map(f32::to_bits),
        d.source[0],
        d.real[0],
        d.hole[0],
        d.fill_weight[0].to_bits(),
    )
}

fn stored_hardware(f: &DestFrame) -> Stored {
    (
        f.samples[0].colour.map(f32::to_bits),
        f.samples[0].inv_z.to_bits(),
        f.samples[0].slopes.map(f32::to_bits),
        f.samples[0].source,
        f.real[0],
        f.hole[0],
        f.samples[0].fill_weight.to_bits(),
    )
}

fn cand() -> impl Strategy<Value = Cand> {
    (prop::array::uniform3(0.0f32..1.0), 0.01f32..5.0, prop::array::uniform2(-0.01f32..0.01), 0u8..4, 0u32..16)
        .prop_map(|(colour, inv_z, slopes, source, better)| Cand { colour, inv_z, slopes, source, better })
}

fn start() -> impl Strategy<Value = Start> {
    prop_oneof![
        Just(Start::Empty),
        (prop::array::uniform3(0.0f32..1.0), 0.0f32..100.0).prop_map(|(c, z)| Start::Hole(c, z)),
    ]
}

/// True if every two candidates are farther apart in 1/Z than the Z
/// tolerance between them (rule 2 decides every meeting).
fn distinct_depths(c: &[Cand]) -> bool {
    c.iter().enumerate().all(|(k, a)| {
        c[k + 1..].iter().all(|b| {
            let tol = gc::tolerance(a.inv_z, a.slopes, b.inv_z, b.slopes, SLOPE_TOL, REL_TOL);
            (a.inv_z as f64 - b.inv_z as f64).abs() > tol
        })
    })
}

proptest! {
    #![proptest_config(common::prop_config(2000))]

    #[test]
    fn candidates_with_distinct_depths_composite_in_any_order(
        s in start(),
        (cands, shuffled) in prop::collection::vec(cand(), 1..8)
            .prop_filter("distinct depths", |c| distinct_depths(c))
            .prop_flat_map(|c| (Just(c.clone()), Just(c).prop_shuffle())),
    ) {
        let (d1, f1) = run(s, &cands);
        let (d2, f2) = run(s, &shuffled);
        prop_assert_eq!(stored_golden(&d1), stored_golden(&d2), "golden depends on the order");
        prop_assert_eq!(stored_hardware(&f1), stored_hardware(&f2), "hardware depends on the order");
        let nearest = cands.iter().max_by(|a, b| a.inv_z.total_cmp(&b.inv_z)).expect("one at least");
        prop_assert_eq!((d1.colour[0], d1.inv_z[0], d1.source[0]), (nearest.colour, nearest.inv_z, nearest.source));
        prop_assert!(d1.real[0] && !d1.hole[0]);
    }

    #[test]
    fn a_real_candidate_always_replaces_hole_fill_and_is_never_made_a_hole(
        hole_colour in prop::array::uniform3(0.0f32..1.0),
        hole_inv_z in 0.0f32..100.0,
        cands in prop::collection::vec(cand(), 1..6),
    ) {
        let (d, f) = run(Start::Hole(hole_colour, hole_inv_z), &cands[..1]);
        let c = cands[0];
        prop_assert_eq!((d.colour[0], d.inv_z[0], d.real[0], d.hole[0]), (c.colour, c.inv_z, true, false));
        prop_assert_eq!((f.samples[0].colour, f.samples[0].inv_z, f.real[0], f.hole[0]), (c.colour, c.inv_z, true, false));
        let (d, f) = run(Start::Hole(hole_colour, hole_inv_z), &cands);
        prop_assert!(d.real[0] && !d.hole[0] && f.real[0] && !f.hole[0]);
        prop_assert_eq!(d.fill_weight[0], 0.0, "a real surface carries no hole-fill weight");
    }

    /// Any sequence, including same-surface meetings within the tolerance
    /// (nearby depths, several sources, random better masks).
    #[test]
    fn golden_and_hardware_compositors_agree(
        s in start(),
        cands in prop::collection::vec(
            (cand(), 0.0f32..0.02).prop_map(|(mut c, j)| { c.inv_z = 1.0 + j; c }), 1..10),
    ) {
        let (d, f) = run(s, &cands);
        prop_assert_eq!(stored_golden(&d), stored_hardware(&f));
        prop_assert_eq!(d.fill_colour[0].map(f32::to_bits), f.samples[0].fill_colour.map(f32::to_bits));
        prop_assert_eq!((d.fill_valid[0], d.fill_distance[0]), (f.fill_valid[0], f.samples[0].fill_distance));
    }
}
