//! Resolve: the display controller's box filter of each pixel's `ss x ss`
//! samples (TR98 §10: frames are expanded to super-samples on chip and
//! resolved for display).
//!
//! Job: turn the finished frame's super-samples into display pixels and
//! say which pixels are wholly covered by warped surfaces.
//!
//! Ports: in, the final derived frame as the display reads it from memory
//! (A-buffer format, expanded); out, display pixels (linear RGB).
//!
//! Rules: empty samples (no surface and no hole fill) count as black; a
//! pixel is *covered* when all its samples hold real surfaces.
//!
//! Throughput: one pixel per cycle of the display clock (not part of the
//! warper's cycle count; its memory reads are: `Client::Output`).
//!
//! Not modelled: the display clock and scan-out (a pure function here, run
//! after the frame's last cycle; no timing test of its own), filters other
//! than the box, gamma (pixels stay linear RGB; reports encode sRGB).

use crate::dest_frame::DestFrame;
use bitvec::vec::BitVec;

/// Resolved pixels and the covered-pixel mask of `f` at `ss x ss` samples
/// per pixel.
pub fn resolve(f: &DestFrame, ss: u32) -> (Vec<[f32; 3]>, BitVec) {
    let (pw, ph) = (f.width / ss, f.height / ss);
    let n = (ss * ss) as f64;
    let mut out = Vec::with_capacity((pw * ph) as usize);
    let mut covered = BitVec::with_capacity((pw * ph) as usize);
    for py in 0..ph {
        for px in 0..pw {
            let mut sum = [0.0f64; 3];
            let mut all = true;
            for j in 0..ss {
                for i in 0..ss {
                    let k = f.index(px * ss + i, py * ss + j);
                    all &= f.real[k];
                    if f.real[k] || f.hole[k] {
                        for (a, v) in sum.iter_mut().zip(f.samples[k].colour) {
                            *a += v as f64;
                        }
                    }
                }
            }
            out.push(sum.map(|a| (a / n) as f32));
            covered.push(all);
        }
    }
    (out, covered)
}
