//! Eight-sheet occlusion-compatible traversal of an image around an epipole
//! (McMillan & Bishop's order in the eight-sheet variant TR98 §9 cites;
//! `docs/warper-reference.md` §2).
//!
//! Rules:
//! 1. The occlusion-compatible direction at pixel `p` is
//!    `D(p) = (ex − px·ew, ey − py·ew)`; the *forward* order visits samples in
//!    increasing order along `D` (toward a front epipole, away from a behind
//!    one). On one epipolar line, a sample nearer the other camera is visited
//!    later.
//! 2. A finite epipole `e` splits the image into up to eight octants by the
//!    lines `x = ex`, `y = ey` and the diagonals. A sample belongs to a
//!    *vertical* octant if `|py − ey| ≥ |px − ex|` (ties go vertical), else to
//!    a horizontal one; quadrants by `px ≥ ex`, `py ≥ ey`. Vertical octants
//!    are scanned row-major, horizontal ones column-major, so every
//!    8-neighbour `q` visited after `p` in the same octant has
//!    `(q − p)·D ≥ 0` (the discrete pitfall of a 4-sheet order).
//! 3. Rows (columns) are visited in the order of the sign of `Dy` (`Dx`),
//!    and samples within them in the order of the other component's sign.
//! 4. Epipole at infinity (`ew = 0`): one sheet; row-major if
//!    `|Dy| ≥ |Dx|`, else column-major. Coincident centres: row-major.
//! 5. Octants may be visited in any order, even interleaved (the order does
//!    not matter for occlusion, because every epipolar half-line stays
//!    within one octant). [`order`] and [`OrderKey`] interleave the two
//!    octants with the same axis and line direction (vertical below,
//!    vertical above, horizontal right, horizontal left of the epipole:
//!    *sweeps* 0–3) by line index, the lower-numbered octant first at one
//!    line (octant number = 4·horizontal + 2·left + 1·above), and the
//!    sweeps by *ring band*: a sample's L-infinity distance from the
//!    epipole (`|dy|` in a vertical octant, `|dx|` in a horizontal one),
//!    less the epipole's L-infinity distance to the image's sample box,
//!    in bands of [`RING_BAND`] lines, counted inward toward a front
//!    epipole and outward from a behind one. The key is (ring band,
//!    sweep, line, octant, position): the sweeps advance together as
//!    square rings around the epipole. [`visit`] and [`sheets`] give the
//!    octants one after the other.
//! 6. The warp uses the *reverse* of this order within each sweep's band
//!    in the reference image, so that its sweep front crosses the derived
//!    image in the hole-fill order (`docs/warper-reference.md` §5, critical
//!    consistency point): the ring bands in reverse, in each band the
//!    sweeps in increasing order, each read backwards ([`warp_order`],
//!    [`OrderKey::warp_key`]).
//!
//! Not modelled here: tile order (the hardware schedule), seams between
//! octants near the epipole (adjacent samples on different octants may be
//! visited in either order).

use glam::DVec2;
use postwarp_rtl::camera::{Epipole, EpipoleKind};

/// Lines per ring band (rule 5): the sweeps interleave band by band; the
/// hardware's sheet sequencer uses the same (`postwarp_rtl::traversal`,
/// `tests/hw_traversal_hole_fill.rs`).
pub const RING_BAND: u32 = 8;
/// More ring bands than any image has (keys hold 20 bits of ring).
const RING_CAP: u64 = 1 << 20;

/// Which axis a sheet is scanned along.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Major {
    /// Row by row (|Dy| ≥ |Dx| in the sheet).
    Row,
    /// Column by column.
    Column,
}

/// One sheet: the samples it holds, in visiting order, and how it is scanned.
#[derive(Clone, Debug, PartialEq)]
pub struct Sheet {
    /// Scan axis.
    pub major: Major,
    /// Step between successive rows (Row) or columns (Column): +1 or −1.
    pub line_step: i32,
    /// Step within a row (Row) or column (Column): +1 or −1.
    pub step: i32,
    /// Samples in visiting order.
    pub samples: Vec<(u32, u32)>,
}

/// A sheet's scan pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SheetInfo {
    /// Scan axis.
    pub major: Major,
    /// Step between successive lines: +1 or −1.
    pub line_step: i32,
    /// Step within a line: +1 or −1.
    pub step: i32,
}

