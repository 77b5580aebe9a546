//! Fixed-point formats of the datapath's fixed mode (`arith = "fixed"`),
//! named by Q format, and the arithmetic primitives both engines apply
//! with them (`docs/fixed-point.md`).
//!
//! Job: parse and print a format name (`"Q16_4"`: signed two's complement,
//! 16 integer bits including the sign, 4 fraction bits), give its range and
//! step, round a value into it, saturate and say so, multiply two values
//! exactly and round once, and build the reciprocal the way hardware does
//! (seed table + Newton–Raphson). [`FixedFormats`] is the parsed set of
//! the fixed mode's knobs.
//!
//! Rules:
//! 1. A format `Qm_n` has `m ≥ 1` integer bits (the sign included),
//!    `n ≥ 0` fraction bits and `m + n ≤ 53`, so that every value of it is
//!    an `f64` exactly: the engines hold fixed-point values in `f64`
//!    registers, always on the format's grid.
//! 2. Rounding is to nearest, ties away from zero.
//! 3. A value beyond the range takes the nearest end of it
//!    (`−2^(m−1)` … `2^(m−1) − 2^−n`) and is a *saturation*; so is NaN,
//!    which becomes 0. Callers count saturations per stage.
//! 4. A product of two format values is computed exactly (integers) and
//!    rounded once into the result's format.
//! 5. The reciprocal ([`FixedFormats::reciprocal`]): normalise the
//!    positive input to `m·2^e`, `m ∈ [1, 2)` (a leading-zero count);
//!    seed `1/m` from a table of `2^recip_table_bits` entries indexed by
//!    the fraction's top bits (each entry the reciprocal of its interval's
//!    midpoint, [`RECIP_WORK_BITS`] fraction bits); `recip_iterations`
//!    Newton–Raphson steps `y ← y·(2 − m·y)` in the same working precision
//!    (each product truncated); scale by `2^−e` and round once into the
//!    output format. Its relative error before the last rounding is at
//!    most `2^−(t+1)·2^k` for `t` table bits and `k` iterations (the
//!    seed's `2^−(t+1)`, squared by each step), plus the working
//!    precision's truncations ([`recip_error_bound`]).
//!
//! Throughput/latency: not applicable (combinational primitives; the
//! units' pipelines are timed by their knobs).
//!
//! Not modelled: the formats of the per-warp constants (`H`, `ê`, the
//! disparity scales and the intrinsics stay `f64`; `docs/fixed-point.md`).

use std::fmt;

/// What a format knob accepts, in words (messages and docs).
pub const QFORMAT_RULE: &str = "a Q format \"Qm_n\": signed, m ≥ 1 integer bits including the sign, n ≥ 0 fraction \
                                bits, m + n ≤ 53 (e.g. \"Q16_16\")";

/// Fraction bits of the reciprocal's working precision (rule 5).
pub const RECIP_WORK_BITS: u32 = 60;

/// A signed fixed-point format `Qm_n` (rule 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct QFormat {
    /// Integer bits, the sign included (`m`).
    pub int_bits: u32,
    /// Fraction bits (`n`).
    pub frac_bits: u32,
}

impl fmt::Display for QFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Q{}_{}", self.int_bits, self.frac_bits)
    }
}

impl QFormat {
    /// `Qm_n`, or `None` if it breaks rule 1.
    pub const fn new(int_bits: u32, frac_bits: u32) -> Option<QFormat> {
        if int_bits >= 1 && int_bits + frac_bits <= 53 { Some(QFormat { int_bits, frac_bits }) } else { None }
    }

