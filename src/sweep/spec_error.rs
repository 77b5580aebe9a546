//! Errors in a sweep specification: the file, the key (as a path such as
//! `traces[1].width` or `hardware.dest_cache_bytes[2]`), the line and
//! column where TOML puts that key, and what was expected.

use std::fmt;
use std::path::{Path, PathBuf};
use toml::de::{DeTable, DeValue};

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Seg {
    /// A table key.
    Key(String),
    /// An array element.
    Index(usize),
}

/// Where a value sits in the specification: a path of keys and indices.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    /// This path extended by key `k`.
    pub fn key(&self, k: &str) -> KeyPath {
        let mut p = self.0.clone();
        p.push(Seg::Key(k.to_string()));
        KeyPath(p)
    }

    /// This path extended by index `i`.
    pub fn index(&self, i: usize) -> KeyPath {
        let mut p = self.0.clone();
        p.push(Seg::Index(i));
        KeyPath(p)
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return write!(f, "(top level)");
        }
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// A bad specification: which file, which key, where, what was expected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct SpecError {
    /// The specification file.
    pub file: PathBuf,
    /// The offending key (empty for whole-file errors such as TOML syntax).
    pub key: String,
    /// 1-based line and column of the key in the file, when known.
    pub at: Option<(usize, usize)>,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some((line, col)) = self.at {
            write!(f, ":{line}:{col}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

/// Makes [`SpecError`]s for one file, finding the position of keys in its
/// text.
pub struct Locator<'a> {
    file: &'a Path,
    text: &'a str,
    doc: Option<DeTable<'a>>,
}

impl<'a> Locator<'a> {
    /// A locator for `text`, the contents of `file`.
    pub fn new(file: &'a Path, text: &'a str) -> Locator<'a> {
        let doc = DeTable::parse(text).ok().map(|t| t.into_inner());
        Locator { file, text, doc }
    }

    /// An error at `path`.
    pub fn error(&self, path: &KeyPath, message: impl Into<String>) -> SpecError {
        SpecError {
            file: self.file.to_path_buf(),
            key: path.to_string(),
            at: self.offset(path).map(|o| self.line_col(o)),
            message: message.into(),
        }
    }

    /// An error about the whole file at byte offset `at` (TOML syntax).
    pub fn syntax(&self, at: Option<usize>, message: impl Into<String>) -> SpecError {
        SpecError {
            file: self.file.to_path_buf(),
            key: String::new(),
            at: at.map(|o| self.line_col(o)),
            message: message.into(),
        }
    }

    fn line_col(&self, offset: usize) -> (usize, usize) {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.rfind('\n').map_or(before.chars().count(), |n| before[n + 1..].chars().count()) + 1;
        (line, col)
    }

    /// Byte offset of the deepest key of `path` that exists in the text.
    fn offset(&self, path: &KeyPath) -> Option<usize> {
        let mut table = self.doc.as_ref()?;
        let mut value: Option<&DeValue> = None;
        let mut best = None;
        for seg in &path.0 {
            match seg {
                Seg::Key(k) => {
                    let t = match value {
                        None => table,
                        Some(DeValue::Table(t)) => t,
                        Some(_) => break,
                    };
                    let Some((key, v)) = t.get_key_value(k.as_str()) else { break };
                    best = Some(key.span().start);
                    table = t;
                    value = Some(v.get_ref());
                }
                Seg::Index(i) => {
                    let Some(DeValue::Array(a)) = value else { break };
                    let Some(v) = a.get(*i) else { break };
                    best = Some(v.span().start);
                    value = Some(v.get_ref());
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_point_at_the_key_line() {
        let text = "runs = 3\n\n[[traces]]\npath = \"a\"\n\n[[traces]]\nscene = \"room\"\nwidth = [32, -1]\n";
        let l = Locator::new(Path::new("s.toml"), text);
        let p = KeyPath::default().key("traces").index(1).key("width");
        let e = l.error(&p, "expected pixels");
        assert_eq!(e.key, "traces[1].width");
        assert_eq!(e.at, Some((8, 1)));
        assert_eq!(e.to_string(), "s.toml:8:1: traces[1].width: expected pixels");
        let e = l.error(&p.index(1), "x");
        assert_eq!(e.at, Some((8, 14)));
        let e = l.error(&KeyPath::default().key("nope"), "unknown key");
        assert_eq!(e.at, None);
    }
}
