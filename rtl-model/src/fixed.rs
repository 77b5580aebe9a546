//! Fixed-point number formats, named by their Q format (as tiny-skia names
//! `FDot16`): `Q16_16` is a signed 32-bit number with 16 fraction bits.
//!
//! Rules: conversion from `f64` rounds to nearest, ties away from zero, and
//! saturates at the format's range; arithmetic saturates too. These are the
//! formats the hardware model's datapath uses for image coordinates and that
//! the golden model's fixed-point mode reproduces bit for bit.

/// Signed fixed point, 16 integer bits (incl. sign) and 16 fraction bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Q16_16(pub i32);

impl Q16_16 {
    /// Number of fraction bits.
    pub const FRAC_BITS: u32 = 16;
    /// One unit.
    pub const ONE: Q16_16 = Q16_16(1 << 16);
    /// Largest representable value.
    pub const MAX: Q16_16 = Q16_16(i32::MAX);
    /// Smallest representable value.
    pub const MIN: Q16_16 = Q16_16(i32::MIN);

    /// Nearest representable value (ties away from zero), saturating; NaN
    /// maps to zero.
    pub fn from_f64(v: f64) -> Q16_16 {
        let scaled = (v * 65536.0).round();
        if scaled.is_nan() {
            Q16_16(0)
        } else if scaled >= i32::MAX as f64 {
            Self::MAX
        } else if scaled <= i32::MIN as f64 {
            Self::MIN
        } else {
            Q16_16(scaled as i32)
        }
    }

    /// Exact value as `f64`.
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / 65536.0
    }

    /// Largest integer not above the value.
    pub fn floor(self) -> i32 {
        self.0 >> 16
    }

    /// Smallest integer not below the value.
    pub fn ceil(self) -> i32 {
        ((self.0 as i64 + 0xFFFF) >> 16) as i32
    }

    /// Saturating addition.
    pub fn saturating_add(self, o: Q16_16) -> Q16_16 {
        Q16_16(self.0.saturating_add(o.0))
    }

    /// Saturating subtraction.
    pub fn saturating_sub(self, o: Q16_16) -> Q16_16 {
        Q16_16(self.0.saturating_sub(o.0))
    }

    /// Product rounded to nearest (ties away from zero), saturating.
    pub fn saturating_mul(self, o: Q16_16) -> Q16_16 {
        let p = self.0 as i64 * o.0 as i64;
        let half = 1i64 << 15;
        let r = if p >= 0 { (p + half) >> 16 } else { -((-p + half) >> 16) };
        Q16_16(r.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_values() {
        assert_eq!(Q16_16::from_f64(1.5).0, 0x18000);
        assert_eq!(Q16_16::from_f64(-0.5).floor(), -1);
        assert_eq!(Q16_16::from_f64(-0.5).ceil(), 0);
        assert_eq!(Q16_16::from_f64(2.0).ceil(), 2);
        assert_eq!(Q16_16::from_f64(1e9), Q16_16::MAX);
        assert_eq!(Q16_16::from_f64(f64::NAN), Q16_16(0));
        assert_eq!(Q16_16::from_f64(3.0).saturating_mul(Q16_16::from_f64(-0.25)).to_f64(), -0.75);
    }

    proptest! {
        #[test]
        fn conversion_is_within_half_an_ulp(v in -30000.0f64..30000.0) {
            let q = Q16_16::from_f64(v);
            prop_assert!((q.to_f64() - v).abs() <= 0.5 / 65536.0 + 1e-12);
        }

        #[test]
        fn mul_matches_i128_reference(a in any::<i32>(), b in any::<i32>()) {
            let exact = a as i128 * b as i128;
            let r = Q16_16(a).saturating_mul(Q16_16(b)).0 as i128;
            let want = (exact as f64 / 65536.0).round().clamp(i32::MIN as f64, i32::MAX as f64) as i128;
            // f64 rounding of the reference can be off by one on huge products.
            prop_assert!((r - want).abs() <= 1, "{a} * {b}: {r} vs {want}");
        }

        #[test]
        fn floor_ceil_bracket(v in any::<i32>()) {
            let q = Q16_16(v);
            prop_assert!(q.floor() as f64 <= q.to_f64());
            prop_assert!(q.ceil() as f64 >= q.to_f64());
            prop_assert!(q.ceil() - q.floor() <= 1);
        }
    }
}