/// Visit every sample of a `width x height` image in the forward
/// occlusion-compatible order for `epipole`, with the scan pattern of the
/// sheet it belongs to. Allocates nothing.
pub fn visit(width: u32, height: u32, epipole: &Epipole, mut f: impl FnMut(&SheetInfo, u32, u32)) {
    match epipole.kind() {
        EpipoleKind::Coincident => scan(&info(single_scan(DVec2::new(0.0, 1.0))), width, height, &mut f),
        EpipoleKind::Infinity { .. } => {
            scan(&info(single_scan(DVec2::new(epipole.h.x, epipole.h.y))), width, height, &mut f)
        }
        EpipoleKind::Front { point } => octants(width, height, point, 1.0, &mut f),
        EpipoleKind::Behind { point } => octants(width, height, point, -1.0, &mut f),
    }
}

fn info((major, line_step, step): (Major, i32, i32)) -> SheetInfo {
    SheetInfo { major, line_step, step }
}

/// The forward occlusion-compatible order of a `width x height` image for
/// `epipole` (in that image's sample coordinates), as a list of sheets.
pub fn sheets(width: u32, height: u32, epipole: &Epipole) -> Vec<Sheet> {
    let mut out: Vec<Sheet> = Vec::new();
    let mut current: Option<SheetInfo> = None;
    visit(width, height, epipole, |s, x, y| {
        // Distinct octants have distinct scan patterns, so a change of
        // pattern is a change of sheet.
        if current != Some(*s) {
            out.push(Sheet { major: s.major, line_step: s.line_step, step: s.step, samples: Vec::new() });
            current = Some(*s);
        }
        out.last_mut().expect("pushed").samples.push((x, y));
    });
    out
}

/// The forward order as one flat list: the samples of [`visit`] with the
/// octants of each sweep interleaved (rule 5), i.e. sorted by
/// [`OrderKey::key`].
pub fn order(width: u32, height: u32, epipole: &Epipole) -> Vec<(u32, u32)> {
    let keys = OrderKey::new(width, height, epipole);
    let mut out: Vec<(u64, (u32, u32))> = Vec::with_capacity(width as usize * height as usize);
    visit(width, height, epipole, |_, x, y| out.push((keys.key(x, y), (x, y))));
    out.sort_unstable_by_key(|e| e.0);
    out.into_iter().map(|e| e.1).collect()
}

/// The warp's order (rule 6): the sweeps in increasing order, each read
/// backwards; sorted by [`OrderKey::warp_key`].
pub fn warp_order(width: u32, height: u32, epipole: &Epipole) -> Vec<(u32, u32)> {
    let keys = OrderKey::new(width, height, epipole);
    // Warp keys are distinct (a bijection of the keys, one per sample):
    // each computed once, any sort gives the order.
    let mut out: Vec<(u64, (u32, u32))> = Vec::with_capacity(width as usize * height as usize);
    visit(width, height, epipole, |_, x, y| out.push((keys.warp_key(x, y), (x, y))));
    out.sort_unstable_by_key(|e| e.0);
    out.into_iter().map(|e| e.1).collect()
}

/// The sweep of octant number `sheet` (rule 5) and which of its two
/// octants it is (0: the lower-numbered).
fn sweep_of(sheet: usize) -> (u64, u64) {
    let (horizontal, left, above) = (sheet & 4 != 0, sheet & 2 != 0, sheet & 1 != 0);
    if horizontal { (2 + left as u64, above as u64) } else { (above as u64, left as u64) }
}

fn sign(v: f64) -> i32 {
    if v < 0.0 { -1 } else { 1 }
}

fn single_scan(d: DVec2) -> (Major, i32, i32) {
    if d.y.abs() >= d.x.abs() { (Major::Row, sign(d.y), sign(d.x)) } else { (Major::Column, sign(d.x), sign(d.y)) }
}

/// Visit every sample of a whole-image sheet.
fn scan(s: &SheetInfo, width: u32, height: u32, f: &mut impl FnMut(&SheetInfo, u32, u32)) {
    let (lines, len) = match s.major {
        Major::Row => (height, width),
        Major::Column => (width, height),
    };
    for k in 0..lines {
        let l = if s.line_step > 0 { k } else { lines - 1 - k };
        for m in 0..len {
            let i = if s.step > 0 { m } else { len - 1 - m };
            match s.major {
                Major::Row => f(s, i, l),
                Major::Column => f(s, l, i),
            }
        }
    }
}

