//! File helpers shared by every reader and writer:
//! - [`input`]: opening inputs: only regular files are read, and a path
//!   that is missing, a directory, a FIFO, a device or a symbolic-link loop
//!   is reported as exactly that, naming the path; text inputs must be
//!   UTF-8 without a byte-order mark;
//! - [`atomic`]: one output file, written under a temporary name in the
//!   same directory and renamed into place;
//! - [`out_dir`]: one output folder, built under a temporary name beside
//!   the target and renamed into place at the end (`--out` / `--force`).

pub mod atomic;
pub mod input;
pub mod out_dir;

pub use atomic::{temp_path, write_atomically, write_bytes_atomically};
pub use input::{InputError, check_input_file, read_input, read_text};
pub use out_dir::OutDir;
