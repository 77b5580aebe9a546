//! The package's integration tests, one module per file of `tests/`, in one
//! test binary: each binary links the whole library and its dependencies, and
//! linking ~60 of them was most of a cold `cargo test --workspace` on 2 cores.
//! One suite: `cargo test --test suite props_raster::` (a file's tests are
//! the module of its name). Kept apart: `sweep_slurm` (its own harness) and
//! `dram_dramsim3` (needs the `dramsim3` feature).

mod common;

mod bad_inputs;
mod bench_cli;
mod budget;
mod cli;
mod determinism;
mod dram_stats;
mod dram_trace;
mod fixed_point;
mod fuzz_corpus;
mod golden_cli;
mod golden_general;
mod golden_rules;
mod hw_abuffer;
mod hw_display_guard;
mod hw_engine;
mod hw_fallback;
mod hw_fill_on_eviction;
mod hw_look_ahead;
mod hw_model;
mod hw_skip_exact;
mod hw_source_cache;
mod hw_stats_snapshot;
mod hw_tiny_displays;
mod hw_traversal_hole_fill;
mod import_middlebury;
mod interrupted_runs;
mod knob_table;
mod mem_layout;
mod methods_baselines;
mod methods_cli;
mod methods_didyk;
mod methods_lochmann;
mod methods_schollmeyer;
mod methods_schollmeyer_transparent;
mod methods_smit;
mod metrics;
mod non_diffuse;
mod precision;
mod props_abuffer;
mod props_composite;
mod props_dram;
mod props_float_ranges;
mod props_hole_fill;
mod props_kernel;
mod props_raster;
mod props_tile_cache;
mod props_trace;
mod props_vector_level;
mod props_warp;
mod report_docs;
mod scene_materials;
mod scene_render;
mod simulate_cli;
mod simulate_docs;
mod simulate_timeline;
mod size;
mod stability;
mod sweep;
mod sweep_steps;
mod trace_format;
mod trace_layers;
