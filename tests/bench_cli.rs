//! `postwarp bench --quick --hmd`: the printed table has every row (the
//! headset row on its small frame, the golden model at both vector levels),
//! each with positive times and rates, and peak RSS per reference sample
//! for the process rows.

use std::process::Command;

#[test]
fn bench_quick_prints_every_row_with_positive_numbers() {
    let out = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["bench", "--quick", "--hmd", "--repeats", "1"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run postwarp bench");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "bench failed: {}\n{text}", String::from_utf8_lossy(&out.stderr));
    let head = text.lines().next().expect("a first line");
    let cores: usize = head
        .strip_prefix("postwarp bench: ")
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("first line names the core count: {head}"));
    assert!(cores >= 1);
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| l.starts_with("| engine") || l.starts_with("| process"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        names,
        [
            "engine golden",
            "engine forward-splat",
            "engine golden baseline-instructions",
            "engine hardware-model",
            "engine hardware-model one-thread",
            "process golden",
            "process golden --flip",
            "process golden",
            "process simulate",
            "process simulate"
        ],
        "{text}"
    );
    assert!(rows[5][1].starts_with("traces/motorcycle 741x500") && rows[6][1] == rows[5][1], "{text}");
    assert!(rows[9][1].starts_with("room 200x200 2x2") && rows[9][1].ends_with("preset hmd2026"), "{text}");
    for r in &rows {
        assert_eq!(r.len(), 8, "eight columns: {r:?}");
        let threads: usize = r[2].parse().expect("threads");
        // The hardware model's default row computes kernel setup's lines
        // on a second thread when there is a second core.
        let want = match r[0] {
            "engine hardware-model" => cores.min(2),
            e if e.starts_with("engine") => 1,
            _ => cores,
        };
        assert_eq!(threads, want, "{r:?}");
        let best: f64 = r[3].parse().expect("best s");
        let median: f64 = r[4].parse().expect("median s");
        let rate: f64 = r[5].parse().expect("samples per second");
        assert!(best > 0.0 && median >= best && rate > 0.0, "{r:?}");
        if r[0].starts_with("process") {
            let mb: f64 = r[6].parse().expect("peak RSS");
            let per: f64 = r[7].parse().expect("peak bytes per reference sample");
            assert!(mb > 0.0 && per > 0.0, "{r:?}");
        }
    }
    let ratio = text
        .lines()
        .find_map(|l| l.strip_prefix("golden/forward-splat throughput ratio: "))
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse::<f64>().ok())
        .expect("the ratio line");
    assert!(ratio > 0.0, "{text}");
    // The vector level the golden rows ran at is named.
    assert!(head.contains("golden warps at vector level "), "{head}");
    assert!(text.lines().any(|l| l.starts_with("golden at the baseline level: ")), "{text}");
    // The golden frame by phase: every phase named once with its mean ms;
    // the warp's own phases took time, the general path's none.
    let split = text
        .lines()
        .find_map(|l| l.split_once("frames: ").filter(|(h, _)| h.starts_with("engine golden by phase, mean ms")))
        .map(|(_, s)| s)
        .expect("the phase line");
    let phases: Vec<(&str, f64)> = split
        .split(", ")
        .map(|p| {
            let (name, ms) = p.rsplit_once(' ').expect("name and ms");
            (name, ms.parse().expect("ms"))
        })
        .collect();
    let mut names: Vec<&str> = postwarp::golden::phase_times::Phase::ALL.iter().map(|p| p.name()).collect();
    names.push(postwarp::golden::phase_times::OTHER);
    assert_eq!(phases.iter().map(|p| p.0).collect::<Vec<_>>(), names, "{split}");
    assert!(phases.iter().all(|p| p.1 >= 0.0), "{split}");
    let ms = |n: &str| phases.iter().find(|p| p.0 == n).map(|p| p.1).expect(n);
    for n in ["transform", "phase A", "phase B", "A-buffer"] {
        assert!(ms(n) > 0.0, "{n}: {split}");
    }
    assert_eq!(ms("general warp"), 0.0, "{split}");
}
