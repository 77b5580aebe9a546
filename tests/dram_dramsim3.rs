//! The DRAMsim3 backend end to end (cargo feature `dramsim3`; CI runs
//! `cargo test --release --features dramsim3 --test dram_dramsim3`):
//! `postwarp simulate --config` with `dram_backend = "dramsim3"` on the
//! bundled room trace gives the ideal backend's images byte for byte, no
//! fewer cycles than a perfect memory (every request back the next cycle),
//! the DRAM statistics of the report, and the same bytes twice.
//!
//! Requests carry the memory map's addresses (`docs/memory-layout.md`), so
//! row hits are a real outcome; against the `mark1998` ideal channel a
//! DRAMsim3 part can be faster or slower (`docs/memory.md`), hence the
//! bounds: a perfect memory, and an ideal channel with the part's peak
//! bandwidth and no latency, are never slower.
//!
//! And the `--dram-trace` file of the room trace, replayed open loop
//! through DRAMsim3 the way its trace CPU does, returns exactly the
//! transactions the report states (`dram_transactions`).
#![cfg(feature = "dramsim3")]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `simulate traces/room` with configuration `toml` into `dir/name`; the report.
fn simulate(dir: &Path, name: &str, toml: &str) -> Value {
    let config = dir.join(format!("{name}.toml"));
    std::fs::write(&config, toml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["simulate", "traces/room", "--out"])
        .arg(dir.join(name))
        .arg("--config")
        .arg(&config)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    // The summary's utilisation is of the part's peak with DRAMsim3.
    let stdout = String::from_utf8_lossy(&out.stdout);
    let part = stdout.contains("of the DRAM part's peak");
    assert_eq!(part, toml.contains("\"dramsim3\""), "{name}: {stdout}");
    serde_json::from_str(&std::fs::read_to_string(dir.join(name).join("report.json")).unwrap()).unwrap()
}

/// Every PNG of a run, by name.
fn pngs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "png"))
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    v.sort();
    v
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key}: {v}"))
}

#[test]
fn dramsim3_runs_the_room_trace_with_the_ideal_images_and_reports_its_dram() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ideal = simulate(d, "ideal", "");
    let perfect = simulate(d, "perfect", "dram_peak_bytes_per_cycle = 1048576\ndram_latency_cycles = 0\n");
    let ds3_toml =
        "dram_backend = \"dramsim3\"\ndram_config = \"DDR4_8Gb_x8_3200\"\ndram_address_mapping = \"rochrababgco\"\n";
    let ds3 = simulate(d, "ds3", ds3_toml);
    // DDR4-3200 x64: 25.4 GB/s = 254 bytes per 10 ns engine cycle; 255
    // and no latency is at least as fast as the part.
    let same_peak = simulate(d, "same-peak", "dram_peak_bytes_per_cycle = 255\ndram_latency_cycles = 0\n");
    assert_eq!(ds3["config"]["dram_backend"], "dramsim3");
    assert_eq!(ds3["config"]["dram_config"], "DDR4_8Gb_x8_3200");
    let images = pngs(&d.join("ideal"));
    assert!(images.len() >= 6, "{:?}", images.iter().map(|i| &i.0).collect::<Vec<_>>());
    assert!(images == pngs(&d.join("ds3")), "the images depend on the DRAM backend");
    let frames = ds3["frames"].as_array().unwrap();
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(f["vs_golden"]["identical"], true, "frame {k}");
        let (c, p, i) = (num(f, "cycles"), num(&perfect["frames"][k], "cycles"), &ideal["frames"][k]);
        assert!(c >= p, "frame {k}: {c} cycles with DRAMsim3, fewer than a perfect memory's {p}");
        let q = num(&same_peak["frames"][k], "cycles");
        assert!(c >= q, "frame {k}: {c} cycles with DRAMsim3, fewer than an ideal channel at its peak's {q}");
        // Same requests and bytes whatever the timing.
        for key in ["dram_requests", "dram_read_bytes", "dram_write_bytes", "dram_requested_bytes"] {
            assert_eq!(f[key], i[key], "frame {k}: {key}");
        }
        let b = &f["dram_backend"];
        let txns = num(b, "read_transactions") + num(b, "write_transactions");
        assert!(txns >= num(f, "dram_requests"), "frame {k}: every request is at least one transaction");
        assert_eq!(num(b, "transaction_bytes"), 64.0 * txns, "DDR4 x64 BL8: 64-byte transactions");
        assert_eq!(num(b, "row_hits") + num(b, "row_misses") + num(b, "row_conflicts"), txns);
        // 10 ns engine cycles over 0.63 ns DRAM cycles.
        let ratio = num(b, "dram_cycles") / num(f, "cycles");
        assert!((ratio - 1e4 / 630.0).abs() < 0.01, "frame {k}: {ratio} DRAM cycles per engine cycle");
        assert_eq!(num(b, "peak_bytes"), 16.0 * num(b, "dram_cycles"));
        let peak = num(f, "dram_backend_peak_gbps");
        assert!((peak - 16.0 / 0.63).abs() < 0.1, "DDR4-3200 x64 peak in GB/s: {peak}");
        let u = num(f, "dram_backend_utilisation");
        assert!(u > 0.0 && u <= 1.0, "{u}");
        let hit = num(f, "dram_row_hit_rate");
        assert!((0.0..=1.0).contains(&hit));
        let reads: f64 = f["dram_read_latency"].as_object().unwrap().values().map(|n| n.as_f64().unwrap()).sum();
        let writes: f64 = f["dram_write_latency"].as_object().unwrap().values().map(|n| n.as_f64().unwrap()).sum();
        assert_eq!(reads + writes, num(f, "dram_requests"));
        for dir in ["dram_read_latency_cycles", "dram_write_latency_cycles"] {
            let l = &f[dir];
            assert!(num(l, "p50") <= num(l, "p99") && num(l, "p99") <= num(l, "max"), "{dir}: {l}");
            assert!(num(l, "p50") >= 1.0, "{dir}: nothing completes in its own cycle");
        }
        assert!(num(f, "dram_achieved_gbps") > 0.0);
    }
    // Deterministic: the same report again (host times aside).
    let again = simulate(d, "ds3-again", ds3_toml);
    let strip = |mut v: Value| {
        for f in v["frames"].as_array_mut().unwrap() {
            f["host_ms"] = Value::Null;
            f["golden_host_ms"] = Value::Null;
        }
        for part in ["total", "mean"] {
            v[part]["host_ms"] = Value::Null;
            v[part]["golden_host_ms"] = Value::Null;
        }
        v
    };
    assert_eq!(strip(again), strip(ds3));
}

