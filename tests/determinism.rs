//! Same trace and configuration, same output bytes, whatever the thread
//! count or the host's vector instructions: `postwarp golden` and
//! `postwarp simulate` run with RAYON_NUM_THREADS=1 and 4 (exr's own writer
//! pool reads it too) write the same files, byte for byte, `report.json`
//! apart from its host-time fields (`*_ms`); the golden model warps the
//! same frames at the baseline and the widest vector level.

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

/// The golden model's frames do not depend on the host's vector
/// instructions (`golden::vector_level`): a warper held to the build's
/// baseline and one at the widest level the host has (AVX2 on most x86-64
/// hosts) give the same planes, pixels and counters, bit for bit, on two
/// bundled traces (a rendered one with several references, a real pair) in
/// the float and fixed datapaths and with the general reconstruction.
#[test]
fn golden_frames_do_not_depend_on_the_vector_level() {
    use postwarp::golden::config::{GoldenConfig, Reconstruction};
    use postwarp::golden::frame::{Warper, prepare_reference};
    use postwarp::run::hw_config::golden_config_for;
    use postwarp::trace::Trace;
    use postwarp_rtl::config::EngineConfig;

    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("traces");
    let (mut baseline, mut widest) = (Warper::new(), Warper::new());
    baseline.baseline_instructions(true);
    assert_eq!(baseline.vector_level().name(), "baseline");
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        assert_eq!(widest.vector_level().name(), "avx2", "an AVX2 host warps with AVX2");
    }
    let mut warped = 0;
    for name in ["room", "motorcycle"] {
        let t = Trace::open(&root.join(name)).unwrap();
        let ss = t.display.supersample;
        let fixed =
            golden_config_for(&EngineConfig { supersample: ss, arith: "fixed".into(), ..EngineConfig::default() });
        let general = GoldenConfig { reconstruction: Reconstruction::General, ..GoldenConfig::default() };
        for (what, cfg) in [("float", GoldenConfig::default()), ("fixed", fixed), ("general", general)] {
            let k = t.derived.len() - 1;
            let refs: Vec<_> = t.derived[k]
                .references
                .iter()
                .map(|&r| prepare_reference(&t.load_reference(r).unwrap().samples, ss, &cfg))
                .collect();
            let refs: Vec<_> = refs.iter().collect();
            let cmd = t.frame_commands(k);
            let (a, b) = (baseline.warp_frame(&cmd, &refs, &cfg), widest.warp_frame(&cmd, &refs, &cfg));
            assert!(a.samples == b.samples, "{name} {what}: sample planes differ between the vector levels");
            assert_eq!((&a.pixels, &a.covered, &a.unseen), (&b.pixels, &b.covered, &b.unseen), "{name} {what}");
            assert_eq!(a.stats, b.stats, "{name} {what}: counters");
            assert!(a.stats.reference_samples > 0 && a.covered.count_ones() > 0, "{name} {what}: something warped");
            warped += 1;
        }
    }
    assert_eq!(warped, 6);
}
