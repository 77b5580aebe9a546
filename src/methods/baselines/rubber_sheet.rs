//! Rubber sheets: the whole reference image as one triangle mesh, with no
//! discontinuity test. The "preventive" hole fill of seed 000 (Schollmeyer
//! et al. §2 and Table 2, "rubber sheets": stretching the texture over the
//! holes, "artificial geometry ... spanning the gap between foreground and
//! background") and the mesh-like resampling TR98 §3–4 shows in its
//! Figure 5 (seed 003): no pinholes, no blockiness inside surfaces, but
//! sheets of interpolated colour stretched across every disocclusion.
//!
//! Job: make a derived frame in which every derived sample inside the
//! warped footprint of a reference is covered, foreground and background
//! connected.
//!
//! Rules:
//! 1. Every valid reference sample is warped with its warp's
//!    [`WarpSetup::warp`] on the sample grids of both cameras; a sample
//!    behind the derived camera (`W <= 0`) or landing at a non-finite
//!    position is *culled*.
//! 2. Every 2x2 group of reference samples A (x, y), B (x+1, y),
//!    C (x, y+1), D (x+1, y+1) is split along the fixed diagonal A–D into
//!    triangles (A, B, D) and (A, D, C), as the golden model's general
//!    mesh (`golden::general` rule 2), but *without* its discontinuity and
//!    fold-over tests: foreground and background are connected.
//! 3. A triangle with a vertex without a surface is dropped
//!    (`dropped_missing`); otherwise one with a culled vertex is dropped
//!    (`dropped_culled`).
//! 4. The rest are drawn with `golden::general::triangle` (top-left rule,
//!    screen-space barycentrics): a triangle whose derived winding is not
//!    positive (back-facing, folded over or degenerate) covers nothing;
//!    no cracks and no double coverage between triangles sharing an edge.
//! 5. Interpolation in the derived image (linear in screen space, as TR98):
//!    colour and 1/Z from the three vertices, starting from the vertex with
//!    the largest weight so that a centre on a vertex gets its exact values.
//! 6. Z test: the larger derived 1/Z wins; on equal 1/Z the sample already
//!    there stays. The winner sets `real`, `colour`, `inv_z` and `source`.
//! 7. Order: references in warp order; groups in raster order of their top
//!    left sample; (A, B, D) before (A, D, C); centres row by row.
//!
//! Parameters: none. Compared with Mark's general path (`golden::general`),
//! the discontinuity threshold (1.4, TR98 §6), the fold-over test and the
//! edge splats are gone: that is the point.
//!
//! Primitives: triangles drawn (rule 4: all three vertices warped, so set
//! up; back-facing and off-image ones included). Counters
//! (`Counters::extra`): `reference_samples`, `culled_samples`,
//! `dropped_missing`, `dropped_culled`, `back_facing` (drawn, zero
//! coverage by winding or non-finite area), `off_image` (front-facing,
//! bounding box off the image), `samples_written` (Z-test wins, empty or
//! nearer), `lost` (Z-test losses).
//!
//! Not modelled: a low-pass filter on depth before meshing (which seed 000
//! notes reduces the artefacts), TR98's old "low-confidence" mesh elements
//! (flat far colour, losing to any true surface), perspective-correct
//! colour interpolation, the hole fill (the paper pairs rubber sheets with
//! none: it is preventive), hardware rasterizer cost.

use crate::golden::general::{Window, triangle};
use crate::golden::planes::DestPlanes;
use crate::methods::{Counters, Input, MethodInfo, Reconstruction};
use glam::DVec2;
use postwarp_rtl::{SampleImage, WarpSetup};
use serde_json::Map;