/// Octant of sample `(x, y)` around `e`: (vertical?, right?, below?).
pub fn octant_of(x: u32, y: u32, e: DVec2) -> (bool, bool, bool) {
    let dx = x as f64 - e.x;
    let dy = y as f64 - e.y;
    (dy.abs() >= dx.abs(), dx >= 0.0, dy >= 0.0)
}

/// The octants in visiting order: (vertical, right, below).
const OCTANTS: [(bool, bool, bool); 8] = [
    (true, true, true),
    (true, true, false),
    (true, false, true),
    (true, false, false),
    (false, true, true),
    (false, true, false),
    (false, false, true),
    (false, false, false),
];

/// Scan pattern of an octant: (major, line_step, step).
fn octant_scan((vertical, right, below): (bool, bool, bool), ew_sign: f64) -> (Major, i32, i32) {
    // D = ew·(e − p): inside this octant its component signs are fixed.
    let dx_sign = if right { -ew_sign } else { ew_sign };
    let dy_sign = if below { -ew_sign } else { ew_sign };
    if vertical { (Major::Row, sign(dy_sign), sign(dx_sign)) } else { (Major::Column, sign(dx_sign), sign(dy_sign)) }
}

fn octants(width: u32, height: u32, e: DVec2, ew_sign: f64, f: &mut impl FnMut(&SheetInfo, u32, u32)) {
    for oct in OCTANTS {
        scan_octant(&info(octant_scan(oct, ew_sign)), width, height, e, oct, f);
    }
}

/// Scan one octant. On each line its samples form one interval: computed
/// from the octant's inequalities, then its ends corrected with the exact
/// membership test [`octant_of`] (so rounding of the epipole can never add
/// or drop a sample), and visited without further tests.
fn scan_octant(
    s: &SheetInfo,
    width: u32,
    height: u32,
    e: DVec2,
    which: (bool, bool, bool),
    f: &mut impl FnMut(&SheetInfo, u32, u32),
) {
    let (lines, len, el, ei) = match s.major {
        Major::Row => (height, width, e.y, e.x),
        Major::Column => (width, height, e.x, e.y),
    };
    let at = |l: u32, i: u32| match s.major {
        Major::Row => (i, l),
        Major::Column => (l, i),
    };
    let member = |l: u32, i: i64| {
        if i < 0 || i >= len as i64 {
            return false;
        }
        let (x, y) = at(l, i as u32);
        octant_of(x, y, e) == which
    };
    for k in 0..lines {
        let l = if s.line_step > 0 { k } else { lines - 1 - k };
        // The octant's inequalities: the line must be on the octant's side
        // of e; along it, the samples lie between e and |d_line| away (on
        // the octant's side). One sample of slack each way, then the exact
        // test trims the ends.
        let d_line = l as f64 - el;
        let (line_side, along_side) = match s.major {
            Major::Row => (which.2, which.1),
            Major::Column => (which.1, which.2),
        };
        if (d_line >= 0.0) != line_side {
            continue;
        }
        let r = d_line.abs();
        let (a, b) = if along_side { (ei, ei + r) } else { (ei - r, ei) };
        let lo = (a.floor() - 1.0).max(0.0);
        let hi = (b.ceil() + 1.0).min(len as f64 - 1.0);
        if lo > hi {
            continue;
        }
        let (mut lo, mut hi) = (lo as i64, hi as i64);
        while lo <= hi && !member(l, lo) {
            lo += 1;
        }
        while hi >= lo && !member(l, hi) {
            hi -= 1;
        }
        if lo > hi {
            continue;
        }
        for m in 0..=(hi - lo) as u32 {
            let i = if s.step > 0 { lo as u32 + m } else { hi as u32 - m };
            let (x, y) = at(l, i);
            f(s, x, y);
        }
    }
}

/// The rank of every sample in the forward order, computable in O(1):
/// sorting samples by [`OrderKey::key`] gives exactly [`order`]. Used to
/// composite candidates in warp order without walking the image in it.
#[derive(Clone, Debug)]
pub struct OrderKey {
    width: u32,
    height: u32,
    /// Finite epipole point, if any.
    point: Option<DVec2>,
    /// The epipole is in front (`ew > 0`): rings are visited inward.
    front: bool,
    /// Scan pattern per octant (finite epipole) or of the single sheet.
    scans: [(Major, i32, i32); 8],
}

