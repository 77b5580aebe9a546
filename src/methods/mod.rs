//! Comparison methods: other ways to make a derived frame from the same
//! [`postwarp_rtl::FrameCommands`] and reference samples as the golden
//! model, so its images and speed have something to be measured against.
//!
//! - [`forward_splat`](mod@forward_splat): the plain per-sample forward
//!   splat with a depth test, no reconstruction and no hole fill (the
//!   baseline of the anchors).

pub mod forward_splat;

pub use forward_splat::{ForwardSplatFrame, ForwardSplatStats, SplatPlanes, forward_splat};