#[test]
fn bad_dramsim3_knobs_are_named_before_any_simulation() {
    let dir = tempfile::tempdir().unwrap();
    for (toml, want) in [
        ("dram_backend = \"dramsim3\"\ndram_config = \"DDR9\"\n", "dram_config = \"DDR9\""),
        ("dram_backend = \"dramsim3\"\ndram_address_mapping = \"rororororoco\"\n", "dram_address_mapping"),
        ("dram_backend = \"dramsim3\"\ndram_config = \"/nonexistent/x.ini\"\n", "/nonexistent/x.ini"),
    ] {
        let config = dir.path().join("bad.toml");
        std::fs::write(&config, toml).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_postwarp"))
            .args(["simulate", "traces/room", "--out"])
            .arg(dir.path().join("out"))
            .arg("--config")
            .arg(&config)
            .current_dir(root())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(want) && err.contains("bad.toml"), "{toml}: {err}");
    }
}

/// DRAMsim3's trace CPU (`src/cpu.cc`, `TraceBasedCPU::ClockTick`): a line
/// `0xADDR READ|WRITE CYCLE` enters when the clock has reached its cycle
/// and the memory accepts it; every transaction returns one callback.
#[test]
fn the_dramsim3_trace_of_the_room_trace_replays_to_the_reports_transactions() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let trace = d.join("room.trc");
    let out = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["simulate", "traces/room", "--out"])
        .arg(d.join("run"))
        .arg("--dram-trace")
        .arg(&trace)
        .args(["--dram-trace-format", "dramsim3"])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("run").join("report.json")).unwrap()).unwrap();
    let stated = num(&report["total"], "dram_transactions") as u64;
    let lines: Vec<(u64, bool, u64)> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(f.len(), 3, "{l}");
            let addr = u64::from_str_radix(f[0].strip_prefix("0x").unwrap(), 16).unwrap();
            (addr, f[1] == "WRITE", f[2].parse().unwrap())
        })
        .collect();
    assert_eq!(lines.len() as u64, stated, "trace lines against the report");
    let ini = root().join("configs/dram/DDR4_8Gb_x8_3200.ini");
    let mut sys = dramsim3::MemorySystem::new(&ini, d).unwrap();
    let (mut next, mut returned, mut clk) = (0usize, 0u64, 0u64);
    let limit = lines.last().map_or(0, |l| l.2) + 10_000_000;
    while (next < lines.len() || returned < next as u64) && clk < limit {
        while let Some(&(addr, write, at)) = lines.get(next) {
            if at > clk || !sys.can_add(addr, write) {
                break;
            }
            assert!(sys.add(addr, write));
            next += 1;
        }
        sys.tick(|_, _| returned += 1);
        clk += 1;
    }
    assert_eq!((next as u64, returned), (stated, stated), "replayed and returned by DRAMsim3 after {clk} cycles");
}
