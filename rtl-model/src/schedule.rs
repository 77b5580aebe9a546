//! Tile manager: the software schedule of one reference warp, computed by
//! the driver from the epipoles and a coarse depth map before the warp
//! starts (TR98 §10: "both caches entirely software-managed").
//!
//! Job, per reference warp:
//! 1. **Fetch plan.** The warp visits the reference in the reverse
//!    eight-sheet order, ring band by ring band and in each band sweep by
//!    sweep ([`crate::traversal::warp_lines`]). Kernel setup needs each
//!    line's 3x3 neighbourhood, so for every run of lines of one sweep
//!    (two sheets interleaved, [`crate::traversal`] rule 6) the fetch
//!    unit streams, line by line, the line before the sheet's first line,
//!    every line, and the line after its last, each widened by one sample
//!    at both ends and merged with its neighbours' widened extents: the
//!    [`FetchInterval`]s. A line's kernels may start once the interval of
//!    the next line has been transformed ([`Schedule::need`]). Samples on
//!    the borders between sweeps are fetched and transformed by both
//!    sweeps (counted); the two sheets of a sweep share one interval per
//!    line.
//! 2. **Off-screen culling.** Lines are split into chunks of
//!    [`CHUNK`] samples. A chunk's kernel corners all lie in the projective
//!    image of the box `[a − 1.5, b + 1.5] x [l − 1.5, l + 1.5] x [δmin,
//!    δmax]` (δ the 1/Z range, extrapolated half a sample by the slopes,
//!    over the [`BLOCK`]-sample blocks the widened chunk touches). If `W > 0`
//!    at its eight corners that image lies in their convex hull, whose
//!    bounding box bounds every kernel of the chunk. `W` is affine in the
//!    box's coordinates, so with `W ≤ 0` at all eight corners every sample
//!    of the chunk is behind the derived camera (no kernel: the chunk
//!    touches nothing); with mixed signs the chunk may touch any tile.
//!    Lines all of whose
//!    chunks miss the derived image are *dead*: not fetched unless a live
//!    neighbour needs them, and no kernels.
//! 3. **Tile retirement.** A destination tile is *retired* once every line
//!    whose chunk bounds touch it has been composited ([`Schedule::retire`]:
//!    the last such line, or `None`). No later kernel can write it, so
//!    hole fill may run on it.
//! 4. **Tile release.** The hole fill visits the derived image in the
//!    forward order around the derived epipole; a tile may leave the cache
//!    once the fill has visited its samples and every sample whose taps can
//!    read it ([`release_order`]).
//!
//! 5. **Tile prefetch.** Each tile's load is issued
//!    `tile_prefetch_distance` lines before the first line that may touch
//!    it, by the warp ([`Schedule::first`]) or by the hole fill
//!    ([`fill_first_lines`]); `units::tile_prefetch` runs the two lists.
//!
//! The schedule only decides *when*; it never changes a value, so a
//! conservative bound costs cache space and time, never correctness.
//!
//! Not modelled: the cost of computing the schedule (driver software, once
//! per reference warp).

use crate::camera::WarpSetup;
use crate::qformat::FixedFormats;
use crate::sample_image::SampleImage;
use crate::traversal::{Line, Major, sweep_of};

/// Samples per culling chunk along a line.
pub const CHUNK: u32 = 16;
/// Side of the coarse depth blocks (reference samples).
pub const BLOCK: u32 = 16;

