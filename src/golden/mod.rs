//! The golden model: Mark's warper on the CPU, frame at a time, in floating
//! point, with no notion of cycles. It never imports the hardware model's
//! units; it shares only the plain data types of `postwarp_rtl` (cameras,
//! sample images, frame commands), the fixed mode's format primitives
//! (`qformat`) and the knob machinery (`knob`, `shared_knobs`).
//!
//! File names match the hardware units in `rtl-model/src/units/`.

pub mod abuffer;
pub mod composite;
pub mod config;
pub mod cull;
pub mod fallback_fill;
pub mod frame;
pub mod general;
pub mod hole_fill;
pub mod kernel_setup;
pub mod phase_times;
pub mod planes;
pub mod raster;
pub mod resolve;
pub mod transform;
pub mod traversal;
pub mod vector_level;
mod warp_aa;
