//! `postwarp`: traces, the scene renderer, the golden model, comparison
//! methods, metrics, reports and the `postwarp` command line, around the
//! cycle-level hardware model in `postwarp-rtl`.
//!
//! Data flow: `trace` (files → [`trace::Trace`]) → `postwarp_rtl::cmd`
//! (frame commands) → golden model | hardware units → images + stats →
//! report. See `ARCHITECTURE.md`.

pub mod bench;
pub mod chart;
pub mod cli;
pub mod dram;
pub mod fuzz_entry;
pub mod golden;
pub mod huge_pages;
pub mod import;
pub mod io_util;
pub mod knobs;
pub mod methods;
pub mod metrics;
pub mod path;
pub mod picture;
pub mod progress;
pub mod report;
pub mod rescore;
pub mod run;
pub mod scene;
pub mod size;
pub mod sweep;
pub mod trace;
pub mod tracegen;

pub use postwarp_rtl as rtl;
