//! The sheet sequencer: the address generator that walks an image in the
//! eight-sheet occlusion-compatible order around an epipole (McMillan &
//! Bishop's order, eight-sheet variant; TR98 §9, `docs/warper-reference.md`
//! §2), emitted as *line descriptors*.
//!
//! Job: turn an epipole and an image size into the sequence of lines a
//! sample-address counter steps through. A [`Line`] is one row or column
//! segment of one sheet: `(sheet, major, line, lo..=hi, step, line_step)`.
//! Downstream units (the warp front end, the hole-fill unit) expand each
//! descriptor into sample addresses, one per clock. [`OrderKey`] is the
//! companion comparator: the position of any sample in the forward order,
//! computed in O(1) from its coordinates, so that "was `q` visited before
//! `p` in this pass?" is one compare instead of a visited bit-plane.
//!
//! Ports (functional): in — image width and height, the homogeneous
//! epipole `(ex, ey, ew)`; out — [`forward_lines`] / [`reverse_lines`], and
//! [`OrderKey::key`] for any sample.
//!
//! Throughput: a line descriptor is produced once per line (at most
//! 8 × max(width, height) descriptors per image); its samples are then
//! emitted one per clock by the consumer. The descriptor's interval ends
//! are computed here with a guess and an exact compare-and-step
//! correction, which in hardware is a short sequential search per line
//! (a couple of compares), hidden behind the previous line's samples.
//!
//! Rules (the order is defined so that it equals the golden model's
//! `traversal::order` sample for sample):
//! 1. The direction of travel at sample `p` is `D(p) = (ex − px·ew,
//!    ey − py·ew)`: toward a front epipole (`ew > 0`), away from a behind
//!    one (`ew < 0`).
//! 2. A finite epipole `e = (ex/ew, ey/ew)` cuts the image into eight
//!    sheets. With `dx = x − e.x`, `dy = y − e.y` evaluated in `f64`, a
//!    sample is *vertical* if `|dy| ≥ |dx|` (a tie is vertical), *right* if
//!    `dx ≥ 0`, *below* if `dy ≥ 0`. Sheet number = 4·horizontal + 2·left +
//!    1·above (sheets are emitted in sweeps, rule 6).
//! 3. Vertical sheets are scanned row by row ([`Major::Row`]), horizontal
//!    ones column by column ([`Major::Column`]). Inside a sheet `D`'s
//!    component signs are fixed: lines advance along the sign of `D`'s
//!    line-axis component, samples within a line along the sign of the
//!    other component (+1 for a zero component).
//! 4. On every line a sheet's samples form one interval, because `dx` (or
//!    `dy`) is a monotone function of the sample coordinate even after
//!    rounding. Its ends are the first samples at which `d ≥ 0`, `d ≥ −r`
//!    (`d > −r` for horizontal sheets), `d > r` (`d ≥ r`) switch on, where
//!    `d` is the offset along the line and `r` the line's distance from the
//!    epipole; each end is guessed arithmetically and then corrected with
//!    the exact comparison, so it can never be off by a rounding error.
//!    Lines whose interval is empty emit no descriptor.
//! 5. Epipole at infinity (`ew = 0` to [`Epipole::INFINITY_TOL`]): one sheet
//!    (number 0), row by row if `|ey| ≥ |ex|`, else column by column, signs
//!    from `(ex, ey)`. Coincident centres (`h = 0`): one sheet, row by row,
//!    top to bottom, left to right.
//! 6. Sweeps and ring bands. Occlusion only happens between samples on
//!    one ray from the epipole, and every such ray lies in one sheet, so
//!    only the order within a sheet is fixed; sheets may be visited in any
//!    order, even interleaved. The two sheets with the same axis and the
//!    same direction across lines ([`sweep_of`]: vertical sheets below,
//!    vertical above, horizontal right, horizontal left of the epipole:
//!    sweeps 0–3) are interleaved by line index into one *sweep*. A line's
//!    *ring band* ([`line_ring`]) is its samples' L-infinity distance from
//!    the epipole (`|dy|` on a row of a vertical sheet, `|dx|` on a column
//!    of a horizontal one), less the image's nearest (the L-infinity
//!    distance from the epipole to the image's sample box, 0 inside it),
//!    in bands of [`RING_BAND`] lines, counted in the travel direction
//!    (inward toward a front epipole, outward from a behind one). The
//!    forward order is sorted by (ring band, sweep, line in travel order,
//!    sheet): the four sweeps advance together as square rings around the
//!    epipole, [`RING_BAND`] lines of one sweep at a time. With the
//!    epipole far outside the image (most frames) the image is one sweep
//!    and the bands change nothing; with the epipole inside, the warp's
//!    front and the hole fill's cross the derived image together even
//!    though the epipolar map turns the sweep borders, so a tile is filled
//!    and leaves the cache soon after the warp has passed it
//!    (`docs/units.md`, "Destination cache").
//! 7. The reverse order ([`reverse_lines`]) is the forward order read
//!    backwards: last line first, each line from its other end.
//! 8. The warp's order ([`warp_lines`], [`warp_key`]) visits the ring
//!    bands in reverse (outward from a front epipole), and in each band
//!    the sweeps in increasing order, each read backwards as in rule 7:
//!    every sheet is exactly backwards, so the warp's sweep front crosses
//!    the derived image in hole-fill order, band by band.
//!
//! Not modelled: the cycle cost of the per-line end search (counted as
//! free), tiling of the image (the engine's tile schedule is separate),
//! and fixed-point epipole arithmetic — the hardware compares in `f64`
//! here, exactly as the golden model does, so the two orders are the same.

