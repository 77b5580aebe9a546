//! Fuzz target `results_csv`: the body is `postwarp::fuzz_entry::run("results_csv", data)`,
//! which `tests/fuzz_corpus.rs` also replays on stable.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = postwarp::fuzz_entry::run("results_csv", data);
});
