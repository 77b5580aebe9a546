//! Stretch hole fill: the epipolar copy without the blur. Seed 000
//! (Schollmeyer et al.) calls it "stretch inpaint" (Table 2: "extend the
//! boundary color of a hole in epipolar direction", which "has similar
//! results as the preventive rubber sheet approach"); TR98 §9 (seed 003)
//! describes it as "filling every hole pixel with the nearest background
//! object along the pixel's epipolar line" and shows its stripes (Fig. 13a,
//! Plate 4b) before adding the blur of Mark's `epipolar` fill.
//!
//! Job: give every empty derived sample (neither `real` nor `hole`) the
//! colour of one real sample: the nearest surface behind it along its
//! epipolar line, on the background side. One tap, no averaging: the filled
//! colours are a subset of the real colours.
//!
//! Rules:
//! 1. Direction: the same convention as Mark's fill (`golden::hole_fill`
//!    rule 1, `golden::traversal` rule 1): with the derived-image epipole
//!    `ê = (ex, ey, ew)` of a reference warp, the occlusion-compatible
//!    direction at `p` is `D(p) = (ex − px·ew, ey − py·ew)`, and a hole is
//!    filled from the `−D(p)` side (the side Mark's forward-order pass has
//!    already visited): away from a front epipole (`ew > 0`), toward a
//!    behind one (`ew < 0`), against `(ex, ey)` for one at infinity. For
//!    coincident centres (`ê = 0`) the traversal's convention `D = (0, 1)`
//!    holds: fill from above.
//! 2. Search: from the hole's centre `p`, march along the exact half-line
//!    `p − t·D(p)/m`, `m = max(|Dx|, |Dy|)`, for `t = 1, 2, …` (one step per
//!    row or column crossed), looking at the sample nearest each point
//!    (coordinates rounded, halves away from zero). The first real sample
//!    met gives the colour; its distance is `t·|D|/m` (samples). The march
//!    stops, unreached, when it leaves the image, or, toward a behind
//!    epipole, when it passes the epipole (beyond it lies the other
//!    half-line). A hole at the epipole itself (`D = 0`) is unreached.
//! 3. Only real samples are sources; filled samples are never copied on,
//!    so each fill is independent of the order holes are visited (no
//!    traversal needed) and the line does not drift as a one-sample-back
//!    propagation does.
//! 4. Several references: one pass per reference warp, in warp order, each
//!    with its warp's derived-image epipole (as `mark::Epipolar` does after
//!    a non-Mark reconstruction), over the samples empty when the fill
//!    began. A later pass replaces an earlier pass's colour only if its
//!    source is strictly nearer (rule 2's distance): TR98 §9.1 weights each
//!    reference's fill by 1/distance; with no averaging allowed, the
//!    largest weight wins outright. Ties keep the earlier warp.
//! 5. Filled samples are flagged `hole`; real samples are never written.
//!
//! Parameters: none. Compared with Mark's fill (`golden::hole_fill`), the
//! near taps (3), far taps (2 at ±4 samples past distance 4) and distance
//! saturation (63 samples) are all gone: one tap, and the search ends only
//! at the image border or the epipole.
//!
//! Counters (`Counters::extra`): `filled` (samples given a colour),
//! `unreached` (empty samples no pass reached), `replaced` (fills a later
//! pass replaced with a nearer source), `march_steps` (samples looked at,
//! all passes: the work).
//!
//! Not modelled: TR98's forward-edge colours (App. B.1: here a hole next
//! to a non-convex foreground can copy the foreground colour), the
//! eight-sheet single pass of a hardware implementation (here a per-hole
//! march, cost proportional to hole size times distance), any blur.

use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, HoleFill, Input, MethodInfo};
use glam::DVec2;
use postwarp_rtl::camera::{Epipole, EpipoleKind};
use serde_json::{Map, json};

/// The source of one hole's fill for one epipole (rule 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Index of the real sample copied.
    pub sample: usize,
    /// Distance from the hole's centre along the epipolar line (samples).
    pub distance: f64,
}

/// Rule 2 for the hole at `(x, y)` of `d` and the epipole `e`; `steps`
/// counts the samples looked at.
pub fn search(d: &DestPlanes, e: &Epipole, x: u32, y: u32, steps: &mut u64) -> Option<Source> {
    let p = DVec2::new(x as f64, y as f64);
    // Back direction −D and, toward a behind epipole, the distance to it.
    let (back, limit) = match e.kind() {
        EpipoleKind::Coincident => (DVec2::new(0.0, -1.0), f64::INFINITY),
        EpipoleKind::Infinity { .. } => (-e.direction_at(p), f64::INFINITY),
        EpipoleKind::Front { .. } => (-e.direction_at(p), f64::INFINITY),
        EpipoleKind::Behind { point } => (-e.direction_at(p), (point - p).length()),
    };
    let m = back.x.abs().max(back.y.abs());
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let v = back / m;
    let step_len = v.length();
    let (w, h) = (d.width as f64, d.height as f64);
    // Each step moves one sample along the major axis: out of the image
    // after at most `max(w, h)` steps.
    for t in 1..=d.width.max(d.height) {
        let q = p + v * t as f64;
        let distance = step_len * t as f64;
        if distance > limit {
            return None;
        }
        let (qx, qy) = (q.x.round(), q.y.round());
        // Also stops on NaN.
        if !(qx >= 0.0 && qy >= 0.0 && qx < w && qy < h) {
            return None;
        }
        *steps += 1;
        let k = qy as usize * d.width as usize + qx as usize;
        if d.real[k] {
            return Some(Source { sample: k, distance });
        }
    }
    None
}