use crate::camera::{Epipole, EpipoleKind};

/// Which axis a sheet's lines run along.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Major {
    /// Lines are rows (fixed `y`); the sheet is vertical (`|Dy| ≥ |Dx|`).
    Row,
    /// Lines are columns (fixed `x`); the sheet is horizontal.
    Column,
}

/// One line descriptor: a run of consecutive samples of one row or column,
/// all in one sheet, with the direction they are visited in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Line {
    /// Sheet number (0–7 around a finite epipole, see the module rules; 0
    /// for the single sheet of an epipole at infinity or coincident centres).
    pub sheet: u8,
    /// Whether the line is a row or a column.
    pub major: Major,
    /// The row `y` ([`Major::Row`]) or the column `x` ([`Major::Column`]).
    pub line: u32,
    /// First sample coordinate along the line covered (inclusive).
    pub lo: u32,
    /// Last sample coordinate along the line covered (inclusive).
    pub hi: u32,
    /// Visiting direction within the line: +1 from `lo` to `hi`, −1 from
    /// `hi` to `lo`.
    pub step: i32,
    /// Direction (+1 or −1 in `line` coordinate) in which the successive
    /// lines of this line's sheet are visited. The line visited just before
    /// this one in the same sheet is (if the sheet covers it) `line −
    /// line_step`: the hole fill's taps lie there.
    pub line_step: i32,
}

impl Line {
    /// Number of samples on the line (≥ 1 for every descriptor the
    /// sequencer emits).
    pub fn len(&self) -> u32 {
        if self.hi < self.lo { 0 } else { self.hi - self.lo + 1 }
    }

    /// True if the line covers no sample (never the case for descriptors
    /// the sequencer emits).
    pub fn is_empty(&self) -> bool {
        self.hi < self.lo
    }

    /// Image coordinates `(x, y)` of the sample at coordinate `along` on
    /// this line.
    pub fn at(&self, along: u32) -> (u32, u32) {
        match self.major {
            Major::Row => (along, self.line),
            Major::Column => (self.line, along),
        }
    }

    /// The samples `(x, y)` in visiting order.
    pub fn samples(&self) -> impl Iterator<Item = (u32, u32)> + use<> {
        let l = *self;
        (0..l.len()).map(move |k| l.at(if l.step > 0 { l.lo + k } else { l.hi - k }))
    }

    /// The same samples visited in the opposite order. Both `step` and
    /// `line_step` flip: a reversed line belongs to the reversed sheet,
    /// whose lines are visited in the opposite direction.
    pub fn reversed(&self) -> Line {
        Line { step: -self.step, line_step: -self.line_step, ..*self }
    }
}

