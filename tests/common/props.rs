//! Generators shared by the property suites (`tests/props_*.rs` and
//! `hw_traversal_hole_fill.rs`).

use glam::DVec3;
use postwarp_rtl::camera::Epipole;
use proptest::prelude::*;

/// The finite epipole at image point `(px, py)` with homogeneous weight
/// `ew` (`ew > 0`: the other centre in front, `ew < 0`: behind).
pub fn finite(px: f64, py: f64, ew: f64) -> Epipole {
    Epipole { h: DVec3::new(px * ew, py * ew, ew) }
}

/// Random epipoles of every kind: anywhere in front or behind (inside the
/// image or far outside), on the half-sample grid (sample centres, rows,
/// columns, diagonals), at infinity in any direction, any homogeneous
/// vector, and coincident centres.
pub fn epipole_strategy() -> impl Strategy<Value = Epipole> {
    let ew = prop_oneof![-4.0f64..-1e-3, 1e-3f64..4.0];
    prop_oneof![
        (-40.0f64..60.0, -40.0f64..60.0, ew).prop_map(|(x, y, w)| finite(x, y, w)),
        (-8i32..40, -8i32..40, prop::sample::select(vec![1.0, -1.0, 0.5, -2.0])).prop_map(|(x, y, w)| finite(
            x as f64 / 2.0,
            y as f64 / 2.0,
            w
        )),
        (0.0f64..std::f64::consts::TAU).prop_map(|a| Epipole { h: DVec3::new(a.cos(), a.sin(), 0.0) }),
        (-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0).prop_map(|(x, y, z)| Epipole { h: DVec3::new(x, y, z) }),
        Just(Epipole { h: DVec3::ZERO }),
    ]
}
