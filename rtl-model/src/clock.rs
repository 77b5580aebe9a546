//! Clock cycles.
//!
//! Job: name a point in simulated time so that it cannot be confused with a
//! count of bytes, samples or anything else (the `Cycle` newtype of
//! mooneye-gb).
//!
//! API: [`Cycle`] wraps a `u64` cycle number counted from 0 at the start of the
//! simulation. `Cycle + u64 -> Cycle` (later point), `Cycle - u64 -> Cycle`
//! (earlier point), `Cycle - Cycle -> u64` (a duration in cycles), `+=`,
//! ordering, [`Cycle::next`], and `Display` as the bare number.
//!
//! Rules: the engine owns the clock; units only receive the current `Cycle`
//! as an argument and never advance it themselves. Durations are plain `u64`
//! cycle counts; only points in time are `Cycle`. Arithmetic that would leave
//! the range of `u64` (a point before cycle 0, or past `u64::MAX`) is a
//! programming error and panics in every build.
//!
//! Throughput/latency: not applicable (a value type).
//!
//! Not modelled: multiple clock domains and clock ratios; every unit runs on
//! the one engine clock.

use std::fmt;
use std::ops::{Add, AddAssign, Sub};

/// A point in simulated time: the cycle number since the start (cycle 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Cycle(pub u64);

impl Cycle {
    /// The first cycle.
    pub const ZERO: Cycle = Cycle(0);

    /// The cycle number.
    pub const fn get(self) -> u64 {
        self.0
    }

    /// The following cycle.
    pub const fn next(self) -> Cycle {
        Cycle(self.0 + 1)
    }
}

impl Add<u64> for Cycle {
    type Output = Cycle;

    /// The point `cycles` later.
    fn add(self, cycles: u64) -> Cycle {
        Cycle(self.0.checked_add(cycles).expect("Cycle + u64 overflowed"))
    }
}

impl AddAssign<u64> for Cycle {
    fn add_assign(&mut self, cycles: u64) {
        *self = *self + cycles;
    }
}

impl Sub<u64> for Cycle {
    type Output = Cycle;

    /// The point `cycles` earlier.
    fn sub(self, cycles: u64) -> Cycle {
        Cycle(self.0.checked_sub(cycles).expect("Cycle - u64 went before cycle 0"))
    }
}

impl Sub<Cycle> for Cycle {
    type Output = u64;

    /// The number of cycles from `earlier` to `self`.
    fn sub(self, earlier: Cycle) -> u64 {
        self.0.checked_sub(earlier.0).expect("Cycle - Cycle: the right-hand side is later")
    }
}

impl fmt::Display for Cycle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_between_points_and_durations() {
        let n = Cycle(10);
        assert_eq!(n + 5, Cycle(15));
        assert_eq!(n - 3, Cycle(7));
        assert_eq!(Cycle(15) - n, 5);
        assert_eq!(n.next(), Cycle(11));
        let mut m = n;
        m += 2;
        assert_eq!(m, Cycle(12));
        assert_eq!(Cycle::ZERO.get(), 0);
    }

    #[test]
    fn ordering_follows_time() {
        assert!(Cycle(3) < Cycle(4));
        assert_eq!(Cycle(7).max(Cycle(2)), Cycle(7));
    }

    #[test]
    fn display_is_the_bare_number() {
        assert_eq!(Cycle(42).to_string(), "42");
    }

    #[test]
    #[should_panic(expected = "right-hand side is later")]
    fn a_negative_duration_panics() {
        let _ = Cycle(1) - Cycle(2);
    }

    #[test]
    #[should_panic(expected = "before cycle 0")]
    fn a_point_before_cycle_zero_panics() {
        let _ = Cycle(1) - 2;
    }
}
