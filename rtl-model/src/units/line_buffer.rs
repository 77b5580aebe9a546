//! Kernel setup's line buffer: the warped samples of the traversal lines
//! around the current one, and the verdicts of their 2x2 groups.
//!
//! Job: give kernel setup the transform of any valid sample of the current
//! line and its neighbours (`warped`), and the verdict of any 2x2 group
//! around them (`group`), each computed once per warp.
//!
//! Ports: written by the transform results kernel setup absorbs; read by
//! kernel setup (groups, corners, the forward-edge neighbour).
//!
//! Throughput: any number of reads per cycle (the buffer is multi-ported in
//! the model; the unit's own throughput limits use).
//!
//! Rules:
//! 1. Its contents are pure functions of the reference samples and the
//!    warp: the transform of a sample, and the verdict of a group, never
//!    depend on when they are read.
//! 2. It holds four lines of the current sheet (the line, the one before,
//!    the one after, and the next one filling in), direct-mapped by line
//!    number modulo 4 and tagged with the position and the warp; a read
//!    that misses recomputes the same value (the host's memo of what the
//!    hardware buffer holds).
//!
//! Not modelled: capacity stalls (the buffer is sized for the longest line
//! of the reference), its write port (the transform's results arrive
//! through the transform pipeline, which is timed).

use super::kernel_setup::{Group, group};
use super::transform::{TransformUnit, Warped};
use crate::hw_reference::HwReference;
use crate::traversal::Major;
use glam::DVec2;

/// A cached transform of sample `(x, y)` in warp `warp` (`some`: not
/// culled).
#[derive(Clone, Copy)]
struct WarpEntry {
    x: u32,
    y: u32,
    warp: u32,
    some: bool,
    w: Warped,
}

/// A cached verdict of the 2x2 group at `(x, y)` in warp `warp`.
#[derive(Clone, Copy)]
struct GroupEntry {
    x: u32,
    y: u32,
    warp: u32,
    g: Group,
}

/// The line buffer (module doc), reused across warps.
#[derive(Default)]
pub struct LineBuffer {
    warps: Vec<WarpEntry>,
    groups: Vec<GroupEntry>,
    /// Entries per ring line (the longer image side).
    stride: usize,
    warp_no: u32,
}

impl LineBuffer {
    /// Ready the buffer for a warp of a `w x h` reference.
    pub fn begin_warp(&mut self, w: u32, h: u32) {
        let stride = w.max(h) as usize;
        if self.stride < stride {
            self.stride = stride;
            let none = Warped { pos: DVec2::ZERO, inv_z: 0.0, e: 0.0 };
            self.warps = vec![WarpEntry { x: 0, y: 0, warp: 0, some: false, w: none }; 4 * stride];
            self.groups = vec![GroupEntry { x: 0, y: 0, warp: 0, g: Group::Missing }; 4 * stride];
        }
        self.warp_no += 1;
    }

    /// Ring slot of position `(x, y)` when the current line runs along
    /// `major`.
    #[inline(always)]
    fn slot(&self, major: Major, x: u32, y: u32) -> usize {
        match major {
            Major::Row => (y & 3) as usize * self.stride + x as usize,
            Major::Column => (x & 3) as usize * self.stride + y as usize,
        }
    }

    /// The transform of valid sample `(x, y)` of `r` (`None`: culled).
    #[inline(always)]
    pub fn warped(&mut self, tu: &TransformUnit, r: &HwReference, major: Major, x: u32, y: u32) -> Option<Warped> {
        let s = self.slot(major, x, y);
        let wno = self.warp_no;
        let e = &mut self.warps[s];
        if e.warp == wno && e.x == x && e.y == y {
            return e.some.then_some(e.w);
        }
        let w = tu.warp(x as f64, y as f64, r.rec(major, x, y).inv_z);
        *e = WarpEntry { x, y, warp: wno, some: w.is_some(), w: w.unwrap_or(e.w) };
        w
    }

    /// The verdict of the 2x2 group whose top-left sample is `(gx, gy)`
    /// (`None`: the group leaves the `w x h` image). `transformed(gi)`
    /// tells whether the transform has already streamed sample `gi` (grid
    /// index) in this warp; reading one it has not is a schedule error.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn group(
        &mut self,
        tu: &TransformUnit,
        r: &HwReference,
        major: Major,
        (gx, gy): (i64, i64),
        threshold: f64,
        transformed: impl Fn(usize) -> bool,
    ) -> Option<Group> {
        let (w, h) = (r.samples.width, r.samples.height);
        if gx < 0 || gy < 0 || gx as u32 + 1 >= w || gy as u32 + 1 >= h {
            return None;
        }
        let (gx, gy) = (gx as u32, gy as u32);
        let s = self.slot(major, gx, gy);
        let e = &self.groups[s];
        if e.warp != self.warp_no || e.x != gx || e.y != gy {
            let mut at = |x: u32, y: u32| {
                let j = r.grid.index(x, y);
                if r.valid_at(j) {
                    assert!(transformed(j), "group read ({x}, {y}) before it was transformed");
                    self.warped(tu, r, major, x, y)
                } else {
                    None
                }
            };
            let (a, b, c, d) = (at(gx, gy), at(gx + 1, gy), at(gx, gy + 1), at(gx + 1, gy + 1));
            let g = group(a, b, c, d, threshold);
            self.groups[s] = GroupEntry { x: gx, y: gy, warp: self.warp_no, g };
        }
        Some(self.groups[s].g)
    }
}
