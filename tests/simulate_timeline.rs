//! `postwarp simulate --timeline`: per frame a Chrome trace event file
//! that parses as JSON with `traceEvents`, one track per unit whose
//! intervals tile the frame exactly and whose per-state cycles equal the
//! unit's counters in `report.json` (busy, each stall reason, idle), one
//! in-flight counter per DRAM client, and the occupancy counters.

use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

const UNITS: [&str; 7] = ["fetch", "transform", "kernel_setup", "raster", "composite", "hole_fill", "abuffer"];
const CLIENTS: [&str; 4] = ["reference_fetch", "tile_fill", "tile_write_back", "output"];

fn simulate(out: &std::path::Path, extra: &[&str]) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let st = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .arg("simulate")
        .arg(root.join("traces/occluders"))
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
}

fn json(p: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))).unwrap()
}

#[test]
fn every_frame_has_a_timeline_whose_unit_intervals_tile_the_frame_and_match_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hw");
    simulate(&out, &["--timeline", "--timeline-resolution", "300"]);
    let report = json(&out.join("report.json"));
    let frames = report["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 6);
    for f in frames {
        let k = f["index"].as_u64().unwrap();
        let t = json(&out.join(format!("timeline-{k:04}.json")));
        let cycles = f["cycles"].as_u64().unwrap();
        assert_eq!(t["otherData"]["cycles"].as_u64(), Some(cycles));
        // Rule 4: time stamps are microseconds at the configured clock,
        // rounded to the nanosecond.
        let hz = t["otherData"]["clock_hz"].as_f64().expect("clock_hz");
        let us = |c: u64| (c as f64 * 1e9 / hz).round() / 1e3;
        let ev = t["traceEvents"].as_array().expect("traceEvents");
        // One named track per unit in process 1.
        let tid_of = |name: &str| {
            ev.iter()
                .find(|e| e["ph"] == "M" && e["name"] == "thread_name" && e["pid"] == 1 && e["args"]["name"] == name)
                .and_then(|e| e["tid"].as_u64())
                .unwrap_or_else(|| panic!("frame {k}: no track for {name}"))
        };
        for unit in UNITS {
            let tid = tid_of(unit);
            let iv: Vec<&Value> = ev.iter().filter(|e| e["ph"] == "X" && e["pid"] == 1 && e["tid"] == tid).collect();
            let (mut at, mut sums) = (0u64, std::collections::BTreeMap::<String, u64>::new());
            for e in &iv {
                let a = &e["args"];
                assert_eq!(a["cycle"].as_u64(), Some(at), "frame {k} {unit}: intervals not contiguous");
                let len = a["cycles"].as_u64().unwrap();
                assert_eq!(e["ts"].as_f64(), Some(us(at)), "frame {k} {unit}: ts of cycle {at}");
                assert_eq!(e["dur"].as_f64(), Some(us(len)), "frame {k} {unit}: dur at cycle {at}");
                let mut parts = 0;
                for (key, v) in a.as_object().unwrap() {
                    if key != "cycle" && key != "cycles" {
                        *sums.entry(key.clone()).or_default() += v.as_u64().unwrap();
                        parts += v.as_u64().unwrap();
                    }
                }
                assert_eq!(parts, len, "frame {k} {unit}: an interval's states do not fill it");
                at += len;
            }
            assert_eq!(at, cycles, "frame {k} {unit}: intervals do not reach the frame's end");
            let u = &f["units"][unit];
            let get = |key: &str| sums.get(key).copied().unwrap_or(0);
            assert_eq!(get("busy"), u["busy"].as_u64().unwrap(), "frame {k} {unit}: busy");
            assert_eq!(get("idle"), u["idle"].as_u64().unwrap(), "frame {k} {unit}: idle");
            for r in ["dram", "tile", "fifo_full", "upstream"] {
                let want = u["stall_by_reason"][r].as_u64().unwrap();
                assert_eq!(get(&format!("stall_{r}")), want, "frame {k} {unit}: stall {r}");
            }
            assert_eq!(get("busy") + u["stall"].as_u64().unwrap() + get("idle"), cycles);
        }
        for c in CLIENTS {
            let name = format!("in flight: {c}");
            assert!(ev.iter().any(|e| e["ph"] == "C" && e["pid"] == 2 && e["name"] == name), "frame {k}: {name}");
        }
        for q in ["kernel FIFO", "stamp FIFO", "destination cache"] {
            assert!(
                ev.iter().any(|e| e["ph"] == "C" && e["pid"] == 3 && e["name"].as_str().unwrap().starts_with(q)),
                "frame {k}: occupancy of {q}"
            );
        }
        // Each track names its capacity; the memory port's queues, which
        // the model does not bound, say so instead of a capacity of 0.
        let tracks: std::collections::BTreeSet<&str> =
            ev.iter().filter(|e| e["ph"] == "C" && e["pid"] == 3).filter_map(|e| e["name"].as_str()).collect();
        assert!(tracks.contains("memory port queues (requests, unbounded)"), "frame {k}: {tracks:?}");
        let c = &report["config"];
        let tiles = c["dest_cache_bytes"].as_u64().unwrap() / (c["tile_size"].as_u64().unwrap().pow(2) * 16);
        assert!(tracks.contains(format!("destination cache (tiles, capacity {tiles})").as_str()), "{tracks:?}");
        assert!(tracks.iter().all(|t| !t.contains("capacity 0")), "frame {k}: {tracks:?}");
        // The DRAM was busy: some request was in flight at some point.
        let flight: f64 = ev
            .iter()
            .filter(|e| e["ph"] == "C" && e["name"] == "in flight: reference_fetch")
            .map(|e| e["args"]["requests"].as_f64().unwrap())
            .sum();
        assert!(flight > 0.0, "frame {k}: no reference fetch in flight");
    }
}

#[test]
fn without_the_flag_there_is_no_timeline_and_the_resolution_needs_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hw");
    simulate(&out, &[]);
    assert!(!out.join("timeline-0000.json").exists());
    let st = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["simulate", "traces/occluders", "--out"])
        .arg(dir.path().join("x"))
        .args(["--timeline-resolution", "64"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("--timeline"));
}
