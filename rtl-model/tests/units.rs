//! The hardware model's integration tests (per-unit timing tests and the
//! schedule's properties), one module per file of `rtl-model/tests/`, in one
//! test binary: `cargo test -p postwarp-rtl --test units unit_raster::`.

mod common;

mod schedule_props;
mod unit_composite;
mod unit_dest_cache;
mod unit_fallback_fill;
mod unit_fetch;
mod unit_hole_fill;
mod unit_kernel_setup;
mod unit_mem_port;
mod unit_packer;
mod unit_raster;
mod unit_tile_manager;
mod unit_tile_prefetch;
mod unit_transform;
