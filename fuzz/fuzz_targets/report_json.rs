//! Fuzz target `report_json`: the body is `postwarp::fuzz_entry::run("report_json", data)`,
//! which `tests/fuzz_corpus.rs` also replays on stable.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = postwarp::fuzz_entry::run("report_json", data);
});
