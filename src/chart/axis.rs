//! Axis ranges and ticks for every chart, computed here rather than by
//! plotters: any finite input gives a finite, non-empty range and at most
//! [`MAX_TICKS`] ticks in a bounded number of steps (plotters' own tick
//! search does not end on a range whose span overflows, e.g. a value of
//! 1.7e308 beside a small one).

use plotters::coord::ranged1d::{AsRangedCoord, DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
use std::ops::Range;

/// Most ticks on an axis.
pub const MAX_TICKS: usize = 10;

/// Largest magnitude an axis end takes; larger values are drawn at the
/// edge. Keeps every span (and `hi - lo`) finite.
pub const LIMIT: f64 = f64::MAX / 8.0;

/// A linear axis over the finite values of `vals`, padded by `pad` of the
/// span on each side (a single value gets ±5 % of itself, or ±1 at 0).
pub fn linear(vals: impl Iterator<Item = f64>, pad: f64) -> Range<f64> {
    let v: Vec<f64> = vals.filter(|x| x.is_finite()).map(|x| x.clamp(-LIMIT, LIMIT)).collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let d = if hi > lo {
        pad * (hi - lo)
    } else if lo != 0.0 {
        0.05 * lo.abs()
    } else {
        1.0
    };
    let (a, b) = ((lo - d).max(-LIMIT * 2.0), (hi + d).min(LIMIT * 2.0));
    if b > a { a..b } else { lo - 1.0..hi + 1.0 }
}

/// A logarithmic axis over the finite positive values of `vals` (a factor
/// 1.25 of margin), or `None` if there are none.
pub fn log(vals: impl Iterator<Item = f64>) -> Option<Range<f64>> {
    let v: Vec<f64> = vals.filter(|x| x.is_finite() && *x > 0.0).map(|x| x.min(LIMIT)).collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return None;
    }
    let (a, b) = ((lo / 1.25).max(f64::MIN_POSITIVE), (hi * 1.25).min(LIMIT * 2.0));
    Some(if b > a { a..b } else { a..a * 2.0 })
}

/// Ticks at round values (1, 2 or 5 times a power of ten) inside `r`, at
/// most [`MAX_TICKS`]; the two ends if no round step fits.
pub fn linear_ticks(r: &Range<f64>) -> Vec<f64> {
    let span = r.end - r.start;
    if !(span.is_finite() && span > 0.0) {
        return vec![r.start];
    }
    let raw = span / MAX_TICKS as f64;
    let p = 10f64.powf(raw.log10().floor());
    let Some(step) = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * p).find(|s| span / s <= MAX_TICKS as f64 && *s > 0.0)
    else {
        return vec![r.start, r.end];
    };
    let first = (r.start / step).ceil();
    let mut out = Vec::new();
    for i in 0..=MAX_TICKS {
        let v = (first + i as f64) * step;
        if !v.is_finite() || v > r.end || out.last().is_some_and(|l| *l >= v) {
            break;
        }
        out.push(if v == 0.0 { 0.0 } else { v });
    }
    if out.is_empty() { vec![r.start, r.end] } else { out }
}

/// Ticks at powers of ten inside `r` (thinned to at most [`MAX_TICKS`]),
/// plus 2 and 5 times them when the range spans less than two decades.
pub fn log_ticks(r: &Range<f64>) -> Vec<f64> {
    if !(r.start > 0.0 && r.end > r.start && r.end.is_finite()) {
        return vec![r.start];
    }
    let (a, b) = (r.start.log10().ceil() as i32, r.end.log10().floor() as i32);
    let decades = (b - a + 1).max(0) as usize;
    let every = decades.div_ceil(MAX_TICKS).max(1);
    let mut out: Vec<f64> = (0..decades).step_by(every).map(|i| 10f64.powi(a + i as i32)).collect();
    if decades < 2 {
        let lo = r.start.log10().floor() as i32;
        for e in lo..=b.max(lo) + 1 {
            for m in [1.0, 2.0, 5.0] {
                let v = m * 10f64.powi(e);
                if v >= r.start && v <= r.end && !out.contains(&v) {
                    out.push(v);
                }
            }
        }
        out.sort_by(f64::total_cmp);
    }
    if out.is_empty() { vec![r.start, r.end] } else { out }
}

/// An axis with the ticks given here (plotters never searches for its
/// own): `inner` maps values, `ticks` are the labelled grid lines.
pub struct Ticked<R> {
    inner: R,
    ticks: Vec<f64>,
}

impl<R: Ranged<ValueType = f64>> Ticked<R> {
    /// `coord` (a range, or a range's `.log_scale()`) ticked at `ticks`.
    pub fn new<C: AsRangedCoord<CoordDescType = R, Value = f64> + Into<R>>(coord: C, ticks: Vec<f64>) -> Ticked<R> {
        Ticked { inner: coord.into(), ticks }
    }
}

impl<R: Ranged<ValueType = f64>> Ranged for Ticked<R> {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() { Vec::new() } else { self.ticks.clone() }
    }

    fn range(&self) -> Range<f64> {
        self.inner.range()
    }
}

/// A linear axis over `r`, ticked by [`linear_ticks`].
pub fn ticked_linear(r: Range<f64>) -> Ticked<RangedCoordf64> {
    let t = linear_ticks(&r);
    Ticked::new(r, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every extreme float gives a finite range and a bounded tick list:
    /// the hang of issue 17 (a `host_ms_per_frame` of 1.7e308) was an
    /// unbounded tick search.
    #[test]
    fn extreme_values_give_finite_ranges_and_few_ticks() {
        let extremes = [
            vec![1.7e308, 1.0],
            vec![-1.7e308, 1.7e308],
            vec![f64::MAX, f64::MIN],
            vec![5e-324, 1e-323],
            vec![1e-320],
            vec![0.0],
            vec![f64::NAN, f64::INFINITY, 3.0],
            vec![],
            vec![1e300, 1e300 + 1e284],
            vec![-0.0, 0.0],
        ];
        for v in &extremes {
            let r = linear(v.iter().copied(), 0.06);
            assert!(r.start.is_finite() && r.end.is_finite() && r.end > r.start, "{v:?}: {r:?}");
            assert!((r.end - r.start).is_finite(), "{v:?}: span overflows");
            let t = linear_ticks(&r);
            assert!(!t.is_empty() && t.len() <= MAX_TICKS + 1, "{v:?}: {t:?}");
            assert!(t.iter().all(|x| x.is_finite()), "{v:?}: {t:?}");
            if let Some(r) = log(v.iter().copied()) {
                assert!(r.start > 0.0 && r.end > r.start && r.end.is_finite(), "{v:?}: {r:?}");
                let t = log_ticks(&r);
                assert!(!t.is_empty() && t.len() <= 3 * MAX_TICKS, "{v:?}: {t:?}");
            }
        }
    }

    #[test]
    fn ticks_are_round() {
        assert_eq!(linear_ticks(&(0.0..10.0)), [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]);
        assert_eq!(linear_ticks(&(19.4..35.2)), [20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0, 34.0]);
        assert_eq!(log_ticks(&(0.8..1200.0)), [1.0, 10.0, 100.0, 1000.0]);
        assert_eq!(log_ticks(&(3.0..40.0)), [5.0, 10.0, 20.0]);
    }
}
