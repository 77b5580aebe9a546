//! Hole fill: the epipolar post-pass after each reference warp (TR98 §9,
//! §9.1, App. B; `docs/warper-reference.md` §4 and §7 items 9, 15).
//!
//! Rules:
//! 1. The derived frame is traversed in the forward eight-sheet order
//!    around the derived-image epipole `ê` (the occlusion-compatible order
//!    of the inverse warp: fill from the −F side).
//! 2. A sample whose hole-fill colour is valid (plane 7: a true surface,
//!    distance 0, or one filled earlier in this pass) is left alone.
//! 3. A hole sample looks one line back (the previous row of a row-major
//!    sheet, the previous column of a column-major one): the three near
//!    taps at offsets −1, 0, +1 along the line. Only taps already visited
//!    in this pass with a valid fill colour count; their fill colours are
//!    averaged with equal weights. Distance = 1 + the smallest tap distance
//!    (saturating at `hole_max_distance`). If that distance exceeds
//!    `hole_far_distance`, the two far taps at ±`hole_far_offset` along the
//!    previous line join the average (5 taps).
//! 4. No valid tap: the sample stays unfilled for this reference.
//! 5. A filled sample that holds no real surface accumulates the fill
//!    into planes 1, 5 and 9 weighted by 1/distance:
//!    `C ← (C·Wt + c/d)/(Wt + 1/d)`, `Wt ← Wt + 1/d` (TR98 §9.1); real
//!    surfaces always win.
//!
//! 6. Fixed mode (`docs/fixed-point.md`): the mean rounds to `q_colour`;
//!    in rule 5, `1/d` and `Wt + 1/d` round to `q_hole_weight`, the
//!    quotient to `q_colour` (a zero weight sum takes the fill colour
//!    itself); saturations are counted. The planes stay `f32`.
//!
//! Work: one scan of the fill-valid plane (a word at a time), then per
//! sample without a valid fill colour its rank, a sort, and at most 5 tap
//! reads with their ranks: bounded by the derived image size, whatever the
//! scene, and proportional to the holes.

use super::planes::DestPlanes;
use super::traversal::{Major, OrderKey};
use postwarp_rtl::camera::Epipole;
use postwarp_rtl::qformat::QFormat;

/// Counters of one hole-fill pass.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct HoleFillStats {
    /// Hole samples filled in this pass.
    pub filled: u64,
    /// Hole samples with no valid tap (left unfilled by this pass).
    pub unreached: u64,
    /// Fills that used the two far taps.
    pub far_taps_used: u64,
    /// Fixed mode: values that saturated (fill colours, weights).
    pub saturations: u64,
}

/// Knobs of the pass.
#[derive(Clone, Copy, Debug)]
pub struct HoleFillParams {
    /// Distance past which the far taps join (samples).
    pub far_distance: u32,
    /// Offset of the far taps (samples).
    pub far_offset: u32,
    /// Saturation of the distance plane (samples).
    pub max_distance: u32,
    /// Fixed mode: the colour and weight formats (`None`: float; rule 6).
    pub fixed: Option<(QFormat, QFormat)>,
}