/// Scan pattern of one sheet: axis, line direction, direction within a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pattern {
    major: Major,
    line_step: i32,
    step: i32,
}

/// Direction of a `D` component: −1 if negative, else +1.
fn dir(v: f64) -> i32 {
    if v < 0.0 { -1 } else { 1 }
}

/// The whole-image sheet for a travel direction `(dx, dy)` (rule 5).
fn single(dx: f64, dy: f64) -> Pattern {
    if dy.abs() >= dx.abs() {
        Pattern { major: Major::Row, line_step: dir(dy), step: dir(dx) }
    } else {
        Pattern { major: Major::Column, line_step: dir(dx), step: dir(dy) }
    }
}

/// The sweep of sheet `sheet` (rule 6): sheets with the same axis and the
/// same direction of travel across lines (vertical sheets on one side of
/// the epipole's row, horizontal ones on one side of its column) share a
/// sweep. Returns (sweep 0–3, 0 for the lower-numbered sheet of the pair or
/// 1 for the other).
pub fn sweep_of(sheet: u8) -> (u8, u8) {
    let (horizontal, left, above) = sheet_bits(sheet);
    if horizontal { (2 + left as u8, above as u8) } else { (above as u8, left as u8) }
}

/// Sheet number → (horizontal, left, above).
fn sheet_bits(sheet: u8) -> (bool, bool, bool) {
    (sheet & 4 != 0, sheet & 2 != 0, sheet & 1 != 0)
}

/// Pattern of sheet `sheet` around a finite epipole; `ew_dir` is +1 for a
/// front epipole, −1 for a behind one (rule 3).
fn sheet_pattern(sheet: u8, ew_dir: i32) -> Pattern {
    let (horizontal, left, above) = sheet_bits(sheet);
    // D = ew·(e − p): right of e its x component has the sign of −ew.
    let dx = if left { ew_dir } else { -ew_dir };
    let dy = if above { ew_dir } else { -ew_dir };
    if horizontal {
        Pattern { major: Major::Column, line_step: dx, step: dy }
    } else {
        Pattern { major: Major::Row, line_step: dy, step: dx }
    }
}

/// How the image is cut into sheets.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cut {
    /// One sheet covering the whole image.
    Single(Pattern),
    /// Eight sheets around the finite epipole `(ex, ey)`.
    Eight { ex: f64, ey: f64, ew_dir: i32 },
}

fn cut(epipole: &Epipole) -> Cut {
    match epipole.kind() {
        EpipoleKind::Coincident => Cut::Single(single(0.0, 1.0)),
        EpipoleKind::Infinity { .. } => Cut::Single(single(epipole.h.x, epipole.h.y)),
        EpipoleKind::Front { point } => Cut::Eight { ex: point.x, ey: point.y, ew_dir: 1 },
        EpipoleKind::Behind { point } => Cut::Eight { ex: point.x, ey: point.y, ew_dir: -1 },
    }
}

/// The sheet of sample `(x, y)` around the finite epipole `(ex, ey)`
/// (rule 2).
fn sheet_of(x: u32, y: u32, ex: f64, ey: f64) -> u8 {
    let dx = x as f64 - ex;
    let dy = y as f64 - ey;
    let horizontal = dy.abs() < dx.abs();
    let left = dx < 0.0;
    let above = dy < 0.0;
    ((horizontal as u8) << 2) | ((left as u8) << 1) | above as u8
}

/// Line coordinates visited in order `step` over `0..n`.
fn ordered(n: u32, step: i32) -> impl Iterator<Item = u32> {
    (0..n).map(move |k| if step > 0 { k } else { n - 1 - k })
}