impl OrderKey {
    /// Keys for a `width x height` image around `epipole`.
    pub fn new(width: u32, height: u32, epipole: &Epipole) -> OrderKey {
        let (point, scans) = match epipole.kind() {
            EpipoleKind::Coincident => (None, [single_scan(DVec2::new(0.0, 1.0)); 8]),
            EpipoleKind::Infinity { .. } => (None, [single_scan(DVec2::new(epipole.h.x, epipole.h.y)); 8]),
            EpipoleKind::Front { point } => (Some(point), OCTANTS.map(|o| octant_scan(o, 1.0))),
            EpipoleKind::Behind { point } => (Some(point), OCTANTS.map(|o| octant_scan(o, -1.0))),
        };
        // Keys hold 20 bits of line and of position.
        assert!(width <= 1 << 20 && height <= 1 << 20, "{width}x{height}: more than 2^20 samples per side");
        let front = matches!(epipole.kind(), EpipoleKind::Front { .. });
        OrderKey { width, height, point, scans, front }
    }

    /// Index of the sheet of sample `(x, y)` (in visiting order for a finite
    /// epipole: OCTANTS).
    fn sheet(&self, x: u32, y: u32) -> usize {
        match self.point {
            None => 0,
            Some(e) => {
                // Index in OCTANTS: vertical first, then right, then below.
                let (v, r, b) = octant_of(x, y, e);
                ((!v as usize) << 2) | ((!r as usize) << 1) | (!b as usize)
            }
        }
    }

    /// The scan pattern of the sheet holding sample `(x, y)` (what [`visit`]
    /// passes along with it).
    pub fn scan_at(&self, x: u32, y: u32) -> SheetInfo {
        info(self.scans[self.sheet(x, y)])
    }

    /// The ring band of sample `(x, y)` in travel order (rule 5): its
    /// L-infinity distance from the epipole, less the image's nearest,
    /// in bands of [`RING_BAND`] lines, counted inward toward a front
    /// epipole.
    fn ring(&self, x: u32, y: u32) -> u64 {
        let Some(e) = self.point else { return 0 };
        let d = match self.scans[self.sheet(x, y)].0 {
            Major::Row => (y as f64 - e.y).abs(),
            Major::Column => (x as f64 - e.x).abs(),
        };
        let (w, h) = ((self.width - 1) as f64, (self.height - 1) as f64);
        let dmin = 0f64.max(-e.x).max(e.x - w).max(-e.y).max(e.y - h);
        let r = (((d - dmin).max(0.0) / RING_BAND as f64).floor() as u64).min(RING_CAP - 1);
        if self.front { RING_CAP - 1 - r } else { r }
    }

    /// `OrderKey` of sample `(x, y)`: ring band, then sweep, then line, then
    /// which octant of the sweep, then position in line (rule 5).
    pub fn key(&self, x: u32, y: u32) -> u64 {
        let sheet = self.sheet(x, y);
        let (major, line_step, step) = self.scans[sheet];
        let (line, along, lines, len) = match major {
            Major::Row => (y, x, self.height, self.width),
            Major::Column => (x, y, self.width, self.height),
        };
        let l = if line_step > 0 { line } else { lines - 1 - line } as u64;
        let a = if step > 0 { along } else { len - 1 - along } as u64;
        let (sweep, half) = sweep_of(sheet);
        (self.ring(x, y) << 44) | (sweep << 42) | (l << 21) | (half << 20) | a
    }

