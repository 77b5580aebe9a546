//! Rasterizer: a flat-shaded axis-aligned rectangle → the derived sample
//! centres it covers (TR98 §7.2, §10).
//!
//! Rules:
//! 1. Coverage is half-open: centre `i` is inside `[x0, x1)` iff
//!    `x0 <= i < x1`, so abutting rectangles never both cover a centre.
//! 2. A rectangle wider (taller) than `limit` centres is an *over-limit*
//!    kernel. With [`OverLimit::Clip`] it is clipped to the `limit` centres
//!    whose middle is nearest the warped sample position; with
//!    [`OverLimit::Allow`] it is drawn whole.
//! 3. Centres outside the image are dropped.
//!
//! Not modelled: the 4x4 stamp's per-clock timing (the hardware model's).

use super::config::OverLimit;

/// Largest |v| [`ceil_i32`] takes.
pub const CEIL_I32_RANGE: f64 = (1u32 << 30) as f64;

/// `v.ceil()` as an `i32` for |v| < [`CEIL_I32_RANGE`] (the caller checks;
/// anything else gives some value), branch-free and without a libm call.
#[inline(always)]
pub fn ceil_i32(v: f64) -> i32 {
    let t = v as i32; // truncates toward zero
    t + ((t as f64) < v) as i32
}

/// `v.ceil()` as an integer, without a libm call on targets lacking a
/// rounding instruction; exact for |v| < 2^52, saturating beyond.
#[inline(always)]
fn ceil_i64(v: f64) -> i64 {
    if v.abs() < 4.5e15 {
        let t = v as i64; // truncates toward zero
        // Branch-free: the fraction is random, a branch would mispredict.
        t + ((t as f64) < v) as i64
    } else {
        v.ceil() as i64
    }
}

/// Sample centres covered by `[lo, hi)` along one axis: `(first, last)`
/// inclusive, empty when `first > last`.
#[inline(always)]
pub fn covered(lo: f64, hi: f64) -> (i64, i64) {
    (ceil_i64(lo), ceil_i64(hi) - 1)
}

/// Clip an inclusive range of centres to `limit` around `centre`.
#[inline(always)]
pub fn clip(range: (i64, i64), centre: f64, limit: u32) -> (i64, i64) {
    let (a, b) = range;
    let n = b - a + 1;
    let l = limit as i64;
    if n <= l {
        return range;
    }
    let start = ((centre - (l as f64 - 1.0) / 2.0).round() as i64).clamp(a, b - l + 1);
    (start, start + l - 1)
}

/// One rasterized rectangle: the inclusive sample ranges to draw (already
/// clipped to the image), and its size before any clipping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// First and last column drawn.
    pub x: (i64, i64),
    /// First and last row drawn.
    pub y: (i64, i64),
    /// Width and height of the kernel in centres before the limit.
    pub size: (u32, u32),
    /// The kernel exceeded the limit on some axis.
    pub over_limit: bool,
}

/// Rasterize box `[x0, x1) x [y0, y1)` for a sample warped to `(cx, cy)`
/// into a `width x height` image.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rect(
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    centre: (f64, f64),
    limit: u32,
    over: OverLimit,
    size: (u32, u32),
) -> Rect {
    rect_of_ranges(covered(x0, x1), covered(y0, y1), centre, limit, over, size)
}

/// [`rect`] from the covered centres along each axis ([`covered`]).
#[inline(always)]
pub fn rect_of_ranges(
    rx: (i64, i64),
    ry: (i64, i64),
    centre: (f64, f64),
    limit: u32,
    over: OverLimit,
    size: (u32, u32),
) -> Rect {
    let len = |r: (i64, i64)| (r.1 - r.0 + 1).max(0) as u32;
    let kernel = (len(rx), len(ry));
    let over_limit = kernel.0 > limit || kernel.1 > limit;
    let (rx, ry) = match over {
        OverLimit::Clip => (clip(rx, centre.0, limit), clip(ry, centre.1, limit)),
        OverLimit::Allow => (rx, ry),
    };
    let x = (rx.0.max(0), rx.1.min(size.0 as i64 - 1));
    let y = (ry.0.max(0), ry.1.min(size.1 as i64 - 1));
    Rect { x, y, size: kernel, over_limit }
}

impl Rect {
    /// Visit every covered sample `(x, y)`.
    #[inline(always)]
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
    fn fast_ceil_matches_ceil() {
        for v in
            [-2.5, -2.0, -1e-300, -0.0, 0.0, 1e-300, 0.5, 1.0, 1.0000001, 3.999999, 1e15 + 0.5, -1e18, 1e18, f64::NAN]
        {
            assert_eq!(ceil_i64(v), v.ceil() as i64, "{v}");
        }
    }

    #[test]
    fn fast_i32_ceil_matches_ceil_in_its_range() {
        let r = CEIL_I32_RANGE;
        let below = |v: f64| f64::from_bits(v.to_bits() - 1);
        for v in [-r + 0.5, -2.5, -2.0, -1e-300, -0.0, 0.0, 1e-300, 0.5, 1.0, below(1.0), 1.0000001, 3.999999, below(r)]
        {
            assert_eq!(ceil_i32(v) as f64, v.ceil(), "{v}");
        }
    }

    #[test]
    fn half_open_coverage() {
        assert_eq!(covered(-0.5, 0.5), (0, 0));
        assert_eq!(covered(0.5, 1.5), (1, 1), "abutting boxes share no centre");
        assert_eq!(covered(0.2, 0.8), (1, 0), "a box between centres covers none");
        assert_eq!(covered(-0.5, 3.5), (0, 3));
    }

    #[test]
    fn clip_keeps_the_window_around_the_sample() {
        assert_eq!(clip((0, 9), 5.2, 4), (4, 7));
        assert_eq!(clip((0, 9), 0.0, 4), (0, 3));
        assert_eq!(clip((0, 9), 9.0, 4), (6, 9));
        assert_eq!(clip((2, 4), 0.0, 4), (2, 4));
    }

    #[test]
    fn rect_counts_and_clips() {
        let r = rect(-0.5, 5.5, 0.0, 1.0, (2.5, 0.5), 4, OverLimit::Clip, (100, 100));
        assert_eq!(r.size, (6, 1));
        assert!(r.over_limit);
        assert_eq!(r.x.1 - r.x.0 + 1, 4);
        let mut n = 0;
        r.for_each(|_, _| n += 1);
        assert_eq!(n, 4);
        let a = rect(-0.5, 5.5, 0.0, 1.0, (2.5, 0.5), 4, OverLimit::Allow, (3, 100));
        assert_eq!(a.x, (0, 2), "clipped to the image");
    }
}
