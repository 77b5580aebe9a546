//! Kernel setup's line buffer: the warped samples of the traversal lines
//! around the current one, and the verdicts of their 2x2 groups.
//!
//! Job: give kernel setup the transform of any valid sample of the current
//! line and of its two neighbour lines, and the verdict of any 2x2 group
//! around them, each computed once per warp.
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
//! 2. Positions are `(line, along)`: the row and column of a row-major
//!    sheet, or the column and row of a column-major one. The buffer holds
//!    four lines of warped samples and four lines of group verdicts, by
//!    line number modulo 4, each tagged with the warp, the sheet's axis and
//!    the line, over the range of positions computed so far; a read of a
//!    position not yet computed computes it (the host's model of what the
//!    hardware buffer holds when kernel setup reads it).
//! 3. A group is named by its top-left sample `(gx, gy)` in image
//!    coordinates, and covers `gx..=gx+1 × gy..=gy+1`; groups reaching past
//!    the image do not exist.
//! 4. Every position computed is listed once ([`LineBuffer::take_warped`]),
//!    so that kernel setup can check that the transform unit has streamed
//!    each valid sample before it reads it (a schedule that lets kernel
//!    setup read ahead of the fetch plan is a bug, and panics).
//!
//! Not modelled: capacity stalls (the buffer is sized for the longest line
//! of the reference), its write port (the transform's results arrive
//! through the transform pipeline, which is timed).

use super::kernel_setup::{Group, group_in};
use super::transform::{TransformUnit, Transformed};
use crate::hw_reference::{HwReference, RefSample};
use crate::ref_blocks::RefBlocks;
use crate::traversal::Major;

/// One buffered line: values at positions `lo..=hi` along it.
struct Row<T> {
    warp: u32,
    major: Major,
    line: i64,
    /// Computed range (inclusive; empty when `lo > hi`).
    lo: i64,
    hi: i64,
    data: Vec<T>,
}

impl<T: Clone> Row<T> {
    fn new(len: usize, fill: T) -> Row<T> {
        Row { warp: 0, major: Major::Row, line: -1, lo: 0, hi: -1, data: vec![fill; len] }
    }

    /// The positions of `a0..=a1` still to compute, as up to two ranges,
    /// after retagging the row for `(warp, major, line)` if it held another.
    fn missing(&mut self, warp: u32, major: Major, line: i64, a0: i64, a1: i64) -> [(i64, i64); 2] {
        if self.warp != warp || self.major != major || self.line != line || self.lo > self.hi {
            self.warp = warp;
            self.major = major;
            self.line = line;
            self.lo = a0;
            self.hi = a1;
            return [(a0, a1), (1, 0)];
        }
        if a0 > self.hi + 1 || a1 < self.lo - 1 {
            // Disjoint from what is held: start the row afresh (no gap is
            // ever claimed computed).
            self.lo = a0;
            self.hi = a1;
            return [(a0, a1), (1, 0)];
        }
        let left = (a0, self.lo - 1);
        let right = (self.hi + 1, a1);
        self.lo = self.lo.min(a0);
        self.hi = self.hi.max(a1);
        [left, right]
    }
}

/// The line buffer (module doc), reused across warps.
#[derive(Default)]
pub struct LineBuffer {
    warp_no: u32,
    /// Lines along each axis: image height and width (samples).
    size: (u32, u32),
    warps: Vec<Row<Option<Transformed>>>,
    groups: Vec<Row<Option<Group>>>,
    /// Host scratch: the reference 1/Z of the run being warped, gathered
    /// before the warp (a column sheet's records are a row apart, and
    /// independent loads overlap their misses where the incremental warp's
    /// chain would wait on each). No model state.
    inv_z_run: Vec<f64>,
    /// Host scratch: the records of that run (`crate::ref_blocks`).
    recs_run: Vec<RefSample>,
    /// The runs of warped positions computed since the last
    /// [`LineBuffer::take_warped`] (rule 4).
    warped: Vec<WarpedRun>,
}

/// A run of positions whose warps the buffer computed: positions `a0..=a1`
/// of line `line` along `major` (rule 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WarpedRun {
    /// The line's axis.
    pub major: Major,
    /// The line.
    pub line: i64,
    /// First position.
    pub a0: i64,
    /// Last position (inclusive).
    pub a1: i64,
}

/// What the buffer reads to compute its contents.
#[derive(Clone, Copy)]
pub struct Sources<'a> {
    /// The warp's transform unit.
    pub tu: &'a TransformUnit,
    /// The reference.
    pub r: &'a HwReference,
    /// Discontinuity threshold (ratio of E).
    pub threshold: f64,
}

impl LineBuffer {
    /// Ready the buffer for a warp of a `w x h` reference.
    pub fn begin_warp(&mut self, w: u32, h: u32) {
        let len = w.max(h) as usize;
        if self.warps.first().is_none_or(|r| r.data.len() < len) {
            self.warps = (0..4).map(|_| Row::new(len, None)).collect();
            self.groups = (0..4).map(|_| Row::new(len, None)).collect();
        }
        self.warp_no += 1;
        self.size = (w, h);
        self.warped.clear();
    }

