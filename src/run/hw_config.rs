//! The golden model's configuration that implements the same rules as a
//! hardware configuration: `postwarp simulate` runs both on one trace and
//! compares them, so their functional knobs must agree.

use crate::golden::config::{GoldenConfig, KNOBS as GOLDEN_KNOBS, OverLimit, Reconstruction, WarpOrder};
use postwarp_rtl::config::{EngineConfig, KNOBS as HW_KNOBS};
use postwarp_rtl::knob::{find, get_by_name, set_by_name};

/// The knobs both engines have: the golden knobs whose name is also a
/// hardware knob, in the golden table's order. Derived from the two knob
/// tables, so a knob added to both is shared without another list.
pub fn shared_knobs() -> impl Iterator<Item = &'static str> {
    GOLDEN_KNOBS.iter().map(|k| k.name).filter(|n| find(HW_KNOBS, n).is_some())
}

/// The golden knobs the hardware fixes, with the value it fixes them to
/// (it draws the anti-aliased rectangles, clips kernels to its stamp,
/// warps in the reverse order and always hole-fills).
fn hardware_fixed() -> GoldenConfig {
    GoldenConfig {
        over_limit: OverLimit::Clip,
        hole_fill: true,
        warp_order: WarpOrder::Reverse,
        reconstruction: Reconstruction::AaRect,
        ..GoldenConfig::default()
    }
}

/// The golden configuration matching `hw`'s functional knobs: the
/// [`shared_knobs`] copied by name, the rest as the hardware fixes them.
pub fn golden_config_for(hw: &EngineConfig) -> GoldenConfig {
    let mut g = hardware_fixed();
    for name in shared_knobs() {
        let v = get_by_name(HW_KNOBS, hw, name).unwrap_or_else(|| unreachable!("{name} is a hardware knob"));
        // `set` fails only on a value of another type; a shared knob has
        // one type in both tables (tests/knob_table.rs).
        set_by_name(GOLDEN_KNOBS, &mut g, name, v)
            .unwrap_or_else(|e| unreachable!("shared knob {name} has another type in the golden table: {e}"));
    }
    g
}

/// The golden knobs that are not shared, with the value
/// [`golden_config_for`] gives them (for the docs).
pub fn fixed_golden_knobs() -> Vec<(&'static str, postwarp_rtl::knob::KnobValue)> {
    let g = hardware_fixed();
    GOLDEN_KNOBS.iter().filter(|k| find(HW_KNOBS, k.name).is_none()).map(|k| (k.name, (k.get)(&g))).collect()
}
