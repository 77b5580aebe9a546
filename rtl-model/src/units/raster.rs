//! Rasterizer: flat-shaded axis-aligned rectangles of at most
//! `kernel_limit` x `kernel_limit` samples (TR98 §7.2, §10: a 4x4 stamp).
//!
//! Job: turn a kernel's bounding box into the derived sample centres it
//! covers, clipped to the stamp around the warped sample and to the image.
//!
//! Ports: in, a kernel (box, warped centre, candidate) from kernel setup;
//! out, up to `kernel_limit²` covered sample addresses with the flat
//! candidate, to the compositor.
//!
//! Throughput: `rects_per_cycle` rectangles per cycle (knob); the stamp
//! compares all its centres in parallel, so a rectangle costs one cycle
//! whatever its size.
//!
//! Rules:
//! 1. Coverage is half-open: centre `c` is inside `[lo, hi)` iff
//!    `lo <= c < hi`, so abutting boxes never double-cover.
//! 2. A box wider or taller than the stamp is clipped per axis to the
//!    `kernel_limit` centres nearest the warped sample (the window start is
//!    `round(centre − (limit − 1)/2)`, clamped into the box), and counted.
//! 3. Then clipped to the derived image.
//!
//! Not modelled: the general path's triangle mesh (TR98 §7.1); boxes drawn
//! larger than the stamp (the hardware cannot).

/// A rasterized rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
    /// Covered columns, inclusive (empty if `x.0 > x.1`).
    pub x: (i64, i64),
    /// Covered rows, inclusive.
    pub y: (i64, i64),
    /// Size of the box before clipping (sample centres per axis).
    pub size: (u32, u32),
    /// The box exceeded the stamp (rule 2).
    pub over_limit: bool,
}

/// Smallest integer `>= v` (`v` finite or not; NaN gives 0), without the
/// libm call in the common case.
#[inline]
fn ceil_to_int(v: f64) -> i64 {
    if v.abs() < 4.5e15 {
        let t = v as i64;
        if (t as f64) < v { t + 1 } else { t }
    } else {
        v.ceil() as i64
    }
}

#[inline]
fn centres_in(lo: f64, hi: f64) -> (i64, i64) {
    (ceil_to_int(lo), ceil_to_int(hi) - 1)
}

#[inline]
fn window(range: (i64, i64), centre: f64, limit: u32) -> (i64, i64) {
    let (a, b) = range;
    let l = limit as i64;
    if b - a < l {
        return range;
    }
    let start = ((centre - (l as f64 - 1.0) / 2.0).round() as i64).clamp(a, b - l + 1);
    (start, start + l - 1)
}

/// Rasterize the box `[x0, x1) x [y0, y1)` of a kernel whose warped sample
/// is at `centre`, with stamp side `limit`, in a `size` image.
#[inline]
pub fn stamp(x0: f64, x1: f64, y0: f64, y1: f64, centre: (f64, f64), limit: u32, size: (u32, u32)) -> Stamp {
    let (rx, ry) = (centres_in(x0, x1), centres_in(y0, y1));
    let n = |r: (i64, i64)| (r.1 - r.0 + 1).max(0) as u32;
    let kernel = (n(rx), n(ry));
    let over_limit = kernel.0 > limit || kernel.1 > limit;
    let (rx, ry) = (window(rx, centre.0, limit), window(ry, centre.1, limit));
    Stamp {
        x: (rx.0.max(0), rx.1.min(size.0 as i64 - 1)),
        y: (ry.0.max(0), ry.1.min(size.1 as i64 - 1)),
        size: kernel,
        over_limit,
    }
}

impl Stamp {
    /// True if no centre is covered.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.x.0 > self.x.1 || self.y.0 > self.y.1
    }

    /// Covered centres (columns, rows) after clipping.
    #[inline]
    pub fn drawn(&self) -> (u32, u32) {
        if self.is_empty() { (0, 0) } else { ((self.x.1 - self.x.0 + 1) as u32, (self.y.1 - self.y.0 + 1) as u32) }
    }

    /// Visit the covered centres in raster order.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(u32, u32)) {
        for y in self.y.0..=self.y.1 {
            for x in self.x.0..=self.x.1 {
                f(x as u32, y as u32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_is_half_open_and_clipped_around_the_sample() {
        let s = stamp(-0.5, 0.5, 0.5, 1.5, (0.0, 1.0), 4, (10, 10));
        assert_eq!((s.x, s.y), ((0, 0), (1, 1)));
        let s = stamp(0.2, 0.8, 0.0, 1.0, (0.5, 0.5), 4, (10, 10));
        assert!(s.is_empty());
        let s = stamp(-0.5, 9.5, -0.5, 1.5, (5.2, 0.5), 4, (10, 10));
        assert_eq!((s.x, s.size, s.over_limit), ((4, 7), (10, 2), true));
        assert_eq!(s.drawn(), (4, 2));
        for v in [-2.5, -2.0, -0.0, 0.5, 1.0, 3.999999, 1e18, f64::NAN] {
            assert_eq!(ceil_to_int(v), v.ceil() as i64, "{v}");
        }
    }
}
