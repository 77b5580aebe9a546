//! Hole filling using a depth-based low-pass filter, Schollmeyer et al.
//! (seed 000, TVCG 2017, §5.2), as the hole fill `low-pass`.
//!
//! Job: fill every derived sample no surface reached with a colour of the
//! *background* around it, blurred the more the farther it is from the
//! hole's border (as Mark blurs his epipolar stripes, TR98 §9, but with a
//! mip-map instead of a sequential sweep).
//!
//! Works on the derived sample grid (`cmd.supersample`), after the
//! reconstruction (one pass over the finished frame, not per reference).
//!
//! Rules:
//! 1. Level 0 of the pyramid is the frame: a sample is *valid* iff it holds
//!    a real surface (`real`), with its colour and depth `Z = 1/inv_z`.
//! 2. Depth-aware reduction (§5.2, Fig. 9): level `l+1` has `⌈w/2⌉ x ⌈h/2⌉`
//!    texels; texel `(i, j)` reads the 4x4 texels `2i−1 ..= 2i+2`,
//!    `2j−1 ..= 2j+2` of level `l` (those inside it) with weights
//!    `[1, 3, 3, 1] x [1, 3, 3, 1]`. Over the valid ones it takes the
//!    weighted mean depth `m`; then colour and depth are the weighted means
//!    over the valid texels *not closer than* the mean (`Z >= m·(1 − 10⁻⁶)`,
//!    the factor only guards rounding). A texel with no valid input is not
//!    valid. Foreground thus dissolves level by level, and holes shrink.
//!    The pyramid goes up to 1x1.
//! 3. Epipolar search (§5.2): for a hole sample `p` and each reference
//!    warp (in warp order) whose derived-image epipole gives a direction
//!    `D(p)` (`Epipole::direction_at`; skipped where it is zero or not
//!    finite), probe along `−D(p)`, the side where the background
//!    uncovered by the warp lies (foreground moves along `+D` relative to
//!    background: `∂x'/∂δ = D(x')/W`), at distances `s = 1, 2, 4, 8, …`
//!    samples (exponentially growing steps) at the nearest sample, until a
//!    real sample is found (a border) or the probe leaves the image.
//! 4. Background preference: of the borders found (one per reference at
//!    most), the one with the largest depth Z wins; on a tie the nearer
//!    one, then the earlier reference.
//! 5. Level: with a border at `s`, the lookup starts at level
//!    `log₂ s + 1` (the first level whose filter reaches the border
//!    conservatively: the filter radius doubles per level). The colour is
//!    a bilinear lookup of that level *at `p` itself*, combining the four
//!    texels around `p` by rule 2's depth-aware rule (valid ones only,
//!    not closer than their mean), with bilinear weights. If that lookup
//!    has no valid texel, the next level is tried, up to the 1x1 level.
//! 6. No border found in any direction (every probe left the image, or no
//!    usable epipole): the lookup starts at level 1 and goes up the same
//!    way (`fallback`). Only a frame without a single real sample leaves
//!    holes empty (`unfilled`, black), so no hole reachable by the search
//!    stays empty.
//! 7. A filled sample gets the colour and the `hole` flag; real samples and
//!    every other plane are never changed.
//!
//! Parameters:
//! | name | unit | value | source |
//! |---|---|---|---|
//! | kernel | texels of the level below | 4x4, weights (1,3,3,1)² | ours (the paper: "a certain kernel size") |
//! | steps | samples | 1, 2, 4, … | paper ("exponentially increasing step size") |
//! | start level | level | log₂ s + 1 | ours (paper: "depends on the distance") |
//! | depth rule | – | not closer than the weighted mean depth | paper |
//!
//! Counters: `filled`, `border_found` (rule 3–5), `fallback` (rule 6),
//! `unfilled`, `pyramid_levels` (levels built; 0 when the frame has no
//! hole, in which case the pass stops at once).
//!
//! Not modelled: the GPU's mip-map hardware and the single shader pass
//! shared with the A-buffer ray casting (§6.1); a refined (binary) border
//! search; trilinear blending between levels. The `stretch` and
//! `rubber-sheet` comparisons of the paper's Table 2 are separate methods
//! (`docs/methods/schollmeyer.md`).

use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, HoleFill, Input, MethodInfo};
use glam::DVec2;
use serde_json::{Map, Value};

/// Rule 2's rounding guard on "not closer than the mean".
const DEPTH_GUARD: f64 = 1e-6;

/// One pyramid level (rules 1–2).
#[derive(Clone, Debug, PartialEq)]
pub struct PyramidLevel {
    /// Texels per row.
    pub width: u32,
    /// Texels per column.
    pub height: u32,
    /// Linear RGB.
    pub colour: Vec<[f32; 3]>,
    /// Depth Z (scene units).
    pub depth: Vec<f32>,
    /// Texel holds surface colour.
    pub valid: Vec<bool>,
}

