//! Memory system: the off-chip memory the warper shares with the renderer
//! and the display.
//!
//! Job: give every unit that reads or writes main memory (reference fetch,
//! destination tile fill and write-back, output) one bandwidth- and
//! latency-limited channel, and count its bytes per client.
//!
//! API: [`dram`] ([`Dram`], [`DramConfig`], [`Client`], [`Access`],
//! [`Request`], [`DRAM_STATS`]), [`backend`] (what times the channel's
//! requests: [`DramBackend`], the default [`IdealBackend`]), [`port`] (the
//! memory port: [`MemPort`], request [`Tag`]s) and [`layout`] (the memory
//! map that gives every request its address: [`MemoryLayout`], [`Region`]).
//!
//! Rules and timing: see [`dram`] and [`backend`]. Not modelled here: on-chip caches (the
//! source and destination caches are units of their own).

pub mod backend;
pub mod dram;
pub mod layout;
pub mod port;

pub use backend::{BackendCounters, DramBackend, DramBackendFactory, IdealBackend, NextEvent};
pub use dram::{Access, Client, DRAM_STATS, Dram, DramConfig, Request};
pub use layout::{MemoryLayout, Region, RegionKind};
pub use port::{MemPort, Req, Tag};
