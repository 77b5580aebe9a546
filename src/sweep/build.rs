//! The identity of the running program, so that a sweep resumed by a
//! different build recomputes instead of reusing results the old code made
//! (`docs/sweep.md`, "Resuming").
//!
//! Rules:
//! 1. The identity is the FNV-1a-64 hash of the running executable's bytes
//!    (computed once per process), so any rebuild that changes the program
//!    changes it, and the same binary copied elsewhere keeps it.
//! 2. It is stored beside results (`points/<hash>.json`, `traces/<hash>/built-by`),
//!    never in their keys or hashes: `results.csv` stays the same bytes on
//!    every machine.
//! 3. If the executable cannot be read, the identity is `unknown`, which
//!    matches only results stored by a build that could not read itself
//!    either.

use super::hash::Fnv;
use std::sync::OnceLock;

/// The running program's identity (module rule 1).
pub fn build_id() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map(|bytes| {
                let mut h = Fnv::default();
                h.write(&bytes);
                h.hex()
            })
            .unwrap_or_else(|_| "unknown".into())
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_identity_is_a_stable_hex_hash() {
        let id = super::build_id();
        assert_eq!(id, super::build_id());
        assert!(id.len() == 16 && id.chars().all(|c| c.is_ascii_hexdigit()), "{id}");
    }
}