/// The smallest `i` in `0..=len` whose offset `d(i) = i − e` (in `f64`)
/// passes the threshold `t` (`d ≥ t`, or `d > t` if `strict`); `len` if
/// none does. `d` is monotone in `i`, so the guess is corrected by stepping
/// with the exact comparison (rule 4).
fn first_past(len: u32, e: f64, t: f64, strict: bool) -> u32 {
    let pass = |i: u32| {
        let d = i as f64 - e;
        if strict { d > t } else { d >= t }
    };
    let guess = (e + t).ceil();
    let mut i = if guess.is_nan() || guess <= 0.0 {
        0
    } else if guess >= len as f64 {
        len
    } else {
        guess as u32
    };
    while i > 0 && pass(i - 1) {
        i -= 1;
    }
    while i < len && !pass(i) {
        i += 1;
    }
    i
}

/// Call `f` with every line of `sheet` around a finite epipole, in order.
fn sheet_lines(width: u32, height: u32, ex: f64, ey: f64, sheet: u8, ew_dir: i32, f: &mut impl FnMut(Line)) {
    let p = sheet_pattern(sheet, ew_dir);
    let (horizontal, left, above) = sheet_bits(sheet);
    // (lines, samples per line, epipole on the line axis, on the along axis,
    //  on the negative side across lines?, on the negative side along?)
    let (lines, len, el, ea, neg_line, neg_along) = match p.major {
        Major::Row => (height, width, ey, ex, above, left),
        Major::Column => (width, height, ex, ey, left, above),
    };
    // Vertical sheets own the ties |dx| = |dy| (rule 2): the along offset
    // may equal r there, not in horizontal sheets.
    let strict = horizontal;
    for l in ordered(lines, p.line_step) {
        let dl = l as f64 - el;
        if (dl < 0.0) != neg_line {
            continue;
        }
        let r = dl.abs();
        let (lo, end) = if neg_along {
            (first_past(len, ea, -r, strict), first_past(len, ea, 0.0, false))
        } else {
            (first_past(len, ea, 0.0, false), first_past(len, ea, r, !strict))
        };
        if lo < end {
            f(Line { sheet, major: p.major, line: l, lo, hi: end - 1, step: p.step, line_step: p.line_step });
        }
    }
}

/// Call `f` with every line descriptor of the forward order.
fn each_line(width: u32, height: u32, epipole: &Epipole, mut f: impl FnMut(Line)) {
    if width == 0 || height == 0 {
        return;
    }
    match cut(epipole) {
        Cut::Single(p) => {
            let (lines, len) = match p.major {
                Major::Row => (height, width),
                Major::Column => (width, height),
            };
            for l in ordered(lines, p.line_step) {
                f(Line { sheet: 0, major: p.major, line: l, lo: 0, hi: len - 1, step: p.step, line_step: p.line_step });
            }
        }
        Cut::Eight { ex, ey, ew_dir } => {
            for sheet in 0..8 {
                sheet_lines(width, height, ex, ey, sheet, ew_dir, &mut f);
            }
        }
    }
}

/// The forward occlusion-compatible order of a `width x height` image
/// around `epipole` (in that image's sample coordinates), as line
/// descriptors: concatenating their [`Line::samples`] visits every sample
/// exactly once, in the golden model's `traversal::order`.
pub fn forward_lines(width: u32, height: u32, epipole: &Epipole) -> Vec<Line> {
    let c = cut(epipole);
    let mut out = Vec::new();
    each_line(width, height, epipole, |l| out.push(l));
    // Rules 6: rings first, then sweeps, then lines in travel order (the
    // sort is stable: at one line the lower-numbered sheet comes first).
    out.sort_by_key(|l| {
        let li = if l.line_step > 0 { l.line as u64 } else { (lines_of(l.major, width, height) - 1 - l.line) as u64 };
        (ring_travel(&c, width, height, l), sweep_of(l.sheet).0, li)
    });
    out
}

/// Lines of the image along `major`.
fn lines_of(major: Major, width: u32, height: u32) -> u32 {
    match major {
        Major::Row => height,
        Major::Column => width,
    }
}

/// Lines per ring band (rule 6): the best of 4, 8, 16 and 32 on the
/// 640x480 room trace's frame 0 (epipole inside; `docs/units.md`, "Ring
/// bands"). Fewer lines re-fetch more (each band of a sweep fetches its
/// neighbour lines again), more lines let the fill lag further.
pub const RING_BAND: u32 = 8;
/// More ring bands than any image has.
const RING_CAP: u64 = 1 << 20;