/// The reference's coarse depth map: per block, the range of 1/Z
/// extrapolated half a sample along the slopes (`+∞..−∞`: no surface).
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseDepth {
    bw: u32,
    bh: u32,
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl CoarseDepth {
    /// The coarse depth map of a reference.
    pub fn new(img: &SampleImage) -> CoarseDepth {
        CoarseDepth::with_inv_z(img, |i| 1.0 / img.z[i] as f64)
    }

    /// The coarse depth map of a reference whose sample `i` has 1/Z
    /// `inv_z(i)` (the fixed mode's rounded 1/Z).
    pub fn with_inv_z(img: &SampleImage, inv_z: impl Fn(usize) -> f64) -> CoarseDepth {
        let w = img.width as usize;
        let mut d = CoarseDepth::empty(img.width, img.height);
        for i in img.valid.iter_ones() {
            d.add((i % w) as u32, (i / w) as u32, inv_z(i), img.inv_z_slopes[i]);
        }
        d
    }

    /// The map of a `w x h` reference with no surface yet.
    pub fn empty(w: u32, h: u32) -> CoarseDepth {
        let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
        CoarseDepth {
            bw,
            bh,
            lo: vec![f64::INFINITY; (bw * bh) as usize],
            hi: vec![f64::NEG_INFINITY; (bw * bh) as usize],
        }
    }

    /// Add sample `(x, y)` with 1/Z `iz` and slopes `s` (the ranges are
    /// minima and maxima: the order of the samples does not matter).
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, iz: f64, s: [f32; 2]) {
        let r = 0.5 * (s[0].abs() as f64 + s[1].abs() as f64);
        let b = ((y / BLOCK) * self.bw + x / BLOCK) as usize;
        self.lo[b] = self.lo[b].min(iz - r);
        self.hi[b] = self.hi[b].max(iz + r);
    }

    /// 1/Z range over the whole reference (`None`: no surface).
    pub fn overall(&self) -> Option<(f64, f64)> {
        let lo = self.lo.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.hi.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo <= hi).then_some((lo, hi))
    }

    /// 1/Z range over the blocks touching samples `[x0, x1] x [y0, y1]`.
    fn range(&self, x0: u32, x1: u32, y0: u32, y1: u32) -> (f64, f64) {
        let (mut l, mut u) = (f64::INFINITY, f64::NEG_INFINITY);
        for by in y0 / BLOCK..=(y1 / BLOCK).min(self.bh - 1) {
            for bx in x0 / BLOCK..=(x1 / BLOCK).min(self.bw - 1) {
                let b = (by * self.bw + bx) as usize;
                l = l.min(self.lo[b]);
                u = u.max(self.hi[b]);
            }
        }
        (l, u)
    }
}

/// A run of samples of one row or column the fetch unit streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FetchInterval {
    /// Row or column.
    pub major: Major,
    /// The row `y` (Row) or column `x` (Column).
    pub line: u32,
    /// First and last coordinate along the line (inclusive).
    pub lo: u32,
    /// Last coordinate along the line (inclusive).
    pub hi: u32,
    /// Streaming direction along the line (+1 or −1).
    pub step: i32,
}

impl FetchInterval {
    /// Image coordinates of the `k`-th sample streamed.
    #[inline]
    pub fn at(&self, k: u32) -> (u32, u32) {
        let a = if self.step > 0 { self.lo + k } else { self.hi - k };
        match self.major {
            Major::Row => (a, self.line),
            Major::Column => (self.line, a),
        }
    }

    /// Samples streamed.
    #[inline]
    pub fn len(&self) -> u32 {
        self.hi - self.lo + 1
    }

    /// Never true for intervals of a schedule.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.hi < self.lo
    }
}

/// The schedule of one reference warp.
#[derive(Clone, Debug)]
pub struct Schedule {
    /// Lines of the reference in warp order.
    pub lines: Vec<Line>,
    /// Per line: some chunk may reach the derived image.
    pub live: Vec<bool>,
    /// Fetch intervals in streaming order.
    pub fetch: Vec<FetchInterval>,
    /// Per line: the kernels may start once fetch intervals `0..=need[k]`
    /// have been transformed (`None`: dead line, no kernels).
    pub need: Vec<Option<usize>>,
    /// Per destination tile (row-major tile grid): the last line whose
    /// kernels may write it (`None`: no kernel can).
    pub retire: Vec<Option<u32>>,
    /// Per destination tile: the first line whose kernels may write it
    /// (`None`: no kernel can); the prefetch of rule 5 runs ahead of it.
    pub first: Vec<Option<u32>>,
    /// Tiles per row and per column of the destination tile grid.
    pub tiles: (u32, u32),
}

