//! One output file at a time: it is written to a temporary name in the same
//! directory and renamed into place, so an interrupted run never leaves a
//! half-written file under the final name. On any failure the temporary
//! file is removed and the error names the file.

use std::io;
use std::path::{Path, PathBuf};

/// The temporary name used while `path` is being written.
pub fn temp_path(path: &Path) -> PathBuf {
    let mut name = std::ffi::OsString::from(".");
    name.push(path.file_name().unwrap_or_default());
    name.push(format!(".{}.tmp", std::process::id()));
    path.with_file_name(name)
}

/// `e` with `what` and `path` in its message (the kind is kept).
fn named(e: io::Error, what: &str, path: &Path) -> io::Error {
    io::Error::new(e.kind(), format!("{what} {}: {e}", path.display()))
}

/// Write `path` by calling `write` on a temporary file, then renaming it.
/// On error the temporary file is removed; I/O errors of this function
/// name the file.
pub fn write_atomically<E>(path: &Path, write: impl FnOnce(&Path) -> Result<(), E>) -> Result<(), E>
where
    E: From<io::Error>,
{
    if path.is_dir() {
        return Err(E::from(io::Error::new(
            io::ErrorKind::IsADirectory,
            format!("{}: is a directory; expected a file name to write", path.display()),
        )));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| named(e, "creating the directory", dir))?;
    }
    let tmp = temp_path(path);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            E::from(named(e, "moving the finished file into place as", path))
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Write bytes atomically; an error names the file.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically(path, |tmp| std::fs::write(tmp, bytes).map_err(|e| named(e, "writing", path)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_rename_names_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        // A directory in the way: the rename onto it fails.
        let target = dir.path().join("report.json");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(target.join("x"), b"x").unwrap();
        let e = write_bytes_atomically(&target, b"{}").unwrap_err().to_string();
        assert!(e.contains(&target.display().to_string()), "{e}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, vec![std::ffi::OsString::from("report.json")], "a temporary file was left");
        // A plain write works and leaves only the file.
        let ok = dir.path().join("a.txt");
        write_bytes_atomically(&ok, b"hello").unwrap();
        assert_eq!(std::fs::read(&ok).unwrap(), b"hello");
    }
}