    /// Parse `"Qm_n"` (rule 1); the error says what was expected.
    pub fn parse(s: &str) -> Result<QFormat, String> {
        let bad = || format!("\"{s}\": expected {QFORMAT_RULE}");
        let rest = s.strip_prefix('Q').ok_or_else(bad)?;
        let (m, n) = rest.split_once('_').ok_or_else(bad)?;
        let digits = |t: &str| !t.is_empty() && t.len() <= 3 && t.bytes().all(|b| b.is_ascii_digit());
        if !digits(m) || !digits(n) {
            return Err(bad());
        }
        let (m, n): (u32, u32) = (m.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
        QFormat::new(m, n).ok_or_else(bad)
    }

    /// True if `s` names a format (rule 1).
    pub fn is_valid(s: &str) -> bool {
        QFormat::parse(s).is_ok()
    }

    /// Total bits (`m + n`).
    pub const fn bits(self) -> u32 {
        self.int_bits + self.frac_bits
    }

    /// The step between adjacent values, `2^−n`.
    pub fn ulp(self) -> f64 {
        (-(self.frac_bits as f64)).exp2()
    }

    /// Largest raw (integer) value, `2^(m+n−1) − 1`.
    pub const fn raw_max(self) -> i64 {
        (1i64 << (self.bits() - 1)) - 1
    }

    /// Smallest raw value, `−2^(m+n−1)`.
    pub const fn raw_min(self) -> i64 {
        -(1i64 << (self.bits() - 1))
    }

    /// Largest value.
    pub fn max(self) -> f64 {
        self.raw_max() as f64 * self.ulp()
    }

    /// Smallest value.
    pub fn min(self) -> f64 {
        self.raw_min() as f64 * self.ulp()
    }

    /// `v` clamped into the range (no rounding): where a saturating value
    /// can end up.
    pub fn clamp(self, v: f64) -> f64 {
        v.clamp(self.min(), self.max())
    }

    /// The raw value of a grid value `v` (exact for values of this format).
    #[inline]
    fn raw_of(self, v: f64) -> i64 {
        (v * (self.frac_bits as f64).exp2()) as i64
    }

    /// `raw · 2^−n`, saturated into the range (rules 3), and whether it
    /// saturated.
    #[inline]
    fn saturate_raw(self, raw: i128) -> (f64, bool) {
        let (lo, hi) = (self.raw_min() as i128, self.raw_max() as i128);
        let sat = raw < lo || raw > hi;
        (raw.clamp(lo, hi) as f64 * self.ulp(), sat)
    }

    /// `v` rounded to nearest, ties away from zero (rule 2), saturated
    /// (rule 3); the flag says whether it saturated.
    #[inline]
    pub fn quantise(self, v: f64) -> (f64, bool) {
        let scaled = (v * (self.frac_bits as f64).exp2()).round();
        if scaled.is_nan() {
            return (0.0, true);
        }
        let (lo, hi) = (self.raw_min() as f64, self.raw_max() as f64);
        if scaled > hi {
            (self.max(), true)
        } else if scaled < lo {
            (self.min(), true)
        } else {
            (scaled * self.ulp(), false)
        }
    }

    /// [`QFormat::quantise`], adding 1 to `sat` if it saturated.
    #[inline]
    pub fn q(self, v: f64, sat: &mut u32) -> f64 {
        let (r, s) = self.quantise(v);
        *sat += s as u32;
        r
    }

    /// The product of `a` (a value of `fa`) and `b` (of `fb`), computed
    /// exactly and rounded once into this format (rule 4).
    #[inline]
    pub fn mul(self, a: f64, fa: QFormat, b: f64, fb: QFormat) -> (f64, bool) {
        let p = fa.raw_of(a) as i128 * fb.raw_of(b) as i128;
        let shift = fa.frac_bits as i32 + fb.frac_bits as i32 - self.frac_bits as i32;
        self.saturate_raw(shift_round(p, shift))
    }
}

/// `v · 2^−shift` rounded to nearest, ties away from zero (`shift` may be
/// negative: an exact left shift, saturating far beyond any format).
#[inline]
fn shift_round(v: i128, shift: i32) -> i128 {
    if shift <= 0 {
        let s = (-shift).min(60) as u32;
        return v.saturating_mul(1i128 << s);
    }
    if shift >= 126 {
        return 0;
    }
    let half = 1i128 << (shift - 1);
    if v >= 0 { (v + half) >> shift } else { -((-v + half) >> shift) }
}

/// The bound of rule 5 on the reciprocal's relative error before its
/// final rounding, for `table_bits` and `iterations`.
pub fn recip_error_bound(table_bits: u32, iterations: u32) -> f64 {
    // The seed's interval half-width, plus its entry's rounding.
    let seed = (-(table_bits as f64 + 1.0)).exp2() + (-(RECIP_WORK_BITS as f64 - 1.0)).exp2();
    // Each step squares the relative error and adds the working
    // precision's two truncations (at most 2^−59 relative, y ≥ 1/2).
    (0..iterations).fold(seed, |e, _| e * e + (-(RECIP_WORK_BITS as f64 - 2.0)).exp2())
}

/// The hardware reciprocal of rule 5: its seed table and iteration count.
#[derive(Clone, Debug, PartialEq)]
pub struct Reciprocal {
    /// Index bits of the seed table.
    pub table_bits: u32,
    /// Newton–Raphson steps.
    pub iterations: u32,
    /// `table[i]` ≈ `2^W / (1 + (i + ½)/2^t)`, `W` = [`RECIP_WORK_BITS`].
    table: Vec<u64>,
}

impl Reciprocal {
    /// The reciprocal with a `2^table_bits`-entry seed table (1 to 16 bits)
    /// and `iterations` steps.
    pub fn new(table_bits: u32, iterations: u32) -> Reciprocal {
        let t = table_bits.clamp(1, 16);
        let table = (0..1u64 << t)
            .map(|i| {
                // 2^W / ((2^(t+1) + 2i + 1) / 2^(t+1)), rounded to nearest.
                let den = (1u128 << (t + 1)) + 2 * i as u128 + 1;
                let num = 1u128 << (RECIP_WORK_BITS + t + 1);
                ((num + den / 2) / den) as u64
            })
            .collect();
        Reciprocal { table_bits: t, iterations, table }
    }

