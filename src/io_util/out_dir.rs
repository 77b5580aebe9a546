//! Output folders that are never half-written (`--out DIR`).
//!
//! Rules:
//! 1. A command builds its folder under a temporary name beside the target,
//!    `.<name>.postwarp-tmp-<pid>-<n>`, and renames it to `<name>` when
//!    everything is written ([`OutDir::commit`]). Until then nothing exists
//!    under the target name, so an interrupted run leaves nothing that
//!    loads; a run that fails removes its temporary folder.
//! 2. An existing target is refused unless it is an empty folder or `force`
//!    is given (`--force`).
//!    With `force` it is replaced, never mixed: at commit the old folder is
//!    renamed aside (`.<name>.postwarp-old-<pid>-<n>`), the new one takes its
//!    name, and the old one is removed. A target that is a file, or that
//!    holds one of the run's inputs, is refused even with `force`.
//! 3. Temporary folders of an earlier run that was killed (its process no
//!    longer exists) are removed when the next run into the same target
//!    starts, and the removal is reported on stderr; those of a run still
//!    going are reported and left alone. Where process liveness cannot be
//!    checked (no `/proc`), leftovers are reported only.
//! 4. Two runs into one target both build their own folder; the second to
//!    finish is refused (or, with `force`, replaces the first's).

use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

static SERIAL: AtomicUsize = AtomicUsize::new(0);

const TMP: &str = "postwarp-tmp";
const OLD: &str = "postwarp-old";

/// An output folder being built (module rules).
#[derive(Debug)]
pub struct OutDir {
    target: PathBuf,
    staging: PathBuf,
    force: bool,
    committed: bool,
}

fn file_name(target: &Path) -> anyhow::Result<String> {
    match target.file_name() {
        Some(n) => Ok(n.to_string_lossy().into_owned()),
        None => bail!("{}: expected a folder name for the output (not `.`, `..` or `/`)", target.display()),
    }
}

fn parent(target: &Path) -> PathBuf {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The process id in a leftover's name `.<name>.<kind>-<pid>-<n>`.
fn leftover_pid(entry: &str, name: &str) -> Option<u32> {
    let rest = entry.strip_prefix('.')?.strip_prefix(name)?.strip_prefix('.')?;
    let rest = rest.strip_prefix(TMP).or_else(|| rest.strip_prefix(OLD))?.strip_prefix('-')?;
    rest.split('-').next()?.parse().ok()
}

/// Whether process `pid` exists, if that can be told.
fn alive(pid: u32) -> Option<bool> {
    let proc = Path::new("/proc");
    proc.join("self").exists().then(|| pid == std::process::id() || proc.join(pid.to_string()).exists())
}

/// Rule 3: remove (or report) leftovers of interrupted runs into `target`.
fn clean_leftovers(target: &Path) -> anyhow::Result<()> {
    let name = file_name(target)?;
    let dir = parent(target);
    let Ok(entries) = std::fs::read_dir(&dir) else { return Ok(()) };
    for e in entries.flatten() {
        let entry = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = leftover_pid(&entry, &name) else { continue };
        let path = dir.join(&entry);
        match alive(pid) {
            Some(false) => {
                std::fs::remove_dir_all(&path).with_context(|| {
                    format!("removing {}, left by an interrupted run (process {pid})", path.display())
                })?;
                eprintln!("note: removed {}, left by an interrupted run (process {pid})", path.display());
            }
            Some(true) if pid == std::process::id() => {}
            Some(true) => eprintln!(
                "note: {} is being written by process {pid}, another run into {}",
                path.display(),
                target.display()
            ),
            None => eprintln!(
                "note: {} may be left by an interrupted run into {} (process {pid}); remove it if no run is going",
                path.display(),
                target.display()
            ),
        }
    }
    Ok(())
}

/// Whether `p` is a folder with nothing in it (not a symbolic link).
fn is_empty_dir(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()) && std::fs::read_dir(p).is_ok_and(|mut d| d.next().is_none())
}

/// Whether `inner` is `outer` or inside it (both made absolute).
fn contains(outer: &Path, inner: &Path) -> bool {
    let (Ok(o), Ok(i)) = (outer.canonicalize(), inner.canonicalize()) else { return false };
    i.starts_with(o)
}

impl OutDir {
    /// Start building `target` (rules 1–3). `inputs` are the paths the run
    /// reads; `force` may not replace a folder holding one of them.
    pub fn create(target: &Path, force: bool, inputs: &[&Path]) -> anyhow::Result<OutDir> {
        let name = file_name(target)?;
        let dir = parent(target);
        match std::fs::symlink_metadata(target) {
            Err(_) => {}
            Ok(m) if !m.is_dir() => {
                bail!(
                    "{}: exists and is not a folder; expected a folder to write into (or a new name)",
                    target.display()
                )
            }
            Ok(_) if is_empty_dir(target) => {}
            Ok(_) if !force => bail!(
                "{}: already exists; give --force to replace it (its contents are removed, not mixed with this run's), \
                 or choose another --out",
                target.display()
            ),
            Ok(_) => {
                if let Some(i) = inputs.iter().find(|i| contains(target, i)) {
                    bail!(
                        "{}: holds this run's input {}; --force would delete it: choose another --out",
                        target.display(),
                        i.display()
                    );
                }
            }
        }
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        clean_leftovers(target)?;
        let n = SERIAL.fetch_add(1, Ordering::Relaxed);
        let staging = dir.join(format!(".{name}.{TMP}-{}-{n}", std::process::id()));
        std::fs::create_dir(&staging)
            .with_context(|| format!("creating the temporary folder {} for {}", staging.display(), target.display()))?;
        Ok(OutDir { target: target.to_path_buf(), staging, force, committed: false })
    }

