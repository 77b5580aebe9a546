//! Compositor: merge a candidate sample into the derived frame (TR98 §8,
//! `docs/warper-reference.md` §4).
//!
//! Rules, per derived sample:
//! 1. A real candidate always beats an empty or hole-fill sample.
//! 2. If `|1/Zc − 1/Zs| > tol`, the larger 1/Z wins (Z-buffer), with the
//!    symmetric tolerance `tol = slope_tol·max(|∇c|₁, |∇s|₁) +
//!    rel_tol·max(1/Zc, 1/Zs)` (slopes in derived samples).
//! 3. Within `tol`, from the same reference: keep the stored sample (ties
//!    resolve to the first drawn). From another reference (TR98 §8): the
//!    compositor checks the candidate's better-reference mask at the stored
//!    sample's source; the bit set means the stored sample's reference sees
//!    the surface better, so the candidate loses; clear, the candidate wins.
//!    (`docs/warper-reference.md` §4 item 3 states the opposite test, which
//!    contradicts its own definition of the mask: we follow the paper.)
//! 4. A write stores colour, 1/Z, slopes, source, clears the hole flag, and
//!    sets the hole-fill colour (plane 6) to the candidate's fill colour
//!    (its own colour, or its forward-edge neighbour's), valid, distance 0.
//! 5. Mesh/splat bit (TR98 §7.1, general path): within `tol` (rule 2's
//!    tolerance, "the same depth"), the kind decides before rule 3: a
//!    [`Kind::Splat`] candidate never overwrites a stored mesh sample
//!    ([`Outcome::SplatRejected`]), and a [`Kind::Mesh`] candidate always
//!    overwrites a stored splat sample ([`Outcome::MeshOverSplat`]),
//!    whatever the sources. Same kind: rule 3. Rules 1 and 2 ignore the
//!    kind (a splat still beats hole fill and a farther mesh sample). A
//!    write sets the plane-`splat` bit iff the candidate is a splat. The
//!    anti-aliased path's kernels are [`Kind::Mesh`] and never meet a
//!    stored splat, so rule 5 leaves that path unchanged.
//!
//! Not modelled: read-modify-write timing and cache ports (hardware).

use super::planes::DestPlanes;

/// Which reconstruction produced a candidate (rule 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Triangle mesh (general path), or an anti-aliased kernel.
    Mesh,
    /// Edge splat (general path).
    Splat,
}

/// A candidate sample produced by rasterizing one kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Derived 1/Z (flat over the kernel).
    pub inv_z: f32,
    /// Derived slopes of 1/Z per sample step.
    pub slopes: [f32; 2],
    /// Reference index in the frame's warp order.
    pub source: u8,
    /// Better-reference mask (bit j: reference j samples this surface better).
    pub better: u32,
    /// Colour for the hole-fill plane.
    pub fill_colour: [f32; 3],
    /// Mesh or splat (rule 5).
    pub kind: Kind,
}

/// Outcome of one composite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Written over an empty or hole-fill sample.
    Filled,
    /// Won the depth test.
    NearerWins,
    /// Within tolerance, from another reference that the stored sample's reference does not beat.
    BetterWins,
    /// Lost (farther, or same surface kept).
    Lost,
    /// Within tolerance, a mesh candidate replaced a stored splat (rule 5).
    MeshOverSplat,
    /// Within tolerance, a splat candidate lost to a stored mesh sample
    /// (rule 5).
    SplatRejected,
}

/// Z tolerance between a candidate and a stored sample (rule 2).
pub fn tolerance(
    c_inv_z: f32,
    c_slopes: [f32; 2],
    s_inv_z: f32,
    s_slopes: [f32; 2],
    slope_tol: f64,
    rel_tol: f64,
) -> f64 {
    let l1 = |s: [f32; 2]| (s[0].abs() + s[1].abs()) as f64;
    slope_tol * l1(c_slopes).max(l1(s_slopes)) + rel_tol * (c_inv_z.max(s_inv_z)) as f64
}

/// Composite candidate `c` into sample `i`.
pub fn composite(d: &mut DestPlanes, i: usize, c: &Candidate, slope_tol: f64, rel_tol: f64) -> Outcome {
    composite_with(d, i, c, || c.better, slope_tol, rel_tol)
}

