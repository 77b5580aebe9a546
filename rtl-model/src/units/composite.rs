//! Compositor: read-modify-write of a candidate sample into the destination
//! tile cache (TR98 §8; `docs/warper-reference.md` §4).
//!
//! Job: decide whether a rasterized candidate replaces the stored sample,
//! and write planes 1–5, 9 and the hole-fill planes 6–8.
//!
//! Ports: in, covered sample addresses with the flat candidate from the
//! rasterizer; read/write, the destination tile cache (the tile must be
//! resident: the engine stalls the compositor on a tile miss).
//!
//! Throughput: one rectangle (up to `kernel_limit²` samples, one stamp)
//! per cycle per rasterizer lane; the read-modify-write is pipelined.
//!
//! Rules, per derived sample:
//! 1. A candidate always beats an empty or hole-fill sample.
//! 2. With `tol = slope_tol·max(|∇c|₁, |∇s|₁) + rel_tol·max(1/Zc, 1/Zs)`,
//!    if `|1/Zc − 1/Zs| > tol` the larger 1/Z wins.
//! 3. Within `tol`: from the same reference the stored sample stays; from
//!    another, the candidate wins unless its better-reference mask has the
//!    stored sample's reference bit set.
//! 4. A write stores colour, 1/Z, slopes and source, clears the hole flag
//!    and weight, and sets the hole-fill colour (the candidate's fill
//!    colour: its own or its forward-edge neighbour's), valid, distance 0.
//!
//! Not modelled: bank conflicts inside the cache (one stamp per cycle).

use crate::dest_frame::DestFrame;

/// A rasterized candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Derived 1/Z (flat over the rectangle).
    pub inv_z: f32,
    /// Derived slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// Reference number in the frame's warp order.
    pub source: u8,
    /// Colour for the hole-fill plane.
    pub fill_colour: [f32; 3],
}

/// What one composite did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Written over an empty or hole-fill sample (rule 1).
    Filled,
    /// Won the depth test (rule 2).
    Nearer,
    /// Won the same-surface arbitration (rule 3).
    Better,
    /// Lost.
    Lost,
}

/// Composite candidate `c` into sample `i`; `better()` yields the
/// candidate's better-reference mask, read only by rule 3.
#[inline]
pub fn composite(
    f: &mut DestFrame,
    i: usize,
    c: &Candidate,
    better: impl FnOnce() -> u32,
    slope_tol: f64,
    rel_tol: f64,
) -> Verdict {
    let verdict = if !f.real[i] {
        Verdict::Filled
    } else {
        let (s, ss) = (f.inv_z[i], f.slopes[i]);
        let l1 = |v: [f32; 2]| (v[0].abs() + v[1].abs()) as f64;
        let tol = slope_tol * l1(c.slopes).max(l1(ss)) + rel_tol * (c.inv_z.max(s)) as f64;
        let diff = c.inv_z as f64 - s as f64;
        if diff.abs() > tol {
            if diff > 0.0 { Verdict::Nearer } else { Verdict::Lost }
        } else if f.source[i] != c.source && better() & (1 << f.source[i]) == 0 {
            Verdict::Better
        } else {
            Verdict::Lost
        }
    };
    if verdict != Verdict::Lost {
        f.colour[i] = c.colour;
        f.inv_z[i] = c.inv_z;
        f.slopes[i] = c.slopes;
        f.source[i] = c.source;
        f.hole.set(i, false);
        f.real.set(i, true);
        f.fill_weight[i] = 0.0;
        f.fill_colour[i] = c.fill_colour;
        f.fill_valid.set(i, true);
        f.fill_distance[i] = 0;
    }
    verdict
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(inv_z: f32, source: u8, r: f32) -> Candidate {
        Candidate { colour: [r, 0.0, 0.0], inv_z, slopes: [0.0; 2], source, fill_colour: [r, 0.0, 0.0] }
    }

    #[test]
    fn z_test_then_same_surface_arbitration() {
        let mut f = DestFrame::new(1, 1);
        f.hole.set(0, true);
        assert_eq!(composite(&mut f, 0, &cand(0.1, 0, 1.0), || 0, 2.0, 0.01), Verdict::Filled);
        assert!(f.real[0] && !f.hole[0]);
        assert_eq!(composite(&mut f, 0, &cand(0.05, 0, 0.5), || 0, 2.0, 0.01), Verdict::Lost);
        assert_eq!(composite(&mut f, 0, &cand(0.2, 0, 0.7), || 0, 2.0, 0.01), Verdict::Nearer);
        assert_eq!(composite(&mut f, 0, &cand(0.2, 0, 0.9), || 0, 2.0, 0.01), Verdict::Lost, "same source keeps");
        assert_eq!(composite(&mut f, 0, &cand(0.2, 1, 0.9), || 0b1, 2.0, 0.01), Verdict::Lost, "stored ref better");
        assert_eq!(composite(&mut f, 0, &cand(0.2, 1, 0.9), || 0, 2.0, 0.01), Verdict::Better);
        assert_eq!(f.colour[0][0], 0.9);
    }
}
