//! Opening inputs. Only regular files are read (a symbolic link is followed
//! to one); anything else is refused before it is opened, so a FIFO never
//! blocks a run and a directory is not reported as missing.
//!
//! Rules:
//! 1. The error names the path and says what it is: missing, a directory,
//!    a FIFO, a socket, a device, a symbolic link to nothing or one that
//!    cannot be resolved (a loop), unreadable.
//! 2. Text inputs ([`read_text`]) must be UTF-8 (the error gives the line
//!    and column of the first bad byte) and must not start with a UTF-8
//!    byte-order mark, which would otherwise be invisible in messages about
//!    the first line.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why an input cannot be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputError {
    /// The path as given.
    pub path: PathBuf,
    /// What is wrong with it and what was expected.
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for InputError {}

fn err(path: &Path, message: impl Into<String>) -> InputError {
    InputError { path: path.to_path_buf(), message: message.into() }
}

/// What a non-regular file is, for messages.
fn kind_of(ft: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_socket() {
            return "a socket";
        }
        if ft.is_block_device() || ft.is_char_device() {
            return "a device";
        }
    }
    if ft.is_dir() { "a directory" } else { "not a regular file" }
}

/// Check that `path` is a regular file (after following symbolic links);
/// `what` names the input in the message ("trace manifest", "image file").
pub fn check_input_file(path: &Path, what: &str) -> Result<(), InputError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) => Err(err(path, format!("is {}; expected the {what}, a regular file", kind_of(m.file_type())))),
        Err(e) => {
            let link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
            Err(if link && e.kind() == std::io::ErrorKind::NotFound {
                let to = std::fs::read_link(path).map(|t| t.display().to_string()).unwrap_or_default();
                err(path, format!("is a symbolic link to `{to}`, which does not exist; expected the {what}"))
            } else if link {
                err(path, format!("is a symbolic link that cannot be resolved ({e}); expected the {what}"))
            } else if e.kind() == std::io::ErrorKind::NotFound {
                err(path, format!("does not exist; expected the {what}"))
            } else {
                err(path, format!("cannot be read ({e}); expected the {what}"))
            })
        }
    }
}

/// The bytes of input file `path` (rule 1).
pub fn read_input(path: &Path, what: &str) -> Result<Vec<u8>, InputError> {
    check_input_file(path, what)?;
    std::fs::read(path).map_err(|e| err(path, format!("cannot read the {what}: {e}")))
}

/// The text of input file `path` (rules 1 and 2).
pub fn read_text(path: &Path, what: &str) -> Result<String, InputError> {
    let bytes = read_input(path, what)?;
    text_of(bytes, path, what)
}

/// Rule 2 on bytes already read.
pub fn text_of(bytes: Vec<u8>, path: &Path, what: &str) -> Result<String, InputError> {
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        return Err(err(
            path,
            format!(
                "line 1 starts with a UTF-8 byte-order mark (bytes EF BB BF); expected the {what} as plain UTF-8 \
                 text (save it without a BOM)"
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = good.iter().filter(|&&b| b == b'\n').count() + 1;
        let col = good.len() - good.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1) + 1;
        err(path, format!("line {line}, column {col}: not UTF-8 text; expected the {what} as UTF-8"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_files_are_named_for_what_they_are() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = read_input(d, "image file").unwrap_err().to_string();
        assert!(e.contains("is a directory; expected the image file"), "{e}");
        let e = read_input(&d.join("nope"), "image file").unwrap_err().to_string();
        assert!(e.ends_with("nope: does not exist; expected the image file"), "{e}");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("loop"), d.join("loop")).unwrap();
            let e = read_input(&d.join("loop"), "image file").unwrap_err().to_string();
            assert!(e.contains("symbolic link that cannot be resolved"), "{e}");
            std::os::unix::fs::symlink(d.join("gone"), d.join("dangling")).unwrap();
            let e = read_input(&d.join("dangling"), "image file").unwrap_err().to_string();
            assert!(e.contains("symbolic link to") && e.contains("gone"), "{e}");
            let fifo = d.join("fifo");
            assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
            // Refused without opening it: opening a FIFO would block.
            let e = read_input(&fifo, "trace manifest").unwrap_err().to_string();
            assert!(e.contains("is a FIFO (named pipe); expected the trace manifest"), "{e}");
        }
    }

    #[test]
    fn text_must_be_utf8_without_a_bom() {
        let p = Path::new("x.toml");
        let e = text_of(b"\xEF\xBB\xBFa = 1\n".to_vec(), p, "configuration").unwrap_err().to_string();
        assert!(e.starts_with("x.toml: line 1 starts with a UTF-8 byte-order mark"), "{e}");
        let e = text_of(b"a = 1\nb = \xFF\n".to_vec(), p, "configuration").unwrap_err().to_string();
        assert!(e.contains("line 2, column 5: not UTF-8"), "{e}");
        assert_eq!(text_of(b"a = 1\n".to_vec(), p, "configuration").unwrap(), "a = 1\n");
    }
}
