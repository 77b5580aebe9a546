//! `postwarp-rtl`: the cycle-level hardware model of Mark's post-rendering 3D
//! image warper (UNC TR98-011), and the plain data types it shares with the
//! golden model in the `postwarp` crate.
//!
//! Architecture invariants (see `ARCHITECTURE.md` at the repository root):
//! - this crate does no file I/O and knows nothing of trace files, scenes,
//!   PNG/EXR files or the command line;
//! - it never calls the golden model; the golden model never calls its units.
//!   The two share only the plain data types in [`camera`], [`sample_image`]
//!   and [`cmd`], the fixed mode's format primitives in [`qformat`] (each
//!   engine applies them in its own code), and the knob machinery
//!   ([`knob`], [`shared_knobs`]).
#![warn(missing_docs)]

pub mod bits;
pub mod budget;
pub mod camera;
pub mod clock;
pub mod cmd;
pub mod config;
pub mod dest_frame;
pub mod engine;
pub mod fifo;
pub mod frame_stats;
pub mod host_hint;
pub mod hw_reference;
pub mod knob;
pub mod lru;
pub mod mem;
pub mod qformat;
pub mod ref_blocks;
pub mod sample_image;
pub mod schedule;
pub mod shared_knobs;
pub mod stats;
pub mod timeline;
pub mod traversal;
pub mod units;
pub mod warp_plan;
pub mod watchdog;
pub mod working_set;

pub use camera::{Camera, Epipole, Intrinsics, PlanarCamera, Pose, WarpSetup};
pub use cmd::{FrameCommands, ReferenceWarp};
pub use dest_frame::DestFrame;
pub use sample_image::SampleImage;
