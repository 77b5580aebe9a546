//! Didyk et al.'s fill of the few holes their adaptive grid leaves (seed
//! 002, VMV 2010 §3.3.1): T-junctions, where a quad borders a neighbour
//! subdivided more, open single-pixel cracks; "we found the most efficient
//! and simplest solution is, to just fill the undefined pixel via
//! inpainting. In practice one can chose a random neighbor pixel in image
//! space."
//!
//! Job: give each empty derived sample next to a real one a real
//! neighbour's colour (`didyk-inpaint`, the default hole fill of `didyk`
//! and `didyk-2ref`).
//!
//! Rules:
//! 1. One pass over the derived samples. An empty sample (neither `real`
//!    nor `hole`) with at least one `real` sample among its 8 neighbours
//!    takes the colour of one of those neighbours and is marked `hole`.
//! 2. The neighbour is "random" but fixed: neighbours are listed in the
//!    order N, NE, E, SE, S, SW, W, NW, the real ones kept, and the one at
//!    `splitmix64(sample index) mod count` is taken. Same frame, same
//!    choice: the output is deterministic.
//! 3. Only `real` neighbours are read, never samples filled in this pass, so
//!    the result does not depend on the scan order; wider holes keep their
//!    interior empty (the paper's holes are one pixel wide).
//!
//! Parameters: none.
//!
//! Not modelled: the GPU's actual random choice (any neighbour would do).

use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, HoleFill, Input, MethodInfo};
use serde_json::{Map, json};

/// The `didyk-inpaint` hole fill.
pub struct DidykInpaint;

/// SplitMix64's output function: a fixed pseudo-random hash.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Rules 1–3 on `d`; returns (filled, left empty).
pub fn inpaint(d: &mut DestPlanes) -> (u64, u64) {
    let (w, h) = (d.width as i64, d.height as i64);
    const ORDER: [(i64, i64); 8] = [(0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1)];
    let (mut filled, mut left) = (0u64, 0u64);
    for y in 0..h {
        for x in 0..w {
            let k = (y * w + x) as usize;
            if d.real[k] || d.hole[k] {
                continue;
            }
            let mut cand = [0usize; 8];
            let mut n = 0;
            for (dx, dy) in ORDER {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && nx < w && ny < h {
                    let j = (ny * w + nx) as usize;
                    if d.real[j] {
                        cand[n] = j;
                        n += 1;
                    }
                }
            }
            if n == 0 {
                left += 1;
                continue;
            }
            let j = cand[(splitmix64(k as u64) % n as u64) as usize];
            d.colour[k] = d.colour[j];
            d.hole.set(k, true);
            filled += 1;
        }
    }
    (filled, left)
}

impl HoleFill for DidykInpaint {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "didyk-inpaint",
            description: "Didyk et al.'s T-junction fill: an empty sample next to a real one takes a (fixed pseudo-random) real 8-neighbour's colour",
            paper: "002 Didyk et al. VMV 2010 §3.3.1",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, _input: &Input, d: &mut DestPlanes) -> Counters {
        let (filled, left) = inpaint(d);
        let mut extra = Map::new();
        extra.insert("filled".into(), json!(filled));
        extra.insert("left_empty".into(), json!(left));
        Counters { primitives: 0, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fills_single_cracks_from_real_neighbours_only() {
        // 5x3, all real except a one-sample vertical crack at x = 2: it
        // takes the colour of a sample at x = 1 or x = 3.
        let mut d = DestPlanes::new(5, 3);
        for k in 0..d.len() {
            let (x, y) = (k % 5, k / 5);
            if x != 2 {
                d.real.set(k, true);
                d.colour[k] = [x as f32, y as f32, 0.0];
            }
        }
        let (filled, left) = inpaint(&mut d);
        assert_eq!((filled, left), (3, 0));
        for y in 0..3 {
            let k = y * 5 + 2;
            assert!(d.hole[k] && !d.real[k]);
            let c = d.colour[k];
            assert!(c[0] == 1.0 || c[0] == 3.0, "{c:?}");
            assert!((c[1] - y as f32).abs() <= 1.0);
        }
        // A sample with no real neighbour stays empty.
        let mut e = DestPlanes::new(3, 3);
        e.real.set(0, true);
        assert_eq!(inpaint(&mut e), (3, 5));
        assert!(!e.hole[8]);
    }
}