/// Counters of one derived frame (units: reference samples or triangles,
/// over all warps).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RubberSheetStats {
    /// Reference samples with a surface.
    pub reference_samples: u64,
    /// Samples behind the derived camera or at non-finite positions.
    pub culled_samples: u64,
    /// Triangles drawn (rule 4).
    pub triangles: u64,
    /// Triangles dropped for a vertex without surface.
    pub dropped_missing: u64,
    /// Triangles dropped for a culled vertex.
    pub dropped_culled: u64,
    /// Drawn triangles of non-positive or non-finite derived area.
    pub back_facing: u64,
    /// Drawn front-facing triangles whose bounding box misses the image.
    pub off_image: u64,
    /// Derived samples written (Z-test wins).
    pub samples_written: u64,
    /// Candidate samples that lost the Z test.
    pub lost: u64,
}

/// A warped vertex: derived position and 1/Z.
#[derive(Clone, Copy)]
struct Vertex {
    pos: DVec2,
    inv_z: f64,
}

/// Rules 1–7 into `d` (an empty frame of the derived sample grid's size).
pub fn rubber_sheet_into(input: &Input, d: &mut DestPlanes) -> RubberSheetStats {
    assert_eq!(input.refs.len(), input.cmd.warps.len(), "one reference image per warp");
    let mut st = RubberSheetStats::default();
    for (j, (warp, img)) in input.cmd.warps.iter().zip(input.refs).enumerate() {
        sheet_reference(&warp.setup, img, j as u8, d, &mut st);
    }
    st
}

/// Rule 1: `None` = no surface; `Some(None)` = culled.
fn warp_all(setup: &WarpSetup, img: &SampleImage, st: &mut RubberSheetStats) -> Vec<Option<Option<Vertex>>> {
    let w = img.width as usize;
    (0..img.len())
        .map(|i| {
            if !img.valid[i] {
                return None;
            }
            st.reference_samples += 1;
            let t = setup.warp((i % w) as f64, (i / w) as f64, 1.0 / img.z[i] as f64);
            if t.w > 0.0 && t.position.is_finite() && t.inv_z.is_finite() {
                Some(Some(Vertex { pos: t.position, inv_z: t.inv_z }))
            } else {
                st.culled_samples += 1;
                Some(None)
            }
        })
        .collect()
}

fn sheet_reference(setup: &WarpSetup, img: &SampleImage, source: u8, d: &mut DestPlanes, st: &mut RubberSheetStats) {
    let warped = warp_all(setup, img, st);
    let (w, h) = (img.width as usize, img.height as usize);
    for gy in 0..h.saturating_sub(1) {
        for gx in 0..w.saturating_sub(1) {
            let (a, b, c, dd) = (gy * w + gx, gy * w + gx + 1, (gy + 1) * w + gx, (gy + 1) * w + gx + 1);
            for tri in [[a, b, dd], [a, dd, c]] {
                let v = tri.map(|k| warped[k]);
                if v.iter().any(|v| v.is_none()) {
                    st.dropped_missing += 1;
                    continue;
                }
                let v = v.map(|v| v.expect("checked"));
                let Some(v) = (v[0].zip(v[1]).zip(v[2])).map(|((a, b), c)| [a, b, c]) else {
                    st.dropped_culled += 1;
                    continue;
                };
                st.triangles += 1;
                draw(v, tri.map(|k| img.colour[k]), source, d, st);
            }
        }
    }
}