/// Bounding box `(x0, x1, y0, y1)` in derived samples of every kernel of
/// the chunk `[a, b]` on `line` (`None`: unbounded, some corner behind the
/// derived camera; `Some(empty)` when the chunk has no surface).
fn chunk_bounds(
    setup: &WarpSetup,
    depth: &CoarseDepth,
    major: Major,
    line: u32,
    a: u32,
    b: u32,
    size: (u32, u32),
) -> Option<(f64, f64, f64, f64)> {
    let (x0, x1, y0, y1) = match major {
        Major::Row => (a, b, line, line),
        Major::Column => (line, line, a, b),
    };
    let (lo, hi) =
        depth.range(x0.saturating_sub(1), (x1 + 1).min(size.0 - 1), y0.saturating_sub(1), (y1 + 1).min(size.1 - 1));
    if lo > hi {
        return Some((f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY));
    }
    let (fx0, fx1) = (x0 as f64 - 1.5, x1 as f64 + 1.5);
    let (fy0, fy1) = (y0 as f64 - 1.5, y1 as f64 + 1.5);
    let mut r = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    let mut behind = 0;
    for (x, y, d) in [
        (fx0, fy0, lo),
        (fx1, fy0, lo),
        (fx0, fy1, lo),
        (fx1, fy1, lo),
        (fx0, fy0, hi),
        (fx1, fy0, hi),
        (fx0, fy1, hi),
        (fx1, fy1, hi),
    ] {
        let w = setup.warp(x, y, d);
        if w.w <= 0.0 {
            behind += 1;
            continue;
        }
        if !w.position.is_finite() {
            return None;
        }
        r = [r[0].min(w.position.x), r[1].max(w.position.x), r[2].min(w.position.y), r[3].max(w.position.y)];
    }
    match behind {
        0 => Some((r[0], r[1], r[2], r[3])),
        8 => Some((f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY)),
        _ => None,
    }
}

impl Schedule {
    /// The schedule of warping a `size` (width, height) reference (coarse depth `depth`) with `setup`
    /// in the order `lines` into a `dst` (width, height) derived image of
    /// `tile`-sample tiles; with `fixed`, the bounds are those of the fixed
    /// mode's kernels ([`FixedFormats::reach`]).
    pub fn new(
        size: (u32, u32),
        depth: &CoarseDepth,
        setup: &WarpSetup,
        lines: Vec<Line>,
        dst: (u32, u32),
        tile: u32,
        fixed: Option<&FixedFormats>,
    ) -> Schedule {
        let tiles = (dst.0.div_ceil(tile), dst.1.div_ceil(tile));
        let mut retire: Vec<Option<u32>> = vec![None; (tiles.0 * tiles.1) as usize];
        let mut first: Vec<Option<u32>> = vec![None; retire.len()];
        let mut live = vec![false; lines.len()];
        let margin = 1e-3;
        for (k, l) in lines.iter().enumerate() {
            let mut a = l.lo;
            while a <= l.hi {
                let b = (a + CHUNK - 1).min(l.hi);
                let mut bounds = chunk_bounds(setup, depth, l.major, l.line, a, b, size);
                // Fixed mode: where its rounded, saturating kernels can reach.
                if let (Some(f), Some((x0, x1, y0, y1))) = (fixed, bounds)
                    && x0 <= x1
                {
                    let ((x0, x1), (y0, y1)) = (f.reach(x0, x1), f.reach(y0, y1));
                    bounds = Some((x0, x1, y0, y1));
                }
                // Tiles the chunk's kernels may touch (all if unbounded).
                let touched = match bounds {
                    None => Some((0, tiles.0 - 1, 0, tiles.1 - 1)),
                    Some((x0, x1, y0, y1)) => {
                        let off = x0 > x1
                            || x1 < -margin
                            || x0 > dst.0 as f64 - 1.0 + margin
                            || y1 < -margin
                            || y0 > dst.1 as f64 - 1.0 + margin;
                        (!off).then(|| {
                            let t = |v: f64, n: u32| ((v.max(0.0) as u64 / tile as u64) as u32).min(n - 1);
                            (
                                t(x0.floor(), tiles.0),
                                t(x1.ceil(), tiles.0),
                                t(y0.floor(), tiles.1),
                                t(y1.ceil(), tiles.1),
                            )
                        })
                    }
                };
                if let Some((tx0, tx1, ty0, ty1)) = touched {
                    live[k] = true;
                    for ty in ty0..=ty1 {
                        for tx in tx0..=tx1 {
                            let t = (ty * tiles.0 + tx) as usize;
                            retire[t] = Some(k as u32);
                            first[t].get_or_insert(k as u32);
                        }
                    }
                }
                a = b + 1;
            }
        }
        let (fetch, need) = fetch_plan(&lines, &live, size);
        Schedule { lines, live, fetch, need, retire, first, tiles }
    }
}

