//! Stable content hashes for file and directory names (`DIR/points/<hash>.json`,
//! `DIR/traces/<hash>/`): 64-bit FNV-1a, written as 16 lower-case hex
//! digits. Stable across Rust versions and platforms, unlike the standard
//! library's hasher; not cryptographic (the inputs are our own).

use crate::trace::Trace;
use anyhow::Context;

/// An FNV-1a (64-bit) hasher.
#[derive(Clone, Copy, Debug)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Feed bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Feed a length-prefixed field, so that `("ab", "c")` and `("a", "bc")`
    /// hash differently.
    pub fn field(&mut self, bytes: &[u8]) {
        self.write(&(bytes.len() as u64).to_le_bytes());
        self.write(bytes);
    }

    /// The hash as 16 hex digits.
    pub fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Hash of a string, as 16 hex digits.
pub fn hash_str(s: &str) -> String {
    let mut h = Fnv::default();
    h.field(s.as_bytes());
    h.hex()
}

/// The content identity of a trace: a hash of its manifest and of every
/// image file the manifest names (references with their v2 layers, then
/// ground truth, in manifest order), each with its name. Two traces with the same bytes
/// have the same identity wherever they are.
pub fn trace_identity(trace: &Trace) -> anyhow::Result<String> {
    let mut h = Fnv::default();
    let read = |p: &std::path::Path| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
    h.field(&read(&trace.manifest)?);
    // Reference images with their v2 layers, then the truths (a v1 trace:
    // the images alone, as before layers existed).
    for f in trace.image_files() {
        h.field(f.to_string_lossy().as_bytes());
        h.field(&read(&trace.dir.join(f))?);
    }
    Ok(h.hex())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_matches_the_published_vectors_and_separates_fields() {
        // FNV-1a 64 test vectors (Fowler, Noll, Vo).
        let mut h = Fnv::default();
        assert_eq!(h.hex(), "cbf29ce484222325");
        h.write(b"a");
        assert_eq!(h.hex(), "af63dc4c8601ec8c");
        let mut h = Fnv::default();
        h.write(b"foobar");
        assert_eq!(h.hex(), "85944171f73967e8");
        let two = |a: &str, b: &str| {
            let mut h = Fnv::default();
            h.field(a.as_bytes());
            h.field(b.as_bytes());
            h.hex()
        };
        assert_ne!(two("ab", "c"), two("a", "bc"));
    }
}