/// Counters of a stretch fill.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StretchStats {
    /// Samples given a colour.
    pub filled: u64,
    /// Empty samples no pass reached.
    pub unreached: u64,
    /// Fills replaced by a later pass with a nearer source.
    pub replaced: u64,
    /// Samples looked at over all passes.
    pub march_steps: u64,
}

/// Rules 1–5 on `d`, one pass per epipole in `epipoles` (warp order).
pub fn stretch(d: &mut DestPlanes, epipoles: &[Epipole]) -> StretchStats {
    let mut st = StretchStats::default();
    let targets: Vec<usize> = (0..d.len()).filter(|&i| !d.real[i] && !d.hole[i]).collect();
    if d.real.not_any() {
        st.unreached = targets.len() as u64;
        return st;
    }
    let mut best: Vec<Option<Source>> = vec![None; targets.len()];
    let w = d.width as usize;
    for e in epipoles {
        for (slot, &i) in best.iter_mut().zip(&targets) {
            let Some(s) = search(d, e, (i % w) as u32, (i / w) as u32, &mut st.march_steps) else { continue };
            match slot {
                Some(old) if s.distance >= old.distance => {}
                Some(_) => {
                    st.replaced += 1;
                    *slot = Some(s);
                }
                None => *slot = Some(s),
            }
        }
    }
    for (slot, &i) in best.iter().zip(&targets) {
        match slot {
            Some(s) => {
                d.colour[i] = d.colour[s.sample];
                d.hole.set(i, true);
                st.filled += 1;
            }
            None => st.unreached += 1,
        }
    }
    st
}

/// The stretch fill as a [`HoleFill`] (`stretch`).
pub struct Stretch;

impl HoleFill for Stretch {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "stretch",
            description: "stretch inpaint: each hole copies the nearest real sample behind it along its epipolar line (background side), no blur",
            paper: "000 Schollmeyer et al. Table 2 \"stretch inpaint\"; 003 TR98-011 §9 without the blur (Fig. 13a)",
            primitive: "",
            default_hole_fill: "",
        }
    }

    fn fill(&self, input: &Input, d: &mut DestPlanes) -> Counters {
        let epipoles: Vec<Epipole> = input.cmd.warps.iter().map(|w| w.setup.epipole_derived).collect();
        let st = stretch(d, &epipoles);
        let mut extra = Map::new();
        for (k, v) in [
            ("filled", st.filled),
            ("unreached", st.unreached),
            ("replaced", st.replaced),
            ("march_steps", st.march_steps),
        ] {
            extra.insert(k.into(), json!(v));
        }
        Counters { primitives: 0, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn copies_the_first_real_sample_against_the_direction() {
        // Real at x = 0 (red) and x = 9 (blue); epipole at infinity along
        // +x: holes copy from their left, i.e. red.
        let mut d = DestPlanes::new(10, 1);
        d.real.set(0, true);
        d.colour[0] = [1.0, 0.0, 0.0];
        d.real.set(9, true);
        d.colour[9] = [0.0, 0.0, 1.0];
        let st = stretch(&mut d, &[Epipole { h: DVec3::new(1.0, 0.0, 0.0) }]);
        assert_eq!((st.filled, st.unreached), (8, 0));
        assert!((1..9).all(|x| d.colour[x] == [1.0, 0.0, 0.0] && d.hole[x]));
        assert_eq!(st.march_steps, (1..=8).sum::<u64>());
    }

    #[test]
    fn nearer_source_of_a_later_pass_wins() {
        let mut d = DestPlanes::new(10, 1);
        d.real.set(0, true);
        d.colour[0] = [1.0, 0.0, 0.0];
        d.real.set(9, true);
        d.colour[9] = [0.0, 0.0, 1.0];
        let right = Epipole { h: DVec3::new(1.0, 0.0, 0.0) };
        let left = Epipole { h: DVec3::new(-1.0, 0.0, 0.0) };
        let st = stretch(&mut d, &[right, left]);
        // Samples 1..=4 are nearer red (tie at none: 4 is 4 from red, 5 from blue).
        for x in 1..9 {
            let want = if x <= 4 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] };
            assert_eq!(d.colour[x], want, "{x}");
        }
        assert_eq!(st.replaced, 4);
    }

    #[test]
    fn behind_epipole_stops_at_the_epipole() {
        // Epipole behind at x = 4.5: the hole at x = 6 looks toward it and
        // finds nothing before passing it (real sample at x = 2 is beyond).
        let mut d = DestPlanes::new(8, 1);
        d.real.set(2, true);
        let st = stretch(&mut d, &[Epipole { h: DVec3::new(-4.5, 0.0, -1.0) }]);
        assert!(!d.hole[6] && !d.hole[7]);
        // x = 3 and 4 look right toward 4.5 and stop; x = 0, 1 look right and hit 2.
        assert!(d.hole[0] && d.hole[1] && !d.hole[3]);
        assert_eq!(st.filled, 2);
    }
}
