//! Replays the committed fuzz corpora on stable Rust, without cargo-fuzz:
//! every file of `fuzz/corpus/<target>/` and every fixed crash reproducer
//! in `fuzz/regressions/<target>/` goes through the same entry point as the
//! fuzz target (`postwarp::fuzz_entry::run`). Each must return, `Ok` or an
//! error naming the input file, without panicking (the entry points also
//! assert what accepted inputs promise, e.g. a manifest prints back to the
//! same trace). A reproducer must keep failing the way its file name says:
//! `*.err.*` ones must be rejected.

use postwarp::fuzz_entry::{INPUT_NAME, TARGETS, run};
use std::path::{Path, PathBuf};

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut v: Vec<PathBuf> = rd.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    v.sort();
    v
}

fn replay(target: &str, file: &Path) -> Result<(), String> {
    let data = std::fs::read(file).unwrap();
    let r = std::panic::catch_unwind(|| run(target, &data))
        .unwrap_or_else(|_| panic!("fuzz target `{target}` panicked on {}", file.display()));
    if let Err(msg) = &r {
        assert!(msg.contains(INPUT_NAME), "{target}: error for {} does not name the input: {msg}", file.display());
    }
    r
}

#[test]
fn every_corpus_file_returns_without_panicking() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    for target in TARGETS {
        let corpus = files(&root.join("corpus").join(target));
        assert!(!corpus.is_empty(), "no corpus for fuzz target `{target}` in fuzz/corpus/{target}/");
        let accepted = corpus.iter().filter(|f| replay(target, f).is_ok()).count();
        // A corpus of only rejected inputs would never reach past the parser.
        assert!(accepted > 0, "`{target}`: none of {} corpus files is accepted", corpus.len());
    }
}

#[test]
fn every_fixed_crash_reproducer_is_rejected_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut n = 0;
    for target in TARGETS {
        for f in files(&root.join(target)) {
            let r = replay(target, &f);
            let name = f.file_name().unwrap().to_string_lossy().into_owned();
            if name.contains(".err.") {
                assert!(r.is_err(), "{target}: reproducer {name} is accepted; it must be rejected");
            }
            n += 1;
        }
    }
    let dirs = std::fs::read_dir(&root).map(|d| d.count()).unwrap_or(0);
    assert!(dirs == 0 || n > 0, "fuzz/regressions/ has directories but no reproducers");
    for d in std::fs::read_dir(&root).into_iter().flatten() {
        let name = d.unwrap().file_name().to_string_lossy().into_owned();
        assert!(TARGETS.contains(&name.as_str()), "fuzz/regressions/{name}/ is not a fuzz target");
    }
}
