//! Compositor: merge a candidate sample into the derived frame (TR98 §8,
//! `warper-reference.md` §4).
//!
//! Rules, per derived sample:
//! 1. A real candidate always beats an empty or hole-fill sample.
//! 2. If `|1/Zc − 1/Zs| > tol`, the larger 1/Z wins (Z-buffer), with the
//!    symmetric tolerance `tol = slope_tol·max(|∇c|₁, |∇s|₁) +
//!    rel_tol·max(1/Zc, 1/Zs)` (slopes in derived samples).
//! 3. Within `tol`, from the same reference: keep the stored sample (ties
//!    resolve to the first drawn); from another reference: the candidate
//!    wins iff its better-reference mask has the stored sample's source bit.
//! 4. A write stores colour, 1/Z, slopes, source, clears the hole flag, and
//!    sets the hole-fill colour (plane 6) to the candidate's fill colour
//!    (its own colour, or its forward-edge neighbour's), valid, distance 0.
//!
//! Not modelled: read-modify-write timing and cache ports (hardware).

use super::planes::DestPlanes;

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
}

/// Outcome of one composite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Written over an empty or hole-fill sample.
    Filled,
    /// Won the depth test.
    NearerWins,
    /// Within tolerance, won by the better-reference mask.
    BetterWins,
    /// Lost (farther, or same surface kept).
    Lost,
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
    let outcome = if !d.real[i] {
        Outcome::Filled
    } else {
        let (s, si) = (d.inv_z[i], d.slopes[i]);
        let tol = tolerance(c.inv_z, c.slopes, s, si, slope_tol, rel_tol);
        let diff = c.inv_z as f64 - s as f64;
        if diff.abs() > tol {
            if diff > 0.0 { Outcome::NearerWins } else { Outcome::Lost }
        } else if d.source[i] != c.source && c.better & (1 << d.source[i]) != 0 {
            Outcome::BetterWins
        } else {
            Outcome::Lost
        }
    };
    if outcome != Outcome::Lost {
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
    }
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(inv_z: f32, source: u8, better: u32, r: f32) -> Candidate {
        Candidate { colour: [r, 0.0, 0.0], inv_z, slopes: [0.0; 2], source, better, fill_colour: [r, 0.0, 0.0] }
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
        // Other source without the bit for source 0: kept.
        assert_eq!(composite(&mut d, 0, &cand(0.201, 1, 0b00, 0.3), 2.0, 0.01), Outcome::Lost);
        // Other source that samples better than source 0: wins.
        assert_eq!(composite(&mut d, 0, &cand(0.199, 1, 0b01, 0.4), 2.0, 0.01), Outcome::BetterWins);
        assert_eq!((d.colour[0][0], d.source[0]), (0.4, 1));
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
}