    /// `1/v` for `v` a positive value of `input`, rounded into `out`
    /// (rule 5); saturates (flag set) when `1/v` exceeds `out`'s range or
    /// `v ≤ 0`.
    pub fn of(&self, v: f64, input: QFormat, out: QFormat) -> (f64, bool) {
        let raw = input.raw_of(v);
        if raw <= 0 {
            return (out.max(), true);
        }
        let w = RECIP_WORK_BITS;
        let p = 63 - raw.leading_zeros(); // v = m · 2^(p − n_in), m ∈ [1, 2)
        // m in the working precision: exact (raw has at most 53 bits < W).
        let m: u128 = (raw as u128) << (w - p);
        let t = self.table_bits;
        let idx = ((m >> (w - t)) & ((1 << t) - 1)) as usize;
        let mut y = self.table[idx] as u128;
        let two = 2u128 << w;
        for _ in 0..self.iterations {
            let e = (m * y) >> w; // m·y, ≈ 1
            y = (y * (two - e.min(two))) >> w;
        }
        // 1/v = y · 2^(n_in − p) / 2^W; in `out`: raw_out = y · 2^(n_in − p + n_out − W).
        let shift = w as i32 + p as i32 - input.frac_bits as i32 - out.frac_bits as i32;
        out.saturate_raw(shift_round(y as i128, shift))
    }
}

/// The names of the fixed mode's format knobs, in [`FixedFormats`] field
/// order (the same in both engines' knob tables).
pub const Q_KNOBS: [&str; 11] = [
    "q_ref_coord",
    "q_ref_inv_z",
    "q_numerator",
    "q_denominator",
    "q_reciprocal",
    "q_position",
    "q_inv_z",
    "q_slope",
    "q_corner",
    "q_colour",
    "q_hole_weight",
];

/// The parsed formats of the fixed mode (rule 1), with the reciprocal.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedFormats {
    /// Reference sample coordinates `(x ± ½, y ± ½)`.
    pub ref_coord: QFormat,
    /// Reference 1/Z.
    pub ref_inv_z: QFormat,
    /// The warp numerators `N.x`, `N.y`.
    pub numerator: QFormat,
    /// The warp denominator `W`.
    pub denominator: QFormat,
    /// `1/W`.
    pub reciprocal: QFormat,
    /// Derived positions `(x', y')`.
    pub position: QFormat,
    /// Derived 1/Z.
    pub inv_z: QFormat,
    /// Slopes of 1/Z (reference and derived) and the expected spacing `E`.
    pub slope: QFormat,
    /// Kernel corners (shared and edge).
    pub corner: QFormat,
    /// Colours (reference, hole-fill planes 1 and 6).
    pub colour: QFormat,
    /// Hole-fill weights (`1/d`, plane 9).
    pub hole_weight: QFormat,
    /// The reciprocal unit (rule 5).
    pub recip: Reciprocal,
}

