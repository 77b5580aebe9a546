//! Which pixels of the right view of a rectified stereo pair the left view
//! sees, from the left view's disparity: the ground truth's `seen` mask of
//! an imported pair (`docs/trace-format.md`, `docs/metrics.md`).
//!
//! Rules:
//! 1. A left pixel `(x, y)` with a finite disparity `d` appears at
//!    `(x − d, y)` in the right view (`middlebury` rules).
//! 2. Each such pixel marks the right pixels whose centres lie within half
//!    a pixel of its image: `x − d − ½ ≤ j < x − d + ½`.
//! 3. Two left neighbours on a row whose disparities differ by at most
//!    [`JOIN_PX`] are one surface: every right pixel centre between their
//!    images is marked too (a slanted surface is stretched, not torn).
//! 4. Everything else is not seen: the strip beyond the left camera's
//!    field of view, disocclusions (background the left view has behind a
//!    foreground edge), and what only unknown-disparity pixels could show.
//!
//! Not modelled: a right pixel showing a surface the left view cannot see
//! in front of one it can (a surface facing only the right camera) is
//! marked seen.

use bitvec::vec::BitVec;

/// Largest disparity difference (pixels) between row neighbours that are
/// taken to be one surface (rule 3).
pub const JOIN_PX: f32 = 1.0;

/// The right-view pixels the left view sees (rules 1–4): `disp` is the
/// left disparity, `width · height` values, rows top to bottom, non-finite
/// where unknown.
pub fn seen_from_disparity(disp: &[f32], width: u32, height: u32) -> BitVec {
    let (w, h) = (width as usize, height as usize);
    let mut seen = BitVec::repeat(false, w * h);
    // Marks right pixel centres j with lo ≤ j < hi on row y.
    let mut mark = |y: usize, lo: f32, hi: f32| {
        let a = lo.ceil().max(0.0);
        let b = hi.ceil().min(w as f32);
        let mut j = a;
        while j < b {
            seen.set(y * w + j as usize, true);
            j += 1.0;
        }
    };
    for y in 0..h {
        for x in 0..w {
            let d = disp[y * w + x];
            if !d.is_finite() {
                continue;
            }
            let p = x as f32 - d;
            mark(y, p - 0.5, p + 0.5);
            if x + 1 < w {
                let dn = disp[y * w + x + 1];
                if dn.is_finite() && (dn - d).abs() <= JOIN_PX {
                    let q = (x + 1) as f32 - dn;
                    mark(y, p.min(q), p.max(q));
                }
            }
        }
    }
    seen
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(seen: &BitVec) -> String {
        seen.iter().map(|b| if *b { '#' } else { '.' }).collect()
    }

    #[test]
    fn a_constant_disparity_leaves_the_right_strip_unseen() {
        let disp = [2.0f32; 8];
        assert_eq!(row(&seen_from_disparity(&disp, 8, 1)), "######..");
    }

    #[test]
    fn a_foreground_step_opens_a_disocclusion() {
        // Background d = 1 on the left half, foreground d = 4 on the right:
        // the right view sees background the left view had behind the step.
        let disp = [1.0, 1.0, 1.0, 1.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0];
        // Background: 0..4 → −1..3 (−1 off the image); foreground: 4..10 → 0..6.
        assert_eq!(row(&seen_from_disparity(&disp, 10, 1)), "######....");
        let disp = [4.0, 4.0, 4.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        // Foreground 0..3 → −4..−1 (off), background 3..10 → 2..9: 0 and 1
        // are beyond the left view's edge on the foreground's side.
        assert_eq!(row(&seen_from_disparity(&disp, 10, 1)), "..#######.");
    }

    #[test]
    fn a_slanted_surface_is_joined_and_unknown_pixels_see_nothing() {
        // Disparity grows by 0.5 per pixel: images 1 px apart... then 0.5.
        let disp = [0.0, 0.5, 1.0, 1.5, 2.0, f32::INFINITY, f32::INFINITY, 3.0];
        let s = seen_from_disparity(&disp, 8, 1);
        // Pixels 0..5 map to 0, 0.5, 1, 1.5, 2 (joined); pixel 7 to 4.
        assert_eq!(row(&s), "###.#...");
    }
}