/// Run one pass over `d` for a warp whose derived-image epipole is `e`.
///
/// Only samples without a valid fill colour do anything (rule 2), so only
/// they are visited, in the traversal's order: sorted by their rank
/// ([`OrderKey`], tested to sort into exactly the order of [`visit`]). A
/// sample was visited before another iff its rank is lower.
///
/// [`visit`]: super::traversal::visit
pub fn hole_fill(d: &mut DestPlanes, e: &Epipole, p: &HoleFillParams) -> HoleFillStats {
    let (w, h) = (d.width as i64, d.height as i64);
    let keys = OrderKey::new(d.width, d.height, e);
    let dw = d.width as usize;
    let order_key = |i: usize| keys.key((i % dw) as u32, (i / dw) as u32);
    let mut holes: Vec<(u64, usize)> = d.fill_valid.iter_zeros().map(|i| (order_key(i), i)).collect();
    holes.sort_unstable();
    let mut st = HoleFillStats::default();
    for (key, i) in holes {
        let (x, y) = (i as i64 % w, i as i64 / w);
        let sheet = keys.scan_at(x as u32, y as u32);
        // Tap at offset `k` along the line, one line back.
        let tap = |k: i64| -> Option<usize> {
            let (tx, ty) = match sheet.major {
                Major::Row => (x + k, y - sheet.line_step as i64),
                Major::Column => (x - sheet.line_step as i64, y + k),
            };
            if tx < 0 || ty < 0 || tx >= w || ty >= h {
                return None;
            }
            let j = (ty * w + tx) as usize;
            (d.fill_valid[j] && order_key(j) < key).then_some(j)
        };
        // Up to 3 near and 2 far taps, in fixed arrays (no allocation).
        let mut taps = [0usize; 5];
        let mut n_taps = 0;
        for k in [-1, 0, 1] {
            if let Some(j) = tap(k) {
                taps[n_taps] = j;
                n_taps += 1;
            }
        }
        if n_taps == 0 {
            st.unreached += 1;
            continue;
        }
        let dist =
            (1 + taps[..n_taps].iter().map(|&j| d.fill_distance[j] as u32).min().unwrap_or(0)).min(p.max_distance);
        if dist > p.far_distance {
            let before = n_taps;
            for k in [-(p.far_offset as i64), p.far_offset as i64] {
                if let Some(j) = tap(k) {
                    taps[n_taps] = j;
                    n_taps += 1;
                }
            }
            if n_taps > before {
                st.far_taps_used += 1;
            }
        }
        let taps = &taps[..n_taps];
        let mut c = [0.0f64; 3];
        for &j in taps {
            for (acc, v) in c.iter_mut().zip(d.fill_colour[j]) {
                *acc += v as f64;
            }
        }
        let n = taps.len() as f64;
        let c = mean(c, n, p, &mut st.saturations);
        st.filled += 1;
        st.saturations += set_fill(d, i, c, dist, p) as u64;
    }
    st
}

/// The fill colour `sum / n` (rule 6 in fixed mode: rounded to
/// `q_colour`, saturations added to `sat`). Shared with the fallback pass.
pub(super) fn mean(sum: [f64; 3], n: f64, p: &HoleFillParams, sat: &mut u64) -> [f32; 3] {
    match p.fixed {
        None => sum.map(|v| (v / n) as f32),
        Some((col, _)) => {
            let mut s = 0;
            let c = sum.map(|v| col.q(v / n, &mut s) as f32);
            *sat += s as u64;
            c
        }
    }
}