    /// `OrderKey` of sample `(x, y)` in the warp's order (rule 6): the ring
    /// bands reversed, each band's sweeps in increasing order, the rest of
    /// [`OrderKey::key`] complemented.
    pub fn warp_key(&self, x: u32, y: u32) -> u64 {
        let k = self.key(x, y);
        let rest = (1u64 << 42) - 1;
        ((RING_CAP - 1 - (k >> 44)) << 44) | (k & !rest & ((1 << 44) - 1)) | (!k & rest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn check_permutation(w: u32, h: u32, o: &[(u32, u32)]) {
        let mut seen = vec![false; (w * h) as usize];
        for &(x, y) in o {
            assert!(!seen[(y * w + x) as usize], "({x},{y}) twice");
            seen[(y * w + x) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s), "not every sample visited");
    }

    /// Within each sheet, every 8-neighbour visited later lies ahead along D.
    fn check_neighbours_ahead(w: u32, h: u32, e: &Epipole) {
        for sheet in sheets(w, h, e) {
            let mut pos = std::collections::HashMap::new();
            for (k, &p) in sheet.samples.iter().enumerate() {
                pos.insert(p, k);
            }
            for (k, &(x, y)) in sheet.samples.iter().enumerate() {
                let d = e.direction_at(DVec2::new(x as f64, y as f64));
                for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let q = (x as i64 + dx, y as i64 + dy);
                    if q.0 < 0 || q.1 < 0 {
                        continue;
                    }
                    if let Some(&kq) = pos.get(&(q.0 as u32, q.1 as u32))
                        && kq > k
                    {
                        let dot = dx as f64 * d.x + dy as f64 * d.y;
                        assert!(
                            dot >= -1e-9,
                            "sheet {:?}: ({x},{y}) then ({},{}) against D {d:?}",
                            sheet.major,
                            q.0,
                            q.1
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn every_case_visits_each_sample_once_in_compatible_order() {
        let (w, h) = (13u32, 9u32);
        // (epipole point, ew) for finite epipoles: h = (px·ew, py·ew, ew).
        let finite = [
            ((6.3, 4.1), 1.0),    // inside, front
            ((6.3, 4.1), -2.0),   // inside, behind
            ((-3.0, 4.0), 1.0),   // left of the image
            ((20.0, -5.0), 0.5),  // above right
            ((20.0, 30.0), -1.0), // below right, behind
            ((6.0, 4.0), 1.0),    // exactly on a sample
        ];
        let mut cases: Vec<DVec3> = finite.iter().map(|&((x, y), w)| DVec3::new(x * w, y * w, w)).collect();
        cases.push(DVec3::new(1.0, 0.2, 0.0)); // infinity, mostly x
        cases.push(DVec3::new(-0.1, -1.0, 0.0)); // infinity, mostly y
        cases.push(DVec3::ZERO); // coincident centres
        for hv in cases {
            let e = Epipole { h: hv };
            let o = order(w, h, &e);
            check_permutation(w, h, &o);
            check_neighbours_ahead(w, h, &e);
        }
    }

    #[test]
    fn order_key_sorts_into_the_traversal_order() {
        let (w, h) = (29u32, 19u32);
        let cases = [
            DVec3::new(6.3, 4.1, 1.0),
            DVec3::new(-12.6, -8.2, -2.0),
            DVec3::new(-3.0, 4.0, 1.0),
            DVec3::new(10.0, -2.5, 0.5),
            DVec3::new(-20.0, -30.0, -1.0),
            DVec3::new(6.0, 4.0, 1.0),
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(-0.1, -1.0, 0.0),
            DVec3::ZERO,
        ];
        for hv in cases {
            let e = Epipole { h: hv };
            let k = OrderKey::new(w, h, &e);
            let o = order(w, h, &e);
            check_permutation(w, h, &o);
            visit(w, h, &e, |s, x, y| assert_eq!(*s, k.scan_at(x, y), "epipole {hv:?} at ({x},{y})"));
            // Interleaving keeps every octant's own order (rule 5) ...
            for sheet in sheets(w, h, &e) {
                let mine: Vec<(u32, u32)> = o.iter().copied().filter(|p| sheet.samples.contains(p)).collect();
                assert_eq!(mine, sheet.samples, "epipole {hv:?}: an octant's order changed");
            }
            // ... and a sweep's front only moves forward: the line index of
            // its samples never decreases along the order.
            let line_rank = |(x, y): (u32, u32)| {
                let s = k.scan_at(x, y);
                let (l, n) = match s.major {
                    Major::Row => (y, h),
                    Major::Column => (x, w),
                };
                if s.line_step > 0 { l } else { n - 1 - l }
            };
            let mut last = [None::<u32>; 4];
            for &p in &o {
                let sweep = (k.key(p.0, p.1) >> 42 & 3) as usize;
                let r = line_rank(p);
                assert!(last[sweep].is_none_or(|q| q <= r), "epipole {hv:?}: sweep {sweep} stepped back at {p:?}");
                last[sweep] = Some(r);
            }
        }
    }

    #[test]
    fn front_epipole_ends_its_sheet_and_behind_starts_it() {
        let e = Epipole { h: DVec3::new(5.0, 5.0, 1.0) };
        let s = sheets(11, 11, &e);
        let own = s.iter().find(|s| s.samples.contains(&(5, 5))).unwrap();
        assert_eq!(*own.samples.last().unwrap(), (5, 5));
        let b = Epipole { h: DVec3::new(-5.0, -5.0, -1.0) };
        let s = sheets(11, 11, &b);
        let own = s.iter().find(|s| s.samples.contains(&(5, 5))).unwrap();
        assert_eq!(own.samples[0], (5, 5));
        // An epipole inside the image gives eight non-empty sheets.
        assert_eq!(s.len(), 8);
    }
}