/// Rules 4–6 for one triangle.
fn draw(v: [Vertex; 3], colour: [[f32; 3]; 3], source: u8, d: &mut DestPlanes, st: &mut RubberSheetStats) {
    let p = v.map(|v| v.pos);
    let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    if !(area2 > 0.0 && area2.is_finite()) {
        st.back_facing += 1;
        return;
    }
    let (x0, x1) = (p[0].x.min(p[1].x).min(p[2].x), p[0].x.max(p[1].x).max(p[2].x));
    let (y0, y1) = (p[0].y.min(p[1].y).min(p[2].y), p[0].y.max(p[1].y).max(p[2].y));
    // Clip to the image in f64 before converting (huge sheets near the
    // camera plane stay cheap).
    let (wf, hf) = (d.width as f64 - 1.0, d.height as f64 - 1.0);
    let win: Window = (
        (x0.ceil().max(0.0) as i64, x1.floor().min(wf) as i64),
        (y0.ceil().max(0.0) as i64, y1.floor().min(hf) as i64),
    );
    if win.0.0 > win.0.1 || win.1.0 > win.1.1 {
        st.off_image += 1;
        return;
    }
    let z = v.map(|v| v.inv_z);
    let width = d.width as usize;
    triangle(p, win, |sx, sy, wts| {
        let b = (0..3).fold(0, |b, k| if wts[k] > wts[b] { k } else { b });
        let lerp = |q: [f64; 3]| q[b] + (0..3).filter(|&k| k != b).map(|k| wts[k] * (q[k] - q[b])).sum::<f64>();
        let inv_z = lerp(z) as f32;
        let k = sy as usize * width + sx as usize;
        if d.real[k] && inv_z <= d.inv_z[k] {
            st.lost += 1;
            return;
        }
        d.real.set(k, true);
        d.inv_z[k] = inv_z;
        d.colour[k] =
            [0, 1, 2].map(|ch| lerp([colour[0][ch] as f64, colour[1][ch] as f64, colour[2][ch] as f64]) as f32);
        d.source[k] = source;
        st.samples_written += 1;
    });
}

/// Rubber sheets as a [`Reconstruction`] (`rubber-sheet`).
pub struct RubberSheet;

impl Reconstruction for RubberSheet {
    fn info(&self) -> MethodInfo {
        MethodInfo {
            name: "rubber-sheet",
            description: "rubber sheets: every 2x2 group of reference samples meshed as two triangles, no discontinuity test, colour and 1/Z interpolated, Z test",
            paper: "000 Schollmeyer et al. §2, Table 2 \"rubber sheets\"; 003 TR98-011 §4 Fig. 5",
            primitive: "triangles",
            default_hole_fill: "none",
        }
    }

    fn reconstruct(&self, input: &Input, out: &mut DestPlanes) -> Counters {
        let st = rubber_sheet_into(input, out);
        let mut extra = Map::new();
        for (k, v) in [
            ("reference_samples", st.reference_samples),
            ("culled_samples", st.culled_samples),
            ("dropped_missing", st.dropped_missing),
            ("dropped_culled", st.dropped_culled),
            ("back_facing", st.back_facing),
            ("off_image", st.off_image),
            ("samples_written", st.samples_written),
            ("lost", st.lost),
        ] {
            extra.insert(k.into(), v.into());
        }
        Counters { primitives: st.triangles, extra }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::Prepared;
    use crate::methods::test_frames::cam;
    use postwarp_rtl::FrameCommands;

    #[test]
    fn identity_warp_covers_the_interior_and_reproduces_it() {
        let c = cam(10, 6, 0.0);
        let mut img = SampleImage::empty(10, 6);
        for i in 0..img.len() {
            img.valid.set(i, i != 23);
            img.z[i] = 2.0;
            img.colour[i] = [i as f32 / 60.0, 0.5, 0.25];
        }
        let cmd = FrameCommands::new(0, c, 1, &[(0, c)]);
        let p: Prepared = Box::new(());
        let input = Input { cmd: &cmd, refs: &[&img], prepared: &[&p] };
        let mut d = input.empty_frame();
        let st = rubber_sheet_into(&input, &mut d);
        // 9x5 groups, 2 triangles each; sample 23 (3, 2) is in 4 groups,
        // touching 6 triangles.
        assert_eq!(st.triangles + st.dropped_missing, 90);
        assert_eq!(st.dropped_missing, 6);
        for y in 0..6 {
            for x in 0..10 {
                let k = y * 10 + x;
                // Bottom and right borders are not owned (top-left rule);
                // each centre is owned by the (A, B, D) triangle of the
                // group it is A of: those touching sample 23 are dropped.
                let near_hole = [(3, 2), (2, 2), (2, 1)].contains(&(x, y));
                let want = x < 9 && y < 5 && !near_hole;
                assert_eq!(d.real[k], want, "({x}, {y})");
                if want {
                    assert_eq!(d.colour[k], img.colour[k]);
                    assert_eq!(d.inv_z[k], 0.5);
                }
            }
        }
    }
}
