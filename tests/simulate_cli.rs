//! `postwarp simulate` end to end: outputs, printed summary against the
//! report, determinism, and configuration errors.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn simulate(trace: &str, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .arg("simulate")
        .arg(root().join("traces").join(trace))
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn simulate_writes_frames_and_a_report_that_the_summary_agrees_with() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a");
    let o = simulate("occluders", &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8(o.stdout).unwrap();
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let frames = report["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 6);
    assert_eq!(report["total"]["identical_frames"], 6, "the hardware model equals the golden model");
    for f in frames {
        let k = f["index"].as_u64().unwrap();
        assert!(out.join(format!("frame-{k:04}.png")).is_file());
        // The summary row of this frame starts with its index and cycles.
        let row = format!("{k:>6} {:>10}", f["cycles"].as_u64().unwrap());
        assert!(stdout.lines().any(|l| l.starts_with(&row)), "no row `{row}` in\n{stdout}");
        let by: u64 =
            f["dram_bytes_by_client"].as_object().unwrap().values().map(|c| c["read"].as_u64().unwrap()).sum();
        assert_eq!(by, f["dram_read_bytes"].as_u64().unwrap());
        let fps = f["frame_rate_at_clock_hz"].as_f64().unwrap();
        assert!((fps - 100e6 / f["cycles"].as_f64().unwrap()).abs() < 1e-6 * fps);
        assert!(f["vs_truth"]["psnr_luma_db"].as_f64().unwrap() > 20.0);
    }
    assert_eq!(report["config"]["clock_hz"], 100_000_000);
    // Same trace and configuration: same report apart from host times.
    let out2 = dir.path().join("b");
    assert!(simulate("occluders", &out2, &[]).status.success());
    let strip = |p: &Path| {
        let mut v: Value = serde_json::from_str(&std::fs::read_to_string(p.join("report.json")).unwrap()).unwrap();
        for f in v["frames"].as_array_mut().unwrap() {
            f["host_ms"] = Value::Null;
            f["golden_host_ms"] = Value::Null;
        }
        for r in ["mean", "total"] {
            v[r]["host_ms"] = Value::Null;
            v[r]["golden_host_ms"] = Value::Null;
        }
        v["trace"] = Value::Null;
        v
    };
    assert_eq!(strip(&out), strip(&out2));
    assert_eq!(std::fs::read(out.join("frame-0003.png")).unwrap(), std::fs::read(out2.join("frame-0003.png")).unwrap());
}

#[test]
fn presets_and_config_files_change_the_hardware_not_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("small.toml");
    std::fs::write(&cfg, "# a tiny destination cache\ndest_cache_bytes = 8192\n").unwrap();
    let base = dir.path().join("base");
    let small = dir.path().join("small");
    assert!(simulate("room", &base, &[]).status.success());
    let o = simulate("room", &small, &["--config", cfg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read =
        |p: &Path| -> Value { serde_json::from_str(&std::fs::read_to_string(p.join("report.json")).unwrap()).unwrap() };
    let (a, b) = (read(&base), read(&small));
    assert_eq!(b["config"]["dest_cache_bytes"], 8192);
    assert_eq!(b["total"]["identical_frames"], 6);
    assert!(
        b["total"]["dest_cache"]["misses_capacity"].as_u64() > a["total"]["dest_cache"]["misses_capacity"].as_u64()
    );
    assert_eq!(
        std::fs::read(base.join("frame-0002.png")).unwrap(),
        std::fs::read(small.join("frame-0002.png")).unwrap()
    );
    let hmd = dir.path().join("hmd");
    assert!(simulate("room", &hmd, &["--preset", "hmd2026"]).status.success());
    let c = read(&hmd);
    assert_eq!(c["config"]["views"], 2);
    assert!(c["mean"]["cycles"].as_f64() < a["mean"]["cycles"].as_f64(), "16 lanes finish sooner");
}

#[test]
fn bad_configurations_are_rejected_with_the_knob_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    let err = |o: Output| {
        assert!(!o.status.success());
        String::from_utf8(o.stderr).unwrap()
    };
    let e = err(simulate("room", &out, &["--preset", "nope"]));
    assert!(e.contains("nope") && e.contains("mark1998"), "{e}");
    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "tile_sise = 16\n").unwrap();
    let e = err(simulate("room", &out, &["--config", cfg.to_str().unwrap()]));
    assert!(e.contains("bad.toml") && e.contains("tile_sise: unknown knob"), "{e}");
    std::fs::write(&cfg, "dest_cache_bytes = 100\n").unwrap();
    let e = err(simulate("room", &out, &["--config", cfg.to_str().unwrap()]));
    assert!(e.contains("dest_cache_bytes = 100"), "{e}");
    let e = err(simulate("room", &out, &["--config", cfg.to_str().unwrap(), "--preset", "mark1998"]));
    assert!(e.contains("cannot be used with"), "{e}");
    assert!(!out.join("report.json").exists(), "nothing written on a rejected configuration");
}

#[test]
fn totals_sum_every_frame_including_keys_only_some_frames_have() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t");
    assert!(simulate("occluders", &out, &[]).status.success());
    let r: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let by_size: u64 = r["total"]["rects_by_size"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(by_size, r["total"]["rects"].as_u64().unwrap());
    let cycles: u64 = r["frames"].as_array().unwrap().iter().map(|f| f["cycles"].as_u64().unwrap()).sum();
    assert_eq!(r["total"]["cycles"].as_u64().unwrap(), cycles);
}