/// Rule 2's depth-aware weighted mean of `taps` `(weight, colour, depth)`
/// (invalid taps left out by the caller).
fn combine(taps: &[(f64, [f32; 3], f32)]) -> Option<([f32; 3], f32)> {
    let (sw, swz) = taps.iter().filter(|t| t.0 > 0.0).fold((0.0, 0.0), |(a, b), t| (a + t.0, b + t.0 * t.2 as f64));
    if sw <= 0.0 {
        return None;
    }
    let m = swz / sw * (1.0 - DEPTH_GUARD);
    let (mut w, mut c, mut z) = (0.0, [0.0f64; 3], 0.0);
    for &(tw, tc, tz) in taps {
        if tw > 0.0 && tz as f64 >= m {
            w += tw;
            z += tw * tz as f64;
            for ch in 0..3 {
                c[ch] += tw * tc[ch] as f64;
            }
        }
    }
    (w > 0.0).then(|| (c.map(|v| (v / w) as f32), (z / w) as f32))
}

/// The depth-aware pyramid of `d` (rules 1–2), level 0 first.
pub fn pyramid(d: &DestPlanes) -> Vec<PyramidLevel> {
    let n = d.len();
    let valid: Vec<bool> = (0..n).map(|i| d.real[i] && d.inv_z[i] > 0.0 && d.inv_z[i].is_finite()).collect();
    let depth: Vec<f32> = (0..n).map(|i| if valid[i] { 1.0 / d.inv_z[i] } else { 0.0 }).collect();
    let mut levels = vec![PyramidLevel { width: d.width, height: d.height, colour: d.colour.clone(), depth, valid }];
    while let Some(l) = levels.last() {
        if (l.width <= 1 && l.height <= 1) || l.width == 0 || l.height == 0 {
            break;
        }
        let next = reduce(l);
        levels.push(next);
    }
    levels
}

/// Rule 2: one level up.
fn reduce(l: &PyramidLevel) -> PyramidLevel {
    const W: [f64; 4] = [1.0, 3.0, 3.0, 1.0];
    let (w, h) = (l.width.div_ceil(2), l.height.div_ceil(2));
    let n = (w * h) as usize;
    let mut out =
        PyramidLevel { width: w, height: h, colour: vec![[0.0; 3]; n], depth: vec![0.0; n], valid: vec![false; n] };
    let mut taps = Vec::with_capacity(16);
    for j in 0..h as i64 {
        for i in 0..w as i64 {
            taps.clear();
            for (ky, &wy) in W.iter().enumerate() {
                let y = 2 * j - 1 + ky as i64;
                if y < 0 || y >= l.height as i64 {
                    continue;
                }
                for (kx, &wx) in W.iter().enumerate() {
                    let x = 2 * i - 1 + kx as i64;
                    if x < 0 || x >= l.width as i64 {
                        continue;
                    }
                    let k = (y * l.width as i64 + x) as usize;
                    if l.valid[k] {
                        taps.push((wx * wy, l.colour[k], l.depth[k]));
                    }
                }
            }
            if let Some((c, z)) = combine(&taps) {
                let o = (j * w as i64 + i) as usize;
                out.colour[o] = c;
                out.depth[o] = z;
                out.valid[o] = true;
            }
        }
    }
    out
}

/// Rule 5's depth-aware bilinear lookup of level `l` (number `level`) at
/// derived sample position `p`.
pub fn lookup(l: &PyramidLevel, level: u32, p: DVec2) -> Option<([f32; 3], f32)> {
    let scale = (1u64 << level) as f64;
    let s = (p + 0.5) / scale - 0.5;
    let (fx, fy) = (s.x.floor(), s.y.floor());
    let (tx, ty) = (s.x - fx, s.y - fy);
    let mut taps = [(0.0, [0.0f32; 3], 0.0f32); 4];
    let mut n = 0;
    for (dy, wy) in [(0.0, 1.0 - ty), (1.0, ty)] {
        for (dx, wx) in [(0.0, 1.0 - tx), (1.0, tx)] {
            let x = (fx + dx).clamp(0.0, l.width as f64 - 1.0) as usize;
            let y = (fy + dy).clamp(0.0, l.height as f64 - 1.0) as usize;
            let k = y * l.width as usize + x;
            if l.valid[k] {
                taps[n] = (wx * wy, l.colour[k], l.depth[k]);
                n += 1;
            }
        }
    }
    combine(&taps[..n])
}

