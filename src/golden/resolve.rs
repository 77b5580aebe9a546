//! Resolve: average each pixel's `ss x ss` samples into a display pixel.
//!
//! Rules: empty samples (no surface and no hole fill reached them) count
//! as black; a pixel is *covered* when every one of its samples holds a
//! real surface (no hole fill, nothing empty).

use super::planes::DestPlanes;
use bitvec::vec::BitVec;

/// Resolved pixels and the covered-pixel mask.
pub fn resolve(d: &DestPlanes, ss: u32) -> (Vec<[f32; 3]>, BitVec) {
    let (pw, ph) = (d.width / ss, d.height / ss);
    let n = (ss * ss) as f64;
    let mut px = Vec::with_capacity((pw * ph) as usize);
    let mut covered = BitVec::with_capacity((pw * ph) as usize);
    for py in 0..ph {
        for pxx in 0..pw {
            let mut acc = [0.0f64; 3];
            let mut all_real = true;
            for j in 0..ss {
                for i in 0..ss {
                    let k = ((py * ss + j) * d.width + pxx * ss + i) as usize;
                    all_real &= d.real[k];
                    if d.real[k] || d.hole[k] {
                        for (a, v) in acc.iter_mut().zip(d.colour[k]) {
                            *a += v as f64;
                        }
                    }
                }
            }
            px.push(acc.map(|a| (a / n) as f32));
            covered.push(all_real);
        }
    }
    (px, covered)
}
