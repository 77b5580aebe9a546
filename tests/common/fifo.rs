//! Bounded FIFO checks: a reader that wrongly opens a FIFO would block
//! forever, so a test that hands a FIFO to the tools runs them through
//! [`unblocked`]. A writer opens the FIFO and closes it at once; a reader
//! that opened it therefore reads an empty file and fails the test's
//! assertion instead of hanging. A tool that refuses the FIFO unopened
//! never meets the writer, which the helper then releases itself.
#![cfg(unix)]

use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

/// Run `f` (which hands `fifo` to the code under test) with a writer on
/// `fifo` that ends any blocking open by the code under test.
pub fn unblocked<T>(fifo: &Path, f: impl FnOnce() -> T) -> T {
    let p = fifo.to_path_buf();
    // Opening for writing blocks until some reader opens; closing at once
    // gives that reader end of file.
    let writer = std::thread::spawn(move || drop(std::fs::OpenOptions::new().write(true).open(p)));
    let out = f();
    // Release the writer: a non-blocking read open succeeds at once and
    // lets a pending write open return. Repeated in case the writer had
    // not reached its open yet.
    while !writer.is_finished() {
        let _ = std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(fifo);
        std::thread::yield_now();
    }
    let _ = writer.join();
    out
}
