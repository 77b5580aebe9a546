//! Importers of real data: captured images with depth turned into traces.
//!
//! Rules: importers read source folders and write traces only through
//! [`crate::trace::TraceWriter`]; they print nothing, and every failure is an
//! error naming the file (and line, for text files) and what was expected.
//!
//! - [`middlebury`]: Middlebury 2014 rectified stereo pairs
//!   (left view + disparity → reference, right view → derived frame with truth).
//! - [`pfm`]: the Portable Float Map reader they need.

pub mod middlebury;
pub mod pfm;

pub use middlebury::{Calib, ImportError, MiddleburyPair, import_middlebury, read_middlebury};
pub use pfm::{PfmError, PfmImage, read_pfm};