/// Store fill colour `c` at distance `dist` in sample `i` (planes 6–8) and,
/// if it holds no real surface, accumulate it into planes 1, 5 and 9
/// (rule 5; in fixed mode rule 6), returning the fixed mode's
/// saturations. Shared with the fallback pass (`fallback_fill.rs`).
pub(super) fn set_fill(d: &mut DestPlanes, i: usize, c: [f32; 3], dist: u32, p: &HoleFillParams) -> u32 {
    d.fill_colour[i] = c;
    d.fill_valid.set(i, true);
    d.fill_distance[i] = dist as u8;
    let mut sat = 0;
    if !d.real[i] {
        let wt = d.fill_weight[i] as f64;
        let old = if d.hole[i] { d.colour[i] } else { [0.0; 3] };
        match p.fixed {
            None => {
                let inv_d = 1.0 / dist as f64;
                for k in 0..3 {
                    d.colour[i][k] = ((old[k] as f64 * wt + c[k] as f64 * inv_d) / (wt + inv_d)) as f32;
                }
                d.fill_weight[i] = (wt + inv_d) as f32;
            }
            Some((col, wf)) => {
                let inv_d = wf.q(1.0 / dist as f64, &mut sat);
                let den = wf.q(wt + inv_d, &mut sat);
                for k in 0..3 {
                    let v = if den > 0.0 { (old[k] as f64 * wt + c[k] as f64 * inv_d) / den } else { c[k] as f64 };
                    d.colour[i][k] = col.q(v, &mut sat) as f32;
                }
                d.fill_weight[i] = den as f32;
            }
        }
        d.hole.set(i, true);
    }
    sat
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn params() -> HoleFillParams {
        HoleFillParams { far_distance: 4, far_offset: 4, max_distance: 63, fixed: None }
    }

    /// A 12x6 frame: columns 0..4 background (colour 0.2), 4..8 a hole,
    /// 8..12 foreground (colour 0.9). Fill direction +x (epipole at
    /// infinity along +x): the hole fills from the background side.
    #[test]
    fn disocclusion_fills_from_the_background_side() {
        let mut d = DestPlanes::new(12, 6);
        for y in 0..6 {
            for x in 0..12 {
                let i = y * 12 + x;
                if !(4..8).contains(&x) {
                    d.real.set(i, true);
                    d.colour[i] = if x < 4 { [0.2; 3] } else { [0.9; 3] };
                }
            }
        }
        d.begin_warp();
        let e = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
        let st = hole_fill(&mut d, &e, &params());
        assert_eq!(st.filled, 24);
        for y in 0..6 {
            for x in 4..8 {
                let i = y * 12 + x;
                assert!(d.hole[i]);
                assert!((d.colour[i][0] - 0.2).abs() < 1e-6, "({x},{y}) = {:?}", d.colour[i]);
                assert_eq!(d.fill_distance[i] as usize, x - 3);
            }
        }
    }

    #[test]
    fn real_samples_are_never_overwritten_and_weights_average() {
        let mut d = DestPlanes::new(4, 1);
        d.real.set(0, true);
        d.colour[0] = [1.0, 0.0, 0.0];
        d.begin_warp();
        let e = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
        hole_fill(&mut d, &e, &params());
        assert_eq!(d.colour[0], [1.0, 0.0, 0.0]);
        // Sample 1 (distance 1) and sample 3 (distance 3) both red.
        assert!(d.hole[1] && d.hole[3]);
        assert!((d.fill_weight[1] - 1.0).abs() < 1e-6 && (d.fill_weight[3] - 1.0 / 3.0).abs() < 1e-6);
        // A second reference fills sample 3 with blue at distance 1: weights 1/3 : 1.
        d.real.set(2, true);
        d.colour[2] = [0.0, 0.0, 1.0];
        d.begin_warp();
        hole_fill(&mut d, &e, &params());
        let c = d.colour[3];
        assert!((c[0] - 0.25).abs() < 1e-6 && (c[2] - 0.75).abs() < 1e-6, "{c:?}");
    }

    #[test]
    fn far_taps_join_past_distance_four() {
        // Fill runs along +x, column by column: far taps are ±4 rows away
        // in the previous column.
        let mut d = DestPlanes::new(12, 12);
        for y in 0..12 {
            d.real.set(y * 12, true);
            d.colour[y * 12] = [y as f32 / 12.0; 3];
        }
        d.begin_warp();
        let st = hole_fill(&mut d, &Epipole { h: DVec3::new(1.0, 0.0, 0.0) }, &params());
        assert_eq!(st.filled, 11 * 12);
        assert!(st.far_taps_used > 0);
        // Distance 5 onward mixes rows ±4: a row-dependent gradient blurs.
        let (a, b) = (d.colour[6 * 12 + 4][0], d.colour[6 * 12 + 8][0]);
        assert!((a - 6.0 / 12.0).abs() < 1e-6, "{a}");
        assert!((b - 6.0 / 12.0).abs() < 0.05, "{b}");
    }

    #[test]
    fn a_hole_with_no_path_back_stays_unfilled() {
        let mut d = DestPlanes::new(5, 1);
        d.real.set(4, true);
        d.begin_warp();
        // Fill runs toward +x: nothing lies behind the holes.
        let st = hole_fill(&mut d, &Epipole { h: DVec3::new(1.0, 0.0, 0.0) }, &params());
        assert_eq!((st.filled, st.unreached), (0, 4));
        assert!(!d.hole[0]);
    }
}
