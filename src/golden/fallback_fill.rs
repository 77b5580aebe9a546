//! Fallback fill: after the last reference warp, the samples no epipolar
//! pass reached (`fallback_fill`, `docs/golden.md`; chosen by measurement
//! in `docs/real-data.md`).
//!
//! Why: Mark's fill (`hole_fill.rs`) propagates colour from the samples one
//! line *behind* a hole in the forward order. A hole with nothing behind
//! it — the strip at the image border that no reference saw, which TR98
//! avoids with wider reference fields of view but a stereo pair cannot —
//! stays empty and resolves to black.
//!
//! Rules (the same datapath as `hole_fill.rs`, run once more, backwards):
//! 1. The pass runs after the last warp and its A-buffer trip, over the
//!    derived frame in the **reverse** of the forward order around the last
//!    warp's derived-image epipole (the forward line list read backwards,
//!    each line from its other end: `traversal::OrderKey`, higher rank
//!    first). It fills from the side Mark's pass could not.
//! 2. Working planes 6–8 start as: a sample holding a real surface or a
//!    hole fill is a source (valid, its plane-1 colour, distance 0); an
//!    empty sample is not.
//! 3. An empty sample looks one line back *in this pass's order* (the next
//!    line of the forward order) at offsets −1, 0, +1; a tap counts if it is
//!    inside the image, was visited earlier in this pass (higher forward
//!    rank) and is valid. Distance, far taps (±`hole_far_offset` past
//!    `hole_far_distance`), saturation and the plain mean of the counted
//!    taps' plane-6 colours are those of `hole_fill.rs` rules 3–5.
//! 4. A filled sample stores the colour in planes 6–8 and accumulates it
//!    into planes 1, 5 and 9 exactly as `hole_fill.rs` rule 5 does (an empty
//!    sample has no earlier colour: it takes the fill, flagged `hole`), and
//!    becomes a source for the rest of the pass.
//! 5. No counted tap: the sample stays empty (`fallback_unreached`): its
//!    epipolar line holds nothing in either direction.
//! 6. Only empty samples change. The frame then takes the A-buffer trip
//!    again (`frame.rs`), as the hardware writes the tiles back.
//!
//! Work: as `hole_fill.rs`, proportional to the empty samples.

use super::hole_fill::{HoleFillParams, mean, set_fill};
use super::planes::DestPlanes;
use super::traversal::{Major, OrderKey};
use postwarp_rtl::camera::Epipole;

/// Counters of the fallback pass.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FallbackStats {
    /// Empty samples the pass filled.
    pub filled: u64,
    /// Empty samples it could not reach (left empty).
    pub unreached: u64,
    /// Fixed mode: values that saturated (fill colours, weights).
    pub saturations: u64,
}

