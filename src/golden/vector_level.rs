//! The vector instructions the golden model's warps run with.
//!
//! The build targets x86-64-v2 (`.cargo/config.toml`): SSE4.2, two f64
//! lanes, on every x86-64 CPU since about 2009. Where the host also has
//! AVX2 (four lanes; most CPUs since 2013), each warp's work runs a second
//! copy of the same code compiled for it, chosen at run time: `WarpStep`
//! in `frame.rs` and what it inlines — culling, the anti-aliased path's
//! transform, group tests, phases A and B, kernel slopes and masks, the
//! plane resets and the A-buffer trip. Out of line, at the baseline at
//! every level: hole fill (inlined too, the frame took 2 % longer), the
//! general reconstruction's warp, the fixed mode's per-sample rounding
//! (`fixed_transform`, `fix_group_row`), the exact edge corners (a few per
//! cent of samples), and after the warps the fallback pass and resolve. The golden frame takes about
//! 10 % less time (`docs/performance.md`); the forward splat and the
//! hardware model gain nothing from AVX2 (measured with the whole crate
//! built for x86-64-v3), so they keep one copy. A build for a wider
//! `target-cpu` (`native`, x86-64-v3) has AVX2 in its baseline already, and
//! both copies are then the same.
//!
//! Values never depend on the level: both copies are the same IEEE-754
//! binary64 operations in the same order. Fused multiply-add is not
//! enabled (and Rust never contracts `a * b + c` on its own), and rounding,
//! square root and conversions are exact in both. `tests/props_vector_level.rs`
//! compares every plane, pixel (bit for bit) and counter of frames warped
//! at both levels.

/// Instruction level of a [`crate::golden::frame::Warper`]'s warps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VectorLevel(Level);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Level {
    Baseline,
    /// Only made by [`VectorLevel::detect`] on a host that has every
    /// feature [`with_avx2`] enables.
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl VectorLevel {
    /// The build's baseline (any host the binary runs on).
    pub const BASELINE: VectorLevel = VectorLevel(Level::Baseline);

    /// The widest level this host has.
    pub fn detect() -> VectorLevel {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
        {
            return VectorLevel(Level::Avx2);
        }
        VectorLevel::BASELINE
    }

    /// Name printed by `postwarp bench`: `baseline` or `avx2`.
    pub fn name(self) -> &'static str {
        match self.0 {
            Level::Baseline => "baseline",
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => "avx2",
        }
    }

    /// Run `w` at this level.
    #[inline(always)]
    pub fn run<W: Work>(self, w: W) -> W::Output {
        match self.0 {
            Level::Baseline => w.run(),
            // SAFETY: `Avx2` is only made by `detect` after the host was
            // found to have every feature `with_avx2` enables.
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => unsafe { with_avx2(w) },
        }
    }
}

/// Work compiled once per level: [`Work::run`] and whatever it inlines
/// (mark it and the loops it calls `#[inline(always)]`: a closure cannot
/// be, and functions called out of line run at the baseline).
pub trait Work {
    /// What the work returns.
    type Output;
    /// Do the work.
    fn run(self) -> Self::Output;
}

/// `w.run()` compiled with AVX2 (and the bit-manipulation instructions of
/// x86-64-v3), without FMA.
///
/// # Safety
/// The host must have the features enabled here.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt")]
#[inline]
unsafe fn with_avx2<W: Work>(w: W) -> W::Output {
    w.run()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_baseline_is_named_and_detection_is_stable() {
        assert_eq!(VectorLevel::BASELINE.name(), "baseline");
        assert_eq!(VectorLevel::detect(), VectorLevel::detect());
        struct Answer;
        impl Work for Answer {
            type Output = u32;
            #[inline(always)]
            fn run(self) -> u32 {
                6 * 7
            }
        }
        assert_eq!(VectorLevel::BASELINE.run(Answer), 42);
        assert_eq!(VectorLevel::detect().run(Answer), 42);
    }
}