/// Rule 3–4: the border found from `p` as (depth, distance), if any.
fn search(d: &DestPlanes, input: &Input, p: DVec2) -> Option<(f32, u32)> {
    let (w, h) = (d.width as i64, d.height as i64);
    let limit = 2 * w.max(h) as u64;
    let mut best: Option<(f32, u32)> = None;
    for warp in &input.cmd.warps {
        let dir = warp.setup.epipole_derived.direction_at(p);
        let len = dir.length();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let u = -dir / len;
        let mut s = 1u64;
        while s <= limit {
            let q = p + u * s as f64;
            let (qx, qy) = (q.x.round(), q.y.round());
            if !(qx >= 0.0 && qy >= 0.0 && qx < w as f64 && qy < h as f64) {
                break;
            }
            let k = qy as usize * w as usize + qx as usize;
            if d.real[k] && d.inv_z[k] > 0.0 {
                let z = 1.0 / d.inv_z[k];
                let better = match best {
                    None => true,
                    Some((bz, bs)) => z > bz || (z == bz && (s as u32) < bs),
                };
                if better {
                    best = Some((z, s as u32));
                }
                break;
            }
            s *= 2;
        }
    }
    best
}

/// The depth-aware low-pass hole fill (module doc).
pub struct LowPass;

impl HoleFill for LowPass {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "low-pass",
            description: "Schollmeyer's depth-aware low-pass fill: background-preferring mip-map, level chosen by an epipolar border search with doubling steps",
            paper: "000 Schollmeyer et al. TVCG 2017 §5.2",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, input: &Input, d: &mut DestPlanes) -> Counters {
        // No hole: nothing to do, and no pyramid to build (same output).
        let any = (0..d.len()).any(|i| !d.real[i] && !d.hole[i]);
        let levels = if any { pyramid(d) } else { Vec::new() };
        let (mut filled, mut found, mut fallback, mut unfilled) = (0u64, 0u64, 0u64, 0u64);
        let w = d.width as usize;
        let top = levels.len().saturating_sub(1) as u32;
        let todo = if any { d.len() } else { 0 };
        for i in 0..todo {
            if d.real[i] || d.hole[i] {
                continue;
            }
            let p = DVec2::new((i % w) as f64, (i / w) as f64);
            let start = match search(d, input, p) {
                Some((_, s)) => {
                    found += 1;
                    s.trailing_zeros() + 1
                }
                None => {
                    fallback += 1;
                    1
                }
            };
            let colour = (start.min(top)..=top).find_map(|l| lookup(&levels[l as usize], l, p));
            match colour {
                Some((c, _)) if top > 0 => {
                    d.colour[i] = c;
                    d.hole.set(i, true);
                    filled += 1;
                }
                _ => unfilled += 1,
            }
        }
        let mut extra = Map::new();
        for (k, v) in [
            ("filled", filled),
            ("border_found", found),
            ("fallback", fallback),
            ("unfilled", unfilled),
            ("pyramid_levels", levels.len() as u64),
        ] {
            extra.insert(k.into(), Value::from(v));
        }
        Counters { primitives: 0, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: u32, h: u32, f: impl Fn(u32, u32) -> Option<([f32; 3], f32)>) -> DestPlanes {
        let mut d = DestPlanes::new(w, h);
        for y in 0..h {
            for x in 0..w {
                if let Some((c, z)) = f(x, y) {
                    let i = (y * w + x) as usize;
                    d.real.set(i, true);
                    d.colour[i] = c;
                    d.inv_z[i] = 1.0 / z;
                }
            }
        }
        d
    }

    #[test]
    fn reduction_drops_the_nearer_layer_and_holes() {
        // Left half near red, right half far blue, one column of holes.
        let d = frame(8, 8, |x, _| match x {
            0..=3 => Some(([1.0, 0.0, 0.0], 1.0)),
            4 => None,
            _ => Some(([0.0, 0.0, 1.0], 10.0)),
        });
        let p = pyramid(&d);
        assert_eq!(p.iter().map(|l| (l.width, l.height)).collect::<Vec<_>>(), [(8, 8), (4, 4), (2, 2), (1, 1)]);
        // Level 1 texel 2 reads columns 3..=6: red (near) and blue (far):
        // only blue survives.
        let t = &p[1];
        assert!(t.valid[2] && t.colour[2] == [0.0, 0.0, 1.0] && t.depth[2] == 10.0);
        // Texel 0 reads only red: stays red.
        assert_eq!(t.colour[0], [1.0, 0.0, 0.0]);
        assert_eq!(p[3].colour[0], [0.0, 0.0, 1.0]);
    }

    #[test]
    fn an_empty_frame_stays_empty_and_a_one_sample_frame_is_left_alone() {
        let d = frame(3, 2, |_, _| None);
        let p = pyramid(&d);
        assert!(p.iter().all(|l| l.valid.iter().all(|v| !v)));
        let one = frame(1, 1, |_, _| None);
        assert_eq!(pyramid(&one).len(), 1);
    }
}
