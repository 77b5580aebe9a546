//! The warper's hardware units, one file each (`docs/units.md`), joined by
//! the engine (`crate::engine`).

pub mod abuffer;
pub mod composite;
pub mod fetch;
pub mod hole_fill;
pub mod kernel_setup;
pub mod raster;
pub mod resolve;
pub mod tile_cache;
pub mod transform;
