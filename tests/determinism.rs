//! Same trace and configuration, same output bytes, whatever the thread
//! count: `postwarp golden` and `postwarp simulate` run with
//! RAYON_NUM_THREADS=1 and 4 (exr's own writer pool reads it too) write the
//! same files, byte for byte, `report.json` apart from its host-time
//! fields (`*_ms`). Whatever the host's vector instructions:
//! `props_vector_level`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(cmd: &str, trace: &str, extra: &[&str], threads: u32, out: &Path) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let st = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args([cmd, root.join(trace).to_str().unwrap(), "--out", out.to_str().unwrap()])
        .args(extra)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .expect("run postwarp");
    assert!(st.status.success(), "{cmd} {trace}: {}", String::from_utf8_lossy(&st.stderr));
}

/// `report.json` without the keys ending in `_ms` (host times).
fn without_times(v: serde_json::Value) -> serde_json::Value {
    match v {
        serde_json::Value::Object(m) => serde_json::Value::Object(
            m.into_iter().filter(|(k, _)| !k.ends_with("_ms")).map(|(k, v)| (k, without_times(v))).collect(),
        ),
        serde_json::Value::Array(a) => serde_json::Value::Array(a.into_iter().map(without_times).collect()),
        v => v,
    }
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    v.sort();
    v
}

fn same_outputs(cmd: &str, trace: &str, extra: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("t1"), tmp.path().join("t4"));
    run(cmd, trace, extra, 1, &a);
    run(cmd, trace, extra, 4, &b);
    let (fa, fb) = (files(&a), files(&b));
    let names = |f: &[PathBuf]| f.iter().map(|p| p.file_name().unwrap().to_owned()).collect::<Vec<_>>();
    assert_eq!(names(&fa), names(&fb), "{cmd} {trace}: the same files");
    assert!(fa.iter().any(|p| p.extension().is_some_and(|e| e == "exr")), "{cmd} writes EXR frames");
    for (x, y) in fa.iter().zip(&fb) {
        let (bx, by) = (std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
        if x.file_name().unwrap() == "report.json" {
            let jx = without_times(serde_json::from_slice(&bx).unwrap());
            let jy = without_times(serde_json::from_slice(&by).unwrap());
            assert_eq!(jx, jy, "{cmd} {trace}: report.json differs beyond host times");
        } else {
            assert!(bx == by, "{cmd} {trace}: {} differs between 1 and 4 threads", x.display());
        }
    }
}

#[test]
fn golden_bytes_do_not_depend_on_the_thread_count() {
    same_outputs("golden", "traces/room", &[]);
    // FLIP too (two threads of C++ beside the other scores).
    same_outputs("golden", "traces/motorcycle", &["--flip"]);
}

#[test]
fn simulate_bytes_do_not_depend_on_the_thread_count() {
    same_outputs("simulate", "traces/room", &[]);
}
