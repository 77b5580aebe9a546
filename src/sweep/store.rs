//! Finished points on disk: `DIR/points/<hash>.json` holds the point's
//! canonical key and its [`Metrics`]; a sweep that restarts loads these
//! instead of running the points again.
//!
//! Rules:
//! 1. The file name is the hash of the key ([`super::hash::hash_str`]); the
//!    file holds the key too, and is used only if its key is the one
//!    expected (a hash collision or a stale format is recomputed).
//! 2. Files are written atomically: a file under its final name is a
//!    finished point.
//! 3. The file records the build that made it ([`super::build::build_id`]);
//!    it is used only by the same build.

use super::point::Metrics;
use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The contents of a point file.
#[derive(Serialize, Deserialize)]
struct StoredPoint {
    /// The point's canonical key (rule 1).
    key: serde_json::Value,
    /// The build that computed it (rule 3).
    build: String,
    /// Its results.
    metrics: Metrics,
}

/// The file of the point with hash `hash`.
pub fn point_file(out: &Path, hash: &str) -> PathBuf {
    out.join("points").join(format!("{hash}.json"))
}

/// What `points/<hash>.json` holds for a point.
#[derive(Clone, Debug, PartialEq)]
pub enum Stored {
    /// The finished point, stored by this build under its key.
    Finished(Box<Metrics>),
    /// No file.
    Absent,
    /// A file that is not a point file: torn, truncated or edited.
    Unreadable,
    /// A point file of another key (a hash collision or an older key format).
    OtherKey,
    /// A point file stored by another build of the program.
    OtherBuild,
}

impl Stored {
    /// The metrics, if the point is finished.
    pub fn metrics(self) -> Option<Metrics> {
        match self {
            Stored::Finished(m) => Some(*m),
            _ => None,
        }
    }

    /// Why the point must be run (empty if finished), for messages.
    pub fn why_missing(&self) -> &'static str {
        match self {
            Stored::Finished(_) => "",
            Stored::Absent => "absent",
            Stored::Unreadable => "unreadable",
            Stored::OtherKey => "another key",
            Stored::OtherBuild => "another build",
        }
    }
}

/// What is stored for the point `key` (module rules 1 and 3).
pub fn check(out: &Path, hash: &str, key: &str) -> Stored {
    let text = match std::fs::read(point_file(out, hash)) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Stored::Absent,
        Err(_) => return Stored::Unreadable,
    };
    let Ok(p) = serde_json::from_slice::<StoredPoint>(&text) else { return Stored::Unreadable };
    if serde_json::to_string(&p.key).ok().as_deref() != Some(key) {
        return Stored::OtherKey;
    }
    if p.build != super::build::build_id() {
        return Stored::OtherBuild;
    }
    Stored::Finished(Box::new(p.metrics))
}

/// The stored metrics of the point `key`, if it finished earlier.
pub fn load(out: &Path, hash: &str, key: &str) -> Option<Metrics> {
    check(out, hash, key).metrics()
}

/// Store a finished point.
pub fn save(out: &Path, hash: &str, key: &str, m: &Metrics) -> anyhow::Result<()> {
    let key = serde_json::from_str(key).context("point key")?;
    let p = StoredPoint { key, build: super::build::build_id().to_string(), metrics: m.clone() };
    let text = serde_json::to_string_pretty(&p)? + "\n";
    let path = point_file(out, hash);
    crate::io_util::write_bytes_atomically(&path, text.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_is_loaded_only_under_its_own_key() {
        let dir = tempfile::tempdir().unwrap();
        // Values whose last digit serde_json's fast float parser gets
        // wrong without `float_roundtrip` (found by tests/sweep.rs).
        let m = Metrics {
            frames: 2,
            psnr_luma_db: Some(31.25),
            ssim_luma: Some(0.9531362610971579),
            dest_cache_hit_rate: Some(0.9780281289703517),
            ..Metrics::default()
        };
        let key = r#"{"format":1,"trace":"ab"}"#;
        save(dir.path(), "h", key, &m).unwrap();
        assert_eq!(load(dir.path(), "h", key), Some(m));
        assert_eq!(load(dir.path(), "h", r#"{"format":1,"trace":"cd"}"#), None);
        assert_eq!(check(dir.path(), "h", r#"{"format":1,"trace":"cd"}"#), Stored::OtherKey);
        assert_eq!(load(dir.path(), "nothing", key), None);
        assert_eq!(check(dir.path(), "nothing", key), Stored::Absent);
        // Another build's file is not used.
        let text = std::fs::read_to_string(point_file(dir.path(), "h")).unwrap();
        let other = text.replace(super::super::build::build_id(), "0123456789abcdef");
        assert_ne!(text, other);
        std::fs::write(point_file(dir.path(), "h"), other).unwrap();
        assert_eq!(check(dir.path(), "h", key), Stored::OtherBuild);
        std::fs::write(point_file(dir.path(), "h"), "{ torn").unwrap();
        assert_eq!(check(dir.path(), "h", key), Stored::Unreadable);
        std::fs::write(point_file(dir.path(), "h"), &text[..text.len() / 2]).unwrap();
        assert_eq!(check(dir.path(), "h", key), Stored::Unreadable);
    }
}