/// [`composite`] with the candidate's better-reference mask supplied on
/// demand: rule 3 is the only reader, so a caller may compute the mask only
/// when a candidate meets a stored sample from another reference within
/// tolerance (`c.better` is then ignored).
#[inline(always)]
pub fn composite_with(
    d: &mut DestPlanes,
    i: usize,
    c: &Candidate,
    better: impl FnOnce() -> u32,
    slope_tol: f64,
    rel_tol: f64,
) -> Outcome {
    let outcome = if !d.real[i] {
        Outcome::Filled
    } else {
        let (s, si) = (d.inv_z[i], d.slopes[i]);
        let tol = tolerance(c.inv_z, c.slopes, s, si, slope_tol, rel_tol);
        let diff = c.inv_z as f64 - s as f64;
        if diff.abs() > tol {
            if diff > 0.0 { Outcome::NearerWins } else { Outcome::Lost }
        } else if c.kind == Kind::Splat && !d.splat[i] {
            Outcome::SplatRejected
        } else if c.kind == Kind::Mesh && d.splat[i] {
            Outcome::MeshOverSplat
        } else if d.source[i] != c.source && better() & (1 << d.source[i]) == 0 {
            Outcome::BetterWins
        } else {
            Outcome::Lost
        }
    };
    if !matches!(outcome, Outcome::Lost | Outcome::SplatRejected) {
        d.colour[i] = c.colour;
        d.inv_z[i] = c.inv_z;
        d.slopes[i] = c.slopes;
        d.source[i] = c.source;
        d.hole.set(i, false);
        d.real.set(i, true);
        d.fill_weight[i] = 0.0;
        d.fill_colour[i] = c.fill_colour;
        d.fill_valid.set(i, true);
        d.fill_distance[i] = 0;
        d.splat.set(i, c.kind == Kind::Splat);
    }
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(inv_z: f32, source: u8, better: u32, r: f32) -> Candidate {
        Candidate {
            colour: [r, 0.0, 0.0],
            inv_z,
            slopes: [0.0; 2],
            source,
            better,
            fill_colour: [r, 0.0, 0.0],
            kind: Kind::Mesh,
        }
    }

    fn splat(inv_z: f32, source: u8, better: u32, r: f32) -> Candidate {
        Candidate { kind: Kind::Splat, ..cand(inv_z, source, better, r) }
    }

    #[test]
    fn z_buffer_and_hole_fill_rules() {
        let mut d = DestPlanes::new(1, 1);
        d.hole.set(0, true);
        d.colour[0] = [0.0, 1.0, 0.0];
        assert_eq!(composite(&mut d, 0, &cand(0.1, 0, 0, 1.0), 2.0, 0.01), Outcome::Filled, "real beats hole fill");
        assert!(!d.hole[0] && d.real[0]);
        assert_eq!(composite(&mut d, 0, &cand(0.05, 0, 0, 0.5), 2.0, 0.01), Outcome::Lost, "farther loses");
        assert_eq!(composite(&mut d, 0, &cand(0.2, 0, 0, 0.7), 2.0, 0.01), Outcome::NearerWins);
        assert_eq!(d.colour[0][0], 0.7);
    }

    #[test]
    fn same_surface_arbitration() {
        let mut d = DestPlanes::new(1, 1);
        composite(&mut d, 0, &cand(0.2, 0, 0, 0.1), 2.0, 0.01);
        // Within tolerance (0.2·1.01), same source: kept.
        assert_eq!(composite(&mut d, 0, &cand(0.201, 0, 0b10, 0.2), 2.0, 0.01), Outcome::Lost);
        // Other source whose mask says source 0 sees the surface better: kept.
        assert_eq!(composite(&mut d, 0, &cand(0.201, 1, 0b01, 0.3), 2.0, 0.01), Outcome::Lost);
        assert_eq!((d.colour[0][0], d.source[0]), (0.1, 0));
        // Other source that source 0 does not beat: the candidate wins.
        assert_eq!(composite(&mut d, 0, &cand(0.199, 1, 0b00, 0.4), 2.0, 0.01), Outcome::BetterWins);
        assert_eq!((d.colour[0][0], d.source[0]), (0.4, 1));
        // And source 0 coming back, with source 1 better: loses.
        assert_eq!(composite(&mut d, 0, &cand(0.2, 0, 0b10, 0.5), 2.0, 0.01), Outcome::Lost);
    }

    #[test]
    fn result_does_not_depend_on_order_of_distinct_depths() {
        let cs = [cand(0.1, 0, 0, 0.1), cand(0.3, 0, 0, 0.3), cand(0.2, 1, 0, 0.2)];
        let orders = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
        let mut results = Vec::new();
        for o in orders {
            let mut d = DestPlanes::new(1, 1);
            for k in o {
                composite(&mut d, 0, &cs[k], 2.0, 0.01);
            }
            results.push((d.colour[0], d.inv_z[0], d.source[0]));
        }
        assert!(results.iter().all(|r| *r == results[0]), "{results:?}");
    }

    #[test]
    fn a_splat_never_overwrites_a_mesh_sample_at_the_same_depth() {
        let mut d = DestPlanes::new(1, 1);
        assert_eq!(composite(&mut d, 0, &cand(0.2, 0, 0, 0.1), 2.0, 0.01), Outcome::Filled);
        assert!(!d.splat[0], "a mesh write clears the bit");
        // Same depth, same source, and even from a source the arbitration would prefer.
        assert_eq!(composite(&mut d, 0, &splat(0.2, 0, 0, 0.5), 2.0, 0.01), Outcome::SplatRejected);
        assert_eq!(composite(&mut d, 0, &splat(0.201, 1, 0b01, 0.6), 2.0, 0.01), Outcome::SplatRejected);
        assert_eq!((d.colour[0][0], d.source[0], d.splat[0]), (0.1, 0, false));
        // A nearer splat still wins the depth test; a farther one loses as usual.
        assert_eq!(composite(&mut d, 0, &splat(0.1, 1, 0, 0.7), 2.0, 0.01), Outcome::Lost);
        assert_eq!(composite(&mut d, 0, &splat(0.4, 1, 0, 0.8), 2.0, 0.01), Outcome::NearerWins);
        assert_eq!((d.colour[0][0], d.splat[0]), (0.8, true));
    }

    #[test]
    fn a_mesh_sample_overwrites_a_splat_at_the_same_depth() {
        let mut d = DestPlanes::new(1, 1);
        d.hole.set(0, true);
        assert_eq!(composite(&mut d, 0, &splat(0.2, 0, 0, 0.1), 2.0, 0.01), Outcome::Filled, "a splat beats hole fill");
        assert!(d.splat[0] && d.real[0] && !d.hole[0]);
        // Splat against splat: rule 3 (same source keeps the stored one).
        assert_eq!(composite(&mut d, 0, &splat(0.2, 0, 0, 0.3), 2.0, 0.01), Outcome::Lost);
        // A mesh sample at the same depth replaces it, from any source.
        assert_eq!(composite(&mut d, 0, &cand(0.201, 1, 0, 0.4), 2.0, 0.01), Outcome::MeshOverSplat);
        assert_eq!((d.colour[0][0], d.source[0], d.splat[0]), (0.4, 1, false));
        // Now mesh against mesh: rule 3 again.
        assert_eq!(composite(&mut d, 0, &cand(0.2, 1, 0, 0.5), 2.0, 0.01), Outcome::Lost);
        // The order of a mesh and a splat at the same depth does not matter.
        let mut e = DestPlanes::new(1, 1);
        composite(&mut e, 0, &cand(0.2, 0, 0, 0.1), 2.0, 0.01);
        composite(&mut e, 0, &splat(0.2, 0, 0, 0.9), 2.0, 0.01);
        let mut f = DestPlanes::new(1, 1);
        composite(&mut f, 0, &splat(0.2, 0, 0, 0.9), 2.0, 0.01);
        composite(&mut f, 0, &cand(0.2, 0, 0, 0.1), 2.0, 0.01);
        assert_eq!((e.colour[0], e.splat[0]), (f.colour[0], f.splat[0]));
    }
}