    /// Lines and positions per line along `major`.
    #[inline]
    fn extent(&self, major: Major) -> (i64, i64) {
        match major {
            Major::Row => (self.size.1 as i64, self.size.0 as i64),
            Major::Column => (self.size.0 as i64, self.size.1 as i64),
        }
    }

    /// Make sure line `line` holds warped samples at `a0..=a1` (clipped to
    /// the image).
    pub fn fill_warps(&mut self, s: Sources<'_>, blocks: &mut RefBlocks, major: Major, line: i64, a0: i64, a1: i64) {
        let (lines, len) = self.extent(major);
        let (a0, a1) = (a0.max(0), a1.min(len - 1));
        if line < 0 || line >= lines || a0 > a1 {
            return;
        }
        let row = &mut self.warps[(line & 3) as usize];
        let step = match major {
            Major::Row => (1.0, 0.0),
            Major::Column => (0.0, 1.0),
        };
        for (b0, b1) in row.missing(self.warp_no, major, line, a0, a1) {
            if b0 > b1 {
                continue;
            }
            let (x0, y0) = at(major, line, b0);
            let out = &mut row.data[b0 as usize..=b1 as usize];
            self.recs_run.clear();
            blocks.line(s.r, major, line as u32, b0 as u32, b1 as u32, &mut self.recs_run);
            self.inv_z_run.clear();
            self.inv_z_run.extend(self.recs_run.iter().map(|rec| s.r.inv_z(rec)));
            let run = &self.inv_z_run;
            s.tu.warp_run((x0 as f64, y0 as f64), step, |k| run[k], out);
            for (a, o) in (b0..=b1).zip(out.iter_mut()) {
                let (x, y) = at(major, line, a);
                if !s.r.valid_at(s.r.grid.index(x, y)) {
                    *o = None;
                }
            }
            self.warped.push(WarpedRun { major, line, a0: b0, a1: b1 });
        }
    }

    /// The runs of positions warped since the last call (rule 4), moved
    /// into `out` (cleared first).
    pub fn take_warped(&mut self, out: &mut Vec<WarpedRun>) {
        out.clear();
        out.append(&mut self.warped);
    }

    /// Make sure group line `line` (groups whose top-left sample is on line
    /// `line`) holds verdicts at `a0..=a1`; the warps of lines `line` and
    /// `line + 1` over `a0..=a1 + 1` must be filled.
    pub fn fill_groups(&mut self, s: Sources<'_>, major: Major, line: i64, a0: i64, a1: i64) {
        let (lines, len) = self.extent(major);
        let reaches_end = a1 >= len - 1;
        let (a0, a1) = (a0.max(0), a1.min(len - 2));
        if line < 0 || line + 1 >= lines || a0 > a1 {
            return;
        }
        let wno = self.warp_no;
        let corner = s.tu.fixed().map(|f| f.corner);
        let (lower, upper) = ((line & 3) as usize, ((line + 1) & 3) as usize);
        let row = &mut self.groups[(line & 3) as usize];
        if reaches_end {
            // The group at the line's last position leaves the image.
            row.data[len as usize - 1] = None;
        }
        for (b0, b1) in row.missing(wno, major, line, a0, a1) {
            for a in b0..b1 + 1 {
                let w = |l: usize, p: i64| self.warps[l].data[p as usize];
                let (p, q, r, t) = (w(lower, a), w(lower, a + 1), w(upper, a), w(upper, a + 1));
                // Rule 3: a = (gx, gy), b = (gx + 1, gy), c = (gx, gy + 1), d.
                let g = match major {
                    Major::Row => group_in(p, q, r, t, s.threshold, corner),
                    Major::Column => group_in(p, r, q, t, s.threshold, corner),
                };
                row.data[a as usize] = Some(g);
            }
        }
        debug_assert!(self.warps[lower].line == line && self.warps[upper].line == line + 1);
    }

    /// The warped samples of line `line`, by position along it (`None`:
    /// the line is off the image). Only positions filled for this line
    /// hold its values.
    #[inline(always)]
    pub fn warp_row(&self, major: Major, line: i64) -> Option<&[Option<Transformed>]> {
        let (lines, len) = self.extent(major);
        (0..lines).contains(&line).then(|| {
            let row = &self.warps[(line & 3) as usize];
            debug_assert!(row.line == line && row.major == major);
            &row.data[..len as usize]
        })
    }

    /// The group verdicts of group line `line` (groups whose top-left
    /// sample is on it), by position along it; `None` in the last position,
    /// whose group leaves the image, once filled that far. `None` for the
    /// whole line if its groups leave the image.
    #[inline(always)]
    pub fn group_row(&self, major: Major, line: i64) -> Option<&[Option<Group>]> {
        let (lines, len) = self.extent(major);
        // A line one sample long has no group: its only group leaves the image.
        (line >= 0 && line + 1 < lines && len >= 2).then(|| {
            let row = &self.groups[(line & 3) as usize];
            debug_assert!(row.line == line && row.major == major);
            &row.data[..len as usize]
        })
    }
}

/// Image coordinates of `(line, along)` on a sheet of axis `major`.
#[inline(always)]
pub fn at(major: Major, line: i64, along: i64) -> (u32, u32) {
    match major {
        Major::Row => (along as u32, line as u32),
        Major::Column => (line as u32, along as u32),
    }
}