/// Rules 1–5 on `d` for the last warp's derived-image epipole `e`: the
/// counters and the samples filled, in fill order.
pub fn fallback_fill(d: &mut DestPlanes, e: &Epipole, p: &HoleFillParams) -> (FallbackStats, Vec<usize>) {
    let (w, h) = (d.width as i64, d.height as i64);
    let keys = OrderKey::new(d.width, d.height, e);
    let dw = d.width as usize;
    let order_key = |i: usize| keys.key((i % dw) as u32, (i / dw) as u32);
    // Rule 2.
    let mut empty: Vec<(u64, usize)> = Vec::new();
    for i in 0..d.len() {
        let source = d.real[i] || d.hole[i];
        d.fill_valid.set(i, source);
        d.fill_colour[i] = if source { d.colour[i] } else { [0.0; 3] };
        d.fill_distance[i] = 0;
        if !source {
            empty.push((order_key(i), i));
        }
    }
    // Rule 1: highest forward rank first.
    empty.sort_unstable_by(|a, b| b.cmp(a));
    let mut st = FallbackStats::default();
    let mut filled = Vec::new();
    for (key, i) in empty {
        let (x, y) = (i as i64 % w, i as i64 / w);
        let sheet = keys.scan_at(x as u32, y as u32);
        // Rule 3: one line back in this pass = one line ahead in the forward order.
        let tap = |k: i64| -> Option<usize> {
            let (tx, ty) = match sheet.major {
                Major::Row => (x + k, y + sheet.line_step as i64),
                Major::Column => (x + sheet.line_step as i64, y + k),
            };
            if tx < 0 || ty < 0 || tx >= w || ty >= h {
                return None;
            }
            let j = (ty * w + tx) as usize;
            (d.fill_valid[j] && order_key(j) > key).then_some(j)
        };
        let mut taps = [0usize; 5];
        let mut n = 0;
        for k in [-1, 0, 1] {
            if let Some(j) = tap(k) {
                taps[n] = j;
                n += 1;
            }
        }
        if n == 0 {
            st.unreached += 1;
            continue;
        }
        let dist = (1 + taps[..n].iter().map(|&j| d.fill_distance[j] as u32).min().unwrap_or(0)).min(p.max_distance);
        if dist > p.far_distance {
            for k in [-(p.far_offset as i64), p.far_offset as i64] {
                if let Some(j) = tap(k) {
                    taps[n] = j;
                    n += 1;
                }
            }
        }
        let mut sum = [0.0f64; 3];
        for &j in &taps[..n] {
            for (acc, v) in sum.iter_mut().zip(d.fill_colour[j]) {
                *acc += v as f64;
            }
        }
        let c = mean(sum, n as f64, p, &mut st.saturations);
        // Rule 4.
        st.saturations += set_fill(d, i, c, dist, p) as u64;
        st.filled += 1;
        filled.push(i);
    }
    (st, filled)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn params() -> HoleFillParams {
        HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63, fixed: None }
    }

    /// Forward order toward +x: Mark's pass cannot reach the samples left
    /// of the first surface; the fallback fills them from the right.
    #[test]
    fn the_border_strip_mark_cannot_reach_is_filled_from_the_other_side() {
        let mut d = DestPlanes::new(8, 3);
        for y in 0..3 {
            for x in 3..8 {
                let i = y * 8 + x;
                d.real.set(i, true);
                d.colour[i] = [0.5, 0.25, 0.125];
            }
        }
        let e = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
        let before = d.clone();
        let (st, filled) = fallback_fill(&mut d, &e, &params());
        assert_eq!(st, FallbackStats { filled: 9, unreached: 0, saturations: 0 });
        assert_eq!(filled.len(), 9);
        for y in 0..3 {
            for x in 0..3 {
                let i = y * 8 + x;
                assert!(d.hole[i] && !d.real[i], "({x},{y})");
                assert_eq!(d.colour[i], [0.5, 0.25, 0.125]);
                assert_eq!(d.fill_distance[i] as usize, 3 - x);
            }
        }
        for i in 0..d.len() {
            if before.real[i] {
                assert_eq!((d.colour[i], d.hole[i]), (before.colour[i], false), "real sample {i} changed");
            }
        }
    }

    #[test]
    fn hole_fill_samples_are_sources_and_are_not_changed() {
        let mut d = DestPlanes::new(4, 1);
        d.hole.set(3, true);
        d.colour[3] = [0.2; 3];
        d.fill_weight[3] = 0.5;
        let (st, _) = fallback_fill(&mut d, &Epipole { h: DVec3::new(1.0, 0.0, 0.0) }, &params());
        assert_eq!(st.filled, 3);
        assert_eq!((d.colour[3], d.fill_weight[3]), ([0.2; 3], 0.5));
        assert_eq!(d.colour[0], [0.2; 3]);
        assert_eq!(d.fill_weight[0], (1.0f64 / 3.0) as f32);
    }

    #[test]
    fn an_empty_frame_stays_empty() {
        let mut d = DestPlanes::new(3, 2);
        let (st, _) = fallback_fill(&mut d, &Epipole { h: DVec3::new(0.0, 1.0, 0.0) }, &params());
        assert_eq!(st, FallbackStats { filled: 0, unreached: 6, saturations: 0 });
        assert!(d.hole.not_any());
    }
}
