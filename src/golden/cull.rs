//! Off-screen culling: reference blocks whose kernels cannot reach the
//! derived image are skipped before any per-sample work. A pure
//! optimisation: it never changes an output sample (the committed golden
//! images check this), and a real warper would skip them too (TR98's
//! reference frames cover 2.6x the display).
//!
//! Rule: every kernel corner of a sample in a block is either a warped
//! sample of the block or its one-sample ring, a mean of such, or an exact
//! edge corner: a warped point `(x ± ½, y ± ½)` with `δ` extrapolated by the
//! slopes. All of them lie in the projective image of the box
//! `[x0 − 1.5, x1 + 1.5] x [y0 − 1.5, y1 + 1.5] x [δmin, δmax]`, with the
//! depth range taken over the block and its neighbour blocks. If `W > 0` at
//! the box's eight corners (hence everywhere in it: W is affine), that image
//! is inside the convex hull of the eight warped corners, so when their
//! bounding box misses the derived sample centres, no kernel of the block
//! covers one. Clipping a kernel only shrinks it.

use super::transform::WarpContext;
use postwarp_rtl::SampleImage;

/// Block side (reference samples).
pub const BLOCK: u32 = 16;

/// Live (not culled) blocks of one reference warp.
#[derive(Clone, Debug)]
pub struct LiveBlocks {
    /// Blocks per row.
    pub bw: u32,
    /// Blocks per column.
    pub bh: u32,
    /// `live[by·bw + bx]`.
    pub live: Vec<bool>,
}

impl LiveBlocks {
    /// Is sample `(x, y)` in a live block?
    pub fn sample_live(&self, x: u32, y: u32) -> bool {
        self.live[((y / BLOCK) * self.bw + x / BLOCK) as usize]
    }

    /// Bounding rectangle `(x0, y0, x1, y1)` (inclusive, samples) of the live
    /// blocks in a `w x h` image, `None` if none is live.
    pub fn bounds(&self, w: u32, h: u32) -> Option<(u32, u32, u32, u32)> {
        let mut b: Option<(u32, u32, u32, u32)> = None;
        for by in 0..self.bh {
            for bx in 0..self.bw {
                if self.live[(by * self.bw + bx) as usize] {
                    let r = (bx * BLOCK, by * BLOCK, ((bx + 1) * BLOCK).min(w) - 1, ((by + 1) * BLOCK).min(h) - 1);
                    b = Some(match b {
                        None => r,
                        Some(o) => (o.0.min(r.0), o.1.min(r.1), o.2.max(r.2), o.3.max(r.3)),
                    });
                }
            }
        }
        b
    }
}

/// Per block of a reference frame: the range of 1/Z extrapolated half a
/// sample along the slopes (a property of the reference alone, computed
/// once when it is prepared).
#[derive(Clone, Debug, PartialEq)]
pub struct BlockDepth {
    /// Reference width (samples).
    pub width: u32,
    /// Reference height (samples).
    pub height: u32,
    /// Blocks per row.
    pub bw: u32,
    /// Blocks per column.
    pub bh: u32,
    /// Smallest extrapolated 1/Z per block (+∞: no surface).
    pub lo: Vec<f64>,
    /// Largest extrapolated 1/Z per block (−∞: no surface).
    pub hi: Vec<f64>,
}

/// The depth ranges of `img`'s blocks.
pub fn block_depth(img: &SampleImage) -> BlockDepth {
    block_depth_of(img, |i| 1.0 / img.z[i] as f64)
}

/// The depth ranges of `img`'s blocks with sample `i`'s 1/Z read as
/// `inv_z(i)` (the fixed mode's rounded 1/Z).
pub fn block_depth_of(img: &SampleImage, inv_z: impl Fn(usize) -> f64) -> BlockDepth {
    let (w, h) = (img.width, img.height);
    let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    let mut lo = vec![f64::INFINITY; (bw * bh) as usize];
    let mut hi = vec![f64::NEG_INFINITY; (bw * bh) as usize];
    for y in 0..h {
        let row = (y / BLOCK) * bw;
        for x in 0..w {
            let i = (y * w + x) as usize;
            if !img.valid[i] {
                continue;
            }
            let iz = inv_z(i);
            let s = img.inv_z_slopes[i];
            let r = 0.5 * (s[0].abs() as f64 + s[1].abs() as f64);
            let b = (row + x / BLOCK) as usize;
            lo[b] = lo[b].min(iz - r);
            hi[b] = hi[b].max(iz + r);
        }
    }
    BlockDepth { width: w, height: h, bw, bh, lo, hi }
}

/// Decide which blocks of a reference with block depths `depth` can reach a
/// `dw x dh` derived image.
#[inline(always)] // into each vector level's warp (`vector_level`)
pub fn live_blocks(ctx: &WarpContext, depth: &BlockDepth, dw: u32, dh: u32) -> LiveBlocks {
    let BlockDepth { width: w, height: h, bw, bh, lo, hi } = depth;
    let (w, h, bw, bh) = (*w, *h, *bw, *bh);
    let margin = 1e-3;
    let mut live = vec![false; (bw * bh) as usize];
    for by in 0..bh {
        for bx in 0..bw {
            // Depth range over the block and its neighbours (the ring).
            let (mut l, mut u) = (f64::INFINITY, f64::NEG_INFINITY);
            for ny in by.saturating_sub(1)..=(by + 1).min(bh - 1) {
                for nx in bx.saturating_sub(1)..=(bx + 1).min(bw - 1) {
                    l = l.min(lo[(ny * bw + nx) as usize]);
                    u = u.max(hi[(ny * bw + nx) as usize]);
                }
            }
            let b = (by * bw + bx) as usize;
            if lo[b] > hi[b] {
                continue; // no surface in the block: nothing to draw
            }
            let x0 = (bx * BLOCK) as f64 - 1.5;
            let x1 = (((bx + 1) * BLOCK).min(w) - 1) as f64 + 1.5;
            let y0 = (by * BLOCK) as f64 - 1.5;
            let y1 = (((by + 1) * BLOCK).min(h) - 1) as f64 + 1.5;
            let mut reach = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
            let mut bounded = l.is_finite() && u.is_finite();
            for &(x, y, iz) in &[
                (x0, y0, l),
                (x1, y0, l),
                (x0, y1, l),
                (x1, y1, l),
                (x0, y0, u),
                (x1, y0, u),
                (x0, y1, u),
                (x1, y1, u),
            ] {
                let wp = ctx.setup.warp(x, y, iz);
                if !(wp.w > 0.0 && wp.position.is_finite()) {
                    bounded = false;
                    break;
                }
                reach = [
                    reach[0].min(wp.position.x),
                    reach[1].max(wp.position.x),
                    reach[2].min(wp.position.y),
                    reach[3].max(wp.position.y),
                ];
            }
            if let (Some(f), true) = (ctx.fixed(), bounded) {
                // Fixed mode: where its rounded, saturating kernels can reach.
                ((reach[0], reach[1]), (reach[2], reach[3])) =
                    (f.reach(reach[0], reach[1]), f.reach(reach[2], reach[3]));
            }
            let off = bounded
                && (reach[1] < -margin
                    || reach[0] > dw as f64 - 1.0 + margin
                    || reach[3] < -margin
                    || reach[2] > dh as f64 - 1.0 + margin);
            live[b] = !off;
        }
    }
    LiveBlocks { bw, bh, live }
}