/// Rule 1: the fetch intervals and each line's need.
fn fetch_plan(lines: &[Line], live: &[bool], size: (u32, u32)) -> (Vec<FetchInterval>, Vec<Option<usize>>) {
    let mut fetch = Vec::new();
    let mut need = vec![None; lines.len()];
    let mut s = 0;
    while s < lines.len() {
        // One sweep (two interleaved sheets, traversal rule 6): consecutive
        // lines with the same sweep, axis and direction.
        let mut e = s + 1;
        while e < lines.len()
            && sweep_of(lines[e].sheet).0 == sweep_of(lines[s].sheet).0
            && lines[e].line_step == lines[s].line_step
            && lines[e].major == lines[s].major
        {
            e += 1;
        }
        let sheet = &lines[s..e];
        let major = sheet[0].major;
        let (n_lines, len) = match major {
            Major::Row => (size.1, size.0),
            Major::Column => (size.0, size.1),
        };
        let dir = sheet[0].line_step as i64;
        // Candidate line coordinates in streaming order: one before, all,
        // one after.
        let first = sheet[0].line as i64 - dir;
        let last = sheet[sheet.len() - 1].line as i64 + dir;
        let count = (last - first) * dir + 1;
        // Widened extent of the live sheet lines per line coordinate
        // (`base + 1 ..= base + count`, one spare slot at each end).
        let base = first.min(last) - 1;
        let mut ext = vec![(i64::MAX, i64::MIN); count as usize + 2];
        for (m, l) in sheet.iter().enumerate() {
            if live[s + m] {
                let e = &mut ext[(l.line as i64 - base) as usize];
                *e = (e.0.min(l.lo as i64 - 1), e.1.max(l.hi as i64 + 1));
            }
        }
        let mut index_of_line = std::collections::HashMap::new();
        for k in 0..count {
            let c = first + k * dir;
            if c < 0 || c >= n_lines as i64 {
                continue;
            }
            // Widened extents of the live sheet lines within one of c.
            let (mut lo, mut hi) = (i64::MAX, i64::MIN);
            for e in &ext[(c - 1 - base) as usize..=(c + 1 - base) as usize] {
                lo = lo.min(e.0);
                hi = hi.max(e.1);
            }
            if lo > hi {
                continue;
            }
            let (lo, hi) = (lo.max(0) as u32, hi.min(len as i64 - 1) as u32);
            index_of_line.insert(c, fetch.len());
            fetch.push(FetchInterval { major, line: c as u32, lo, hi, step: sheet[0].step });
        }
        for (m, l) in sheet.iter().enumerate() {
            if !live[s + m] {
                continue;
            }
            // The next line if it exists in the image, else this one.
            let next = l.line as i64 + dir;
            need[s + m] = index_of_line.get(&next).or_else(|| index_of_line.get(&(l.line as i64))).copied();
        }
        s = e;
    }
    (fetch, need)
}

