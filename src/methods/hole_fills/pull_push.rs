//! Pull-push hole fill (Gortler, Grzeszczuk, Szeliski, Cohen, *The
//! Lumigraph*, SIGGRAPH 1996, §3.3 "pull-push"; also called push-pull):
//! the generic scattered-data fill a 3D warp can fall back on, blind to
//! depth and to the epipolar geometry. A baseline for Mark's epipolar fill
//! (TR98 §9) and for the stretch fill (`stretch.rs`, beside it).
//!
//! Job: give every empty derived sample (neither `real` nor `hole`) a
//! colour, a smooth mix of the real samples around it, near ones weighing
//! more; leave real samples alone.
//!
//! Rules:
//! 1. Level 0 is the derived sample grid: a real sample has weight 1 and its
//!    colour, any other sample weight 0 (earlier hole-fill colours are not
//!    used as data).
//! 2. Pull: level `k + 1` has `ceil(w/2) x ceil(h/2)` samples; its sample
//!    `(i, j)` sits on level `k`'s sample `(2i, 2j)` and gathers the 3x3
//!    level-`k` samples around it with the tent filter `t(0) = 1`,
//!    `t(±1) = 1/2` per axis (taps off the level are skipped):
//!    `W = Σ t·t·min(w, 1)`, colour `= Σ t·t·min(w, 1)·c / W` (0 if `W = 0`).
//!    Weights are not normalised: a fully covered neighbourhood gives
//!    `W = 4`, which the `min(w, 1)` of the next use clamps to full
//!    confidence (Gortler's clamp). Levels are built until one is 1x1.
//! 3. Push, from the coarsest level down: the coarsest level's colour is
//!    final; at level `k` the parent colour `p` is the bilinear
//!    interpolation of level `k + 1`'s final colours at `(x/2, y/2)` (even
//!    coordinates sit on a parent, odd ones halfway between two, clamped at
//!    the border), and the final colour is
//!    `min(w, 1)·c + (1 − min(w, 1))·p`.
//! 4. Every empty level-0 sample takes its final colour and is flagged
//!    `hole`; real samples and samples already flagged `hole` are not
//!    written. Arithmetic is in f64, rounded to f32 once at the end: a
//!    frame whose real samples all share one colour fills with exactly that
//!    colour.
//! 5. If the frame has no real sample, nothing is filled (all empty samples
//!    are counted `unreached`). Otherwise every empty sample is filled: each
//!    level-`k` sample feeds a level-`k + 1` sample with tap weight at least
//!    1/2, so a positive weight reaches the 1x1 level, and rule 3 gives
//!    every sample of every level a colour.
//! 6. One pass per frame, after the reconstruction, whatever the number of
//!    references (the fill does not depend on the references' epipoles).
//!
//! Parameters (fixed, not knobs):
//! - pull filter: 3x3 tent, (1/2, 1, 1/2) per axis (unitless weights);
//!   Gortler §3.3 filters with a tent;
//! - confidence clamp: 1 (unitless), Gortler §3.3's `min(w, 1)`;
//! - push interpolation: bilinear, the transpose of the tent (this model's
//!   choice);
//! - pyramid depth: down to 1x1, `ceil(log2(max(w, h))) + 1` levels
//!   (Gortler: to the coarsest level).
//!
//! Counters (`Counters::extra`): `filled` (samples filled), `unreached`
//! (empty samples left empty: only when the frame has no real sample),
//! `levels` (pyramid levels, level 0 included; 0 when there was nothing to
//! fill or nothing to fill from).
//!
//! Not modelled: depth (foreground and background colours mix alike in a
//! disocclusion: the fill is not "background-first" like TR98's), the
//! Lumigraph's splatting of level 0 with fractional weights (here the
//! reconstruction already resampled), per-level timing of a GPU mip-map
//! implementation.

use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, HoleFill, Input, MethodInfo};
use serde_json::{Map, json};

/// One pyramid level: size, colours, weights (f64).
struct Level {
    w: usize,
    h: usize,
    colour: Vec<[f64; 3]>,
    weight: Vec<f64>,
}

/// Tent taps along one axis: (offset, weight).
const TENT: [(i64, f64); 3] = [(-1, 0.5), (0, 1.0), (1, 0.5)];

/// Rule 2: the level above `l`.
fn pull(l: &Level) -> Level {
    let (w, h) = (l.w.div_ceil(2), l.h.div_ceil(2));
    let mut colour = vec![[0.0; 3]; w * h];
    let mut weight = vec![0.0; w * h];
    for j in 0..h {
        for i in 0..w {
            let (mut wsum, mut c) = (0.0, [0.0f64; 3]);
            for (dy, ty) in TENT {
                let y = 2 * j as i64 + dy;
                if y < 0 || y >= l.h as i64 {
                    continue;
                }
                for (dx, tx) in TENT {
                    let x = 2 * i as i64 + dx;
                    if x < 0 || x >= l.w as i64 {
                        continue;
                    }
                    let k = y as usize * l.w + x as usize;
                    let m = l.weight[k].min(1.0);
                    if m == 0.0 {
                        continue;
                    }
                    let t = tx * ty * m;
                    wsum += t;
                    for (a, v) in c.iter_mut().zip(l.colour[k]) {
                        *a += t * v;
                    }
                }
            }
            let k = j * w + i;
            weight[k] = wsum;
            if wsum > 0.0 {
                colour[k] = c.map(|v| v / wsum);
            }
        }
    }
    Level { w, h, colour, weight }
}

