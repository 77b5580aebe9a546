//! The golden model's configuration that implements the same rules as a
//! hardware configuration: `postwarp simulate` runs both on one trace and
//! compares them, so their functional knobs must agree.

use crate::golden::config::{GoldenConfig, OverLimit, Reconstruction, WarpOrder};
use postwarp_rtl::config::EngineConfig;

/// The golden configuration matching `hw`'s functional knobs (the hardware
/// draws the anti-aliased rectangles, clips kernels to its stamp, warps in
/// the reverse order and always hole-fills).
pub fn golden_config_for(hw: &EngineConfig) -> GoldenConfig {
    GoldenConfig {
        threshold: hw.threshold,
        kernel_limit: hw.kernel_limit,
        over_limit: OverLimit::Clip,
        slope_tol: hw.slope_tol,
        rel_tol: hw.rel_tol,
        better_margin: hw.better_margin,
        abuffer_fragments: hw.abuffer_fragments,
        hole_fill: true,
        fallback_fill: hw.fallback_fill,
        hole_far_distance: hw.hole_far_distance,
        hole_far_offset: hw.hole_far_offset,
        hole_max_distance: hw.hole_max_distance,
        warp_order: WarpOrder::Reverse,
        reconstruction: Reconstruction::AaRect,
    }
}