/// Derived samples by which the fixed mode widens the schedule's and the
/// culling's warped bounds: more than the fixed-point geometry's error
/// at the smallest precisions [`FixedFormats::from_knobs`] accepts.
pub const BOUND_MARGIN: f64 = 0.25;

impl FixedFormats {
    /// Parse the format knobs' values `q` (in [`Q_KNOBS`] order) and check
    /// the rules between them; errors name the knob.
    pub fn from_knobs(q: [&str; 11], table_bits: u32, iterations: u32) -> Result<FixedFormats, String> {
        let mut f = [QFormat { int_bits: 1, frac_bits: 0 }; 11];
        for (k, (name, s)) in Q_KNOBS.iter().zip(q).enumerate() {
            f[k] = QFormat::parse(s).map_err(|e| format!("{name} = {e}"))?;
        }
        let [
            ref_coord,
            ref_inv_z,
            numerator,
            denominator,
            reciprocal,
            position,
            inv_z,
            slope,
            corner,
            colour,
            hole_weight,
        ] = f;
        let out = FixedFormats {
            ref_coord,
            ref_inv_z,
            numerator,
            denominator,
            reciprocal,
            position,
            inv_z,
            slope,
            corner,
            colour,
            hole_weight,
            recip: Reciprocal::new(table_bits, iterations),
        };
        out.check_precision(table_bits, iterations)?;
        Ok(out)
    }

    /// The precision the schedule's bound margin ([`BOUND_MARGIN`]) needs
    /// of the geometry (`docs/fixed-point.md`, "Why minimum precisions").
    fn check_precision(&self, table_bits: u32, iterations: u32) -> Result<(), String> {
        let need = |name: &str, f: QFormat, n: u32, why: &str| {
            if f.frac_bits < n {
                Err(format!("{name} = \"{f}\": expected at least {n} fraction bits ({why})"))
            } else {
                Ok(())
            }
        };
        need("q_ref_coord", self.ref_coord, 1, "the edge corners sit at x ± 1/2")?;
        for (name, f) in [
            ("q_numerator", self.numerator),
            ("q_denominator", self.denominator),
            ("q_position", self.position),
            ("q_corner", self.corner),
        ] {
            need(name, f, 12, "the schedule's bounds allow a quarter sample of fixed-point error")?;
        }
        need("q_reciprocal", self.reciprocal, 16, "the schedule's bounds allow a quarter sample of fixed-point error")?;
        let bound = recip_error_bound(table_bits, iterations);
        if (table_bits as u64 + 1) << iterations.min(16) < 20 {
            return Err(format!(
                "recip_iterations = {iterations}: expected (recip_table_bits + 1) · 2^recip_iterations ≥ 20 (relative \
                 error at most 2^-20; recip_table_bits = {table_bits} gives {bound:.1e})"
            ));
        }
        Ok(())
    }

    /// `1/v` of a value of [`FixedFormats::denominator`] in
    /// [`FixedFormats::reciprocal`] (rule 5), and whether it saturated.
    #[inline]
    pub fn reciprocal_of(&self, v: f64) -> (f64, bool) {
        self.recip.of(v, self.denominator, self.reciprocal)
    }

