//! The hardware model's documentation against what the code produces:
//! every key of `postwarp simulate`'s `report.json` is in `docs/report.md`,
//! every knob of `postwarp_rtl::config::KNOBS` is in `docs/units.md`.

use postwarp_rtl::config::KNOBS;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn simulate(trace: &str, out: &Path) -> Value {
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .arg("simulate")
        .arg(root().join("traces").join(trace))
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// Every object key under `v`, recursively, with its path for messages.
/// The keys of `rects_by_size` are data (`"WxH"`), not names: skipped.
fn keys(v: &Value, path: &str, out: &mut Vec<(String, String)>) {
    match v {
        Value::Object(m) => {
            for (k, child) in m {
                let p = format!("{path}.{k}");
                out.push((k.clone(), p.clone()));
                if k != "rects_by_size" {
                    keys(child, &p, out);
                }
            }
        }
        Value::Array(a) => {
            for (i, child) in a.iter().enumerate() {
                keys(child, &format!("{path}[{i}]"), out);
            }
        }
        _ => {}
    }
}

#[test]
fn every_simulate_report_key_is_documented() {
    let doc = std::fs::read_to_string(root().join("docs/report.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let r = simulate("occluders", dir.path());
    let mut found = Vec::new();
    for key in r.as_object().unwrap().keys() {
        found.push((key.clone(), key.clone()));
    }
    keys(&r["frames"][0], "frames[0]", &mut found);
    keys(&r["total"], "total", &mut found);
    keys(&r["mean"], "mean", &mut found);
    keys(&r["config"], "config", &mut found);
    // The objects named in the brief must be there and must have been walked.
    for (path, v) in [
        ("frames[0].units", &r["frames"][0]["units"]),
        ("frames[0].dram_bytes_by_client", &r["frames"][0]["dram_bytes_by_client"]),
        ("config", &r["config"]),
    ] {
        assert!(v.as_object().is_some_and(|m| !m.is_empty()), "{path} is not a non-empty object");
    }
    assert!(found.len() > 100, "only {} keys found", found.len());
    let missing: Vec<&String> =
        found.iter().filter(|(k, _)| !doc.contains(&format!("`{k}`"))).map(|(_, p)| p).collect();
    assert!(missing.is_empty(), "docs/report.md lacks these report keys: {missing:?}");
}

#[test]
fn every_knob_is_documented() {
    let doc = std::fs::read_to_string(root().join("docs/units.md")).unwrap();
    for (name, unit, _) in KNOBS {
        assert!(doc.contains(&format!("| `{name}` | {unit} |")), "docs/units.md lacks the knob row `{name}` ({unit})");
    }
}
