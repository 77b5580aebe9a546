//! Importers of real data: captured images with depth turned into traces.
//!
//! Rules: importers read source folders and write traces only through
//! [`crate::trace::TraceWriter`]; they print nothing, and every failure is an
//! error naming the file (and line, for text files) and what was expected.
//!
//! - [`middlebury`]: Middlebury 2014 rectified stereo pairs
//!   (left view + disparity → reference, right view → derived frame with truth).
//! - [`pfm`]: the Portable Float Map reader they need.
//! - [`depth_fill`]: `--fill-unknown-depth`, unknown depth filled from the
//!   background side before the warp.
//! - [`visibility`]: the truth's `seen` mask of a stereo pair, from the
//!   disparity.

pub mod depth_fill;
pub mod middlebury;
pub mod pfm;
pub mod visibility;

pub use depth_fill::FillUnknownDepth;
pub use middlebury::{
    Calib, ImportError, MiddleburyPair, import_middlebury, import_middlebury_with, read_middlebury,
    read_middlebury_with,
};
pub use pfm::{PfmError, PfmImage, read_pfm};