/// Every tile segment the hole fill's pass over `lines` touches: for each
/// line (its index in `lines`), the segments of its own samples and of the
/// taps its samples read on the line before it in its sheet
/// (`l.line − l.line_step`, at positions `a + k` for `k` in `tap_offsets`),
/// each with the visit number of the last visit that touches it. Along a
/// line the visit numbers grow in visiting order, so that is the visit of
/// the segment's last sample in visiting order (for taps, of the sample
/// whose tap is the segment's last).
fn for_each_fill_segment(
    lines: &[Line],
    dst: (u32, u32),
    tile: u32,
    tap_offsets: &[i64],
    mut seen: impl FnMut(usize, u64, usize),
) {
    let tw = dst.0.div_ceil(tile);
    let t = tile as i64;
    let mut visit = 0u64;
    for (index, l) in lines.iter().enumerate() {
        let (lo, hi) = (l.lo as i64, l.hi as i64);
        // The visit number of the sample at position `a` of this line.
        let v = |a: i64| visit + 1 + if l.step > 0 { (a - lo) as u64 } else { (hi - a) as u64 };
        let (n_lines, len) = match l.major {
            Major::Row => (dst.1 as i64, dst.0 as i64),
            Major::Column => (dst.0 as i64, dst.1 as i64),
        };
        let tile_at = |line: i64, a: i64| -> usize {
            let (x, y) = match l.major {
                Major::Row => (a, line),
                Major::Column => (line, a),
            };
            ((y / t) * tw as i64 + x / t) as usize
        };
        // Every tile segment of positions b0..=b1 on `line`, each touched
        // by the sample at `b - k` for b in the segment.
        let mut touch = |line: i64, b0: i64, b1: i64, k: i64| {
            let mut b = b0;
            while b <= b1 {
                let end = ((b / t + 1) * t - 1).min(b1);
                let last = if l.step > 0 { v(end - k) } else { v(b - k) };
                seen(index, last, tile_at(line, b));
                b = end + 1;
            }
        };
        touch(l.line as i64, lo, hi, 0);
        let prev = l.line as i64 - l.line_step as i64;
        if (0..n_lines).contains(&prev) {
            for &k in tap_offsets {
                touch(prev, (lo + k).max(0), (hi + k).min(len - 1), k);
            }
        }
        visit += l.len() as u64;
    }
}

/// Rule 4: destination tiles in the order the hole fill releases them,
/// each with the number of fill visits after which it may leave: the
/// visits of its own samples and of every sample whose taps fall in it.
/// `lines` is the fill order; a sample at position `a` of line `l` has its
/// taps at positions `a + k` (`k` in `tap_offsets`) of the line before it
/// in its sheet (`l.line − l.line_step`), as the hole fill's are.
///
/// Computed per line and per tile segment, not per sample
/// ([`for_each_fill_segment`]).
pub fn release_order(lines: &[Line], dst: (u32, u32), tile: u32, tap_offsets: &[i64]) -> Vec<(u64, u32)> {
    let mut last = vec![0u64; (dst.0.div_ceil(tile) * dst.1.div_ceil(tile)) as usize];
    for_each_fill_segment(lines, dst, tile, tap_offsets, |_, visit, t| last[t] = last[t].max(visit));
    let mut order: Vec<(u64, u32)> = last.iter().enumerate().map(|(t, &v)| (v, t as u32)).collect();
    order.sort_unstable();
    order
}

/// Rule 5: per destination tile, the first line of the hole fill's pass
/// over `lines` that reads or writes it (its own samples or its taps, as in
/// [`release_order`]); `None` for a tile the pass never reaches.
pub fn fill_first_lines(lines: &[Line], dst: (u32, u32), tile: u32, tap_offsets: &[i64]) -> Vec<Option<u32>> {
    let mut first: Vec<Option<u32>> = vec![None; (dst.0.div_ceil(tile) * dst.1.div_ceil(tile)) as usize];
    for_each_fill_segment(lines, dst, tile, tap_offsets, |line, _, t| {
        first[t].get_or_insert(line as u32);
    });
    first
}