/// The ring of `line`'s samples in the forward order's travel direction
/// (rule 6): the band of their L-infinity distance from the epipole,
/// counted from the image's nearest point, reversed toward a front epipole.
/// The ring band of `line` in the forward order's travel direction
/// (rule 6; 0 for a single-sheet image).
pub fn line_ring(width: u32, height: u32, epipole: &Epipole, line: &Line) -> u64 {
    ring_travel(&cut(epipole), width, height, line)
}

fn ring_travel(c: &Cut, width: u32, height: u32, l: &Line) -> u64 {
    let Cut::Eight { ex, ey, ew_dir } = *c else { return 0 };
    let d = match l.major {
        Major::Row => (l.line as f64 - ey).abs(),
        Major::Column => (l.line as f64 - ex).abs(),
    };
    ring_of(d, ex, ey, ew_dir, width, height)
}

fn ring_of(d: f64, ex: f64, ey: f64, ew_dir: i32, width: u32, height: u32) -> u64 {
    let dmin = 0f64.max(-ex).max(ex - (width - 1) as f64).max(-ey).max(ey - (height - 1) as f64);
    let r = (((d - dmin).max(0.0) / RING_BAND as f64).floor() as u64).min(RING_CAP - 1);
    if ew_dir > 0 { RING_CAP - 1 - r } else { r }
}

/// The reverse of [`forward_lines`]: the lines in the opposite order, each
/// [`Line::reversed`], so the samples come exactly in reverse forward order.
pub fn reverse_lines(width: u32, height: u32, epipole: &Epipole) -> Vec<Line> {
    let mut out = forward_lines(width, height, epipole);
    out.reverse();
    for l in &mut out {
        *l = l.reversed();
    }
    out
}

/// The warp's order (rule 8): the sweeps in increasing order, each one
/// read backwards (last line first, each line from its other end).
pub fn warp_lines(width: u32, height: u32, epipole: &Epipole) -> Vec<Line> {
    let c = cut(epipole);
    let mut back = reverse_lines(width, height, epipole);
    back.sort_by_key(|l| (RING_CAP - 1 - ring_travel(&c, width, height, l), sweep_of(l.sheet).0));
    back
}

/// The position of a sample in the warp's order ([`warp_lines`]), from
/// its [`OrderKey::key`] `k`: the same sweep, the rest of the key
/// complemented, so that sorting by it gives the warp's order.
pub fn warp_key(k: u64, keys: &OrderKey) -> u64 {
    let span = keys.sweep_span();
    let ring = 4 * span;
    let (r, sweep, rest) = (k / ring, k % ring / span, k % span);
    (RING_CAP - 1 - r) * ring + sweep * span + (span - 1 - rest)
}

/// The position of any sample in the forward order, in O(1): sorting
/// samples by [`OrderKey::key`] gives exactly the order of [`forward_lines`].
/// In hardware: the sheet classifier of rule 2 and two conditional
/// subtractions, so "visited earlier in this pass" is one compare.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderKey {
    width: u32,
    height: u32,
    cut: Cut,
    /// Scan pattern of each sheet (all eight equal for a single sheet).
    patterns: [Pattern; 8],
}

impl OrderKey {
    /// The ranker for a `width x height` image around `epipole`.
    pub fn new(width: u32, height: u32, epipole: &Epipole) -> OrderKey {
        let cut = cut(epipole);
        let patterns = match cut {
            Cut::Single(p) => [p; 8],
            Cut::Eight { ew_dir, .. } => std::array::from_fn(|s| sheet_pattern(s as u8, ew_dir)),
        };
        OrderKey { width, height, cut, patterns }
    }

    /// Keys per sweep: `key / sweep_span()` is a sample's sweep.
    pub fn sweep_span(&self) -> u64 {
        2 * self.width as u64 * self.height as u64
    }