/// Rule 3: final colours of `l` given its parent's final colours.
fn push(l: &mut Level, parent: &Level) {
    // Bilinear taps of fine coordinate `x` on the parent: (lo, hi, weight of hi).
    let taps = |x: usize, n: usize| -> (usize, usize, f64) {
        let lo = x / 2;
        if x % 2 == 0 { (lo, lo, 0.0) } else { (lo, (lo + 1).min(n - 1), 0.5) }
    };
    for y in 0..l.h {
        let (y0, y1, fy) = taps(y, parent.h);
        for x in 0..l.w {
            let k = y * l.w + x;
            let m = l.weight[k].min(1.0);
            if m >= 1.0 {
                continue;
            }
            let (x0, x1, fx) = taps(x, parent.w);
            let at = |xx: usize, yy: usize| parent.colour[yy * parent.w + xx];
            let (c00, c10, c01, c11) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
            let mut p = [0.0; 3];
            for ch in 0..3 {
                let top = c00[ch] + fx * (c10[ch] - c00[ch]);
                let bottom = c01[ch] + fx * (c11[ch] - c01[ch]);
                p[ch] = top + fy * (bottom - top);
            }
            let c = &mut l.colour[k];
            for ch in 0..3 {
                c[ch] = m * c[ch] + (1.0 - m) * p[ch];
            }
        }
    }
}

/// Rules 1–5 on `d`; returns (filled, unreached, levels).
pub fn pull_push(d: &mut DestPlanes) -> (u64, u64, u64) {
    let (w, h) = (d.width as usize, d.height as usize);
    let empty = |d: &DestPlanes, i: usize| !d.real[i] && !d.hole[i];
    let targets = (0..d.len()).filter(|&i| empty(d, i)).count() as u64;
    if d.real.not_any() || targets == 0 || w == 0 || h == 0 {
        return (0, targets, 0);
    }
    let mut base = Level { w, h, colour: vec![[0.0; 3]; w * h], weight: vec![0.0; w * h] };
    for i in d.real.iter_ones() {
        base.weight[i] = 1.0;
        base.colour[i] = d.colour[i].map(f64::from);
    }
    let mut levels = vec![base];
    while {
        let top = levels.last().expect("level 0");
        top.w > 1 || top.h > 1
    } {
        let next = pull(levels.last().expect("level 0"));
        levels.push(next);
    }
    for k in (0..levels.len() - 1).rev() {
        let (fine, coarse) = levels.split_at_mut(k + 1);
        push(&mut fine[k], &coarse[0]);
    }
    let n_levels = levels.len() as u64;
    let base = &levels[0];
    let mut filled = 0;
    for i in 0..d.len() {
        if empty(d, i) {
            d.colour[i] = base.colour[i].map(|v| v as f32);
            d.hole.set(i, true);
            filled += 1;
        }
    }
    (filled, targets - filled, n_levels)
}

/// The pull-push fill as a [`HoleFill`] (`pull-push`).
pub struct PullPush;

impl HoleFill for PullPush {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "pull-push",
            description: "pull-push: a weighted image pyramid (3x3 tent pull, bilinear push) fills every empty sample from the real ones around it",
            paper: "Gortler et al. 1996 (Lumigraph) §3.3; seed 003 TR98 cites it as [10]",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, _input: &Input, d: &mut DestPlanes) -> Counters {
        let (filled, unreached, levels) = pull_push(d);
        let mut extra = Map::new();
        extra.insert("filled".into(), json!(filled));
        extra.insert("unreached".into(), json!(unreached));
        extra.insert("levels".into(), json!(levels));
        Counters { primitives: 0, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_real_sample_fills_everything_with_its_colour() {
        let mut d = DestPlanes::new(7, 5);
        d.real.set(12, true);
        d.colour[12] = [0.3, 0.6, 0.9];
        let (filled, unreached, levels) = pull_push(&mut d);
        assert_eq!((filled, unreached, levels), (34, 0, 4));
        assert!(d.colour.iter().all(|&c| c == [0.3, 0.6, 0.9]));
        assert_eq!(d.hole.count_ones(), 34);
        assert!(!d.hole[12]);
    }

    #[test]
    fn an_empty_frame_stays_empty() {
        let mut d = DestPlanes::new(4, 3);
        assert_eq!(pull_push(&mut d), (0, 12, 0));
        assert!(d.hole.not_any());
    }

    #[test]
    fn a_gap_between_two_colours_takes_a_mix_of_both() {
        let mut d = DestPlanes::new(16, 1);
        for x in 0..16 {
            if !(6..10).contains(&x) {
                d.real.set(x, true);
                d.colour[x] = if x < 6 { [0.0; 3] } else { [1.0; 3] };
            }
        }
        pull_push(&mut d);
        for x in 6..10 {
            assert!(d.colour[x][0] > 0.0 && d.colour[x][0] < 1.0, "{x}: {:?}", d.colour[x]);
        }
        // Nearer the white side, whiter.
        assert!(d.colour[9][0] > d.colour[6][0]);
    }
}
