//! Trace errors: every one names the file, the line when there is one, and
//! what was expected.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error reading or writing a trace.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceError {
    /// The file at fault (manifest or image).
    pub file: PathBuf,
    /// 1-based line in `file`, when the error has one.
    pub line: Option<usize>,
    /// What was wrong and what was expected.
    pub message: String,
    /// For image errors: the manifest and line that named the image.
    pub referenced_from: Option<(PathBuf, Option<usize>)>,
}

impl TraceError {
    /// An error at a line of a file.
    pub fn at(file: &Path, line: Option<usize>, message: impl Into<String>) -> TraceError {
        TraceError { file: file.to_path_buf(), line, message: message.into(), referenced_from: None }
    }

    /// An error about a whole file.
    pub fn file(file: &Path, message: impl Into<String>) -> TraceError {
        Self::at(file, None, message)
    }

    /// An I/O error on a file.
    pub fn io(file: &Path, e: &std::io::Error) -> TraceError {
        Self::file(file, format!("cannot read or write: {e}"))
    }

    /// Record the manifest line that named the faulty image.
    pub fn referenced_from(mut self, manifest: &Path, line: Option<usize>) -> TraceError {
        self.referenced_from = Some((manifest.to_path_buf(), line));
        self
    }
}

impl fmt::Display for TraceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        write!(f, ": {}", self.message)?;
        if let Some((m, l)) = &self.referenced_from {
            write!(f, " (image named at {}", m.display())?;
            if let Some(l) = l {
                write!(f, ":{l}")?;
            }
            write!(f, ")")?;
        }
        Ok(())
    }
}

impl std::error::Error for TraceError {}

impl From<std::io::Error> for TraceError {
    fn from(e: std::io::Error) -> Self {
        TraceError { file: PathBuf::new(), line: None, message: e.to_string(), referenced_from: None }
    }
}