    /// OrderKey of sample `(x, y)` (inside the image): distinct for distinct
    /// samples, increasing along the forward order. Encoded as
    /// `sweep · 2·width·height + line index · 2·line length + half · line
    /// length + index in line` (rule 6; `half` is 0 for the lower-numbered
    /// sheet of the sweep).
    pub fn key(&self, x: u32, y: u32) -> u64 {
        debug_assert!(x < self.width && y < self.height, "({x},{y}) outside {}x{}", self.width, self.height);
        let sheet = match self.cut {
            Cut::Single(_) => 0,
            Cut::Eight { ex, ey, .. } => sheet_of(x, y, ex, ey),
        };
        let p = self.patterns[sheet as usize];
        let (l, a, lines, len) = match p.major {
            Major::Row => (y, x, self.height, self.width),
            Major::Column => (x, y, self.width, self.height),
        };
        let li = if p.line_step > 0 { l } else { lines - 1 - l } as u64;
        let ai = if p.step > 0 { a } else { len - 1 - a } as u64;
        let n = self.width as u64 * self.height as u64;
        let (sweep, half) = sweep_of(sheet);
        let ring = match self.cut {
            Cut::Single(_) => 0,
            Cut::Eight { ex, ey, ew_dir } => {
                let d = match p.major {
                    Major::Row => (y as f64 - ey).abs(),
                    Major::Column => (x as f64 - ex).abs(),
                };
                ring_of(d, ex, ey, ew_dir, self.width, self.height)
            }
        };
        ring * 8 * n + sweep as u64 * 2 * n + li * 2 * len as u64 + half as u64 * len as u64 + ai
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn all(width: u32, height: u32, e: &Epipole) -> Vec<(u32, u32)> {
        forward_lines(width, height, e).iter().flat_map(|l| l.samples()).collect()
    }

    #[test]
    fn every_sample_once_and_ranks_increase() {
        for h in [
            DVec3::new(3.3, 2.1, 1.0),
            DVec3::new(-3.0, -2.0, -1.0),
            DVec3::new(30.0, -4.0, 1.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::ZERO,
        ] {
            let e = Epipole { h };
            let (w, ht) = (7u32, 5u32);
            let o = all(w, ht, &e);
            let mut seen = vec![false; (w * ht) as usize];
            for &(x, y) in &o {
                assert!(!std::mem::replace(&mut seen[(y * w + x) as usize], true));
            }
            assert_eq!(o.len(), (w * ht) as usize);
            let r = OrderKey::new(w, ht, &e);
            assert!(o.windows(2).all(|p| r.key(p[0].0, p[0].1) < r.key(p[1].0, p[1].1)), "{h:?}");
            let back: Vec<_> = reverse_lines(w, ht, &e).iter().flat_map(|l| l.samples()).collect();
            assert!(back.iter().eq(o.iter().rev()));
            // The warp's order: sorted by its key, sweeps increasing, and
            // every sheet exactly backwards.
            let warp_lines = warp_lines(w, ht, &e);
            let warp: Vec<_> = warp_lines.iter().flat_map(|l| l.samples()).collect();
            let wk = |p: &(u32, u32)| warp_key(r.key(p.0, p.1), &r);
            assert!(warp.windows(2).all(|p| wk(&p[0]) < wk(&p[1])), "{h:?}");
            assert!(
                warp.windows(2)
                    .all(|p| r.key(p[0].0, p[0].1) / r.sweep_span() <= r.key(p[1].0, p[1].1) / r.sweep_span())
            );
            for sheet in 0..8 {
                let mine = |ls: &[Line]| -> Vec<(u32, u32)> {
                    ls.iter().filter(|l| l.sheet == sheet).flat_map(|l| l.samples()).collect()
                };
                let mut fwd = mine(&forward_lines(w, ht, &e));
                fwd.reverse();
                assert_eq!(mine(&warp_lines), fwd, "{h:?}: sheet {sheet} not exactly backwards");
            }
        }
    }

    #[test]
    fn front_epipole_sample_is_last_of_its_sheet() {
        let e = Epipole { h: DVec3::new(2.0, 2.0, 1.0) };
        let lines = forward_lines(5, 5, &e);
        let sheet0: Vec<_> = lines.iter().filter(|l| l.sheet == 0).flat_map(|l| l.samples()).collect();
        assert_eq!(sheet0.last(), Some(&(2, 2)));
    }
}