    /// A warped bound `(lo, hi)` of one axis (derived samples, from the
    /// `f64` warp of a box's corners) as the fixed mode's kernels can
    /// reach it: positions and corners saturate into their ranges, so the
    /// bound is clamped the same ways, and widened by [`BOUND_MARGIN`]
    /// for the rounding of the fixed-point warp.
    pub fn reach(&self, lo: f64, hi: f64) -> (f64, f64) {
        let (p, c) = (self.position, self.corner);
        let lo = p.clamp(lo).min(c.clamp(lo)).min(c.clamp(p.clamp(lo)));
        let hi = p.clamp(hi).max(c.clamp(hi)).max(c.clamp(p.clamp(hi)));
        (lo - BOUND_MARGIN, hi + BOUND_MARGIN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(s: &str) -> QFormat {
        QFormat::parse(s).unwrap()
    }

    #[test]
    fn formats_parse_print_and_refuse() {
        let f = q("Q16_4");
        assert_eq!((f.int_bits, f.frac_bits, f.bits()), (16, 4, 20));
        assert_eq!(f.to_string(), "Q16_4");
        assert_eq!((f.max(), f.min(), f.ulp()), (32768.0 - 0.0625, -32768.0, 0.0625));
        for bad in ["Q0_0", "Q40_40", "X16_16", "Q16", "Q16_", "Q_4", "q16_4", "Q16_4x", "Q1_53", "Q-1_4", "Q+1_4"] {
            let e = QFormat::parse(bad).unwrap_err();
            assert!(e.contains(bad) && e.contains("expected a Q format"), "{bad}: {e}");
        }
        assert!(QFormat::is_valid("Q1_52") && QFormat::is_valid("Q53_0"));
    }

    #[test]
    fn rounding_is_to_nearest_ties_away_and_saturation_is_flagged() {
        let f = q("Q8_2"); // step 0.25, range −128 … 127.75
        assert_eq!(f.quantise(0.125), (0.25, false));
        assert_eq!(f.quantise(-0.125), (-0.25, false));
        assert_eq!(f.quantise(0.1), (0.0, false));
        assert_eq!(f.quantise(0.374), (0.25, false));
        assert_eq!(f.quantise(127.8), (127.75, false));
        assert_eq!(f.quantise(127.9), (127.75, true));
        assert_eq!(f.quantise(-128.1), (-128.0, false));
        assert_eq!(f.quantise(-128.2), (-128.0, true));
        assert_eq!(f.quantise(f64::NAN), (0.0, true));
        assert_eq!(f.quantise(f64::INFINITY), (127.75, true));
        let mut n = 0;
        assert_eq!(f.q(1000.0, &mut n) + f.q(1.0, &mut n), 128.75);
        assert_eq!(n, 1);
        // Every value of a format is an f64 exactly (rule 1).
        let wide = q("Q1_52");
        let (v, s) = wide.quantise(0.3);
        assert!(!s && (v - 0.3).abs() <= wide.ulp() / 2.0);
    }

    #[test]
    fn products_are_exact_then_rounded_once() {
        let (a, b, out) = (q("Q18_14"), q("Q8_24"), q("Q16_16"));
        let (x, y) = (a.quantise(1234.56789).0, b.quantise(0.987654321).0);
        let (p, s) = out.mul(x, a, y, b);
        assert!(!s);
        assert_eq!(p, out.quantise(x * y).0, "the f64 product of these is exact enough to round the same");
        // Ties away from zero, both signs.
        let h = q("Q8_1");
        assert_eq!(h.mul(0.25, q("Q8_2"), 1.0, q("Q8_0")), (0.5, false));
        assert_eq!(h.mul(-0.25, q("Q8_2"), 1.0, q("Q8_0")), (-0.5, false));
        assert_eq!(q("Q7_16").mul(100.0, a, 1.0, b), (q("Q7_16").max(), true));
    }

    /// Rule 5's bound holds over inputs spread across many octaves, for
    /// several tables and iteration counts.
    #[test]
    fn the_reciprocal_is_within_its_error_bound() {
        let (input, out) = (q("Q8_24"), q("Q20_30"));
        for (t, k) in [(8, 2), (8, 1), (4, 2), (3, 3), (12, 1), (8, 0)] {
            let r = Reciprocal::new(t, k);
            let bound = recip_error_bound(t, k);
            let mut worst: f64 = 0.0;
            let mut seed = 0x9e3779b97f4a7c15u64;
            for _ in 0..20000 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                // log-uniform in [2^-20, 2^7)
                let e = (seed >> 11) as f64 / (1u64 << 53) as f64;
                let v = input.quantise((-20.0 + 27.0 * e).exp2()).0;
                if v <= 0.0 {
                    continue;
                }
                let (got, sat) = r.of(v, input, out);
                if sat {
                    assert!(1.0 / v > out.max(), "{v}");
                    continue;
                }
                // The bound relative to 1/v, plus the last rounding's half step.
                let err = (got - 1.0 / v).abs();
                assert!(err <= bound / v * 1.0001 + out.ulp() / 2.0, "t {t} k {k}: 1/{v} = {got}, error {err:e}");
                worst = worst.max(err * v);
            }
            assert!(worst > 0.0, "some rounding happened");
            if k == 0 {
                assert!(worst > 1e-4, "a seed alone is coarse: {worst:e}");
            }
        }
        // The default construction: 2^-36 before rounding, so the Q8_24
        // output's own step dominates.
        assert!(recip_error_bound(8, 2) < 1e-10);
        let r = Reciprocal::new(8, 2);
        assert_eq!(r.of(2.0, input, q("Q8_24")), (0.5, false));
        assert_eq!(r.of(0.0, input, q("Q8_24")), (q("Q8_24").max(), true));
        assert_eq!(r.of(1.0 / 256.0, input, q("Q8_24")), (q("Q8_24").max(), true), "256 is past Q8's 127.99…");
    }

    #[test]
    fn the_knob_set_parses_and_names_the_knob_in_its_errors() {
        let mut v =
            ["Q16_4", "Q8_24", "Q18_14", "Q8_24", "Q8_24", "Q16_16", "Q8_24", "Q8_24", "Q16_16", "Q8_24", "Q8_24"];
        let f = FixedFormats::from_knobs(v, 8, 2).unwrap();
        assert_eq!((f.position, f.hole_weight), (q("Q16_16"), q("Q8_24")));
        v[5] = "Q16";
        let e = FixedFormats::from_knobs(v, 8, 2).unwrap_err();
        assert!(e.starts_with("q_position = \"Q16\": expected a Q format"), "{e}");
        v[5] = "Q16_8";
        let e = FixedFormats::from_knobs(v, 8, 2).unwrap_err();
        assert!(e.starts_with("q_position = \"Q16_8\": expected at least 12 fraction bits"), "{e}");
        v[5] = "Q16_16";
        let e = FixedFormats::from_knobs(v, 2, 1).unwrap_err();
        assert!(e.starts_with("recip_iterations = 1"), "{e}");
        assert!(FixedFormats::from_knobs(v, 4, 2).is_ok(), "(4 + 1) · 4 = 20 bits");
    }

    #[test]
    fn the_reach_covers_every_saturated_position() {
        let f = FixedFormats::from_knobs(
            ["Q16_4", "Q8_24", "Q18_14", "Q8_24", "Q8_24", "Q7_16", "Q8_24", "Q8_24", "Q16_16", "Q8_24", "Q8_24"],
            8,
            2,
        )
        .unwrap();
        // A bound far right of Q7_16's range: positions land at its end.
        let (lo, hi) = f.reach(500.0, 520.0);
        assert!(lo <= f.position.max() && hi >= 520.0, "{lo} {hi}");
        let (lo, hi) = f.reach(10.0, 20.0);
        assert_eq!((lo, hi), (10.0 - BOUND_MARGIN, 20.0 + BOUND_MARGIN));
    }
}