    /// Where the run writes until [`OutDir::commit`].
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The final folder.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Move the finished folder into place (rules 1, 2 and 4).
    pub fn commit(mut self) -> anyhow::Result<PathBuf> {
        if is_empty_dir(&self.target) {
            // Nothing to mix with: it gives way (a rename onto a folder is
            // not portable).
            let _ = std::fs::remove_dir(&self.target);
        }
        let exists = std::fs::symlink_metadata(&self.target).is_ok();
        if exists && !self.force {
            bail!(
                "{}: appeared while this run was working (another run into the same --out?); this run's output was \
                 discarded: give --force to replace it",
                self.target.display()
            );
        }
        if exists {
            let name = file_name(&self.target)?;
            let n = SERIAL.fetch_add(1, Ordering::Relaxed);
            let old = parent(&self.target).join(format!(".{name}.{OLD}-{}-{n}", std::process::id()));
            std::fs::rename(&self.target, &old).with_context(|| {
                format!("moving the old {} aside to {} to replace it", self.target.display(), old.display())
            })?;
            std::fs::rename(&self.staging, &self.target).with_context(|| {
                format!("moving the finished {} into place as {}", self.staging.display(), self.target.display())
            })?;
            self.committed = true;
            std::fs::remove_dir_all(&old).with_context(|| format!("removing the replaced folder {}", old.display()))?;
        } else {
            std::fs::rename(&self.staging, &self.target).with_context(|| {
                format!("moving the finished {} into place as {}", self.staging.display(), self.target.display())
            })?;
            self.committed = true;
        }
        Ok(self.target.clone())
    }
}

impl Drop for OutDir {
    /// A run that did not commit (an error) removes its temporary folder.
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn a_folder_appears_whole_and_replaces_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out");
        let o = OutDir::create(&target, false, &[]).unwrap();
        std::fs::write(o.path().join("a"), b"1").unwrap();
        assert!(!target.exists(), "nothing under the target name before commit");
        o.commit().unwrap();
        assert_eq!(names(&target), ["a"]);
        let e = OutDir::create(&target, false, &[]).unwrap_err().to_string();
        assert!(e.contains("already exists; give --force"), "{e}");
        let o = OutDir::create(&target, true, &[]).unwrap();
        std::fs::write(o.path().join("b"), b"2").unwrap();
        assert_eq!(names(&target), ["a"], "the old folder stays whole until commit");
        o.commit().unwrap();
        assert_eq!(names(&target), ["b"], "replaced, not mixed");
        assert_eq!(names(dir.path()), ["out"], "no temporary or old folder left");
        // An empty folder is no one's output: it is used without --force.
        let empty = dir.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let o = OutDir::create(&empty, false, &[]).unwrap();
        std::fs::write(o.path().join("c"), b"3").unwrap();
        o.commit().unwrap();
        assert_eq!(names(&empty), ["c"]);
        std::fs::remove_dir_all(&empty).unwrap();
        // A failed run leaves nothing.
        let o = OutDir::create(&dir.path().join("new"), false, &[]).unwrap();
        std::fs::write(o.path().join("c"), b"3").unwrap();
        drop(o);
        assert_eq!(names(dir.path()), ["out"]);
    }

    #[test]
    fn inputs_files_and_leftovers() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("t");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(target.join("postwarp.trace"), b"x").unwrap();
        let e = OutDir::create(&target, true, &[&target.join("postwarp.trace")]).unwrap_err().to_string();
        assert!(e.contains("holds this run's input"), "{e}");
        let f = dir.path().join("file");
        std::fs::write(&f, b"x").unwrap();
        let e = OutDir::create(&f, true, &[]).unwrap_err().to_string();
        assert!(e.contains("is not a folder"), "{e}");
        // A leftover of a process that no longer exists is removed.
        if alive(1).is_some() {
            let dead = dir.path().join(format!(".t.{TMP}-4294967295-0"));
            std::fs::create_dir(&dead).unwrap();
            std::fs::write(dead.join("frame-0000.png"), b"x").unwrap();
            let o = OutDir::create(&dir.path().join("t"), true, &[]).unwrap();
            assert!(!dead.exists(), "leftover not removed");
            drop(o);
        }
        assert_eq!(leftover_pid(".t.postwarp-tmp-12-3", "t"), Some(12));
        assert_eq!(leftover_pid(".t.postwarp-old-7-0", "t"), Some(7));
        assert_eq!(leftover_pid(".tt.postwarp-tmp-12-3", "t"), None);
    }
}
